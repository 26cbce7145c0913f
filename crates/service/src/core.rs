//! The re-planning decisions, free of any transport: what the planner does
//! with a vehicle state, with a waypoint snapshot, and when it re-plans.
//!
//! Contract:
//! - Re-plans from the node the vehicle is heading to (or is at), with the
//!   time left minus the vehicle's time until it is free there, excluding
//!   every node already visited (so every completed task too).
//! - Triggers: the first plan (or a vehicle holding without a plan), an
//!   arrival at a waypoint, and a sensor update that removes an edge of the
//!   remaining plan, makes it infeasible, or changes its remaining time by
//!   more than `replan_threshold_s` against what it was planned for.
//! - Warm start: the remaining part of the previous plan, when it is still a
//!   valid route of the new problem.
//! - A solve runs the fixed iteration budget, cut at the deadline
//!   (`trigger arrival + deadline − publish margin`) unless cutting is off (the
//!   deterministic lockstep mode). The best route is always published: the
//!   decoder only builds valid routes, and when nothing fits the budget it is
//!   the quickest path to the goal, flagged `fallback`.
//! - Every random draw of re-plan k comes from `derive_seed(seed, k)`.
//! - After [`PlannerCore::new`], handling input and re-planning allocate
//!   nothing (the buffers, the problem tables, the snapshot copy and the
//!   latency histogram are all sized at construction).

use std::time::{Duration, Instant};

use hdrhistogram::Histogram;

use auv_core::capacity::{DEFAULT_WORDS, LARGEST_WORDS, PerNode, nodes_of};
use auv_core::problem::{NodeSet, Problem, ProblemError};
use auv_core::rng::{PlannerRng, derive_seed};
use auv_core::route::{Route, RouteEval};
use auv_core::solver::{Algorithm, Budget, Solver, StopReason, run};
use auv_messages::msg::{
    AckStatus, CommandAck, CommandKind, FromCode, MAX_WIRE_NODES, OperatorCommand, Outcome, Plan, PlannerPhase,
    PlannerStatus, RefuseReason, RejectCounters, TriggerKind, VehicleMode, VehicleState, WaypointSnapshot,
    boxed_zeroed,
};
use auv_messages::network::{fill_problem, objective};
use auv_platform::clock::mono_now_ns;

/// Settings of the re-planning service; [`ServiceConfig::default`] documents each default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServiceConfig {
    /// Trigger sent → plan published (default 20 ms).
    pub deadline: Duration,
    /// Time kept free after the solver stops for building and publishing
    /// the plan (our choice: 1 ms, far above the measured publish cost).
    pub publish_margin: Duration,
    /// Solver iterations per re-plan (the paper's PSO budget, 150).
    pub iterations: u32,
    /// A sensor update re-plans when the remaining plan time moves by more
    /// than this, s (our choice: 120 s, about the shortest task time).
    pub replan_threshold_s: f64,
    /// Cut solves at the deadline (off in lockstep for determinism).
    pub cut_at_deadline: bool,
    /// Time held back from every plan's budget, s, against dynamic
    /// waypoints drifting while the vehicle is committed to an edge (a plan
    /// that uses the budget to the second cannot absorb a longer edge).
    pub reserve_s: f64,
    /// Expected extra time to reach each waypoint while it drifts, s, by
    /// node id (see `scenario::chase`); added to the edges' planned times,
    /// half at each end, so a route pays it once per drifting waypoint.
    pub arrival_allowance_s: [f64; MAX_WIRE_NODES],
    /// Seed of the planner's random draws.
    pub seed: u64,
    /// The solver `make_solver` builds (default `auto`).
    pub algorithm: Algorithm,
    /// Scenario fingerprint of this process.
    pub fingerprint: u64,
    /// Plans published before the steady state begins (our choice: 1; the
    /// first plan establishes every connection).
    pub warmup_plans: u64,
}

pub use auv_core::problem::DEFAULT_RESERVE_S;

impl Default for ServiceConfig {
    fn default() -> Self {
        Self {
            deadline: Duration::from_millis(20),
            publish_margin: Duration::from_millis(1),
            iterations: 150,
            replan_threshold_s: 120.0,
            cut_at_deadline: true,
            reserve_s: DEFAULT_RESERVE_S,
            arrival_allowance_s: [0.0; MAX_WIRE_NODES],
            seed: 1,
            algorithm: Algorithm::Auto,
            fingerprint: 0,
            warmup_plans: 1,
        }
    }
}

/// What the service saw and did, for the mission log. Only mission-time and
/// planning figures: no wall-clock values, so a lockstep run logs the same
/// bytes every time.
#[derive(Clone, Copy, Debug, PartialEq)]
// The plan's route (u16 ids since the capacity classes) makes one variant
// large; events go to a callback by reference, never stored in bulk.
#[allow(clippy::large_enum_variant)]
pub enum ServiceEvent {
    /// A waypoint snapshot was applied.
    SensorUpdate {
        /// Mission time of the snapshot, s.
        t: f64,
        /// Its epoch.
        epoch: u64,
        /// Edges in the network.
        edges: u32,
        /// Re-plan trigger it caused, if any.
        trigger: Option<TriggerKind>,
    },
    /// The vehicle reached a waypoint.
    Arrival {
        /// Mission time, s.
        t: f64,
        /// Where (x, y), m.
        at: (f64, f64),
        /// The waypoint.
        node: u32,
        /// Tasks completed so far.
        tasks: u32,
        /// Weight collected so far.
        weight: f64,
        /// Time left, s.
        time_left_s: f64,
    },
    /// A plan was published.
    Plan {
        /// Vehicle's mission time of the trigger, s.
        t: f64,
        /// Re-plan counter.
        replan: u32,
        /// Why.
        trigger: TriggerKind,
        /// The route from the vehicle's next node to the goal (in the
        /// largest class, so one event type serves every class).
        route: Route<LARGEST_WORDS>,
        /// Its figures.
        eval: RouteEval,
        /// Budget planned for, s.
        budget_s: f64,
        /// Iterations run.
        iterations: u32,
        /// Cut by the deadline.
        deadline_cut: bool,
        /// The vehicle's position (x, y) when the trigger was answered (for plots), m.
        at: (f64, f64),
    },
    /// An operator's command was applied or refused.
    Command {
        /// Vehicle's mission time, s.
        t: f64,
        /// The command's id.
        id: u64,
        /// What it asked for.
        kind: CommandKind,
        /// Applied or refused.
        status: AckStatus,
        /// Why it was refused ([`RefuseReason::None`] when applied).
        reason: RefuseReason,
        /// The new budget of a set-time-budget, the waypoint of a task
        /// command (0 otherwise).
        value: f64,
        /// A repeat of a command already answered (answered again, not applied again).
        repeat: bool,
    },
    /// The vehicle reported the end of the mission.
    Finished {
        /// Mission time, s.
        t: f64,
        /// How it ended.
        outcome: Outcome,
    },
}

