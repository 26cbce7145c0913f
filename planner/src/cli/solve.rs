//! `planner solve`: solve one `auv-route-instance/1` file (paper-model
//! instances with edge tasks and classic orienteering instances with node
//! prizes alike) and print the format's solution object.
//!
//! Contract: the figures printed are recomputed from the instance and the
//! route ([`auv_core::solution::Solution::new`]), not copied from the solver.
//! The same instance, algorithm, seed and iteration count print the same
//! output except `solve_ms` (wall clock) and `solve_thread_cpu_ms` (the
//! solving thread's CPU clock, `CLOCK_THREAD_CPUTIME_ID`: on a shared
//! machine the wall time also counts waiting for a core).
//!
//! `--algorithm exact` runs the branch-and-bound
//! ([`auv_core::solver::exact::solve_exact`], the format's full order: best
//! objective value, ties to the smaller route time) and, besides the
//! format's fields, reports `proved_optimal`, `bound` (an upper bound on the
//! weight, or a lower bound on the cost) and `gap` (|bound − value| / |value|,
//! a fraction; 0 when proved). The format allows extra fields ("at least").
//! A search stopped by `--time-limit S` reports `stop` = `deadline`; a
//! finished one `converged`; `iterations` counts search nodes (saturating).
//!
//! The solvers run on the smallest capacity class that holds the instance
//! (64, 128, 256 or 512 nodes, [`auv_core::capacity::Class`]); more nodes
//! than 512 is a one-line error (exit 2).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use auv_core::instance::Instance;
use auv_core::problem::Problem;
use auv_core::rng::PlannerRng;
use auv_core::solution::{RunInfo, Solution};
use auv_core::solver::exact::{ExactSettings, solve_exact};
use auv_core::solver::{self, Algorithm, Budget, SolveOutcome, Solver, StopReason};
use auv_platform::clock::thread_cpu_time_s;
use clap::ValueEnum;

use super::{CliError, DEFAULT_SEED, load_instance, print};

/// The solvers `--algorithm` offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AlgorithmArg {
    /// The default planner: memetic PSO with local search and ruin-and-recreate.
    Auto,
    /// Particle swarm optimisation (paper: 150 particles).
    Pso,
    /// Biogeography-based optimisation (paper: 50 habitats, 10 elites).
    Bbo,
    /// Branch-and-bound: proves the optimum, or reports a bound and gap
    /// when `--time-limit` stops it.
    Exact,
}

impl AlgorithmArg {
    /// Builds the solver with the paper's settings, its iteration budget
    /// replaced by `iterations` when given (so PSO's inertia schedule spans
    /// the iterations actually run). Returns the solver and its budget, or
    /// `None` for `exact`, which is not an anytime swarm ([`run_exact`]).
    pub fn build<const W: usize>(self, iterations: Option<u32>, deadline: bool) -> Option<(Box<dyn Solver<W>>, u32)> {
        let algorithm = match self {
            Self::Exact => return None,
            Self::Auto => Algorithm::Auto,
            Self::Pso => Algorithm::Pso,
            Self::Bbo => Algorithm::Bbo,
        };
        // Under a deadline auto's budget is unbounded, so it uses the whole
        // deadline; the paper's swarms keep their iteration budget.
        let unbounded = deadline && algorithm == Algorithm::Auto;
        let n = iterations.unwrap_or(if unbounded {
            u32::MAX
        } else {
            algorithm.paper_iterations()
        });
        Some((algorithm.build(n), n))
    }
}

