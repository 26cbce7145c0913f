//! `report.json` and the human summary of a mission.

use serde_json::{Value, json};

use auv_messages::msg::{AllocCounters, Outcome, REJECT_KINDS, RejectCounters, RejectKind};

/// Everything the report states.
#[derive(Clone, Debug)]
pub struct Report {
    /// How the mission ended.
    pub outcome: Outcome,
    /// Why, when it did not reach the goal.
    pub reason: Option<String>,
    /// Mission time used, s.
    pub time_used_s: f64,
    /// Budget, s.
    pub time_available_s: f64,
    /// Tasks completed.
    pub tasks_completed: u32,
    /// Weight collected.
    pub weight: f64,
    /// Distance travelled, m.
    pub distance_m: f64,
    /// Waypoints visited, in order.
    pub route: Vec<usize>,
    /// Plans published.
    pub plans: u64,
    /// Plan latency (trigger arrival → plan published), µs: p50, p99, max.
    pub latency_us: (u64, u64, u64),
    /// Deadline, ms.
    pub deadline_ms: f64,
    /// Plans published after the deadline.
    pub deadline_misses: u64,
    /// Solves cut by the deadline.
    pub deadline_cuts: u64,
    /// Plans that fell back to the quickest path.
    pub fallbacks: u64,
    /// Solver iterations over all plans.
    pub iterations_total: u64,
    /// The planner's allocation counters.
    pub alloc: AllocCounters,
    /// Whether the planner ran on the counting allocator.
    pub allocator_installed: bool,
    /// Snapshots the planner applied.
    pub sensor_updates: u64,
    /// Input the planner rejected, by kind.
    pub rejected: RejectCounters,
    /// Input the vehicle rejected, by kind (from its last state message).
    pub rejected_vehicle: RejectCounters,
    /// Plans the vehicle set aside as stale (not faults: at speed, a plan
    /// can arrive after the vehicle left the waypoint it was planned from).
    pub stale_plans: u32,
    /// Scenario seed.
    pub seed: u64,
    /// Planner seed.
    pub planner_seed: u64,
    /// Scenario fingerprint.
    pub fingerprint: u64,
    /// Scenario description.
    pub scenario: String,
    /// Lockstep or scaled.
    pub lockstep: bool,
    /// Mission seconds per real second (scaled mode).
    pub time_scale: f64,
    /// Wall time of the run, s.
    pub wall_time_s: f64,
    /// Shared-memory and iceoryx2 files of the run left after it.
    pub shm_files_left: usize,
    /// Restarts, stalls and safe hold, by process and cause.
    pub supervision: super::supervisor::SupervisionReport,
    /// Arrivals the vehicle's states announced on the wire.
    pub announced_arrivals: usize,
    /// Tasks the vehicle's states announced on the wire.
    pub announced_tasks: u32,
    /// Announced arrivals and tasks missing from the journal (must be 0).
    pub lost_journal_events: u64,
    /// Planner processes whose plans the latency figures summarise (more
    /// than one: the largest of their quantiles).
    pub latency_sessions: usize,
    /// Faults injected and what came of them (`--faults`).
    pub faults: Option<super::supervise::FaultReport>,
    /// Times the vehicle resumed from its journal.
    pub vehicle_restarts: u64,
    /// Solver iterations per plan asked for.
    pub iterations_budget: u32,
    /// What the deadline cuts cost, when measured.
    pub cut: Option<auv_service::core::CutCounters>,
    /// Peak resident set size of the child processes (planner, sensor-sim,
    /// vehicle-sim), kB; 0 where not measured (the planner on a thread, or
    /// lockstep without --planner-process).
    pub rss_kb: [u64; 3],
    /// SCHED_FIFO priority of the planner's service thread (None: normal
    /// scheduling).
    pub rt_priority: Option<i32>,
}

impl Report {
    /// Whether the goal was reached.
    pub fn goal_reached(&self) -> bool {
        self.outcome == Outcome::GoalReached
    }