#[derive(Clone, Copy, Debug)]
struct Pending {
    kind: TriggerKind,
    sent_ns: u64,
    /// When the triggering message was taken off the transport: the
    /// deadline counts from here (the deadline counts from the trigger's arrival).
    received_ns: u64,
    mission_time_s: f64,
}

fn rank(k: TriggerKind) -> u8 {
    match k {
        TriggerKind::Initial | TriggerKind::Arrival | TriggerKind::Operator => 3,
        TriggerKind::EdgeLost => 2,
        TriggerKind::Infeasible => 1,
        TriggerKind::TimeChanged | TriggerKind::SensorBack => 0,
    }
}

/// The latest vehicle state, as far as planning needs it.
#[derive(Clone, Copy, Debug, Default)]
struct VehicleView<const W: usize> {
    known: bool,
    session: u64,
    seq: u64,
    mission_time_s: f64,
    to_node: usize,
    time_left_s: f64,
    eta_free_s: f64,
    arrivals: u32,
    visited: NodeSet<W>,
}

/// The last published plan.
#[derive(Clone, Copy)]
struct PlanView<const W: usize> {
    route: Route<W>,
    /// `cum_s[i]`: planned time from `route[i]` to the goal, s.
    cum_s: PerNode<f64, W>,
    /// (session, arrivals, to_node) of the vehicle state it answered.
    key: (u64, u32, usize),
}

/// What the operator's commands changed, applied at every re-plan.
#[derive(Clone, Copy, Debug, Default)]
struct OperatorView<const W: usize> {
    /// Plan the quickest path to the goal from now on.
    abort: bool,
    /// Mission time the budget ends at, s (`None`: the vehicle's own budget).
    budget_end_s: Option<f64>,
    /// Waypoints never to plan through.
    removed: NodeSet<W>,
}

/// The answer to one command, kept to answer a repeat of it the same way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AckRecord {
    /// The command's id (0: empty slot).
    pub id: u64,
    /// [`CommandKind`] code (0 when malformed).
    pub kind: u32,
    /// Applied or refused.
    pub status: u32,
    /// [`RefuseReason`] code.
    pub reason: u32,
    /// `seq` of the plan it caused (0: none).
    pub plan_seq: u64,
    /// Re-plan counter of that plan (0: none).
    pub replan: u32,
}

impl AckRecord {
    /// Writes the ack message for this answer at mission time `t`, s.
    pub fn fill(&self, t: f64, m: &mut CommandAck) {
        m.header.mission_time_s = t.max(0.0);
        m.command_id = self.id;
        m.plan_seq = self.plan_seq;
        m.kind = self.kind;
        m.status = self.status;
        m.reason = self.reason;
        m.replan = self.replan;
    }
}

/// Commands remembered for repeats (our choice: far more than an operator
/// sends within a reconnect; the oldest is forgotten first).
const RECENT_COMMANDS: usize = 64;

/// Applied commands whose plan is still to be published.
const PENDING_ACKS: usize = 8;

/// Counters the status message and the report carry.
#[derive(Clone, Copy, Debug, Default)]
pub struct ServiceCounters {
    /// Plans published.
    pub plans: u64,
    /// Triggers seen.
    pub triggers: u64,
    /// Snapshots applied.
    pub sensor_updates: u64,
    /// Snapshots that did not trigger a re-plan (while a plan existed).
    pub updates_without_replan: u64,
    /// Plans published after the deadline.
    pub deadline_misses: u64,
    /// Solves cut by the deadline.
    pub deadline_cuts: u64,
    /// Plans that fell back to the quickest path.
    pub fallbacks: u64,
    /// Triggers with no route at all (goal unreachable): nothing published.
    pub unplannable: u64,
    /// Latest trigger arrival → plan published latency, ns.
    pub last_latency_ns: u64,
    /// Largest trigger arrival → plan published latency, ns.
    pub max_latency_ns: u64,
    /// Solver iterations of the latest plan.
    pub last_iterations: u32,
    /// Solver iterations over all plans.
    pub iterations_total: u64,
    /// Overload figures of the plans cut by the deadline (the anytime path).
    pub cut: CutCounters,
}

/// What cutting solves at the deadline cost (under overload): iterations
/// run against the budget, and the weight of the cut plans against the
/// warm start they began from (the previous plan's remainder: what the
/// vehicle would have followed without the re-plan).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CutCounters {
    /// Solver iterations of the cut plans.
    pub iterations: u64,
    /// Cut plans that had a warm start.
    pub with_warm_start: u64,
    /// Weight of those plans.
    pub weight: f64,
    /// Weight of their warm starts on the same problem.
    pub warm_start_weight: f64,
}

/// Everything a re-plan produced, ready to publish.
#[derive(Clone, Copy, Debug)]
pub struct PlanResult<const W: usize = DEFAULT_WORDS> {
    /// Route from the vehicle's next node to the goal.
    pub route: Route<W>,
    /// Its figures.
    pub eval: RouteEval,
    /// Budget planned for, s.
    pub budget_s: f64,
    /// Why.
    pub trigger: TriggerKind,
    /// `sent_mono_ns` of the trigger.
    pub trigger_sent_ns: u64,
    /// When the trigger was taken off the transport (the deadline's origin), ns.
    pub trigger_received_ns: u64,
    /// Vehicle's mission time of the trigger.
    pub mission_time_s: f64,
    /// Iterations run.
    pub iterations: u32,
    /// Stopped by the deadline.
    pub deadline_cut: bool,
    /// Solver wall time, ns.
    pub solve_ns: u64,
    /// Vehicle state answered.
    pub state_seq: u64,
    /// Snapshot planned on.
    pub epoch: u64,
    /// Re-plan counter.
    pub replan: u32,
}

/// The planner's state between messages, in the capacity class of `W`
/// words (`64 · W` waypoints).
pub struct PlannerCore<const W: usize = DEFAULT_WORDS> {
    cfg: ServiceConfig,
    solver: Box<dyn Solver<W>>,
    problem: Problem<W>,
    snapshot: WaypointSnapshot,
    have_snapshot: bool,
    vehicle: VehicleView<W>,
    plan: Option<PlanView<W>>,
    pending: Option<Pending>,
    counters: ServiceCounters,
    latency_us: Histogram<u64>,
    answered_state: (u64, u64),
    answered_epoch: u64,
    finished: bool,
    warm: Route<W>,
    last_state: Box<VehicleState>,
    /// SCHED_FIFO priority the service thread runs at (0: normal scheduling).
    rt_priority: u32,
    operator: OperatorView<W>,
    /// Answers to the latest commands, a ring.
    recent: [AckRecord; RECENT_COMMANDS],
    recent_next: usize,
    /// Applied commands waiting for the plan they cause.
    pending_acks: [AckRecord; PENDING_ACKS],
}

