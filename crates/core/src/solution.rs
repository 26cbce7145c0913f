//! The solution object of the interchange format (`instance-format.md`,
//! "Solution output"): what `solve --json` prints and what other commands
//! (Monte Carlo, quality checks, missions) reuse.
//!
//! Contract: a [`Solution`] is built only by [`Solution::new`], which
//! recomputes every figure from the instance and the route through
//! [`RouteStats::from_instance`] (the one place the formulas live), never
//! from a solver's own bookkeeping; so an outside checker that follows the
//! format recomputes the same numbers. [`Solution::verify`] is that check.
//! JSON field names are the format's; f64 values are written
//! shortest-round-trip, so a parsed solution compares bit-for-bit.
//!
//! Units: seconds, metres, milliseconds (`solve_ms`, `solve_thread_cpu_ms`).

use serde::{Deserialize, Serialize};

use crate::instance::{Instance, Objective};
use crate::route::{RouteError, RouteStats};
use crate::solver::{SolveOutcome, StopReason};

/// How a route was obtained: the run's facts that the instance cannot tell.
#[derive(Clone, Debug, PartialEq)]
pub struct RunInfo {
    /// Solver name (`pso`, `bbo`, …).
    pub algorithm: String,
    /// The seed of the run's [`crate::rng::PlannerRng`].
    pub seed: u64,
    /// Iterations (generations) completed after the start.
    pub iterations: u32,
    /// Why the solve stopped.
    pub stop: StopReason,
    /// Wall-clock time of the solve, ms.
    pub solve_ms: f64,
    /// CPU time the solving thread spent in the solve, ms (read by the
    /// caller: this crate has no clock of its own).
    pub solve_thread_cpu_ms: f64,
}

impl RunInfo {
    /// The facts of a finished [`crate::solver::run`] whose thread spent
    /// `thread_cpu_ms` of CPU time on it.
    pub fn from_outcome(algorithm: &str, seed: u64, outcome: &SolveOutcome, thread_cpu_ms: f64) -> Self {
        Self {
            algorithm: algorithm.to_string(),
            seed,
            iterations: outcome.iterations,
            stop: outcome.stop,
            solve_ms: outcome.elapsed.as_secs_f64() * 1e3,
            solve_thread_cpu_ms: thread_cpu_ms,
        }
    }
}

/// One solved instance, as printed by `solve --json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Solution {
    /// Node ids from start to goal.
    pub route: Vec<usize>,
    /// Route time within the budget (1e-6 relative).
    pub feasible: bool,
    /// Route weight W_R = Σ ρ/ξ + Σ prize.
    pub weight: f64,
    /// Route time T_R, s.
    pub time_s: f64,
    /// Route distance D_R, m.
    pub distance_m: f64,
    /// The paper's cost φ1·|T_R − T_available| + φ2·Σ ξ/ρ under the
    /// instance's `paper_cost`; 0 under `max_weight`.
    pub cost: f64,
    /// Tasks completed (edges travelled).
    pub tasks: u32,
    /// Wall-clock time of the solve, ms (with `solve_thread_cpu_ms`, the
    /// only figures that vary between runs with the same seed).
    pub solve_ms: f64,
    /// CPU time of the solving thread during the solve, ms: on a shared
    /// machine the wall time includes waiting for a core, this does not.
    /// 0 in a solution written without it.
    #[serde(default)]
    pub solve_thread_cpu_ms: f64,
    /// Iterations (generations) completed.
    pub iterations: u32,
    /// Solver name.
    pub algorithm: String,
    /// Seed of the run.
    pub seed: u64,
    /// Why the solve stopped: `budget`, `deadline` or `converged`.
    pub stop: String,
    /// The instance's objective kind: `max_weight` or `paper_cost`.
    pub objective: String,
    /// The instance's name.
    #[serde(default)]
    pub instance: String,
}

/// A reported figure that disagrees with the recomputation.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SolutionMismatch {
    /// The route is not a route of the instance.
    #[error("route is invalid: {0}")]
    Route(#[from] RouteError),
    /// A figure differs.
    #[error("{field} is {reported} but the instance and route give {recomputed}")]
    Figure {
        /// The field.
        field: &'static str,
        /// What the solution says.
        reported: String,
        /// What the recomputation says.
        recomputed: String,
    },
}

/// The format's name of an objective kind.
pub fn objective_kind(objective: Objective) -> &'static str {
    match objective {
        Objective::MaxWeight => "max_weight",
        Objective::PaperCost { .. } => "paper_cost",
    }
}

