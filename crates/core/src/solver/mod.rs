//! Solvers and the anytime contract they share.
//!
//! A [`Solver`] is built once with every buffer it needs, then for each
//! problem: [`Solver::start`] yields a valid best-so-far route immediately,
//! and each [`Solver::step`] is one bounded quantum of work (one PSO or BBO
//! generation). The best-so-far changes only on strict improvement, so the
//! caller may publish it at any stop. [`run`] drives a solver to a fixed
//! iteration budget or a deadline, whichever comes first, and says why it
//! stopped (house style §1). Solvers know nothing of transport or files.
//!
//! [`Algorithm`] names the solvers for the command line (`pso`, `bbo`) and
//! builds them with the paper's settings as `Box<dyn Solver + Send>`; boxes
//! are solvers too, so generic code (the conformance suite in
//! `planner/tests/conformance.rs`) takes them as they are.
//!
//! Randomness: PSO and BBO seed their own vector generators (`lanes.rs`)
//! from the caller's `PlannerRng` in `start` and draw only from those
//! afterwards, so a solve is a function of the seed the caller's generator
//! was built from; `step` leaves the caller's generator untouched.

pub mod auto;
pub mod bbo;
pub mod beam;
pub mod exact;
pub mod ils;
mod lanes;
pub mod local;
pub mod objective;
pub mod pso;
pub mod risk_search;

use std::time::{Duration, Instant};

use auto::{AUTO_ITERATIONS, Auto, AutoSettings};
use bbo::{Bbo, BboSettings};
use pso::{Pso, PsoSettings};

use crate::capacity::DEFAULT_WORDS;
use crate::problem::Problem;
use crate::rng::PlannerRng;
use crate::route::{Route, RouteEval};

/// Why a solve stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// The iteration budget was spent.
    Budget,
    /// The deadline arrived first.
    Deadline,
    /// The solver proved it cannot improve further.
    Converged,
}

impl StopReason {
    /// Lower-case name for reports.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Budget => "budget",
            Self::Deadline => "deadline",
            Self::Converged => "converged",
        }
    }
}

/// How long a solve may run.
#[derive(Clone, Copy, Debug)]
pub struct Budget {
    /// Iterations (generations) at most.
    pub iterations: u32,
    /// Wall-clock instant by which the solve must return, if any.
    pub deadline: Option<Instant>,
}

impl Budget {
    /// A fixed number of iterations and no deadline.
    pub fn iterations(iterations: u32) -> Self {
        Self {
            iterations,
            deadline: None,
        }
    }
}

/// What a finished solve reports besides its route.
#[derive(Clone, Copy, Debug)]
pub struct SolveOutcome {
    /// Iterations completed after the start.
    pub iterations: u32,
    /// Why it stopped.
    pub stop: StopReason,
    /// Wall-clock time of the whole solve, start included.
    pub elapsed: Duration,
}

/// An anytime route solver.
pub trait Solver<const W: usize = DEFAULT_WORDS> {
    /// Short lower-case name (`pso`, `bbo`, …).
    fn name(&self) -> &'static str;

    /// Resets for `problem` and builds the initial population; afterwards
    /// [`Solver::best`] is a valid route. `warm` (a route of this problem)
    /// seeds part of the population when given. Must not allocate.
    fn start(&mut self, problem: &Problem<W>, rng: &mut PlannerRng, warm: Option<&Route<W>>);

    /// One generation. Returns `false` when the solver has converged and
    /// further steps cannot change the result. Must not allocate.
    fn step(&mut self, problem: &Problem<W>, rng: &mut PlannerRng) -> bool;

    /// The best route so far and its figures.
    fn best(&self) -> (&Route<W>, &RouteEval);
}

/// A boxed solver is a solver (so `Algorithm::build`'s boxes go wherever a
/// `S: Solver` does, e.g. the generic conformance suite).
impl<const W: usize, S: Solver<W> + ?Sized> Solver<W> for Box<S> {
    fn name(&self) -> &'static str {
        (**self).name()
    }
    fn start(&mut self, problem: &Problem<W>, rng: &mut PlannerRng, warm: Option<&Route<W>>) {
        (**self).start(problem, rng, warm)
    }
    fn step(&mut self, problem: &Problem<W>, rng: &mut PlannerRng) -> bool {
        (**self).step(problem, rng)
    }
    fn best(&self) -> (&Route<W>, &RouteEval) {
        (**self).best()
    }
}

