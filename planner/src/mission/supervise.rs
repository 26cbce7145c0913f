//! What the mission's supervisor watches and injects: a passive monitor of
//! the three topics (liveness by last-message age, the planner's counters
//! by session), and the fault plan (SIGKILL, SIGSTOP/SIGCONT) that
//! `planner mission --faults` and `planner soak` inject.
//!
//! Contract:
//! - The monitor only subscribes (it never publishes, so it changes nothing
//!   the others see); liveness is the age of a process's last message, and a
//!   process silent for longer than its timeout is reported once per
//!   silence (a *stall*), and again when it is heard from (*recovered*).
//!   Expected message rates (scaled time): vehicle 20 Hz, planner status
//!   every 250 ms when idle, sensor one snapshot per sensor period of
//!   mission time. Stall detection runs in scaled time only: in lockstep
//!   every process waits for the others, so silence names no culprit.
//! - Faults are drawn from the fault seed only ([`plan_faults`]): same seed,
//!   same kinds, targets and mission times. They are injected one at a time,
//!   the next only after the previous one was cleared (restarted process
//!   heard from again, paused process continued).
//! - The planner's counters restart with each planner process; the monitor
//!   keeps each session's latest status and sums them.

use std::time::{Duration, Instant};

use serde_json::{Value, json};

use auv_core::rng::PlannerRng;
use auv_messages::msg::{
    AllocCounters, PlannerStatus, REJECT_KINDS, RejectCounters, Validate, VehicleState, WaypointSnapshot,
};
use auv_transport::ipc::{IpcContext, IpcInbox, IpcSnapshotInbox, Shm};
use auv_transport::{Inbox, IpcOptions, SetupError};

/// A supervised process.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Proc {
    /// `planner serve`.
    Planner = 0,
    /// `sensor-sim`.
    Sensor = 1,
    /// `vehicle-sim`.
    Vehicle = 2,
}

impl Proc {
    /// All three, in index order.
    pub const ALL: [Proc; 3] = [Proc::Planner, Proc::Sensor, Proc::Vehicle];

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Planner => "planner",
            Self::Sensor => "sensor-sim",
            Self::Vehicle => "vehicle-sim",
        }
    }
}

/// What is done to a process.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FaultKind {
    /// SIGKILL, then a restart.
    Kill,
    /// SIGSTOP, then SIGCONT after the pause.
    Pause,
}

impl FaultKind {
    /// snake_case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Kill => "kill",
            Self::Pause => "pause",
        }
    }
}

/// One planned fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fault {
    /// Mission time to inject it at, s.
    pub at_s: f64,
    /// The target.
    pub target: Proc,
    /// What.
    pub kind: FaultKind,
}

impl Fault {
    /// `kill_planner`, `pause_sensor-sim`, …: the key of its kind in reports.
    pub fn key(&self) -> String {
        format!("{}_{}", self.kind.name(), self.target.name())
    }
}

/// `n` faults at random mission times in [5 %, 75 %] of `budget_s`, in
/// time order, targets and kinds drawn uniformly from `targets` × {kill,
/// pause} (the late quarter is left fault-free so a mission can end).
pub fn plan_faults(seed: u64, n: usize, budget_s: f64, targets: &[Proc]) -> Vec<Fault> {
    let mut rng = PlannerRng::new(seed ^ 0xFA17_FA17_FA17_FA17);
    if targets.is_empty() {
        return Vec::new();
    }
    let mut v: Vec<Fault> = (0..n)
        .map(|_| {
            let at_s = budget_s * (0.05 + 0.70 * rng.next_f64());
            let target = targets[rng.below(targets.len() as u32) as usize];
            let kind = if rng.next_f64() < 0.5 {
                FaultKind::Kill
            } else {
                FaultKind::Pause
            };
            Fault { at_s, target, kind }
        })
        .collect();
    v.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    v
}

/// What the monitor saw of one process.
#[derive(Clone, Copy, Debug, Default)]
struct Liveness {
    last: Option<Instant>,
    stalled_since: Option<Instant>,
}

/// A stall or a recovery, for the fault log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LivenessEvent {
    /// `proc` has been silent for `silent` (longer than its timeout).
    Stalled {
        /// Who.
        proc: Proc,
        /// Silent for this long when detected.
        silent: Duration,
    },
    /// `proc` was heard from again after `silent`.
    Recovered {
        /// Who.
        proc: Proc,
        /// How long it was silent.
        silent: Duration,
    },
}

