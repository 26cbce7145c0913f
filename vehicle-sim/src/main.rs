//! `vehicle-sim`: the simulated AUV. Follows the latest plan over iceoryx2,
//! publishes its state at a fixed rate and on every arrival, and ends at the
//! goal (success) or when its time runs out (failure).
//!
//! Time: scaled (default 1000× real time; the mission clock starts with the
//! first waypoint snapshot) or `--lockstep`: as fast as possible, stopping at
//! every arrival and every sensor update until the planner has answered, so
//! the same seeds give the same mission.
//!
//! Input: snapshots are validated and checked against the scenario's world
//! (waypoints over water, inside their bounds), plans against the network
//! and the route so far (edges, unvisited waypoints); rejections are counted
//! by kind in every state message (`rejected`) and logged rate-limited.
//!
//! Tests: `--inject KIND[,KIND…]` also sends one bad state next to each good
//! one after the first (kinds in turn; see [`auv_messages::wire`]).
//!
//! Safe hold: on SIGUSR1 (the supervisor's request) the vehicle takes no
//! more plans, goes on to the waypoint it is heading for and ends the
//! mission there (outcome `safe_hold`, journaled as `hold` then `end`).
//!
//! Exit status: 0 when the mission ended (goal, time out or safe hold), 1 on
//! an error, 2 on bad arguments, 130 when stopped by a signal.

use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

use auv_messages::journal::{Journal, JournalEvent, JournalSummary, Resume};
use auv_messages::msg::{Outcome, Plan, PlannerStatus, RejectCounters, VehicleEvent, VehicleState, WaypointSnapshot};
use auv_messages::wire::{Fault, FaultCycle, VEHICLE_FAULTS, WireRules, corrupt_state};
use auv_platform::clock::mono_now_ns;
use auv_platform::signal;
use auv_transport::faulty::{Corrupt, FaultyOutbox};
use auv_transport::guard::Guarded;
use auv_transport::ipc::{IpcContext, IpcInbox, IpcOutbox, IpcSnapshotInbox, IpcWaker, Shm, Stamp};
use auv_transport::{IpcArgs, Outbox, Role, Wake, Waker};
use auv_world::load::{ScenarioArgs, load_world};
use clap::Parser;
use vehicle_sim::sim::{PlanOffer, SimEvent, VehicleSim};

#[derive(Parser, Debug)]
#[command(
    name = "vehicle-sim",
    about = "Simulated AUV following the planner's plans over iceoryx2"
)]
struct Args {
    #[command(flatten)]
    ipc: IpcArgs,
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// Run as fast as possible, waiting for the planner's answer at every
    /// arrival and sensor update (deterministic).
    #[arg(long)]
    lockstep: bool,
    /// Mission seconds per real second (ignored with --lockstep).
    #[arg(long, default_value_t = 1000.0)]
    time_scale: f64,
    /// State messages per real second in scaled time.
    #[arg(long, default_value_t = 20.0)]
    state_rate_hz: f64,
    /// Lockstep: give up when an answer takes longer than this, real s.
    #[arg(long, default_value_t = 30.0)]
    answer_timeout_s: f64,
    /// Append-only journal of the events acted on (JSON lines, written as
    /// they happen). When it already holds a mission that has not ended,
    /// the vehicle resumes from it (restart after a crash).
    #[arg(long, value_name = "FILE")]
    journal: Option<std::path::PathBuf>,
    /// Tests: send a bad state next to each good one after the first, these
    /// kinds in turn: non_finite, node_out_of_range, out_of_order, repeated,
    /// foreign_scenario, malformed, out_of_range, or all.
    #[arg(long, value_name = "KIND[,KIND…]")]
    inject: Option<String>,
}