/// Figures every real route beats under [`Problem::better`] (infeasible
/// with infinite time), the best-so-far before the first decode.
pub(crate) const WORST: RouteEval = RouteEval {
    time_s: f64::INFINITY,
    distance_m: 0.0,
    weight: 0.0,
    risk_ratio_sum: 0.0,
    tasks: 0,
    feasible: false,
};

/// The solvers the command line can pick by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Algorithm {
    /// [`Pso`] with the paper's settings.
    Pso,
    /// [`Bbo`] with the paper's settings.
    Bbo,
    /// [`Auto`], the memetic default planner.
    Auto,
}

/// A name that is not an [`Algorithm`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown algorithm `{0}` (expected one of: pso, bbo, auto)")]
pub struct UnknownAlgorithm(pub String);

impl Algorithm {
    /// Every algorithm, in a fixed order (reports, Monte Carlo columns).
    pub const ALL: [Self; 3] = [Self::Pso, Self::Bbo, Self::Auto];

    /// The name used on the command line and in reports.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Pso => "pso",
            Self::Bbo => "bbo",
            Self::Auto => "auto",
        }
    }

    /// Iterations of the paper's full budget: 150 PSO iterations (paper),
    /// 150 BBO generations (our choice, the paper is silent);
    /// [`AUTO_ITERATIONS`] steps of `auto` (a deadline usually cuts it).
    pub fn paper_iterations(self) -> u32 {
        match self {
            Self::Pso => PsoSettings::paper().iterations,
            Self::Bbo => BboSettings::paper().generations,
            Self::Auto => AUTO_ITERATIONS,
        }
    }

    /// A solver with the paper's settings and a budget of `iterations`
    /// (which also sets the PSO's inertia schedule). Allocates every buffer
    /// now; drive it with [`run`] and `Budget::iterations(iterations)`.
    pub fn build<const W: usize>(self, iterations: u32) -> Box<dyn Solver<W> + Send> {
        match self {
            Self::Pso => Box::new(Pso::new(PsoSettings {
                iterations,
                ..PsoSettings::paper()
            })),
            Self::Bbo => Box::new(Bbo::new(BboSettings {
                generations: iterations,
                ..BboSettings::paper()
            })),
            // Auto's inertia schedule is its own; the budget is only run's.
            Self::Auto => Box::new(Auto::new(AutoSettings::default())),
        }
    }
}

impl core::fmt::Display for Algorithm {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl core::str::FromStr for Algorithm {
    type Err = UnknownAlgorithm;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|a| a.as_str() == s)
            .ok_or_else(|| UnknownAlgorithm(s.to_owned()))
    }
}

/// Runs `solver` on `problem` within `budget`.
pub fn run<const W: usize, S: Solver<W> + ?Sized>(
    solver: &mut S,
    problem: &Problem<W>,
    rng: &mut PlannerRng,
    warm: Option<&Route<W>>,
    budget: Budget,
) -> SolveOutcome {
    let t0 = Instant::now();
    solver.start(problem, rng, warm);
    let mut iterations = 0;
    let mut stop = StopReason::Budget;
    while iterations < budget.iterations {
        if budget.deadline.is_some_and(|d| Instant::now() >= d) {
            stop = StopReason::Deadline;
            break;
        }
        iterations += 1;
        if !solver.step(problem, rng) {
            stop = StopReason::Converged;
            break;
        }
    }
    SolveOutcome {
        iterations,
        stop,
        elapsed: t0.elapsed(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn algorithms_round_trip_their_names() {
        for a in Algorithm::ALL {
            assert_eq!(a.as_str().parse::<Algorithm>(), Ok(a));
            assert_eq!(a.build::<2>(7).name(), a.as_str());
        }
        assert_eq!(Algorithm::Pso.paper_iterations(), 150);
        assert_eq!(Algorithm::Bbo.paper_iterations(), 150);
        let err = "PSO".parse::<Algorithm>().unwrap_err();
        assert_eq!(
            err.to_string(),
            "unknown algorithm `PSO` (expected one of: pso, bbo, auto)"
        );
    }
}