/// The passive topic monitor.
pub struct Monitor {
    _ctx: IpcContext<Shm>,
    states: IpcInbox<Shm, VehicleState>,
    snapshots: IpcSnapshotInbox<Shm>,
    status: IpcInbox<Shm, PlannerStatus>,
    live: [Liveness; 3],
    timeouts: [Duration; 3],
    /// Latest status per planner session, in order of first sight.
    sessions: Vec<PlannerStatus>,
    last_state: Option<VehicleState>,
    /// What the vehicle announced on the wire: the longest route any state
    /// carried and the most tasks any state counted.
    announced: Announced,
    last_epoch: u64,
    /// The run's scenario: messages from elsewhere, or malformed ones (bad
    /// input injected for tests), are not signs of life.
    fingerprint: u64,
}

impl Monitor {
    /// Subscribes to the three topics of the run `opts` describes; a process
    /// silent for longer than `timeouts[proc]` is stalled.
    pub fn new(opts: &IpcOptions, timeouts: [Duration; 3], fingerprint: u64) -> Result<Self, SetupError> {
        let ctx = IpcContext::<Shm>::new(opts, "supervisor")?;
        Ok(Self {
            states: ctx.inbox()?,
            snapshots: ctx.snapshot_inbox()?,
            status: ctx.inbox()?,
            _ctx: ctx,
            live: [Liveness::default(); 3],
            timeouts,
            sessions: Vec::new(),
            last_state: None,
            announced: Announced::default(),
            last_epoch: 0,
            fingerprint,
        })
    }

    /// Drains the topics and checks liveness; liveness events go to `out`.
    /// `watch[proc]`: whether `proc` should be talking now (running, not
    /// being restarted, mission not over).
    pub fn poll(&mut self, watch: [bool; 3], out: &mut Vec<LivenessEvent>) {
        let now = Instant::now();
        let mut heard = [false; 3];
        let fp = self.fingerprint;
        let good = |h: &auv_messages::msg::Header, valid: Result<(), auv_messages::msg::RejectKind>| {
            h.fingerprint == fp && valid.is_ok()
        };
        let mut last_state = self.last_state;
        let announced = &mut self.announced;
        let _ = self.states.drain(&mut |s: &VehicleState| {
            if good(&s.header, s.validate()) {
                heard[Proc::Vehicle as usize] = true;
                last_state = Some(*s);
                announced.add(s);
            }
        });
        self.last_state = last_state;
        let mut epoch = self.last_epoch;
        let _ = self.snapshots.drain(&mut |s: &WaypointSnapshot| {
            if good(&s.header, s.validate()) {
                heard[Proc::Sensor as usize] = true;
                epoch = epoch.max(s.epoch);
            }
        });
        self.last_epoch = epoch;
        let sessions = &mut self.sessions;
        let _ = self.status.drain(&mut |s: &PlannerStatus| {
            if !good(&s.header, s.validate()) {
                return;
            }
            heard[Proc::Planner as usize] = true;
            match sessions.iter_mut().find(|x| x.header.session == s.header.session) {
                Some(prev) => *prev = *s,
                None => sessions.push(*s),
            }
        });
        for p in Proc::ALL {
            let l = &mut self.live[p as usize];
            if heard[p as usize] {
                if let Some(since) = l.stalled_since.take() {
                    out.push(LivenessEvent::Recovered {
                        proc: p,
                        silent: now.duration_since(since) + self.timeouts[p as usize],
                    });
                }
                l.last = Some(now);
                continue;
            }
            if !watch[p as usize] {
                continue;
            }
            if let Some(last) = l.last
                && l.stalled_since.is_none()
                && now.duration_since(last) > self.timeouts[p as usize]
            {
                l.stalled_since = Some(now);
                out.push(LivenessEvent::Stalled {
                    proc: p,
                    silent: now.duration_since(last),
                });
            }
        }
    }

    /// Forgets `p`'s last message (it is being restarted: its silence until
    /// its first message is start-up, not a stall).
    pub fn forget(&mut self, p: Proc) {
        self.live[p as usize] = Liveness::default();
    }

    /// Whether `p` has been heard from since it was last forgotten.
    pub fn heard(&self, p: Proc) -> bool {
        self.live[p as usize].last.is_some()
    }

    /// How long `p` has been in a reported stall (`None`: it is not).
    pub fn stalled_for(&self, p: Proc) -> Option<Duration> {
        self.live[p as usize].stalled_since.map(|t| t.elapsed())
    }

    /// Whether `p` is in a reported stall now.
    pub fn stalled(&self, p: Proc) -> bool {
        self.live[p as usize].stalled_since.is_some()
    }

    /// The vehicle's latest state.
    pub fn last_state(&self) -> Option<&VehicleState> {
        self.last_state.as_ref()
    }

    /// What the vehicle announced on the wire.
    pub fn announced(&self) -> &Announced {
        &self.announced
    }

    /// The latest snapshot epoch seen.
    pub fn last_epoch(&self) -> u64 {
        self.last_epoch
    }