    /// The report as JSON.
    pub fn to_json(&self) -> Value {
        let kinds = |c: &RejectCounters| -> serde_json::Map<String, Value> {
            (0..REJECT_KINDS)
                .map(|k| (RejectKind::ALL[k].as_str().to_string(), json!(c.0[k])))
                .collect()
        };
        let all = self.all_rejected();
        json!({
            "goal_reached": self.goal_reached(),
            "outcome": auv_messages::msg::outcome_name(self.outcome),
            "reason": self.reason,
            "time_used_s": self.time_used_s,
            "time_available_s": self.time_available_s,
            "tasks_completed": self.tasks_completed,
            "weight": self.weight,
            "distance_m": self.distance_m,
            "route": self.route,
            "replans": self.plans.saturating_sub(1),
            "plans": self.plans,
            "plan_latency_us": {
                "p50": self.latency_us.0,
                "p99": self.latency_us.1,
                "max": self.latency_us.2,
                "planner_processes": self.latency_sessions,
                "source": if self.latency_sessions > 1 { "largest of the planner processes' own histograms" } else { "the planner's own histogram" },
            },
            "deadline_ms": self.deadline_ms,
            "deadline_misses": self.deadline_misses,
            "deadline_cuts": self.deadline_cuts,
            "fallback_plans": self.fallbacks,
            "solver_iterations": {
                "total": self.iterations_total,
                "mean_per_plan": self.iterations_total as f64 / self.plans.max(1) as f64,
                "budget_per_plan": self.iterations_budget,
            },
            "anytime": self.anytime_json(),
            "steady_state_allocations": self.alloc.sys_allocs_steady,
            "allocations": {
                "allocator_installed": self.allocator_installed,
                "steady_state_measured": self.alloc.steady == 1,
                "system_allocs_steady": self.alloc.sys_allocs_steady,
                "system_frees_steady": self.alloc.sys_frees_steady,
                "system_allocs_total": self.alloc.sys_allocs_total,
                "pool_allocs_steady": self.alloc.pool_allocs_steady,
                "pool_high_water": self.alloc.pool_high_water,
                "pool_capacity": self.alloc.pool_capacity,
                "pool_misses": self.alloc.pool_misses,
                "note": "pool blocks are iceoryx2 0.10's 48 B loan state and its connections to restarted peers, served from a pool reserved at start-up",
            },
            "sensor_updates": self.sensor_updates,
            "rejected_messages": all.total(),
            "rejected_by_kind": kinds(&all),
            "rejected_by_receiver": {
                "planner": kinds(&self.rejected),
                "vehicle": kinds(&self.rejected_vehicle),
            },
            "stale_plans": self.stale_plans,
            "seed": self.seed,
            "rt_priority": self.rt_priority,
            "planner_seed": self.planner_seed,
            "fingerprint": format!("{:016x}", self.fingerprint),
            "scenario": self.scenario,
            "lockstep": self.lockstep,
            "time_scale": if self.lockstep { Value::Null } else { json!(self.time_scale) },
            "wall_time_s": self.wall_time_s,
            "shm_files_left": self.shm_files_left,
            "supervision": self.supervision.to_json(),
            "journal_check": {
                "announced_arrivals": self.announced_arrivals,
                "announced_tasks": self.announced_tasks,
                "lost_events": self.lost_journal_events,
            },
            "vehicle_restarts": self.vehicle_restarts,
            "rss_kb_peak": {
                "planner": self.rss_kb[0],
                "sensor-sim": self.rss_kb[1],
                "vehicle-sim": self.rss_kb[2],
            },
            "faults": self.faults.as_ref().map(|f| f.to_json(matches!(self.outcome, Outcome::GoalReached | Outcome::TimedOut))),
        })
    }