/// Largest latency the histogram resolves, µs (one minute: anything above is a miss anyway).
const LATENCY_MAX_US: u64 = 60_000_000;

impl<const W: usize> PlannerCore<W> {
    /// Waypoints the core's class holds.
    pub const CAPACITY: usize = nodes_of(W);

    /// A core with every buffer allocated.
    pub fn new(cfg: ServiceConfig, solver: Box<dyn Solver<W>>) -> Self {
        // 3 significant digits over 1 µs..60 s: fixed size, never resized.
        let latency_us =
            Histogram::new_with_bounds(1, LATENCY_MAX_US, 3).unwrap_or_else(|_| Histogram::new(3).unwrap());
        Self {
            cfg,
            solver,
            problem: Problem::new(),
            snapshot: WaypointSnapshot::new(),
            have_snapshot: false,
            vehicle: VehicleView::default(),
            plan: None,
            pending: None,
            counters: ServiceCounters::default(),
            latency_us,
            answered_state: (0, 0),
            answered_epoch: 0,
            finished: false,
            warm: Route::new(),
            last_state: boxed_zeroed(),
            rt_priority: 0,
            operator: OperatorView::default(),
            recent: [AckRecord::default(); RECENT_COMMANDS],
            recent_next: 0,
            pending_acks: [AckRecord::default(); PENDING_ACKS],
        }
    }

    /// Records the scheduling the service thread runs under (the SCHED_FIFO
    /// priority in force, if any), for the status message.
    pub fn set_rt_priority(&mut self, rt_priority: Option<i32>) {
        self.rt_priority = rt_priority.and_then(|p| u32::try_from(p).ok()).unwrap_or(0);
    }

    /// The settings.
    pub fn config(&self) -> &ServiceConfig {
        &self.cfg
    }

    /// The counters.
    pub fn counters(&self) -> &ServiceCounters {
        &self.counters
    }

    /// Trigger arrival → plan published latencies so far, µs.
    pub fn latency_us(&self) -> &Histogram<u64> {
        &self.latency_us
    }

    /// Whether the vehicle reported the end of the mission.
    pub fn finished(&self) -> bool {
        self.finished
    }

    /// Whether a trigger waits for a re-plan.
    pub fn has_pending(&self) -> bool {
        self.pending.is_some()
    }

    /// The latest snapshot applied, if any.
    pub fn snapshot(&self) -> Option<&WaypointSnapshot> {
        self.have_snapshot.then_some(&self.snapshot)
    }

    fn trigger(&mut self, kind: TriggerKind, sent_ns: u64, received_ns: u64, mission_time_s: f64) {
        self.counters.triggers += 1;
        self.pending = Some(match self.pending {
            None => Pending {
                kind,
                sent_ns,
                received_ns,
                mission_time_s,
            },
            Some(p) => Pending {
                kind: if rank(kind) > rank(p.kind) { kind } else { p.kind },
                sent_ns: p.sent_ns.min(sent_ns),
                received_ns: p.received_ns.min(received_ns),
                mission_time_s: p.mission_time_s.max(mission_time_s),
            },
        });
    }

    /// The latest vehicle state accepted, if any.
    pub fn last_state(&self) -> Option<&VehicleState> {
        self.vehicle.known.then_some(&*self.last_state)
    }