/// Arguments of `planner solve`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Instance file in the `auv-route-instance/1` format.
    #[arg(long, value_name = "FILE", required_unless_present = "mission")]
    pub instance: Option<PathBuf>,
    /// Or a mission file (`auv-mission/1`): solves its first snapshot, the
    /// one `planner export --mission FILE` writes.
    #[arg(long, value_name = "FILE", conflicts_with = "instance")]
    pub mission: Option<PathBuf>,
    /// Solver to run.
    #[arg(long, value_enum, default_value_t = AlgorithmArg::Auto)]
    pub algorithm: AlgorithmArg,
    /// Seed of the planner's random generator; the output reports it.
    #[arg(long, default_value_t = DEFAULT_SEED, allow_negative_numbers = true)]
    pub seed: u64,
    /// Wall-clock budget of the whole solve in milliseconds (the best route
    /// found by then is printed); auto, pso and bbo.
    #[arg(long, value_name = "D", value_parser = clap::value_parser!(u64).range(1..))]
    pub deadline_ms: Option<u64>,
    /// Iterations (generations) to run, at least 1 [default: the paper's 150; auto: 300].
    #[arg(
        long,
        value_name = "N",
        value_parser = clap::value_parser!(u32).range(1..),
        allow_negative_numbers = true
    )]
    pub iterations: Option<u32>,
    /// Exact only: stop the search after S seconds (> 0) and report the
    /// best route with its bound and gap [default: run to proof].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub time_limit: Option<String>,
    /// Print the solution object as JSON instead of a readable summary.
    #[arg(long)]
    pub json: bool,
}

/// Longest `--time-limit` accepted, s (a week: beyond that a typo is likelier
/// than intent, and `Duration` arithmetic stays far from overflow).
const MAX_TIME_LIMIT_S: f64 = 7.0 * 24.0 * 3600.0;

/// Parses `--time-limit`: seconds, finite, > 0 and at most a week. Parsed
/// here rather than by clap so the error is our one line.
fn parse_time_limit(text: &str) -> Result<Duration, CliError> {
    match text.trim().parse::<f64>() {
        Ok(s) if s.is_finite() && s > 0.0 && s <= MAX_TIME_LIMIT_S => Ok(Duration::from_secs_f64(s)),
        _ => Err(CliError::Usage(format!(
            "--time-limit {text}: must be a number of seconds > 0 and at most {MAX_TIME_LIMIT_S}"
        ))),
    }
}

/// Runs `planner solve`.
pub fn run(args: Args) -> Result<(), CliError> {
    let (inst, path) = match (&args.instance, &args.mission) {
        (Some(path), _) => (load_instance(path)?, path.clone()),
        (None, Some(path)) => {
            let m = auv_world::mission_file::load(path, auv_world::mission_file::Overrides::default())?;
            (m.world.snapshot(&m.name), path.clone())
        }
        (None, None) => return Err(CliError::Usage("give --instance FILE or --mission FILE".into())),
    };
    let class = super::capacity_class(&inst, &path)?;
    auv_core::with_class!(class, W => solve_in::<W>(&args, &inst, &path))
}

/// [`run`] on the capacity class of `W` words.
fn solve_in<const W: usize>(args: &Args, inst: &Instance, path: &std::path::Path) -> Result<(), CliError> {
    let problem = Problem::<W>::from_instance(inst).map_err(|source| CliError::Problem {
        path: path.to_path_buf(),
        source,
    })?;
    let Some((mut solver, iterations)) = args.algorithm.build::<W>(args.iterations, args.deadline_ms.is_some()) else {
        return run_exact(args, path, inst, &problem);
    };
    if let Some(t) = &args.time_limit {
        return Err(CliError::Usage(format!(
            "--time-limit {t}: only --algorithm exact takes a time limit (the others take --deadline-ms D)"
        )));
    }
    let mut rng = PlannerRng::new(args.seed);
    let cpu0 = thread_cpu_time_s();
    let outcome = solver::run(
        solver.as_mut(),
        &problem,
        &mut rng,
        None,
        Budget {
            iterations,
            deadline: args.deadline_ms.map(|d| Instant::now() + Duration::from_millis(d)),
        },
    );
    let cpu_ms = cpu_ms_since(cpu0);
    let route = solver.best().0.to_vec();
    let info = RunInfo::from_outcome(solver.name(), args.seed, &outcome, cpu_ms);
    let solution = Solution::new(inst, &route, &info).map_err(|e| {
        CliError::Internal(format!(
            "{} returned {route:?}, which is not a route of the instance: {e}",
            solver.name()
        ))
    })?;
    if args.json {
        print(&(solution.to_json() + "\n"))
    } else {
        print(&solution.summary(inst))
    }
}

