//! The service loop: wait, drain, re-plan, publish. It only moves messages
//! between the transport traits and [`PlannerCore`] (house style §2).
//!
//! Per wake-up: drain vehicle states, then snapshots (a fixed order, so a
//! lockstep run handles the same inputs in the same order every time),
//! re-plan if a trigger is pending, publish the plan, then the status. The
//! status tells a lockstep vehicle which of its messages have been answered;
//! it also goes out every [`HEARTBEAT`] while idle so peers can tell a live
//! planner from a stopped one.

use core::time::Duration;

use super::alloc;
use super::core::{PlannerCore, ServiceEvent};
use crate::msg::{Plan, PlannerStatus, RejectCounters, VehicleState, WaypointSnapshot};
use crate::transport::clock::mono_now_ns;
use crate::transport::guard::Guarded;
use crate::transport::{Inbox, Outbox, TransportError, Wake, Waker};

/// Longest idle wait before the loop looks at shutdown and heartbeat.
pub const IDLE_WAIT: Duration = Duration::from_millis(50);

/// Status period while nothing happens.
pub const HEARTBEAT: Duration = Duration::from_millis(250);

/// The planner's ports.
pub struct PlannerPorts<W, IS, IW, OP, OS>
where
    W: Waker,
    IS: Inbox<VehicleState>,
    IW: Inbox<WaypointSnapshot>,
    OP: Outbox<Plan>,
    OS: Outbox<PlannerStatus>,
{
    /// Wakes on vehicle states and snapshots.
    pub waker: W,
    /// Vehicle states, validated.
    pub states: Guarded<VehicleState, IS>,
    /// Waypoint snapshots, validated.
    pub snapshots: Guarded<WaypointSnapshot, IW>,
    /// Plans out.
    pub plans: OP,
    /// Status out.
    pub status: OS,
}

/// Why the loop returned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExitReason {
    /// The vehicle reported the end of the mission.
    Finished,
    /// SIGINT or SIGTERM.
    Shutdown,
    /// `keep_going` said stop.
    Stopped,
}

impl<W, IS, IW, OP, OS> PlannerPorts<W, IS, IW, OP, OS>
where
    W: Waker,
    IS: Inbox<VehicleState>,
    IW: Inbox<WaypointSnapshot>,
    OP: Outbox<Plan>,
    OS: Outbox<PlannerStatus>,
{
    /// Rejected input so far, both topics.
    pub fn rejected(&self) -> RejectCounters {
        let mut r = *self.states.rejected();
        r.merge(self.snapshots.rejected());
        r
    }

    fn publish_status(&mut self, core: &PlannerCore) -> Result<(), TransportError> {
        let rejected = self.rejected();
        self.status
            .publish(&mut |m: &mut PlannerStatus| core.fill_status(&rejected, m))?;
        Ok(())
    }
}

/// Runs the service until the mission ends, a signal arrives, or
/// `keep_going` returns false (checked once per wake-up).
pub fn run_service<W, IS, IW, OP, OS>(
    core: &mut PlannerCore,
    ports: &mut PlannerPorts<W, IS, IW, OP, OS>,
    events: &mut dyn FnMut(&ServiceEvent),
    keep_going: &mut dyn FnMut(&PlannerCore) -> bool,
) -> Result<ExitReason, TransportError>
where
    W: Waker,
    IS: Inbox<VehicleState>,
    IW: Inbox<WaypointSnapshot>,
    OP: Outbox<Plan>,
    OS: Outbox<PlannerStatus>,
{
    let warmup = core.config().warmup_plans;
    if warmup == 0 {
        alloc::begin_steady_state();
    }
    let exit = service_loop(core, ports, events, keep_going, warmup);
    alloc::end_steady_state();
    exit
}

fn service_loop<W, IS, IW, OP, OS>(
    core: &mut PlannerCore,
    ports: &mut PlannerPorts<W, IS, IW, OP, OS>,
    events: &mut dyn FnMut(&ServiceEvent),
    keep_going: &mut dyn FnMut(&PlannerCore) -> bool,
    warmup: u64,
) -> Result<ExitReason, TransportError>
where
    W: Waker,
    IS: Inbox<VehicleState>,
    IW: Inbox<WaypointSnapshot>,
    OP: Outbox<Plan>,
    OS: Outbox<PlannerStatus>,
{
    let mut last_status_ns = 0u64;
    let mut arm_steady = false;
    loop {
        if !keep_going(core) {
            return Ok(ExitReason::Stopped);
        }
        match ports.waker.wait(IDLE_WAIT)? {
            Wake::Shutdown => return Ok(ExitReason::Shutdown),
            Wake::Timeout => {
                ports.plans.refresh();
                ports.status.refresh();
            }
            Wake::Woken(_) => {}
        }
        let received_ns = mono_now_ns();
        let mut handled = ports.states.drain(&mut |s| core.on_state(s, received_ns, events))?;
        handled += ports
            .snapshots
            .drain(&mut |s| core.on_snapshot(s, received_ns, events))?;
        if core.finished() {
            // The peers leave now; their disconnection is tear-down, not
            // steady state (a notifier reallocates its listener list).
            alloc::end_steady_state();
            ports.publish_status(core)?;
            return Ok(ExitReason::Finished);
        }
        if let Some(result) = core.replan() {
            handled += 1;
            if let Ok(r) = result {
                ports.plans.publish(&mut |m: &mut Plan| core.fill_plan(&r, m))?;
                core.published(&r, mono_now_ns(), events);
                // Warm-up ends after the status that follows this plan: the
                // first send of each port connects it to its consumers
                // (iceoryx2 opens a notifier's listener connections lazily,
                // which allocates).
                arm_steady |= core.counters().plans == warmup;
            }
        }
        let now = mono_now_ns();
        if handled > 0 || now.saturating_sub(last_status_ns) >= HEARTBEAT.as_nanos() as u64 {
            ports.publish_status(core)?;
            last_status_ns = now;
            if arm_steady {
                alloc::begin_steady_state();
                arm_steady = false;
            }
        }
    }
}