    /// What the next plan is computed from: the snapshot in force and the
    /// vehicle's route so far (borrowed, for a plan outbox that needs them).
    pub fn plan_context(&self) -> crate::plan_out::PlanContext<'_> {
        crate::plan_out::PlanContext {
            snapshot: self.snapshot(),
            visited: self
                .last_state()
                .map_or(&[][..], |s| auv_messages::msg::route_ids(&s.route, s.route_len)),
        }
    }

    /// The vehicle's mission time as last reported, s.
    pub fn mission_time_s(&self) -> f64 {
        self.vehicle.mission_time_s
    }

    /// Handles an accepted vehicle state, taken off the transport at `received_ns`.
    pub fn on_state(&mut self, s: &VehicleState, received_ns: u64, events: &mut dyn FnMut(&ServiceEvent)) {
        *self.last_state = *s;
        let mut visited = NodeSet::EMPTY;
        for &id in auv_messages::msg::route_ids(&s.route, s.route_len) {
            // Ids beyond the class are no waypoint of this network (the
            // receiver's rules refuse them; never index past the set).
            if (id as usize) < Self::CAPACITY {
                visited.insert(id as usize);
            }
        }
        let prev = self.vehicle;
        self.vehicle = VehicleView {
            known: true,
            session: s.header.session,
            seq: s.header.seq,
            mission_time_s: s.header.mission_time_s,
            to_node: s.to_node as usize,
            time_left_s: s.time_left_s,
            eta_free_s: s.eta_free_s,
            arrivals: s.arrivals,
            visited,
        };
        let t = s.header.mission_time_s;
        let restarted = prev.known && prev.session != s.header.session;
        if s.outcome != Outcome::Running as u32 {
            if !self.finished {
                self.finished = true;
                if let Some(outcome) = auv_messages::msg::FromCode::from_code(s.outcome) {
                    events(&ServiceEvent::Finished { t, outcome });
                }
            }
            self.pending = None;
            self.answered_state = (s.header.session, s.header.seq);
            return;
        }
        let arrived = prev.known && !restarted && s.arrivals > prev.arrivals;
        let at_goal = self.have_snapshot && s.to_node == self.snapshot.goal;
        if arrived {
            events(&ServiceEvent::Arrival {
                t,
                at: (s.position[0], s.position[1]),
                node: s.to_node,
                tasks: s.tasks_completed,
                weight: s.weight,
                time_left_s: s.time_left_s,
            });
            if !at_goal {
                self.trigger(TriggerKind::Arrival, s.header.sent_mono_ns, received_ns, t);
            }
        } else if !at_goal && self.needs_initial_plan(s) {
            self.trigger(TriggerKind::Initial, s.header.sent_mono_ns, received_ns, t);
        }
        if self.pending.is_none() {
            self.answered_state = (s.header.session, s.header.seq);
        }
    }

    /// A vehicle without a plan gets one, once per (session, arrival, node):
    /// if it rejected our answer, re-planning the same thing would not help.
    fn needs_initial_plan(&self, s: &VehicleState) -> bool {
        let holding = s.mode == VehicleMode::NoPlan as u32 || s.mode == VehicleMode::Holding as u32;
        let key = (s.header.session, s.arrivals, s.to_node as usize);
        holding && self.plan.is_none_or(|p| p.key != key)
    }

    /// Handles an accepted snapshot, taken off the transport at
    /// `received_ns`: keeps a copy and checks whether it invalidates the
    /// current plan.
    pub fn on_snapshot(&mut self, s: &WaypointSnapshot, received_ns: u64, events: &mut dyn FnMut(&ServiceEvent)) {
        // A new sender session is a restarted sensor: re-plan on what it
        // reports even when the usual thresholds would not.
        let sensor_back = self.have_snapshot && s.header.session != self.snapshot.header.session;
        if self.snapshot.copy_snapshot(s).is_err() {
            // Cannot happen: both buffers hold the largest network.
            return;
        }
        self.have_snapshot = true;
        self.counters.sensor_updates += 1;
        let trigger = self
            .sensor_trigger()
            .or_else(|| (sensor_back && self.plan_in_progress()).then_some(TriggerKind::SensorBack));
        if let Some(kind) = trigger {
            self.trigger(kind, s.header.sent_mono_ns, received_ns, self.vehicle.mission_time_s);
        } else if self.plan.is_some() {
            self.counters.updates_without_replan += 1;
        }
        events(&ServiceEvent::SensorUpdate {
            t: s.header.mission_time_s,
            epoch: s.epoch,
            edges: s.edge_count,
            trigger,
        });
        if self.pending.is_none() {
            self.answered_epoch = s.epoch;
        }
    }

    /// Handles an accepted operator command, taken off the transport at
    /// `received_ns`: validates it against the mission (see
    /// [`RefuseReason`]), applies it and triggers a re-plan. Returns the ack
    /// to send now (a refusal, or the stored answer to a repeat); an applied
    /// command's ack waits for its plan ([`PlannerCore::take_acks`]).
    pub fn on_command(
        &mut self,
        c: &OperatorCommand,
        received_ns: u64,
        events: &mut dyn FnMut(&ServiceEvent),
    ) -> Option<AckRecord> {
        let t = self.vehicle.mission_time_s;
        let kind = CommandKind::from_code(c.kind);
        let value = match kind {
            Some(CommandKind::SetTimeBudget) => c.value_s,
            Some(CommandKind::AddTask | CommandKind::RemoveTask) => f64::from(c.node),
            _ => 0.0,
        };
        let repeat = self
            .recent
            .iter()
            .chain(self.pending_acks.iter())
            .find(|r| r.id == c.command_id && r.id != 0)
            .copied();
        if let Some(r) = repeat {
            if let Some(kind) = kind {
                events(&ServiceEvent::Command {
                    t,
                    id: c.command_id,
                    kind,
                    status: AckStatus::from_code(r.status).unwrap_or(AckStatus::Refused),
                    reason: RefuseReason::from_code(r.reason).unwrap_or(RefuseReason::Malformed),
                    value,
                    repeat: true,
                });
            }
            // A repeat of one still waiting for its plan is answered with it.
            return (r.plan_seq != 0 || r.status == AckStatus::Refused as u32).then_some(r);
        }
        let verdict = match kind {
            None => Err(RefuseReason::Malformed),
            Some(k) => self.check_command(k, c),
        };
        let mut rec = AckRecord {
            id: c.command_id,
            kind: kind.map_or(0, |k| k as u32),
            status: AckStatus::Applied as u32,
            reason: RefuseReason::None as u32,
            plan_seq: 0,
            replan: 0,
        };
        if let Some(kind) = kind {
            events(&ServiceEvent::Command {
                t,
                id: c.command_id,
                kind,
                status: if verdict.is_ok() {
                    AckStatus::Applied
                } else {
                    AckStatus::Refused
                },
                reason: verdict.err().unwrap_or(RefuseReason::None),
                value,
                repeat: false,
            });
        }
        match (verdict, kind) {
            (Ok(()), Some(k)) => {
                match k {
                    CommandKind::AbortToGoal => self.operator.abort = true,
                    CommandKind::SetTimeBudget => self.operator.budget_end_s = Some(c.value_s),
                    CommandKind::AddTask => self.operator.removed.remove(c.node as usize),
                    CommandKind::RemoveTask => self.operator.removed.insert(c.node as usize),
                }
                match self.pending_acks.iter_mut().find(|r| r.id == 0) {
                    Some(slot) => *slot = rec,
                    // More applied commands than one plan answers: answer
                    // this one now, without a plan number.
                    None => {
                        self.remember(rec);
                        return Some(rec);
                    }
                }
                self.trigger(TriggerKind::Operator, c.header.sent_mono_ns, received_ns, t);
                None
            }
            (verdict, _) => {
                rec.status = AckStatus::Refused as u32;
                rec.reason = verdict.err().unwrap_or(RefuseReason::Malformed) as u32;
                self.remember(rec);
                Some(rec)
            }
        }
    }

    fn check_command(&self, kind: CommandKind, c: &OperatorCommand) -> Result<(), RefuseReason> {
        if !self.vehicle.known || !self.have_snapshot || self.finished {
            return Err(RefuseReason::NotRunning);
        }
        let v = &self.vehicle;
        match kind {
            CommandKind::AbortToGoal if self.operator.abort => Err(RefuseReason::NoChange),
            CommandKind::AbortToGoal => Ok(()),
            CommandKind::SetTimeBudget => {
                let own = self.snapshot.time_available_s;
                if c.value_s.is_finite() && c.value_s > v.mission_time_s && c.value_s <= own {
                    Ok(())
                } else {
                    Err(RefuseReason::BudgetOutOfRange)
                }
            }
            CommandKind::AddTask | CommandKind::RemoveTask => {
                let id = c.node as usize;
                let s = &self.snapshot;
                if id >= s.node_count as usize || id == s.start as usize || id == s.goal as usize {
                    return Err(RefuseReason::BadWaypoint);
                }
                if v.visited.contains(id) || v.to_node == id {
                    return Err(RefuseReason::AlreadyVisited);
                }
                let removed = self.operator.removed.contains(id);
                if removed == (kind == CommandKind::RemoveTask) {
                    return Err(RefuseReason::NoChange);
                }
                Ok(())
            }
        }
    }

    fn remember(&mut self, rec: AckRecord) {
        self.recent[self.recent_next] = rec;
        self.recent_next = (self.recent_next + 1) % RECENT_COMMANDS;
    }

    /// Whether applied commands wait for their plan.
    pub fn has_pending_acks(&self) -> bool {
        self.pending_acks.iter().any(|r| r.id != 0)
    }

    /// Answers the applied commands waiting for a plan: the plan `plan_seq`
    /// (re-plan `replan`) was published for them, or none could be made (0, 0).
    pub fn take_acks(&mut self, plan_seq: u64, replan: u32, each: &mut dyn FnMut(&AckRecord)) {
        for k in 0..PENDING_ACKS {
            let mut r = self.pending_acks[k];
            if r.id == 0 {
                continue;
            }
            r.plan_seq = plan_seq;
            r.replan = replan;
            self.pending_acks[k] = AckRecord::default();
            self.remember(r);
            each(&r);
        }
    }

    /// Where the vehicle will be free, its budget from there and what to exclude.
    fn planning_frame(&self) -> (usize, f64, NodeSet<W>) {
        let v = &self.vehicle;
        let start = v.to_node;
        let mut excluded = v.visited;
        for id in self.operator.removed.iter() {
            excluded.insert(id);
        }
        excluded.remove(start);
        let time_left = match self.operator.budget_end_s {
            Some(end) => v.time_left_s.min(end - v.mission_time_s),
            None => v.time_left_s,
        };
        // A budget must be > 0; an exhausted one plans the quickest path
        // (which is what an abort to the goal asks for).
        let budget = if self.operator.abort {
            1e-3
        } else {
            (time_left - v.eta_free_s - self.config().reserve_s).max(1e-3)
        };
        (start, budget, excluded)
    }

    /// The part of the last plan from the vehicle's next node on.
    fn remaining_plan(&self) -> Option<(Route<W>, usize)> {
        let p = self.plan.as_ref()?;
        let i = p.route.iter().position(|id| id == self.vehicle.to_node)?;
        let mut r = Route::new();
        for id in p.route.iter().skip(i) {
            r.push(id);
        }
        Some((r, i))
    }

    /// A plan is being followed and something is left to re-plan: nothing
    /// is once the vehicle heads to (or works at) the goal.
    fn plan_in_progress(&self) -> bool {
        let at_goal = self.vehicle.to_node == self.snapshot.goal as usize;
        self.vehicle.known && self.plan.is_some() && !self.finished && !at_goal
    }

    fn sensor_trigger(&mut self) -> Option<TriggerKind> {
        if !self.plan_in_progress() {
            return None;
        }
        let (start, budget, excluded) = self.planning_frame();
        let (rest, i) = self.remaining_plan()?;
        let allowance = &self.cfg.arrival_allowance_s;
        if fill_problem(&self.snapshot, &mut self.problem, start, excluded, budget, allowance).is_err() {
            return Some(TriggerKind::EdgeLost);
        }
        let Some(e) = self.problem.evaluate(&rest) else {
            return Some(TriggerKind::EdgeLost);
        };
        // Heading for the goal by the quickest path: only a lost edge matters.
        if self.operator.abort {
            return None;
        }
        if !e.feasible {
            return Some(TriggerKind::Infeasible);
        }
        let planned = self.plan.as_ref().map_or(e.time_s, |p| p.cum_s[i]);
        ((e.time_s - planned).abs() > self.cfg.replan_threshold_s).then_some(TriggerKind::TimeChanged)
    }

    /// Re-plans for the pending trigger, if there is one and enough is known.
    /// Returns the plan to publish; `Err` when no route joins the vehicle and
    /// the goal (the trigger is answered without a plan).
    pub fn replan(&mut self) -> Option<Result<PlanResult<W>, ProblemError>> {
        let pending = self.pending?;
        if !self.have_snapshot || !self.vehicle.known {
            return None;
        }
        self.pending = None;
        let (start, budget, excluded) = self.planning_frame();
        let answered = (self.vehicle.session, self.vehicle.seq);
        let epoch = self.snapshot.epoch;
        let allowance = &self.cfg.arrival_allowance_s;
        if let Err(e) = fill_problem(&self.snapshot, &mut self.problem, start, excluded, budget, allowance) {
            self.counters.unplannable += 1;
            self.answered_state = answered;
            self.answered_epoch = epoch;
            return Some(Err(e));
        }
        let mut warm_weight = None;
        let rest = self.remaining_plan();
        let warm = match rest.and_then(|(r, _)| self.problem.evaluate(&r).map(|e| (r, e))) {
            Some((r, e)) => {
                warm_weight = e.feasible.then_some(e.weight);
                self.warm = r;
                Some(&self.warm)
            }
            None => None,
        };
        let replan = self.counters.plans as u32 + 1;
        let mut rng = PlannerRng::new(derive_seed(self.cfg.seed, u64::from(replan)));
        let deadline = self.cfg.cut_at_deadline.then(|| {
            let stop_ns = pending
                .received_ns
                .saturating_add((self.cfg.deadline.saturating_sub(self.cfg.publish_margin)).as_nanos() as u64);
            Instant::now() + Duration::from_nanos(stop_ns.saturating_sub(mono_now_ns()))
        });
        let outcome = run(
            self.solver.as_mut(),
            &self.problem,
            &mut rng,
            warm,
            Budget {
                iterations: self.cfg.iterations,
                deadline,
            },
        );
        let (route, eval) = self.solver.best();
        let (route, eval) = (*route, *eval);
        let mut cum_s = PerNode::splat(0.0);
        let mut acc = 0.0;
        for k in (0..route.len().saturating_sub(1)).rev() {
            acc += self.problem.time_s(route.get(k), route.get(k + 1));
            cum_s[k] = acc;
        }
        self.plan = Some(PlanView {
            route,
            cum_s,
            key: (self.vehicle.session, self.vehicle.arrivals, start),
        });
        self.counters.plans += 1;
        self.counters.last_iterations = outcome.iterations;
        self.counters.iterations_total += u64::from(outcome.iterations);
        let deadline_cut = outcome.stop == StopReason::Deadline;
        self.counters.deadline_cuts += u64::from(deadline_cut);
        if deadline_cut {
            let c = &mut self.counters.cut;
            c.iterations += u64::from(outcome.iterations);
            if let Some(w) = warm_weight {
                c.with_warm_start += 1;
                c.weight += eval.weight;
                c.warm_start_weight += w;
            }
        }
        self.counters.fallbacks += u64::from(!eval.feasible);
        self.answered_state = answered;
        self.answered_epoch = epoch;
        Some(Ok(PlanResult {
            route,
            eval,
            budget_s: budget,
            trigger: pending.kind,
            trigger_sent_ns: pending.sent_ns,
            trigger_received_ns: pending.received_ns,
            mission_time_s: pending.mission_time_s,
            iterations: outcome.iterations,
            deadline_cut,
            solve_ns: outcome.elapsed.as_nanos() as u64,
            state_seq: answered.1,
            epoch,
            replan,
        }))
    }

    /// Writes a plan message for `r` (header's mission time included).
    pub fn fill_plan(&self, r: &PlanResult<W>, m: &mut Plan) {
        m.header.mission_time_s = r.mission_time_s.max(0.0);
        m.state_seq = r.state_seq;
        m.snapshot_epoch = r.epoch;
        m.trigger_sent_mono_ns = r.trigger_sent_ns;
        m.trigger_received_mono_ns = r.trigger_received_ns;
        m.compute_ns = mono_now_ns().saturating_sub(r.trigger_received_ns);
        m.solve_ns = r.solve_ns;
        m.time_s = r.eval.time_s;
        m.weight = r.eval.weight;
        m.distance_m = r.eval.distance_m;
        m.budget_s = r.budget_s;
        m.trigger = r.trigger as u32;
        m.iterations = r.iterations;
        m.deadline_cut = u32::from(r.deadline_cut);
        m.feasible = u32::from(r.eval.feasible);
        m.fallback = u32::from(!r.eval.feasible);
        m.replan = r.replan;
        m.route_len = r.route.len() as u32;
        let ids = r.route.ids();
        m.route[..ids.len()].copy_from_slice(ids);
    }

    /// Records that the plan for `r` was published at `published_ns`.
    pub fn published(&mut self, r: &PlanResult<W>, published_ns: u64, events: &mut dyn FnMut(&ServiceEvent)) {
        // The deadline's latency: trigger arrival → plan published.
        let latency = published_ns.saturating_sub(r.trigger_received_ns);
        self.counters.last_latency_ns = latency;
        self.counters.max_latency_ns = self.counters.max_latency_ns.max(latency);
        if latency > self.cfg.deadline.as_nanos() as u64 {
            self.counters.deadline_misses += 1;
        }
        let us = (latency / 1000).clamp(1, LATENCY_MAX_US);
        let _ = self.latency_us.record(us);
        let at = (self.last_state.position[0], self.last_state.position[1]);
        events(&ServiceEvent::Plan {
            t: r.mission_time_s,
            replan: r.replan,
            trigger: r.trigger,
            // Every class fits the largest.
            route: r.route.to_class().unwrap_or_default(),
            eval: r.eval,
            budget_s: r.budget_s,
            iterations: r.iterations,
            deadline_cut: r.deadline_cut,
            at,
        });
    }

    /// Writes the status message (header's mission time included).
    pub fn fill_status(&self, rejected: &RejectCounters, m: &mut PlannerStatus) {
        let c = &self.counters;
        m.header.mission_time_s = self.vehicle.mission_time_s.max(0.0);
        m.handled_state_session = self.answered_state.0;
        m.handled_state_seq = self.answered_state.1;
        m.handled_epoch = self.answered_epoch;
        m.plans = c.plans;
        m.triggers = c.triggers;
        m.sensor_updates = c.sensor_updates;
        m.updates_without_replan = c.updates_without_replan;
        m.deadline_misses = c.deadline_misses;
        m.deadline_cuts = c.deadline_cuts;
        m.fallbacks = c.fallbacks;
        m.last_latency_ns = c.last_latency_ns;
        m.max_latency_ns = c.max_latency_ns;
        m.deadline_ns = self.cfg.deadline.as_nanos() as u64;
        m.alloc = super::alloc::counters();
        m.rejected = rejected.0;
        m.iterations_total = c.iterations_total;
        // The process's own latency distribution and anytime costs travel
        // with every status, so a supervisor sees them without sharing memory
        // with the service (quantiles of the histogram: no allocation).
        let (p50, p99) = if self.latency_us.is_empty() {
            (0, 0)
        } else {
            (
                self.latency_us.value_at_quantile(0.5),
                self.latency_us.value_at_quantile(0.99),
            )
        };
        m.latency_p50_ns = p50.saturating_mul(1000);
        m.latency_p99_ns = p99.saturating_mul(1000);
        m.cut_iterations = c.cut.iterations;
        m.cut_with_warm_start = c.cut.with_warm_start;
        m.cut_weight = c.cut.weight;
        m.cut_warm_start_weight = c.cut.warm_start_weight;
        m.last_iterations = c.last_iterations;
        m.rt_priority = self.rt_priority;
        m.phase = if self.finished {
            PlannerPhase::Finished
        } else if self.plan.is_some() {
            PlannerPhase::Running
        } else {
            PlannerPhase::Waiting
        } as u32;
    }

    /// The objective of the latest snapshot (max_weight before any).
    pub fn objective(&self) -> auv_core::instance::Objective {
        objective(&self.snapshot)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::standin::RandomKeySearch;
    use auv_core::fixtures::random_instance;
    use auv_messages::msg::{Header, VehicleEvent};
    use auv_messages::network::write_snapshot;

    fn snapshot(inst: &auv_core::instance::Instance, epoch: u64) -> WaypointSnapshot {
        let mut s = WaypointSnapshot::new();
        write_snapshot(inst, epoch, &mut s).unwrap();
        s.header = Header {
            seq: epoch + 1,
            session: 1,
            fingerprint: 0,
            sent_mono_ns: mono_now_ns(),
            mission_time_s: 60.0 * epoch as f64,
        };
        s
    }

    fn state(seq: u64, to: u32, arrivals: u32, visited: &[u16], time_left: f64) -> VehicleState {
        // SAFETY-free: a zeroed state via the message helper.
        let mut s = *boxed_zeroed::<VehicleState>();
        s.header = Header {
            seq,
            session: 2,
            fingerprint: 0,
            sent_mono_ns: mono_now_ns(),
            mission_time_s: 31_000.0 - time_left,
        };
        s.to_node = to;
        s.from_node = to;
        s.arrivals = arrivals;
        s.time_left_s = time_left;
        s.mode = if arrivals == 0 {
            VehicleMode::NoPlan
        } else {
            VehicleMode::Working
        } as u32;
        s.event = VehicleEvent::Arrival as u32;
        s.route_len = visited.len() as u32;
        s.route[..visited.len()].copy_from_slice(visited);
        s
    }

    fn core() -> PlannerCore {
        let cfg = ServiceConfig {
            cut_at_deadline: false,
            iterations: 20,
            ..ServiceConfig::default()
        };
        PlannerCore::new(cfg, Box::new(RandomKeySearch::new(10)))
    }

    /// A core that has planned from node 0 on `inst` (snapshot epoch 0) and
    /// published that plan.
    fn core_with_first_plan(inst: &auv_core::instance::Instance) -> (PlannerCore, PlanResult) {
        let mut c = core();
        let mut sink = |_: &ServiceEvent| {};
        c.on_snapshot(&snapshot(inst, 0), mono_now_ns(), &mut sink);
        c.on_state(&state(1, 0, 0, &[0], 20_000.0), mono_now_ns(), &mut sink);
        let r = c.replan().unwrap().unwrap();
        c.published(&r, mono_now_ns(), &mut sink);
        (c, r)
    }

    #[test]
    fn first_plan_waits_for_both_inputs_then_starts_at_the_vehicle() {
        let inst = random_instance(20, 0.35, 20_000.0, 7);
        let mut c = core();
        let mut log = Vec::new();
        c.on_state(&state(1, 0, 0, &[0], 20_000.0), mono_now_ns(), &mut |e| log.push(*e));
        assert!(c.has_pending());
        assert!(c.replan().is_none(), "no snapshot yet");
        c.on_snapshot(&snapshot(&inst, 0), mono_now_ns(), &mut |e| log.push(*e));
        let r = c.replan().unwrap().unwrap();
        assert_eq!(r.trigger, TriggerKind::Initial);
        assert_eq!(r.route.get(0), 0);
        assert_eq!(r.route.last(), Some(inst.goal));
        assert!(r.eval.feasible);
        assert!(!c.has_pending());
    }

    #[test]
    fn plans_hold_the_reserve_back_from_the_time_left() {
        let inst = random_instance(20, 0.35, 20_000.0, 7);
        for reserve_s in [0.0, 1_500.0] {
            let cfg = ServiceConfig {
                cut_at_deadline: false,
                iterations: 20,
                reserve_s,
                ..ServiceConfig::default()
            };
            let mut c = PlannerCore::new(cfg, Box::new(RandomKeySearch::new(10)));
            let mut sink = |_: &ServiceEvent| {};
            c.on_snapshot(&snapshot(&inst, 0), mono_now_ns(), &mut sink);
            c.on_state(&state(1, 0, 0, &[0], 20_000.0), mono_now_ns(), &mut sink);
            let r = c.replan().unwrap().unwrap();
            assert_eq!(r.budget_s, 20_000.0 - reserve_s);
            assert!(r.eval.time_s <= 20_000.0 - reserve_s);
        }
    }

    #[test]
    fn arrival_replans_from_the_node_excluding_visited_ones() {
        let inst = random_instance(20, 0.35, 20_000.0, 8);
        let mut c = core();
        let mut sink = |_: &ServiceEvent| {};
        c.on_snapshot(&snapshot(&inst, 0), mono_now_ns(), &mut sink);
        c.on_state(&state(1, 0, 0, &[0], 20_000.0), mono_now_ns(), &mut sink);
        let first = c.replan().unwrap().unwrap();
        let next = first.route.get(1) as u32;
        c.published(&first, mono_now_ns(), &mut sink);
        // Periodic state, no arrival: no trigger.
        let mut s = state(2, next, 0, &[0], 19_000.0);
        s.mode = VehicleMode::Travelling as u32;
        c.on_state(&s, mono_now_ns(), &mut sink);
        assert!(!c.has_pending());
        c.on_state(
            &state(3, next, 1, &[0, next as u16], 18_000.0),
            mono_now_ns(),
            &mut sink,
        );
        let r = c.replan().unwrap().unwrap();
        assert_eq!(r.trigger, TriggerKind::Arrival);
        assert_eq!(r.route.get(0), next as usize);
        assert!(r.route.iter().all(|id| id != 0), "visited node 0 reused: {:?}", r.route);
    }

    #[test]
    fn a_snapshot_that_removes_a_plan_edge_triggers_and_one_that_changes_nothing_does_not() {
        let inst = random_instance(20, 0.35, 20_000.0, 9);
        let (mut c, r) = core_with_first_plan(&inst);
        let mut sink = |_: &ServiceEvent| {};
        c.on_snapshot(&snapshot(&inst, 1), mono_now_ns(), &mut sink);
        assert!(!c.has_pending(), "an identical network must not re-plan");
        assert_eq!(c.counters().updates_without_replan, 1);
        let (a, b) = (r.route.get(0), r.route.get(1));
        let mut cut = inst.clone();
        cut.edges
            .retain(|e| !((e.a == a && e.b == b) || (e.a == b && e.b == a)));
        c.on_snapshot(&snapshot(&cut, 2), mono_now_ns(), &mut sink);
        let r2 = c.replan().unwrap().unwrap();
        assert_eq!(r2.trigger, TriggerKind::EdgeLost);
        assert!(r2.route.len() < 2 || (r2.route.get(0), r2.route.get(1)) != (a, b));
    }

    #[test]
    fn a_restarted_sensor_triggers_a_replan_on_its_first_snapshot() {
        let inst = random_instance(20, 0.35, 20_000.0, 9);
        let (mut c, _) = core_with_first_plan(&inst);
        let mut sink = |_: &ServiceEvent| {};
        // The same network from the same sensor: nothing to do.
        c.on_snapshot(&snapshot(&inst, 1), mono_now_ns(), &mut sink);
        assert!(!c.has_pending());
        // The same network from a new sensor session (a restart): re-plan.
        let mut back = snapshot(&inst, 1);
        back.header.session = 7;
        back.header.seq = 1;
        c.on_snapshot(&back, mono_now_ns(), &mut sink);
        let r2 = c.replan().unwrap().unwrap();
        assert_eq!(r2.trigger, TriggerKind::SensorBack);
        assert!(r2.eval.feasible);
        // Its next snapshot is ordinary again.
        c.published(&r2, mono_now_ns(), &mut sink);
        let mut next = snapshot(&inst, 2);
        next.header.session = 7;
        c.on_snapshot(&next, mono_now_ns(), &mut sink);
        assert!(!c.has_pending());
    }

    #[test]
    fn copying_a_snapshot_keeps_every_field_in_use() {
        let inst = random_instance(15, 0.4, 9_000.0, 4);
        let mut src = snapshot(&inst, 3);
        src.next_update_s = 240.0;
        src.phi1 = 0.5;
        let mut dst = WaypointSnapshot::new();
        dst.copy_snapshot(&src).unwrap();
        assert_eq!(dst.header, src.header);
        assert_eq!((dst.epoch, dst.next_update_s, dst.phi1), (3, 240.0, 0.5));
        assert_eq!(
            auv_messages::network::to_instance(&dst, "x"),
            auv_messages::network::to_instance(&src, "x")
        );
    }

    #[test]
    fn nothing_is_replanned_once_the_vehicle_is_at_the_goal() {
        let inst = random_instance(20, 0.35, 20_000.0, 8);
        let (mut c, _) = core_with_first_plan(&inst);
        let mut sink = |_: &ServiceEvent| {};
        let goal = inst.goal as u32;
        c.on_state(&state(2, goal, 1, &[0, goal as u16], 1_000.0), mono_now_ns(), &mut sink);
        assert!(!c.has_pending(), "an arrival at the goal needs no plan");
        let mut cut = inst.clone();
        cut.edges.clear();
        c.on_snapshot(&snapshot(&cut, 1), mono_now_ns(), &mut sink);
        assert!(!c.has_pending(), "a network change at the goal needs no plan");
    }

    fn command(id: u64, kind: CommandKind, value_s: f64, node: u32) -> OperatorCommand {
        let mut c = *boxed_zeroed::<OperatorCommand>();
        c.header.seq = id;
        c.command_id = id;
        c.kind = kind as u32;
        c.value_s = value_s;
        c.node = node;
        c
    }

    #[test]
    fn commands_are_refused_with_a_reason_before_the_mission_and_when_out_of_range() {
        let inst = random_instance(20, 0.35, 20_000.0, 7);
        let mut c = core();
        let mut log = Vec::new();
        let r = c.on_command(&command(1, CommandKind::AbortToGoal, 0.0, 0), mono_now_ns(), &mut |e| {
            log.push(*e)
        });
        assert_eq!(r.map(|r| r.reason), Some(RefuseReason::NotRunning as u32));
        let (mut c, first) = core_with_first_plan(&inst);
        let mut sink = |_: &ServiceEvent| {};
        let goal = inst.goal as u32;
        let off_plan = (1..inst.nodes.len() as u32 - 1)
            .find(|n| !first.route.iter().any(|id| id as u32 == *n))
            .unwrap();
        for (cmd, why) in [
            (
                command(2, CommandKind::SetTimeBudget, 1e9, 0),
                RefuseReason::BudgetOutOfRange,
            ),
            (
                command(3, CommandKind::SetTimeBudget, 0.5, 0),
                RefuseReason::BudgetOutOfRange,
            ),
            (
                command(4, CommandKind::RemoveTask, 0.0, goal),
                RefuseReason::BadWaypoint,
            ),
            (command(5, CommandKind::RemoveTask, 0.0, 0), RefuseReason::BadWaypoint),
            (command(6, CommandKind::RemoveTask, 0.0, 99), RefuseReason::BadWaypoint),
            (command(7, CommandKind::AddTask, 0.0, off_plan), RefuseReason::NoChange),
            (
                OperatorCommand {
                    kind: 99,
                    ..command(8, CommandKind::AbortToGoal, 0.0, 0)
                },
                RefuseReason::Malformed,
            ),
        ] {
            let r = c.on_command(&cmd, mono_now_ns(), &mut sink).expect("an answer now");
            assert_eq!((r.status, r.reason), (AckStatus::Refused as u32, why as u32), "{cmd:?}");
            assert!(!c.has_pending(), "a refused command changes nothing");
        }
        assert!(log.iter().all(|e| matches!(
            e,
            ServiceEvent::Command {
                status: AckStatus::Refused,
                ..
            }
        )));
    }

    #[test]
    fn an_applied_command_replans_is_acked_with_its_plan_and_a_repeat_is_not_applied_again() {
        let inst = random_instance(20, 0.35, 20_000.0, 7);
        let (mut c, first) = core_with_first_plan(&inst);
        let mut log = Vec::new();
        let off = first.route.get(2) as u32;
        let cmd = command(11, CommandKind::RemoveTask, 0.0, off);
        assert_eq!(
            c.on_command(&cmd, mono_now_ns(), &mut |e| log.push(*e)),
            None,
            "the ack waits for the plan"
        );
        assert!(c.has_pending() && c.has_pending_acks());
        // The same id while its plan is being made: still one command.
        assert_eq!(c.on_command(&cmd, mono_now_ns(), &mut |e| log.push(*e)), None);
        let r = c.replan().unwrap().unwrap();
        assert_eq!(r.trigger, TriggerKind::Operator);
        assert!(
            r.route.iter().all(|id| id as u32 != off),
            "{:?} passes the removed {off}",
            r.route
        );
        let mut acks = Vec::new();
        c.take_acks(77, r.replan, &mut |a| acks.push(*a));
        assert_eq!(acks.len(), 1);
        assert_eq!(
            (acks[0].id, acks[0].plan_seq, acks[0].status),
            (11, 77, AckStatus::Applied as u32)
        );
        assert!(!c.has_pending_acks());
        // After a reconnect the console sends it again: the same answer, nothing re-planned.
        let again = c
            .on_command(&cmd, mono_now_ns(), &mut |e| log.push(*e))
            .expect("answered at once");
        assert_eq!(again, acks[0]);
        assert!(!c.has_pending());
        let repeats = log
            .iter()
            .filter(|e| matches!(e, ServiceEvent::Command { repeat: true, .. }))
            .count();
        assert_eq!(repeats, 2);
    }

    #[test]
    fn abort_plans_the_quickest_path_and_a_budget_caps_the_plans() {
        let inst = random_instance(20, 0.35, 20_000.0, 7);
        let (mut c, _) = core_with_first_plan(&inst);
        let mut sink = |_: &ServiceEvent| {};
        assert_eq!(
            c.on_command(
                &command(21, CommandKind::SetTimeBudget, 12_000.0, 0),
                mono_now_ns(),
                &mut sink
            ),
            None
        );
        let r = c.replan().unwrap().unwrap();
        // The vehicle has used 11 000 s of 31 000: 1 000 s are left of 12 000.
        assert!(r.budget_s <= 12_000.0 - 11_000.0, "{}", r.budget_s);
        assert_eq!(
            c.on_command(&command(22, CommandKind::AbortToGoal, 0.0, 0), mono_now_ns(), &mut sink),
            None
        );
        let r = c.replan().unwrap().unwrap();
        assert_eq!(r.route.last(), Some(inst.goal));
        assert!(r.budget_s < 0.01, "{}", r.budget_s);
        let again = c.on_command(&command(23, CommandKind::AbortToGoal, 0.0, 0), mono_now_ns(), &mut sink);
        assert_eq!(again.map(|a| a.reason), Some(RefuseReason::NoChange as u32));
    }

    #[test]
    fn same_seed_same_plans() {
        let inst = random_instance(25, 0.3, 15_000.0, 10);
        let plans = || {
            let mut c = core();
            let mut sink = |_: &ServiceEvent| {};
            c.on_snapshot(&snapshot(&inst, 0), mono_now_ns(), &mut sink);
            c.on_state(&state(1, 0, 0, &[0], 15_000.0), mono_now_ns(), &mut sink);
            c.replan().unwrap().unwrap().route
        };
        assert_eq!(plans(), plans());
    }
}