/// This thread's CPU time since `cpu0` (a [`thread_cpu_time_s`] reading), ms.
fn cpu_ms_since(cpu0: f64) -> f64 {
    ((thread_cpu_time_s() - cpu0) * 1e3).max(0.0)
}

/// The exact solver's solution object: the format's fields, then its own.
#[derive(serde::Serialize)]
struct ExactSolution<'a> {
    #[serde(flatten)]
    solution: &'a Solution,
    /// No feasible route is better.
    proved_optimal: bool,
    /// Upper bound on the weight (`max_weight`) or lower bound on the cost (`paper_cost`).
    bound: f64,
    /// |bound − value| / |value|, a fraction; 0 when proved.
    gap: f64,
}

/// `planner solve --algorithm exact`.
fn run_exact<const W: usize>(
    args: &Args,
    path: &std::path::Path,
    inst: &Instance,
    problem: &Problem<W>,
) -> Result<(), CliError> {
    // Check every argument before the (possibly long) search.
    let time_limit = args.time_limit.as_deref().map(parse_time_limit).transpose()?;
    if let Some(d) = args.deadline_ms {
        return Err(CliError::Usage(format!(
            "--deadline-ms {d}: exact takes --time-limit S (seconds) instead"
        )));
    }
    if let Some(n) = args.iterations {
        return Err(CliError::Usage(format!(
            "--iterations {n}: exact has no iteration budget (use --time-limit S)"
        )));
    }
    let settings = ExactSettings {
        time_limit,
        ..ExactSettings::default()
    };
    let cpu0 = thread_cpu_time_s();
    let out =
        solve_exact(problem, &settings).map_err(|e| CliError::Usage(format!("{}: exact: {e}", path.display())))?;
    let cpu_ms = cpu_ms_since(cpu0);
    let route = out.route.to_vec();
    let outcome = SolveOutcome {
        iterations: u32::try_from(out.nodes_explored).unwrap_or(u32::MAX),
        stop: if out.proved_optimal {
            StopReason::Converged
        } else {
            StopReason::Deadline
        },
        elapsed: out.elapsed,
    };
    let info = RunInfo::from_outcome("exact", args.seed, &outcome, cpu_ms);
    let solution = Solution::new(inst, &route, &info).map_err(|e| {
        CliError::Internal(format!(
            "exact returned {route:?}, which is not a route of the instance: {e}"
        ))
    })?;
    if args.json {
        // The format's object plus three fields it allows ("at least").
        let doc = ExactSolution {
            solution: &solution,
            proved_optimal: out.proved_optimal,
            bound: out.bound,
            gap: out.gap,
        };
        let text = serde_json::to_string_pretty(&doc).map_err(|e| CliError::Internal(e.to_string()))?;
        print(&(text + "\n"))
    } else {
        let mut text = solution.summary(inst);
        let what = match inst.objective {
            auv_core::instance::Objective::MaxWeight => "upper bound on the weight",
            auv_core::instance::Objective::PaperCost { .. } => "lower bound on the cost",
        };
        if out.proved_optimal {
            text.push_str(&format!(
                "{:<10} proved ({} search nodes)\n",
                "optimum", out.nodes_explored
            ));
        } else {
            text.push_str(&format!(
                "{:<10} NOT proved: stopped by the time limit after {} search nodes\n",
                "optimum", out.nodes_explored
            ));
        }
        text.push_str(&format!(
            "{:<10} {:.6} ({what}); gap {:.4} %\n",
            "bound",
            out.bound,
            100.0 * out.gap
        ));
        print(&text)
    }
}