    /// Planner processes seen (one status session each).
    pub fn planner_sessions(&self) -> usize {
        self.sessions.len()
    }

    /// The planner's counters summed over its sessions. Latency quantiles
    /// come from each process's own histogram: exact with one planner
    /// process; after restarts, the largest of the processes' quantiles (an
    /// upper bound: summaries of separate histograms do not merge exactly).
    pub fn planner_totals(&self) -> PlannerTotals {
        let mut t = PlannerTotals {
            rt_priority: self
                .sessions
                .iter()
                .map(|s| s.rt_priority)
                .min()
                .filter(|&p| p > 0)
                .and_then(|p| i32::try_from(p).ok()),
            ..PlannerTotals::default()
        };
        let mut cut = auv_service::core::CutCounters::default();
        for s in &self.sessions {
            t.plans += s.plans;
            t.sensor_updates += s.sensor_updates;
            t.deadline_misses += s.deadline_misses;
            t.deadline_cuts += s.deadline_cuts;
            t.fallbacks += s.fallbacks;
            t.iterations_total += s.iterations_total;
            t.max_latency_us = t.max_latency_us.max(s.max_latency_ns / 1000);
            let mut r = RejectCounters::default();
            r.0.copy_from_slice(&s.rejected[..REJECT_KINDS]);
            t.rejected.merge(&r);
            t.alloc.sys_allocs_total += s.alloc.sys_allocs_total;
            t.alloc.sys_allocs_steady += s.alloc.sys_allocs_steady;
            t.alloc.sys_frees_steady += s.alloc.sys_frees_steady;
            t.alloc.pool_allocs_steady += s.alloc.pool_allocs_steady;
            t.alloc.pool_high_water = t.alloc.pool_high_water.max(s.alloc.pool_high_water);
            t.alloc.pool_capacity = t.alloc.pool_capacity.max(s.alloc.pool_capacity);
            t.alloc.pool_misses += s.alloc.pool_misses;
            t.alloc.steady = t.alloc.steady.max(s.alloc.steady);
            t.latency_us.0 = t.latency_us.0.max(s.latency_p50_ns / 1000);
            t.latency_us.1 = t.latency_us.1.max(s.latency_p99_ns / 1000);
            cut.iterations += s.cut_iterations;
            cut.with_warm_start += s.cut_with_warm_start;
            cut.weight += s.cut_weight;
            cut.warm_start_weight += s.cut_warm_start_weight;
        }
        t.latency_us.2 = t.max_latency_us;
        t.latency_sessions = self.sessions.iter().filter(|s| s.plans > 0).count();
        t.cut = Some(cut);
        t
    }
}

/// What the vehicle's states announced over the whole run (all its
/// processes): every arrival and task a state reported had been acted on,
/// so it must be in the journal, which is written before each publish.
#[derive(Clone, Debug, Default)]
pub struct Announced {
    /// The longest route a state carried.
    pub route: Vec<usize>,
    /// The most tasks a state counted.
    pub tasks: u32,
}

impl Announced {
    fn add(&mut self, s: &VehicleState) {
        let route = auv_messages::msg::route_ids(&s.route, s.route_len);
        if route.len() > self.route.len() {
            self.route = route.iter().map(|&b| usize::from(b)).collect();
        }
        self.tasks = self.tasks.max(s.tasks_completed);
    }

    /// Announced events the journal does not have: arrivals past the part
    /// of the announced route the journal's route agrees with, and tasks
    /// beyond the journal's count.
    pub fn missing_from(&self, journal_route: &[usize], journal_tasks: u32) -> u64 {
        let common = self.route.iter().zip(journal_route).take_while(|(a, b)| a == b).count();
        (self.route.len() - common) as u64 + u64::from(self.tasks.saturating_sub(journal_tasks))
    }
}

/// The planner's counters over all its processes.
#[derive(Clone, Copy, Debug, Default)]
pub struct PlannerTotals {
    /// Plans published.
    pub plans: u64,
    /// Snapshots applied.
    pub sensor_updates: u64,
    /// Plans published after the deadline.
    pub deadline_misses: u64,
    /// Solves cut by the deadline.
    pub deadline_cuts: u64,
    /// Quickest-path fallbacks.
    pub fallbacks: u64,
    /// Solver iterations.
    pub iterations_total: u64,
    /// Largest latency, µs.
    pub max_latency_us: u64,
    /// Latency p50, p99, max, µs (see [`Monitor::planner_totals`]).
    pub latency_us: (u64, u64, u64),
    /// Planner processes whose plans the latency figures summarise.
    pub latency_sessions: usize,
    /// Rejected input by kind.
    pub rejected: RejectCounters,
    /// Allocation counters, summed over the planner's processes.
    pub alloc: AllocCounters,
    /// What the deadline cuts cost (`None`: no status seen).
    pub cut: Option<auv_service::core::CutCounters>,
    /// SCHED_FIFO priority every planner process ran its service thread at
    /// (the lowest; `None` when one ran on normal scheduling or none reported).
    pub rt_priority: Option<i32>,
}

