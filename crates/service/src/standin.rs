//! A small anytime solver for the service's own tests: random-key search
//! around the best priority vector, with warm start. It keeps the service
//! testable independently of the PSO/BBO implementations; the binaries use
//! the paper's PSO.
//!
//! Contract: the [`Solver`] contract (valid route after `start`, strict
//! improvement only, no allocation in `start`/`step`).

use auv_core::decode::{Decoder, PRIORITY_MAX, PRIORITY_MIN};
use auv_core::problem::{MAX_NODES, Problem};
use auv_core::rng::PlannerRng;
use auv_core::route::{Route, RouteEval};
use auv_core::solver::Solver;

/// Random-key local search.
pub struct RandomKeySearch {
    samples: usize,
    decoder: Decoder,
    best_prio: [f64; MAX_NODES],
    cand: [f64; MAX_NODES],
    best: Route,
    best_eval: RouteEval,
    route: Route,
}

/// Priorities that make the decoder retrace `route` when it fits the budget:
/// route nodes get strictly decreasing top priorities, every other node the
/// lowest.
pub fn encode_route(route: &Route, out: &mut [f64]) {
    out.fill(PRIORITY_MIN);
    for (i, id) in route.iter().enumerate() {
        if id < out.len() {
            out[id] = PRIORITY_MAX - i as f64;
        }
    }
}

impl RandomKeySearch {
    /// A solver that decodes `samples` candidates per step.
    pub fn new(samples: usize) -> Self {
        Self {
            samples: samples.max(1),
            decoder: Decoder::new(),
            best_prio: [0.0; MAX_NODES],
            cand: [0.0; MAX_NODES],
            best: Route::new(),
            best_eval: RouteEval::default(),
            route: Route::new(),
        }
    }

    fn try_candidate(&mut self, p: &Problem) {
        let e = self.decoder.decode(p, &self.cand, &mut self.route);
        if p.better(&e, &self.best_eval) {
            self.best_eval = e;
            self.best = self.route;
            self.best_prio = self.cand;
        }
    }
}

impl Solver for RandomKeySearch {
    fn name(&self) -> &'static str {
        "random-key"
    }

    fn start(&mut self, p: &Problem, rng: &mut PlannerRng, warm: Option<&Route>) {
        let n = p.n();
        for v in &mut self.cand[..n] {
            *v = rng.uniform(PRIORITY_MIN, PRIORITY_MAX);
        }
        self.best_eval = self.decoder.decode(p, &self.cand, &mut self.best);
        self.best_prio = self.cand;
        if let Some(w) = warm {
            encode_route(w, &mut self.cand[..n]);
            self.try_candidate(p);
        }
    }

    fn step(&mut self, p: &Problem, rng: &mut PlannerRng) -> bool {
        let n = p.n();
        for _ in 0..self.samples {
            let restart = rng.next_f64() < 0.2;
            for i in 0..n {
                self.cand[i] = if restart {
                    rng.uniform(PRIORITY_MIN, PRIORITY_MAX)
                } else {
                    (self.best_prio[i] + rng.normal(0.0, 40.0)).clamp(PRIORITY_MIN, PRIORITY_MAX)
                };
            }
            self.try_candidate(p);
        }
        true
    }

    fn best(&self) -> (&Route, &RouteEval) {
        (&self.best, &self.best_eval)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_core::fixtures::random_instance;
    use auv_core::solver::{Budget, run};

    #[test]
    fn warm_start_is_kept_when_it_is_the_best() {
        let inst = random_instance(25, 0.3, 9000.0, 5);
        let p = Problem::from_instance(&inst).unwrap();
        let mut s = RandomKeySearch::new(20);
        let mut rng = PlannerRng::new(1);
        run(&mut s, &p, &mut rng, None, Budget::iterations(30));
        let (first, e1) = s.best();
        let (first, e1) = (*first, *e1);
        assert!(p.evaluate(&first).is_some());
        // Restarting from the best route can only keep or improve it.
        let mut rng = PlannerRng::new(2);
        run(&mut s, &p, &mut rng, Some(&first), Budget::iterations(0));
        let (_, e2) = s.best();
        assert!(!p.better(&e1, e2), "warm start lost quality: {e1:?} vs {e2:?}");
    }
}