#[derive(Debug, thiserror::Error)]
enum Error {
    #[error(transparent)]
    Setup(#[from] auv_transport::SetupError),
    #[error(transparent)]
    World(#[from] auv_world::load::WorldError),
    #[error("transport: {0}")]
    Transport(#[from] auv_transport::TransportError),
    #[error("{0}")]
    Usage(String),
    #[error(transparent)]
    Journal(#[from] auv_messages::journal::JournalError),
    #[error(
        "no answer within {0} s while waiting for {1} ({2}): are the planner and sensor-sim running with the same --ipc-prefix?"
    )]
    NoAnswer(f64, &'static str, String),
}

type S = Shm;

/// Makes an injected state bad (see [`corrupt_state`]).
struct BadState {
    /// Waypoints in the network (for out-of-range ids).
    n: usize,
}

impl Corrupt<VehicleState> for BadState {
    fn corrupt(&mut self, fault: Fault, m: &mut VehicleState) {
        corrupt_state(fault, m, self.n);
    }
}

struct Ports {
    waker: IpcWaker<S>,
    /// Bad states next to the good under `--inject`.
    state: FaultyOutbox<IpcOutbox<S, VehicleState>, BadState>,
    snapshots: Guarded<WaypointSnapshot, IpcSnapshotInbox<S>>,
    plans: Guarded<Plan, IpcInbox<S, Plan>>,
    status: Guarded<PlannerStatus, IpcInbox<S, PlannerStatus>>,
}

/// The latest planner status seen.
#[derive(Clone, Copy, Default)]
struct Answered {
    session: u64,
    state_seq: u64,
    epoch: u64,
}

struct Vehicle {
    sim: VehicleSim,
    ports: Ports,
    answered: Answered,
    time_scale: f64,
    journal: Option<Journal>,
    /// A safe hold is under way.
    holding: bool,
}

impl Ports {
    /// The vehicle's ports in `ctx`: states carry `stamp` (with `faults`
    /// injected, node ids below `n`), inputs are accepted from `stamp`'s
    /// scenario. Snapshots are checked against the scenario only; `main`
    /// adds the world's check.
    fn open(ctx: &IpcContext<S>, stamp: Stamp, faults: FaultCycle, n: usize) -> Result<Self, Error> {
        let fingerprint = stamp.fingerprint;
        Ok(Self {
            waker: ctx.waker(Role::Vehicle)?,
            state: FaultyOutbox::new(ctx.outbox::<VehicleState>(stamp)?, faults, BadState { n }),
            snapshots: Guarded::new(ctx.snapshot_inbox()?, fingerprint, "vehicle-sim"),
            plans: Guarded::new(ctx.inbox::<Plan>()?, fingerprint, "vehicle-sim"),
            status: Guarded::new(ctx.inbox::<PlannerStatus>()?, fingerprint, "vehicle-sim"),
        })
    }
}

impl Vehicle {
    /// A vehicle without a network yet (it starts with the first snapshot);
    /// `time_scale` 0 is lockstep.
    fn new(ports: Ports, time_scale: f64, journal: Option<Journal>) -> Self {
        Self {
            sim: VehicleSim::new(),
            ports,
            answered: Answered::default(),
            time_scale,
            journal,
            holding: false,
        }
    }

    /// Drains every inbox: snapshots first, then plans (catching up on
    /// snapshots when a plan names a newer one), then status; then plans
    /// again when a status came in. A plan answering a trigger is sent
    /// before the status that says so, so a plan published between the two
    /// drains is queued by the time its status is seen: taking it before
    /// moving on keeps lockstep runs deterministic.
    fn drain(&mut self) -> Result<(), Error> {
        let sim = &mut self.sim;
        self.ports.snapshots.drain(&mut |s| sim.apply_snapshot(s))?;
        self.drain_plans()?;
        let answered = &mut self.answered;
        let statuses = self.ports.status.drain(&mut |st| {
            *answered = Answered {
                session: st.handled_state_session,
                state_seq: st.handled_state_seq,
                epoch: st.handled_epoch,
            }
        })?;
        if statuses > 0 {
            self.drain_plans()?;
        }
        Ok(())
    }

    /// Offers every plan that arrived to the simulation, journaling those taken.
    ///
    /// A plan computed on a snapshot this vehicle has not drained yet is
    /// checked against that snapshot, not the one before: the sensor sent it
    /// before the planner could read it, so it is queued here; draining it
    /// first keeps an edge the new snapshot added from looking like a bad
    /// plan (and lockstep runs from depending on when each queue is read).
    fn drain_plans(&mut self) -> Result<(), Error> {
        let sim = &mut self.sim;
        let snapshots = &mut self.ports.snapshots;
        let mut catch_up = Ok(0);
        let mut rejected = Vec::new();
        let mut accepted = Vec::new();
        self.ports.plans.drain(&mut |p| {
            if p.snapshot_epoch > sim.epoch() && catch_up.is_ok() {
                catch_up = snapshots.drain(&mut |s| sim.apply_snapshot(s));
            }
            match sim.offer_plan(p) {
                Err(kind) => rejected.push((kind, p.header.fingerprint)),
                Ok(PlanOffer::Stale) => {}
                Ok(PlanOffer::Taken) => accepted.push(JournalEvent::Plan {
                    t: sim.time(),
                    seq: p.header.seq,
                    route: sim.plan().iter().map(|&b| b as usize).collect(),
                }),
            }
        })?;
        catch_up?;
        for (kind, fp) in rejected {
            self.ports.plans.reject_later(kind, fp);
        }
        for e in &accepted {
            self.record(e)?;
        }
        Ok(())
    }

    /// Appends `e` to the journal, if there is one.
    fn record(&mut self, e: &JournalEvent) -> Result<(), Error> {
        if let Some(j) = &mut self.journal {
            j.append(e)?;
        }
        Ok(())
    }

    /// Journals a simulation event (before it is published: an event is in
    /// the journal before anyone acts on it).
    fn record_sim(&mut self, ev: SimEvent) -> Result<(), Error> {
        let t = self.sim.time();
        let e = match ev {
            SimEvent::Arrival { node } => {
                let (task_s, task_weight) = self.sim.current_task();
                JournalEvent::Arrival {
                    t,
                    node,
                    pos: self.sim.position(),
                    distance_m: self.sim.totals().2,
                    task_s,
                    task_weight,
                }
            }
            SimEvent::TaskDone { node } => JournalEvent::Task {
                t,
                node,
                weight: self.sim.current_task().1,
            },
            SimEvent::Finished(Outcome::SafeHold) => {
                let node = self.sim.next_waypoint();
                self.record(&JournalEvent::Hold { t, node })?;
                JournalEvent::End {
                    t,
                    outcome: Outcome::SafeHold,
                }
            }
            SimEvent::Finished(outcome) => JournalEvent::End { t, outcome },
        };
        self.record(&e)
    }

    /// Everything this vehicle rejected so far, by kind.
    fn rejected(&self) -> RejectCounters {
        let mut r = *self.ports.snapshots.rejected();
        r.merge(self.ports.plans.rejected());
        r.merge(self.ports.status.rejected());
        r
    }

    /// Publishes the state for `event`; returns the good message's sequence
    /// number. With `--inject`, a bad copy goes out next to it (never next
    /// to the first or the last state).
    fn publish(&mut self, event: VehicleEvent, needs_answer: bool) -> Result<u64, Error> {
        let rejected = self.rejected();
        let (sim, scale) = (&self.sim, self.time_scale);
        let mut good = |m: &mut VehicleState| {
            sim.fill_state(event, scale, needs_answer, m);
            m.rejected = rejected.0;
        };
        let out = &mut self.ports.state;
        let seq = match event {
            VehicleEvent::Start | VehicleEvent::Finished => out.publish_alone(&mut good)?,
            _ => out.publish(&mut good)?,
        };
        Ok(seq)
    }

    /// Waits until `done` holds, draining inputs; `false` on shutdown. A
    /// safe hold ends the wait too (the vehicle no longer waits for anyone).
    fn wait_for(&mut self, timeout_s: f64, what: &'static str, done: &dyn Fn(&Vehicle) -> bool) -> Result<bool, Error> {
        let t0 = Instant::now();
        loop {
            self.drain()?;
            if done(self) || self.check_hold() {
                return Ok(true);
            }
            if t0.elapsed().as_secs_f64() > timeout_s {
                let seen = format!(
                    "mission time {:.1} s, snapshot epoch {}, planner answered state {} and epoch {}",
                    self.sim.time(),
                    self.sim.epoch(),
                    self.answered.state_seq,
                    self.answered.epoch
                );
                return Err(Error::NoAnswer(timeout_s, what, seen));
            }
            match self.ports.waker.wait(Duration::from_millis(50))? {
                Wake::Shutdown => return Ok(false),
                Wake::Timeout => self.ports.state.refresh(),
                Wake::Woken(_) => {}
            }
        }
    }

    /// Starts the safe hold the supervisor asked for (SIGUSR1), once the
    /// vehicle is on the network; whether it is holding.
    fn check_hold(&mut self) -> bool {
        if signal::hold_requested() && self.sim.has_network() && !self.holding {
            self.holding = true;
            self.sim.hold();
            eprintln!(
                "vehicle-sim: safe hold requested at mission time {:.1} s: holding at waypoint {}",
                self.sim.time(),
                self.sim.next_waypoint()
            );
        }
        self.holding
    }

    fn answered(&self, session: u64, seq: u64) -> bool {
        self.answered.session == session && self.answered.state_seq >= seq
    }

    fn lockstep(&mut self, timeout_s: f64, session: u64) -> Result<Outcome, Error> {
        let seq = self.publish(VehicleEvent::Start, true)?;
        if !self.wait_for(timeout_s, "the first plan", &|v| v.answered(session, seq))? {
            return Ok(Outcome::Aborted);
        }
        loop {
            let tick = self.sim.epoch_next_update();
            let ev = self.sim.step_until(tick);
            if let Some(e) = ev {
                self.record_sim(e)?;
            }
            match ev {
                Some(SimEvent::Arrival { .. }) => {
                    let seq = self.publish(VehicleEvent::Arrival, true)?;
                    if !self.wait_for(timeout_s, "the planner's answer", &|v| v.answered(session, seq))? {
                        return Ok(Outcome::Aborted);
                    }
                }
                Some(SimEvent::TaskDone { .. }) => {}
                Some(SimEvent::Finished(outcome)) => {
                    self.publish(VehicleEvent::Finished, false)?;
                    return Ok(outcome);
                }
                None => {
                    let epoch = self.sim.epoch() + 1;
                    let seq = self.publish(VehicleEvent::Tick, true)?;
                    let ok = self.wait_for(timeout_s, "the sensor update", &|v| {
                        v.sim.epoch() >= epoch && v.answered(session, seq) && v.answered.epoch >= epoch
                    })?;
                    if !ok {
                        return Ok(Outcome::Aborted);
                    }
                }
            }
        }
    }

    fn scaled(&mut self, rate_hz: f64) -> Result<Outcome, Error> {
        let t0 = mono_now_ns();
        // A resumed vehicle's clock goes on from its journal's last event.
        let t_start = self.sim.time();
        let scale = self.time_scale;
        let period_ns = (1e9 / rate_hz) as u64;
        let mut next_periodic = t0;
        self.publish(VehicleEvent::Start, false)?;
        loop {
            let now = mono_now_ns();
            let t = t_start + (now - t0) as f64 * 1e-9 * scale;
            while let Some(ev) = self.sim.step_until(t) {
                self.record_sim(ev)?;
                match ev {
                    SimEvent::Arrival { .. } => {
                        self.publish(VehicleEvent::Arrival, false)?;
                    }
                    SimEvent::TaskDone { .. } => {}
                    SimEvent::Finished(outcome) => {
                        self.publish(VehicleEvent::Finished, false)?;
                        return Ok(outcome);
                    }
                }
            }
            if now >= next_periodic {
                self.publish(VehicleEvent::Periodic, false)?;
                next_periodic = now + period_ns;
            }
            let to_event_ns = ((self.sim.next_event_time() - t) / scale * 1e9).max(0.0);
            let wait_ns = (next_periodic.saturating_sub(now) as f64).min(to_event_ns).min(50e6);
            match self.ports.waker.wait(Duration::from_nanos(wait_ns as u64))? {
                Wake::Shutdown => return Ok(Outcome::Aborted),
                Wake::Timeout => self.ports.state.refresh(),
                Wake::Woken(_) => {}
            }
            self.drain()?;
            self.check_hold();
        }
    }
}

fn run(args: &Args) -> Result<Outcome, Error> {
    if !(args.time_scale.is_finite() && args.time_scale > 0.0) {
        return Err(Error::Usage(format!("--time-scale {}: must be > 0", args.time_scale)));
    }
    if !(args.state_rate_hz.is_finite() && args.state_rate_hz > 0.0) {
        return Err(Error::Usage(format!(
            "--state-rate-hz {}: must be > 0",
            args.state_rate_hz
        )));
    }
    if !(args.answer_timeout_s.is_finite() && args.answer_timeout_s > 0.0) {
        return Err(Error::Usage(format!(
            "--answer-timeout-s {}: must be > 0",
            args.answer_timeout_s
        )));
    }
    let faults = FaultCycle::parse_opt("--inject", args.inject.as_deref(), &VEHICLE_FAULTS)
        .map_err(|e| Error::Usage(e.to_string()))?;
    signal::install();
    signal::install_hold();
    let world = load_world(&args.scenario)?;
    let fingerprint = world.fingerprint();
    let rules = Arc::new(WireRules::new(&world));
    drop(world);
    let opts = args.ipc.options()?;
    let ctx = IpcContext::<S>::new(&opts, "vehicle-sim")?;
    let stamp = Stamp::new(fingerprint);
    let mut ports = Ports::open(&ctx, stamp, faults, rules.n())?;
    ports.snapshots = ports.snapshots.with_check(rules.snapshot_check());
    let earlier = match &args.journal {
        Some(p) => JournalSummary::read(p)?,
        None => JournalSummary::default(),
    };
    if let Some(o) = earlier.outcome() {
        // Restarted after the end: nothing to do (a new mission needs a new journal).
        eprintln!("vehicle-sim: the journal's mission already ended; nothing to resume");
        return Ok(o);
    }
    let resume: Option<Resume> = earlier.resume();
    let journal = args.journal.as_deref().map(Journal::open).transpose()?;
    let time_scale = if args.lockstep { 0.0 } else { args.time_scale };
    let mut v = Vehicle::new(ports, time_scale, journal);
    // The mission clock starts with the first snapshot.
    let timeout = args.answer_timeout_s;
    if !v.wait_for(timeout, "the first waypoint snapshot", &|v| v.sim.has_network())? {
        return Ok(Outcome::Aborted);
    }
    if let Some(r) = &resume {
        v.sim.resume(r);
        eprintln!(
            "vehicle-sim: resumed from the journal at mission time {:.1} s, waypoint {}, {} tasks",
            r.t,
            r.route.last().copied().unwrap_or(0),
            r.tasks
        );
    }
    let start = JournalEvent::Start {
        t: v.sim.time(),
        node: v.sim.route().last().unwrap_or(0),
        resumed: resume.is_some(),
    };
    v.record(&start)?;
    let outcome = if args.lockstep {
        v.lockstep(timeout, stamp.session)?
    } else {
        v.scaled(args.state_rate_hz)?
    };
    if outcome == Outcome::Aborted {
        v.sim.abort();
        v.record(&JournalEvent::End {
            t: v.sim.time(),
            outcome,
        })?;
        v.publish(VehicleEvent::Finished, false)?;
    }
    let (tasks, weight, distance) = v.sim.totals();
    eprintln!(
        "vehicle-sim: {} at mission time {:.1} s: {} tasks, weight {:.2}, {:.0} m, route {:?}",
        match outcome {
            Outcome::GoalReached => "goal reached",
            Outcome::TimedOut => "out of time",
            Outcome::Aborted => "stopped",
            Outcome::SafeHold => "safe hold",
            Outcome::Running => "running",
        },
        v.sim.time(),
        tasks,
        weight,
        distance,
        v.sim.route()
    );
    let r = v.rejected();
    if r.total() > 0 {
        eprintln!("vehicle-sim: rejected {} input message(s) in all: {r}", r.total());
    }
    Ok(outcome)
}

fn main() -> ExitCode {
    let args = match Args::try_parse() {
        Ok(a) => a,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    match run(&args) {
        Ok(Outcome::Aborted) => ExitCode::from(130),
        Ok(_) => ExitCode::SUCCESS,
        Err(e @ Error::Usage(_)) => {
            eprintln!("vehicle-sim: error: {e}");
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("vehicle-sim: error: {e}");
            ExitCode::from(1)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_core::fixtures::line_instance;
    use auv_messages::network::write_snapshot;
    use auv_transport::{IpcOptions, WaitMode, unique_prefix};

    #[test]
    fn a_plan_on_a_snapshot_still_queued_is_checked_against_that_snapshot() {
        let opts = IpcOptions::new(Some(&unique_prefix("vq")), "auv1", WaitMode::Event).unwrap();
        let ctx = IpcContext::<S>::new(&opts, "test-vehicle").unwrap();
        let fp = 9;
        let ports = Ports::open(&ctx, Stamp::new(fp), FaultCycle::NONE, 4).unwrap();
        let mut v = Vehicle::new(ports, 0.0, None);
        let mut sensor = ctx.snapshot_outbox(Stamp::new(fp), 4).unwrap();
        let mut planner = ctx.outbox::<Plan>(Stamp::new(fp)).unwrap();
        // Epoch 0 lacks the edge 1 - 2; epoch 1 has it.
        let full = line_instance();
        let mut cut = full.clone();
        cut.edges.retain(|e| (e.a, e.b) != (1, 2));
        sensor.publish(&mut |m| write_snapshot(&cut, 0, m).unwrap()).unwrap();
        v.drain().unwrap();
        assert_eq!(v.sim.epoch(), 0);
        // The sensor's next update and a plan computed on it arrive after
        // the vehicle drained its snapshots: only plans are drained next.
        sensor.publish(&mut |m| write_snapshot(&full, 1, m).unwrap()).unwrap();
        planner
            .publish(&mut |m: &mut Plan| {
                m.snapshot_epoch = 1;
                m.route_len = 4;
                m.route[..4].copy_from_slice(&[0, 1, 2, 3]);
            })
            .unwrap();
        v.drain_plans().unwrap();
        assert_eq!(v.sim.epoch(), 1);
        assert_eq!(v.sim.plan(), &[0, 1, 2, 3]);
        assert_eq!(v.rejected().total(), 0, "{}", v.rejected());
    }
}
