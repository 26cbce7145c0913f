//! `planner solve`: solve one `auv-route-instance/1` file (paper-model
//! instances with edge tasks and classic orienteering instances with node
//! prizes alike) and print the format's solution object.
//!
//! Contract: the figures printed are recomputed from the instance and the
//! route ([`planner::solution::Solution::new`]), not copied from the solver.
//! The same instance, algorithm, seed and iteration count print the same
//! output except `solve_ms`.

use std::path::PathBuf;

use clap::ValueEnum;
use planner::problem::Problem;
use planner::rng::PlannerRng;
use planner::solution::{RunInfo, Solution};
use planner::solver::bbo::{Bbo, BboSettings};
use planner::solver::pso::{Pso, PsoSettings};
use planner::solver::{self, Budget, Solver};

use super::{CliError, DEFAULT_SEED, load_instance, print};

/// The solvers `--algorithm` offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AlgorithmArg {
    /// Particle swarm optimisation (paper: 150 particles).
    Pso,
    /// Biogeography-based optimisation (paper: 50 habitats, 10 elites).
    Bbo,
}

impl AlgorithmArg {
    /// Builds the solver with the paper's settings, its iteration budget
    /// replaced by `iterations` when given (so PSO's inertia schedule spans
    /// the iterations actually run). Returns the solver and its budget.
    pub fn build(self, iterations: Option<u32>) -> (Box<dyn Solver>, u32) {
        match self {
            Self::Pso => {
                let mut s = PsoSettings::paper();
                s.iterations = iterations.unwrap_or(s.iterations);
                (Box::new(Pso::new(s)), s.iterations)
            }
            Self::Bbo => {
                let mut s = BboSettings::paper();
                s.generations = iterations.unwrap_or(s.generations);
                (Box::new(Bbo::new(s)), s.generations)
            }
        }
    }
}

/// Arguments of `planner solve`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Instance file in the `auv-route-instance/1` format.
    #[arg(long, value_name = "FILE")]
    pub instance: PathBuf,
    /// Solver to run.
    #[arg(long, value_enum, default_value_t = AlgorithmArg::Pso)]
    pub algorithm: AlgorithmArg,
    /// Seed of the planner's random generator; the output reports it.
    #[arg(long, default_value_t = DEFAULT_SEED, allow_negative_numbers = true)]
    pub seed: u64,
    /// Iterations (generations) to run, at least 1 [default: the paper's 150].
    #[arg(
        long,
        value_name = "N",
        value_parser = clap::value_parser!(u32).range(1..),
        allow_negative_numbers = true
    )]
    pub iterations: Option<u32>,
    /// Print the solution object as JSON instead of a readable summary.
    #[arg(long)]
    pub json: bool,
}

/// Runs `planner solve`.
pub fn run(args: Args) -> Result<(), CliError> {
    let inst = load_instance(&args.instance)?;
    let problem = Problem::from_instance(&inst).map_err(|source| CliError::Problem {
        path: args.instance.clone(),
        source,
    })?;
    let (mut solver, iterations) = args.algorithm.build(args.iterations);
    let mut rng = PlannerRng::new(args.seed);
    let outcome = solver::run(
        solver.as_mut(),
        &problem,
        &mut rng,
        None,
        Budget::iterations(iterations),
    );
    let route = solver.best().0.to_vec();
    let info = RunInfo::from_outcome(solver.name(), args.seed, &outcome);
    let solution = Solution::new(&inst, &route, &info).map_err(|e| {
        CliError::Internal(format!(
            "{} returned {route:?}, which is not a route of the instance: {e}",
            solver.name()
        ))
    })?;
    if args.json {
        print(&(solution.to_json() + "\n"))
    } else {
        print(&solution.summary(&inst))
    }
}