/// What the faults of one mission came to.
#[derive(Clone, Debug, Default)]
pub struct FaultReport {
    /// Faults planned.
    pub planned: Vec<Fault>,
    /// Faults injected, by key (`kill_planner`, …).
    pub injected: std::collections::BTreeMap<String, u64>,
    /// Faults the mission came through, by key: a killed process restarted
    /// and heard from again, a paused one detected and heard from again.
    pub cleared: std::collections::BTreeMap<String, u64>,
    /// SIGSTOP → stall detected, ms: the largest.
    pub detect_ms_max: f64,
    /// The stall timeouts, ms, by process.
    pub timeouts_ms: [f64; 3],
    /// Faults not injected because their turn came too late in the
    /// mission (after [`LATEST_INJECTION`] of the budget).
    pub skipped_late: u64,
}

/// Share of the time budget after which no fault is injected any more
/// (faults wait for the previous one to clear, so late ones can bunch up
/// against the mission's end, where there is no time left to clear them).
pub const LATEST_INJECTION: f64 = 0.85;

impl FaultReport {
    /// Faults injected.
    pub fn injected_total(&self) -> u64 {
        self.injected.values().sum()
    }

    /// The report's `faults` object. `survived`: whether the mission still
    /// ended normally; then every fault injected was survived. `cleared` is
    /// the stronger record: the restarted process was heard from again, the
    /// paused one was detected and heard from again; a fault the mission's
    /// end overtook before that is `cut_short_by_end`.
    pub fn to_json(&self, survived: bool) -> Value {
        let survived_by_kind: serde_json::Map<String, Value> = self
            .injected
            .iter()
            .map(|(k, v)| (k.clone(), json!(if survived { *v } else { 0 })))
            .collect();
        let cleared: u64 = self.cleared.values().sum();
        json!({
            "planned": self.planned.len(),
            "injected": self.injected_total(),
            "injected_by_kind": self.injected,
            "survived_by_kind": survived_by_kind,
            "cleared_by_kind": self.cleared,
            "cut_short_by_end": self.injected_total().saturating_sub(cleared),
            "skipped_late": self.skipped_late,
            "stall_detect_ms_max": self.detect_ms_max,
            "stall_timeout_ms": {
                "planner": self.timeouts_ms[0],
                "sensor-sim": self.timeouts_ms[1],
                "vehicle-sim": self.timeouts_ms[2],
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faults_are_drawn_from_the_seed_in_time_order_within_the_window() {
        let a = plan_faults(5, 12, 1000.0, &Proc::ALL);
        assert_eq!(a, plan_faults(5, 12, 1000.0, &Proc::ALL));
        assert_ne!(a, plan_faults(6, 12, 1000.0, &Proc::ALL));
        assert!(a.windows(2).all(|w| w[0].at_s <= w[1].at_s));
        assert!(a.iter().all(|f| (50.0..=750.0).contains(&f.at_s)));
        assert!(a.iter().any(|f| f.kind == FaultKind::Kill) && a.iter().any(|f| f.kind == FaultKind::Pause));
        let only = plan_faults(5, 12, 1000.0, &[Proc::Sensor]);
        assert!(only.iter().all(|f| f.target == Proc::Sensor));
        assert!(plan_faults(5, 3, 1000.0, &[]).is_empty());
        assert_eq!(a[0].key(), format!("{}_{}", a[0].kind.name(), a[0].target.name()));
    }

    #[test]
    fn announced_events_missing_from_the_journal_are_counted() {
        let a = Announced {
            route: vec![0, 3, 5],
            tasks: 2,
        };
        assert_eq!(a.missing_from(&[0, 3, 5, 7], 3), 0);
        assert_eq!(a.missing_from(&[0, 3], 2), 1);
        assert_eq!(a.missing_from(&[0, 4, 5], 1), 3);
    }

    #[test]
    fn the_fault_report_separates_survived_from_cleared() {
        let mut r = FaultReport::default();
        r.injected.insert("kill_planner".into(), 2);
        r.injected.insert("pause_sensor-sim".into(), 1);
        r.cleared.insert("kill_planner".into(), 2);
        let j = r.to_json(true);
        assert_eq!(j["injected"], 3);
        assert_eq!(j["survived_by_kind"]["pause_sensor-sim"], 1);
        assert_eq!(j["cleared_by_kind"]["kill_planner"], 2);
        assert_eq!(j["cut_short_by_end"], 1);
        let failed = r.to_json(false);
        assert_eq!(failed["survived_by_kind"]["kill_planner"], 0);
    }
}
