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
use super::core::{AckRecord, PlannerCore, ServiceEvent};
use super::plan_out::PlanOutbox;
use auv_messages::msg::{
    CommandAck, OperatorCommand, Plan, PlannerStatus, RejectCounters, VehicleState, WaypointSnapshot,
};
use auv_platform::clock::mono_now_ns;
use auv_transport::guard::Guarded;
use auv_transport::{Inbox, Outbox, TransportError, Wake, Waker};

/// Longest idle wait before the loop looks at shutdown and heartbeat.
pub const IDLE_WAIT: Duration = Duration::from_millis(50);

/// Status period while nothing happens.
pub const HEARTBEAT: Duration = Duration::from_millis(250);

/// The planner's ports.
pub struct PlannerPorts<W, IS, IW, OP, OS, IC, OA>
where
    W: Waker,
    IS: Inbox<VehicleState>,
    IW: Inbox<WaypointSnapshot>,
    OP: PlanOutbox,
    OS: Outbox<PlannerStatus>,
    IC: Inbox<OperatorCommand>,
    OA: Outbox<CommandAck>,
{
    /// Wakes on vehicle states and snapshots.
    pub waker: W,
    /// Vehicle states, validated.
    pub states: Guarded<VehicleState, IS>,
    /// Waypoint snapshots, validated.
    pub snapshots: Guarded<WaypointSnapshot, IW>,
    /// Plans out (with `--inject-plan`, a [`super::plan_out::FaultyPlans`]).
    pub plans: OP,
    /// Status out.
    pub status: OS,
    /// Operator commands (from the shore link), validated.
    pub commands: Guarded<OperatorCommand, IC>,
    /// Command acks out.
    pub acks: OA,
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

impl<W, IS, IW, OP, OS, IC, OA> PlannerPorts<W, IS, IW, OP, OS, IC, OA>
where
    W: Waker,
    IS: Inbox<VehicleState>,
    IW: Inbox<WaypointSnapshot>,
    OP: PlanOutbox,
    OS: Outbox<PlannerStatus>,
    IC: Inbox<OperatorCommand>,
    OA: Outbox<CommandAck>,
{
    /// Rejected input so far, every input topic.
    pub fn rejected(&self) -> RejectCounters {
        let mut r = *self.states.rejected();
        r.merge(self.snapshots.rejected());
        r.merge(self.commands.rejected());
        r
    }

    fn publish_acks<const K: usize>(
        &mut self,
        core: &mut PlannerCore<K>,
        plan_seq: u64,
        replan: u32,
    ) -> Result<(), TransportError> {
        let acks = &mut self.acks;
        let mut result = Ok(());
        let t = core.mission_time_s();
        core.take_acks(plan_seq, replan, &mut |r: &AckRecord| {
            if result.is_ok() {
                result = acks.publish(&mut |m: &mut CommandAck| r.fill(t, m)).map(|_| ());
            }
        });
        result
    }

    fn publish_status<const K: usize>(&mut self, core: &PlannerCore<K>) -> Result<(), TransportError> {
        let rejected = self.rejected();
        self.status
            .publish(&mut |m: &mut PlannerStatus| core.fill_status(&rejected, m))?;
        Ok(())
    }
}

/// Runs the service until the mission ends, a signal arrives, or
/// `keep_going` returns false (checked once per wake-up). The core's
/// capacity class `K` is the mission's; the ports do not depend on it.
pub fn run_service<W, IS, IW, OP, OS, IC, OA, const K: usize>(
    core: &mut PlannerCore<K>,
    ports: &mut PlannerPorts<W, IS, IW, OP, OS, IC, OA>,
    events: &mut dyn FnMut(&ServiceEvent),
    keep_going: &mut dyn FnMut(&PlannerCore<K>) -> bool,
) -> Result<ExitReason, TransportError>
where
    W: Waker,
    IS: Inbox<VehicleState>,
    IW: Inbox<WaypointSnapshot>,
    OP: PlanOutbox,
    OS: Outbox<PlannerStatus>,
    IC: Inbox<OperatorCommand>,
    OA: Outbox<CommandAck>,
{
    let warmup = core.config().warmup_plans;
    if warmup == 0 {
        alloc::begin_steady_state();
    }
    let exit = service_loop(core, ports, events, keep_going, warmup);
    alloc::end_steady_state();
    exit
}

fn service_loop<W, IS, IW, OP, OS, IC, OA, const K: usize>(
    core: &mut PlannerCore<K>,
    ports: &mut PlannerPorts<W, IS, IW, OP, OS, IC, OA>,
    events: &mut dyn FnMut(&ServiceEvent),
    keep_going: &mut dyn FnMut(&PlannerCore<K>) -> bool,
    warmup: u64,
) -> Result<ExitReason, TransportError>
where
    W: Waker,
    IS: Inbox<VehicleState>,
    IW: Inbox<WaypointSnapshot>,
    OP: PlanOutbox,
    OS: Outbox<PlannerStatus>,
    IC: Inbox<OperatorCommand>,
    OA: Outbox<CommandAck>,
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
        // Commands after the inputs they are checked against.
        let acks = &mut ports.acks;
        let mut ack_result = Ok(0);
        handled += ports.commands.drain(&mut |c| {
            if let Some(r) = core.on_command(c, received_ns, events)
                && ack_result.is_ok()
            {
                let t = core.mission_time_s();
                ack_result = acks.publish(&mut |m: &mut CommandAck| r.fill(t, m));
            }
        })?;
        ack_result?;
        if core.finished() {
            // The peers leave now; their disconnection is tear-down, not
            // steady state (a notifier reallocates its listener list).
            alloc::end_steady_state();
            ports.publish_acks(core, 0, 0)?;
            ports.publish_status(core)?;
            return Ok(ExitReason::Finished);
        }
        if let Some(result) = core.replan() {
            handled += 1;
            match result {
                Ok(r) => {
                    let plan_seq = ports
                        .plans
                        .publish_plan(core.plan_context(), &mut |m: &mut Plan| core.fill_plan(&r, m))?;
                    core.published(&r, mono_now_ns(), events);
                    if core.has_pending_acks() {
                        ports.publish_acks(core, plan_seq, r.replan)?;
                    }
                    // Warm-up ends after the status that follows this plan: the
                    // first send of each port connects it to its consumers
                    // (iceoryx2 opens a notifier's listener connections lazily,
                    // which allocates).
                    arm_steady |= core.counters().plans == warmup;
                }
                // No route to the goal: the commands are answered without a plan.
                Err(_) if core.has_pending_acks() => ports.publish_acks(core, 0, 0)?,
                Err(_) => {}
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::ServiceConfig;
    use crate::standin::RandomKeySearch;
    use auv_core::fixtures::random_instance;
    use auv_messages::msg::{Outcome, PlannerPhase, VehicleMode};
    use auv_messages::network::write_snapshot;
    use auv_transport::ipc::{InProcess, IpcContext, Stamp};
    use auv_transport::{IpcOptions, Role, WaitMode, unique_prefix};

    #[test]
    fn the_loop_answers_a_vehicle_with_a_plan_then_a_status_and_stops_when_it_finishes() {
        let opts = IpcOptions::new(Some(&unique_prefix("r")), "loop", WaitMode::Event).unwrap();
        let ctx = IpcContext::<InProcess>::new(&opts, "test").unwrap();
        let fp = 77;
        let mut ports = PlannerPorts {
            waker: ctx.waker(Role::Planner).unwrap(),
            states: Guarded::new(ctx.inbox::<VehicleState>().unwrap(), fp, "planner"),
            snapshots: Guarded::new(ctx.snapshot_inbox().unwrap(), fp, "planner"),
            plans: ctx.outbox::<Plan>(Stamp::new(fp)).unwrap(),
            status: ctx.outbox::<PlannerStatus>(Stamp::new(fp)).unwrap(),
            commands: Guarded::new(ctx.inbox::<OperatorCommand>().unwrap(), fp, "planner"),
            acks: ctx.outbox::<CommandAck>(Stamp::new(fp)).unwrap(),
        };
        // The peers: a sensor, a vehicle, and one foreign sender.
        let mut snap_out = ctx.snapshot_outbox(Stamp::new(fp), 15).unwrap();
        let mut state_out = ctx.outbox::<VehicleState>(Stamp::new(fp)).unwrap();
        let mut foreign = ctx.outbox::<VehicleState>(Stamp::new(fp + 1)).unwrap();
        let mut plans_in = ctx.inbox::<Plan>().unwrap();
        let mut status_in = ctx.inbox::<PlannerStatus>().unwrap();
        let inst = random_instance(15, 0.4, 20_000.0, 2);
        snap_out.publish(&mut |m| write_snapshot(&inst, 0, m).unwrap()).unwrap();
        let vehicle = |m: &mut VehicleState| {
            m.time_left_s = 20_000.0;
            m.mode = VehicleMode::NoPlan as u32;
            m.route_len = 1;
        };
        foreign.publish(&mut |m| vehicle(m)).unwrap();
        let seq = state_out.publish(&mut |m| vehicle(m)).unwrap();
        let cfg = ServiceConfig {
            fingerprint: fp,
            cut_at_deadline: false,
            iterations: 10,
            ..ServiceConfig::default()
        };
        let mut core: PlannerCore = PlannerCore::new(cfg, Box::new(RandomKeySearch::new(5)));
        let mut rounds = 0;
        let exit = run_service(&mut core, &mut ports, &mut |_| {}, &mut |c| {
            rounds += 1;
            c.counters().plans == 0 && rounds < 100
        })
        .unwrap();
        assert_eq!(exit, ExitReason::Stopped);
        let mut plan = None;
        plans_in.drain(&mut |p: &Plan| plan = Some(*p)).unwrap();
        let plan = plan.expect("a plan");
        assert_eq!(plan.state_seq, seq);
        assert_eq!(plan.route[0], 0);
        assert_eq!(plan.route[plan.route_len as usize - 1] as usize, inst.goal);
        // Status goes out after the plan and answers the vehicle's state.
        let mut status = None;
        status_in.drain(&mut |s: &PlannerStatus| status = Some(*s)).unwrap();
        let status = status.expect("a status");
        assert_eq!(status.handled_state_seq, seq);
        assert_eq!(status.plans, 1);
        assert_eq!(status.phase, PlannerPhase::Running as u32);
        assert_eq!(
            status.rejected[auv_messages::msg::RejectKind::ForeignScenario as usize],
            1
        );
        // The vehicle reports the end: the loop returns.
        state_out
            .publish(&mut |m| {
                vehicle(m);
                m.outcome = Outcome::GoalReached as u32;
            })
            .unwrap();
        let exit = run_service(&mut core, &mut ports, &mut |_| {}, &mut |_| true).unwrap();
        assert_eq!(exit, ExitReason::Finished);
    }
}
