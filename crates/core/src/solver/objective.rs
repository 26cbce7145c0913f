//! The instance's objective as the heuristics see it: what a change of a
//! feasible route's figures is worth. One place, shared by every move
//! evaluation, insertion rule and kick of `auto` (the full ranking of two
//! routes, feasibility first, is [`Problem::better`] / [`Problem::score`]).
//!
//! On a feasible route T_R ≤ T_available, so `paper_cost`'s
//! φ1·|T_R − T_available| is φ1·(T_available − T_R): every second the route
//! spends is worth φ1, and every task's ξ/ρ costs φ2. `max_weight` values
//! the weight gained and nothing else. Scores are "higher is better" for
//! both, like [`Problem::score`].

use crate::instance::Objective;
use crate::problem::Problem;

/// The value of route changes under one objective.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Value {
    /// Worth of one second more route time (φ1 for paper_cost, 0 else).
    per_second: f64,
    /// Worth of one unit of weight (1 for max_weight, 0 else).
    per_weight: f64,
    /// Cost of one unit of Σ ξ/ρ (φ2 for paper_cost, 0 else).
    per_risk: f64,
}

impl Value {
    /// The value of `problem`'s objective.
    pub fn of<const W: usize>(problem: &Problem<W>) -> Self {
        Self::new(problem.objective())
    }

    /// The value of `objective`.
    pub fn new(objective: Objective) -> Self {
        match objective {
            Objective::MaxWeight => Self {
                per_second: 0.0,
                per_weight: 1.0,
                per_risk: 0.0,
            },
            Objective::PaperCost { phi1, phi2 } => Self {
                per_second: phi1,
                per_weight: 0.0,
                per_risk: phi2,
            },
        }
    }

    /// Score change of a feasible route whose time changes by `dt`, weight
    /// by `dw` and Σ ξ/ρ by `dr` (staying feasible).
    #[inline]
    pub fn delta(&self, dt: f64, dw: f64, dr: f64) -> f64 {
        self.per_second * dt + self.static_delta(dw, dr)
    }

    /// The part of [`Value::delta`] that does not depend on time: what a
    /// reordering or exchange is worth before the time it frees is spent.
    #[inline]
    pub fn static_delta(&self, dw: f64, dr: f64) -> f64 {
        self.per_weight * dw - self.per_risk * dr
    }

    /// Whether spending time is worth something by itself (paper_cost).
    #[inline]
    pub fn values_time(&self) -> bool {
        self.per_second > 0.0
    }

    /// Worth of an insertion per second of budget it uses: the ratio greedy
    /// insertion ranks by. An insertion that saves time (possible without
    /// the triangle inequality) and gains is worth more than any that
    /// spends time; one that neither gains nor spends is worth nothing.
    #[inline]
    pub fn insertion_ratio(&self, dt: f64, dw: f64, dr: f64) -> f64 {
        self.noisy_insertion_ratio(dt, dw, dr, 1.0)
    }

    /// [`Value::insertion_ratio`] with the time-independent part scaled by
    /// `noise` ≥ 1 when it gains and divided by it when it costs: the noise
    /// moves the choice among insertions by what tells them apart, whatever
    /// the objective (a noise on the whole ratio would drown paper_cost's
    /// small risk differences under its common φ1 per second).
    #[inline]
    pub fn noisy_insertion_ratio(&self, dt: f64, dw: f64, dr: f64, noise: f64) -> f64 {
        let s = self.static_delta(dw, dr);
        let s = if s > 0.0 { s * noise } else { s / noise };
        let gain = self.per_second * dt + s;
        if dt > 1e-9 {
            gain / dt
        } else if gain > 0.0 {
            1e12 * gain
        } else {
            f64::NEG_INFINITY
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn max_weight_values_weight_only() {
        let v = Value::new(Objective::MaxWeight);
        assert_eq!(v.delta(100.0, 3.0, 0.5), 3.0);
        assert_eq!(v.insertion_ratio(10.0, 5.0, 1.0), 0.5);
        assert!(!v.values_time());
        // A gain that also saves time beats every time-spending one.
        assert!(v.insertion_ratio(-1.0, 1.0, 0.0) > v.insertion_ratio(1e-6, 1e3, 0.0));
    }

    #[test]
    fn paper_cost_values_time_and_charges_risk() {
        let v = Value::new(Objective::PaperCost { phi1: 0.01, phi2: 2.0 });
        // 100 s more (cost −1) and ξ/ρ +0.25 (cost +0.5): score +0.5.
        assert!((v.delta(100.0, 7.0, 0.25) - 0.5).abs() < 1e-12);
        assert!(v.values_time());
        assert_eq!(v.static_delta(7.0, 0.25), -0.5);
        assert_eq!(v.insertion_ratio(0.0, 1.0, 1.0), f64::NEG_INFINITY);
    }

    #[test]
    fn delta_matches_the_score_difference_of_feasible_routes() {
        use crate::route::RouteEval;
        let o = Objective::PaperCost { phi1: 0.3, phi2: 1.5 };
        let (a, b) = (
            RouteEval {
                time_s: 800.0,
                risk_ratio_sum: 2.0,
                feasible: true,
                ..RouteEval::default()
            },
            RouteEval {
                time_s: 950.0,
                risk_ratio_sum: 2.5,
                feasible: true,
                ..RouteEval::default()
            },
        );
        let budget = 1000.0;
        let diff = -b.cost(o, budget) + a.cost(o, budget);
        assert!((Value::new(o).delta(150.0, 0.0, 0.5) - diff).abs() < 1e-9);
    }
}