    /// The cost of the deadline cuts: how many plans were cut, the
    /// iterations they ran against the budget, and their weight against
    /// the warm start they improved on.
    fn anytime_json(&self) -> Value {
        let Some(c) = self.cut else {
            return json!({"plans_cut": self.deadline_cuts, "measured": false});
        };
        let cuts = self.deadline_cuts.max(1) as f64;
        let warm = c.with_warm_start.max(1) as f64;
        json!({
            "measured": true,
            "plans_cut": self.deadline_cuts,
            "plans_cut_share": self.deadline_cuts as f64 / self.plans.max(1) as f64,
            "iterations_budget": self.iterations_budget,
            "mean_iterations_cut": c.iterations as f64 / cuts,
            "iterations_run_share_cut": c.iterations as f64 / cuts / f64::from(self.iterations_budget.max(1)),
            "cut_with_warm_start": c.with_warm_start,
            "mean_weight_cut": c.weight / warm,
            "mean_weight_warm_start": c.warm_start_weight / warm,
        })
    }

    /// Rejections of both receivers together (a bad snapshot refused by the
    /// planner and by the vehicle counts twice: each refused it).
    pub fn all_rejected(&self) -> RejectCounters {
        let mut all = self.rejected;
        all.merge(&self.rejected_vehicle);
        all
    }

    /// A few lines for people.
    pub fn summary(&self) -> String {
        let mut text = self.figures();
        if let Some(why) = &self.reason {
            text.push_str(&format!("\nwhy: {why}"));
        }
        let sup = &self.supervision;
        let restarts: u64 = sup.restarts.iter().flatten().sum();
        let stalls: u64 = sup.stalls.iter().flatten().sum();
        if restarts + stalls > 0 {
            let each = |m: &[[u64; 2]; 3]| {
                super::supervise::Proc::ALL
                    .iter()
                    .map(|&p| format!("{} {}", p.name(), m[p as usize].iter().sum::<u64>()))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            text.push_str(&format!(
                "\nsupervisor: {restarts} restarts ({}), {stalls} stalls ({})",
                each(&sup.restarts),
                each(&sup.stalls)
            ));
        }
        text
    }

    fn figures(&self) -> String {
        let verdict = match self.outcome {
            Outcome::GoalReached => "goal reached",
            Outcome::TimedOut => "OUT OF TIME before the goal",
            Outcome::Aborted => "stopped before the end",
            Outcome::SafeHold => "SAFE HOLD before the goal",
            Outcome::Running => "ended without a final state",
        };
        format!(
            "mission: {verdict} — {:.0} of {:.0} s used, {} tasks, weight {:.2}, {:.1} km\n\
             route: {:?}\n\
             planner: {} plans ({} re-plans), latency p50 {} µs, p99 {} µs, max {} µs; \
             {} deadline misses (deadline {} ms), {} cut by the deadline, {} fallbacks\n\
             allocations in steady state: {} system, {} pool blocks (high water {} of {}); \
             {} sensor updates; {} rejected messages{}; {} stale plans set aside by the vehicle\n\
             ({}; {}, planner on {}, wall time {:.1} s)",
            self.time_used_s,
            self.time_available_s,
            self.tasks_completed,
            self.weight,
            self.distance_m / 1000.0,
            self.route,
            self.plans,
            self.plans.saturating_sub(1),
            self.latency_us.0,
            self.latency_us.1,
            self.latency_us.2,
            self.deadline_misses,
            self.deadline_ms,
            self.deadline_cuts,
            self.fallbacks,
            self.alloc.sys_allocs_steady,
            self.alloc.pool_allocs_steady,
            self.alloc.pool_high_water,
            self.alloc.pool_capacity,
            self.sensor_updates,
            self.all_rejected().total(),
            {
                let all = self.all_rejected();
                if all.total() > 0 {
                    format!(" ({all})")
                } else {
                    String::new()
                }
            },
            self.stale_plans,
            self.scenario,
            if self.lockstep {
                "lockstep".to_string()
            } else {
                format!("{}× real time", self.time_scale)
            },
            self.rt_priority
                .map_or("normal scheduling".to_string(), |p| format!("SCHED_FIFO {p}")),
            self.wall_time_s
        )
    }
}