impl Solution {
    /// The solution for `route` on `inst`, every figure recomputed from the two.
    pub fn new(inst: &Instance, route: &[usize], run: &RunInfo) -> Result<Self, RouteError> {
        let s = RouteStats::from_instance(inst, route)?;
        Ok(Self {
            route: route.to_vec(),
            feasible: s.feasible,
            weight: s.weight,
            time_s: s.time_s,
            distance_m: s.distance_m,
            cost: s.cost,
            tasks: s.tasks,
            solve_ms: run.solve_ms,
            solve_thread_cpu_ms: run.solve_thread_cpu_ms,
            iterations: run.iterations,
            algorithm: run.algorithm.clone(),
            seed: run.seed,
            stop: run.stop.as_str().to_string(),
            objective: objective_kind(inst.objective).to_string(),
            instance: inst.name.clone(),
        })
    }

    /// Checks every figure against the recomputation from `inst` (exact
    /// equality: the same formulas in the same order give the same bits).
    pub fn verify(&self, inst: &Instance) -> Result<(), SolutionMismatch> {
        let s = RouteStats::from_instance(inst, &self.route)?;
        let floats = [
            ("weight", self.weight, s.weight),
            ("time_s", self.time_s, s.time_s),
            ("distance_m", self.distance_m, s.distance_m),
            ("cost", self.cost, s.cost),
        ];
        for (field, reported, recomputed) in floats {
            if reported.to_bits() != recomputed.to_bits() {
                return Err(SolutionMismatch::Figure {
                    field,
                    reported: reported.to_string(),
                    recomputed: recomputed.to_string(),
                });
            }
        }
        let mismatch = |field, reported: &dyn ToString, recomputed: &dyn ToString| SolutionMismatch::Figure {
            field,
            reported: reported.to_string(),
            recomputed: recomputed.to_string(),
        };
        if self.tasks != s.tasks {
            return Err(mismatch("tasks", &self.tasks, &s.tasks));
        }
        if self.feasible != s.feasible {
            return Err(mismatch("feasible", &self.feasible, &s.feasible));
        }
        let kind = objective_kind(inst.objective);
        if self.objective != kind {
            return Err(mismatch("objective", &self.objective, &kind));
        }
        Ok(())
    }

    /// Pretty-printed JSON.
    pub fn to_json(&self) -> String {
        // Plain strings, integers and finite floats: serialising cannot fail.
        serde_json::to_string_pretty(self).expect("solution serialises")
    }

    /// Parses a solution object (fields beyond these are ignored).
    pub fn from_json(text: &str) -> Result<Self, serde_json::Error> {
        serde_json::from_str(text)
    }

