//! Solvers and the anytime contract they share.
//!
//! A [`Solver`] is built once with every buffer it needs, then for each
//! problem: [`Solver::start`] yields a valid best-so-far route immediately,
//! and each [`Solver::step`] is one bounded quantum of work (one PSO or BBO
//! generation). The best-so-far changes only on strict improvement, so the
//! caller may publish it at any stop. [`run`] drives a solver to a fixed
//! iteration budget or a deadline, whichever comes first, and says why it
//! stopped (house style §1). Solvers know nothing of transport or files.

pub mod bbo;
pub mod exact;
pub mod local;
pub mod pso;

use std::time::{Duration, Instant};

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
pub trait Solver {
    /// Short lower-case name (`pso`, `bbo`, …).
    fn name(&self) -> &'static str;

    /// Resets for `problem` and builds the initial population; afterwards
    /// [`Solver::best`] is a valid route. `warm` (a route of this problem)
    /// seeds part of the population when given. Must not allocate.
    fn start(&mut self, problem: &Problem, rng: &mut PlannerRng, warm: Option<&Route>);

    /// One generation. Returns `false` when the solver has converged and
    /// further steps cannot change the result. Must not allocate.
    fn step(&mut self, problem: &Problem, rng: &mut PlannerRng) -> bool;

    /// The best route so far and its figures.
    fn best(&self) -> (&Route, &RouteEval);
}

/// Runs `solver` on `problem` within `budget`.
pub fn run<S: Solver + ?Sized>(
    solver: &mut S,
    problem: &Problem,
    rng: &mut PlannerRng,
    warm: Option<&Route>,
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