    /// A short human-readable report, one fact per line.
    pub fn summary(&self, inst: &Instance) -> String {
        let route: Vec<String> = self.route.iter().map(usize::to_string).collect();
        let mut out = String::new();
        let mut line = |label: &str, value: String| {
            out.push_str(&format!("{label:<10} {value}\n"));
        };
        line(
            "instance",
            format!(
                "{} ({} nodes, {} edges, objective {})",
                if self.instance.is_empty() {
                    "(unnamed)"
                } else {
                    &self.instance
                },
                inst.nodes.len(),
                inst.edges.len(),
                self.objective
            ),
        );
        line(
            "solver",
            format!(
                "{}, seed {}, {} iterations, stopped on {}, {:.3} ms ({:.3} ms thread CPU)",
                self.algorithm, self.seed, self.iterations, self.stop, self.solve_ms, self.solve_thread_cpu_ms
            ),
        );
        line("route", route.join(" -> "));
        line(
            "feasible",
            format!(
                "{} (time {:.3} s of {:.3} s available)",
                if self.feasible { "yes" } else { "NO" },
                self.time_s,
                inst.time_available_s
            ),
        );
        line("weight", format!("{:.6}", self.weight));
        line("distance", format!("{:.3} m", self.distance_m));
        line("tasks", self.tasks.to_string());
        if let Objective::PaperCost { phi1, phi2 } = inst.objective {
            line("cost", format!("{:.6} (phi1 {phi1}, phi2 {phi2})", self.cost));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::line_instance;

    fn run() -> RunInfo {
        RunInfo {
            algorithm: "pso".into(),
            seed: 7,
            iterations: 150,
            stop: StopReason::Budget,
            solve_ms: 1.25,
            solve_thread_cpu_ms: 1.0,
        }
    }

    #[test]
    fn figures_come_from_the_instance() {
        // Line fixture: 0-1-2-3, 100 m apart, speed 1, task 10 s, risk 0.5.
        let inst = line_instance();
        let s = Solution::new(&inst, &[0, 1, 2, 3], &run()).unwrap();
        assert_eq!(s.time_s, 330.0);
        assert_eq!(s.distance_m, 300.0);
        assert_eq!(s.weight, (2.0 + 3.0 + 4.0) / 0.5);
        assert_eq!(s.tasks, 3);
        assert!(s.feasible);
        assert_eq!(s.cost, 0.0);
        assert_eq!(s.objective, "max_weight");
        assert_eq!(s.stop, "budget");
        s.verify(&inst).unwrap();
    }

    #[test]
    fn paper_cost_is_reported() {
        let mut inst = line_instance();
        inst.objective = Objective::PaperCost { phi1: 0.5, phi2: 2.0 };
        let s = Solution::new(&inst, &[0, 3], &run()).unwrap();
        // Edge 0-3: 300 m at 1 m/s + 10 s = 310 s; |310 − 1000|·0.5 + 2·(0.5/1).
        assert_eq!(s.cost, 345.0 + 1.0);
        assert_eq!(s.objective, "paper_cost");
    }

    #[test]
    fn invalid_routes_are_refused() {
        let inst = line_instance();
        assert!(Solution::new(&inst, &[0, 2, 3], &run()).is_err());
        assert!(Solution::new(&inst, &[0, 1], &run()).is_err());
    }

    #[test]
    fn json_has_the_format_fields_and_round_trips_exactly() {
        let inst = line_instance();
        let mut s = Solution::new(&inst, &[0, 1, 2, 3], &run()).unwrap();
        s.solve_ms = 0.1 + 0.2;
        let text = s.to_json();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        for key in [
            "route",
            "feasible",
            "weight",
            "time_s",
            "distance_m",
            "cost",
            "tasks",
            "solve_ms",
            "solve_thread_cpu_ms",
            "iterations",
            "algorithm",
            "seed",
            "stop",
            "objective",
        ] {
            assert!(v.get(key).is_some(), "missing {key} in {text}");
        }
        assert_eq!(v["route"], serde_json::json!([0, 1, 2, 3]));
        assert_eq!(v["seed"], 7);
        assert_eq!(Solution::from_json(&text).unwrap(), s);
    }

    #[test]
    fn json_floats_round_trip_bit_for_bit() {
        // serde_json parses floats exactly only with its `float_roundtrip`
        // feature (the workspace enables it); without it about one value in
        // ten comes back one ulp off and `verify` after a round trip fails.
        let inst = line_instance();
        let mut rng = crate::rng::PlannerRng::new(99);
        for _ in 0..200 {
            let mut s = Solution::new(&inst, &[0, 3], &run()).unwrap();
            s.weight = rng.uniform(0.0, 1e3);
            s.time_s = rng.uniform(0.0, 4e4);
            s.distance_m = rng.uniform(0.0, 5e4);
            s.cost = rng.uniform(0.0, 1.0);
            let back = Solution::from_json(&s.to_json()).unwrap();
            assert_eq!(back.weight.to_bits(), s.weight.to_bits());
            assert_eq!(back.time_s.to_bits(), s.time_s.to_bits());
            assert_eq!(back.distance_m.to_bits(), s.distance_m.to_bits());
            assert_eq!(back.cost.to_bits(), s.cost.to_bits());
        }
    }

    #[test]
    fn verify_catches_a_wrong_figure() {
        let inst = line_instance();
        let good = Solution::new(&inst, &[0, 1, 2, 3], &run()).unwrap();
        let mut bad = good.clone();
        bad.weight += 1e-9;
        assert!(bad.verify(&inst).unwrap_err().to_string().starts_with("weight is"));
        let mut bad = good.clone();
        bad.feasible = false;
        assert!(bad.verify(&inst).is_err());
        let mut bad = good;
        bad.route = vec![0, 2, 3];
        assert!(matches!(bad.verify(&inst), Err(SolutionMismatch::Route(_))));
    }

    #[test]
    fn summary_names_the_essentials() {
        let inst = line_instance();
        let text = Solution::new(&inst, &[0, 3], &run()).unwrap().summary(&inst);
        assert!(text.contains("route      0 -> 3"), "{text}");
        assert!(text.contains("feasible   yes"), "{text}");
        assert!(text.contains("seed 7"), "{text}");
    }
}
