//! The paper's Monte Carlo study: the same algorithms on many network
//! changes of one scenario, with a summary table, a per-run CSV and the
//! analogues of the paper's Fig. 4–8.
//!
//! Contract: run k redraws the dynamic waypoints with the world's k-th redraw
//! generator ([`World::redraw_rng`]), so every algorithm of a run plans on
//! the same network and a run's network does not depend on which thread ran
//! it. Each solve is timed on the thread that runs it (thread CPU time, and
//! it runs alone on that thread), and each solver draws from its own seed
//! `derive_seed(seed, run · 64 + algorithm index)`, reported per row. Same
//! settings and seed → identical records except the CPU times.
//!
//! Every run also re-plans, as the paper's Fig. 8 does: after the plan, the
//! dynamic waypoints of run k are redrawn once more within their bounds (the
//! world's redraw generator [`CHANGE_STREAM`] + k, the same model as
//! sensor-sim's redraws), and the same solver re-plans on the changed
//! network from the start with the full budget, warm-started from the plan
//! when the plan is still a route of the changed network (as the service
//! does), with seed `derive_seed(seed, run · 64 + 32 + algorithm index)`.
//! The same solver with the same seed also re-plans cold, so the warm
//! start's share of the route's stability can be told apart. The figure
//! recorded is the number of edges that differ between the plan and the
//! re-plan ([`edges_changed`]).

use auv_platform::clock::thread_cpu_time_s;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::plot::{self, BoundMarker, MapFigure, Panel, PlotError, RouteLayer, Series};
use auv_core::instance::Objective;
use auv_core::problem::{NodeSet, Problem, ProblemError};
use auv_core::rng::{PlannerRng, derive_seed};
use auv_core::solver::{Budget, Solver};
use auv_world::chart::WaterMap;
use auv_world::scenario::World;

/// φ1 of the paper's cost when the scenario's objective does not give one:
/// 1e-3 per second of unused (or exceeded) time. Our choice: the paper's
/// values are not available to us; with it the time term (0–31 for the
/// default budget) and the risk term (Σ ξ/ρ, about 0.1 per task) both matter.
pub const DEFAULT_PHI1: f64 = 1e-3;
/// φ2 of the paper's cost when the scenario's objective does not give one
/// (our choice, see [`DEFAULT_PHI1`]).
pub const DEFAULT_PHI2: f64 = 1.0;

/// Offset of the redraw generators of the re-plan's network change: run k's
/// change is the world's redraw number `CHANGE_STREAM + k`, far from the
/// runs' own redraws 1..=runs.
pub const CHANGE_STREAM: u64 = 1 << 32;

/// A named solver constructor: the study builds one solver per worker.
pub struct AlgorithmSpec {
    /// Name in the table and the CSV.
    pub name: &'static str,
    /// Builds a solver (called once per worker thread).
    pub build: Box<dyn Fn() -> Box<dyn Solver + Send> + Sync>,
    /// Iterations per solve.
    pub iterations: u32,
}

/// Study settings.
#[derive(Clone, Copy, Debug)]
pub struct StudySettings {
    /// Network changes (runs).
    pub runs: usize,
    /// Seed of the solvers' streams (the world carries its own seed).
    pub seed: u64,
    /// Worker threads for independent runs.
    pub threads: usize,
    /// Fraction of the network's edges kept, in (0, 1]; 1 keeps them all.
    /// Which edges is fixed per waypoint pair by the world's seed
    /// ([`keeps_edge`]), so every run and both networks of a re-plan thin
    /// the same pairs.
    pub edge_density: f64,
    /// (φ1, φ2) of the reported cost ([`cost_weights`] of the scenario's
    /// objective unless set).
    pub cost_phi: (f64, f64),
}

impl StudySettings {
    /// `runs` runs on `threads` threads from `seed`, every edge kept, the
    /// cost reported with the default weights (those of a `max_weight`
    /// scenario).
    pub fn new(runs: usize, seed: u64, threads: usize) -> Self {
        Self {
            runs,
            seed,
            threads,
            edge_density: 1.0,
            cost_phi: cost_weights(Objective::MaxWeight),
        }
    }
}

/// Whether the study keeps waypoint pair (a, b) at `density`: a draw fixed
/// by the world's seed and the pair, below `density`.
pub fn keeps_edge(world_seed: u64, density: f64, a: usize, b: usize) -> bool {
    if density >= 1.0 {
        return true;
    }
    let (lo, hi) = (a.min(b) as u64, a.max(b) as u64);
    let draw = derive_seed(world_seed ^ 0xED6E_D0E5_17E5_0000, lo * 1024 + hi);
    ((draw >> 11) as f64) * (1.0 / 9_007_199_254_740_992.0) < density
}

/// Edges (unordered waypoint pairs) in one route and not in the other: the
/// size of the symmetric difference of their edge sets. 0 for the same
/// route; a route that gains one detour (one edge replaced by two) changes 3.
pub fn edges_changed(old: &[usize], new: &[usize]) -> u32 {
    let edges = |r: &[usize]| -> Vec<(usize, usize)> {
        let mut e: Vec<(usize, usize)> = r.windows(2).map(|w| (w[0].min(w[1]), w[0].max(w[1]))).collect();
        e.sort_unstable();
        e.dedup();
        e
    };
    let (a, b) = (edges(old), edges(new));
    let only_a = a.iter().filter(|e| b.binary_search(e).is_err()).count();
    let only_b = b.iter().filter(|e| a.binary_search(e).is_err()).count();
    (only_a + only_b) as u32
}

/// The re-plan of one run (see the module notes).
#[derive(Clone, Debug, PartialEq)]
pub struct Replan {
    /// The plan was still a route of the changed network, so it warm-started
    /// the re-plan (false: an edge of it vanished, the re-plan started cold).
    pub warm_start: bool,
    /// Edges changed between the plan and the warm re-plan.
    pub edges_changed: u32,
    /// Edges changed between the plan and a cold re-plan (same solver, same
    /// seed, no warm start).
    pub edges_changed_cold: u32,
    /// Weight of the warm re-plan.
    pub weight: f64,
    /// Weight of the cold re-plan.
    pub weight_cold: f64,
    /// The warm re-plan's route is within the budget.
    pub feasible: bool,
    /// The warm re-plan's route (node ids).
    pub route: Vec<usize>,
}

/// One algorithm on one run.
#[derive(Clone, Debug, PartialEq)]
pub struct RunRecord {
    /// Run number, 1-based as in the paper's figures.
    pub run: usize,
    /// Algorithm name.
    pub algorithm: &'static str,
    /// The solver's seed.
    pub seed: u64,
    /// The paper's cost φ1·|T_R − T_available| + φ2·Σ ξ/ρ.
    pub cost: f64,
    /// Thread CPU time of the solve, ms.
    pub cpu_ms: f64,
    /// Route time T_R, s.
    pub route_time_s: f64,
    /// Route distance D_R, m.
    pub distance_m: f64,
    /// Tasks completed (edges).
    pub tasks: u32,
    /// Weight W_R.
    pub weight: f64,
    /// Time over the budget, s.
    pub violation_s: f64,
    /// Within the budget.
    pub feasible: bool,
    /// The route (node ids).
    pub route: Vec<usize>,
    /// The re-plan after the network change.
    pub replan: Replan,
}

/// Why the study failed.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// A run's network could not be turned into a problem.
    #[error("run {run}: {source}")]
    Problem {
        /// Run number.
        run: usize,
        /// Why.
        source: ProblemError,
    },
    /// Settings out of range.
    #[error("invalid study settings: {0}")]
    Settings(&'static str),
    /// Writing an output failed.
    #[error("cannot write {path}: {message}")]
    Write {
        /// The file.
        path: String,
        /// The OS error.
        message: String,
    },
    /// A figure failed.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// The cost weights the study reports with: the scenario's own when its
/// objective is the paper's cost, otherwise the defaults above.
pub fn cost_weights(objective: Objective) -> (f64, f64) {
    match objective {
        Objective::PaperCost { phi1, phi2 } => (phi1, phi2),
        Objective::MaxWeight => (DEFAULT_PHI1, DEFAULT_PHI2),
    }
}

/// The network of run `run` (1-based): the base world with the dynamic
/// waypoints redrawn by the run's generator.
pub fn world_of_run(base: &World, run: usize, map: &impl WaterMap) -> World {
    let mut w = base.clone();
    let mut rng = base.redraw_rng(run as u64);
    w.redraw_dynamic(&mut rng, map);
    w
}

/// The network run `run` re-plans on: run `run`'s network with the dynamic
/// waypoints redrawn once more (generator [`CHANGE_STREAM`] + run).
pub fn changed_world_of_run(base: &World, run: usize, map: &impl WaterMap) -> World {
    let mut w = world_of_run(base, run, map);
    let mut rng = base.redraw_rng(CHANGE_STREAM + run as u64);
    w.redraw_dynamic(&mut rng, map);
    w
}

/// The records of one run, or why it failed.
type RunOutcome = Result<Vec<RunRecord>, StudyError>;

/// Reads one metric off a record.
pub type Metric = fn(&RunRecord) -> f64;

/// Runs the study. `progress` is called once per finished run (from any
/// worker thread).
pub fn run_study<M: WaterMap + Sync>(
    base: &World,
    map: &M,
    settings: StudySettings,
    algorithms: &[AlgorithmSpec],
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<RunRecord>, StudyError> {
    if settings.runs == 0 {
        return Err(StudyError::Settings("runs must be at least 1"));
    }
    if algorithms.is_empty() {
        return Err(StudyError::Settings("no algorithm to run"));
    }
    if algorithms.len() > 32 {
        return Err(StudyError::Settings("at most 32 algorithms (seed slots)"));
    }
    if !(settings.edge_density > 0.0 && settings.edge_density <= 1.0) {
        return Err(StudyError::Settings("edge density must be in (0, 1]"));
    }
    let threads = settings.threads.clamp(1, settings.runs);
    let next = AtomicUsize::new(1);
    let results: Mutex<Vec<Option<RunOutcome>>> = Mutex::new((0..settings.runs).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| {
                let mut solvers: Vec<Box<dyn Solver + Send>> = algorithms.iter().map(|a| (a.build)()).collect();
                let (mut problem, mut changed) = (Problem::new(), Problem::new());
                loop {
                    let run = next.fetch_add(1, Ordering::Relaxed);
                    if run > settings.runs {
                        break;
                    }
                    let outcome = one_run(
                        base,
                        map,
                        settings,
                        algorithms,
                        &mut solvers,
                        run,
                        &mut problem,
                        &mut changed,
                    );
                    if let Ok(mut slots) = results.lock() {
                        slots[run - 1] = Some(outcome);
                    }
                    progress();
                }
            });
        }
    });
    let slots = results.into_inner().unwrap_or_else(|poisoned| poisoned.into_inner());
    let mut records = Vec::with_capacity(settings.runs * algorithms.len());
    for slot in slots {
        // Every run index 1..=runs is claimed by exactly one worker.
        records.extend(slot.ok_or(StudyError::Settings("a run did not complete"))??);
    }
    Ok(records)
}

/// Fills `problem` with `world`'s network (thinned to the study's density)
/// from the start with the scenario's budget.
fn fill(world: &World, problem: &mut Problem, density: f64, run: usize) -> Result<(), StudyError> {
    let seed = world.seed();
    world
        .fill_problem_with(
            problem,
            world.start(),
            NodeSet::EMPTY,
            world.config().time_available_s,
            |a, b| keeps_edge(seed, density, a, b),
        )
        .map_err(|source| StudyError::Problem { run, source })
}

/// Plans, then re-plans after the change, with every algorithm on run `run`.
#[allow(clippy::too_many_arguments)]
fn one_run<M: WaterMap>(
    base: &World,
    map: &M,
    settings: StudySettings,
    algorithms: &[AlgorithmSpec],
    solvers: &mut [Box<dyn Solver + Send>],
    run: usize,
    problem: &mut Problem,
    changed: &mut Problem,
) -> RunOutcome {
    let (phi1, phi2) = settings.cost_phi;
    let budget_s = base.config().time_available_s;
    fill(&world_of_run(base, run, map), problem, settings.edge_density, run)?;
    fill(
        &changed_world_of_run(base, run, map),
        changed,
        settings.edge_density,
        run,
    )?;
    let mut records = Vec::with_capacity(algorithms.len());
    for (ai, (spec, solver)) in algorithms.iter().zip(solvers.iter_mut()).enumerate() {
        let budget = Budget::iterations(spec.iterations);
        let seed = derive_seed(settings.seed, run as u64 * 64 + ai as u64);
        let mut rng = PlannerRng::new(seed);
        let t0 = thread_cpu_time_s();
        auv_core::solver::run(solver.as_mut(), problem, &mut rng, None, budget);
        let cpu_ms = (thread_cpu_time_s() - t0) * 1e3;
        let (route, eval) = solver.best();
        let (plan, eval) = (*route, *eval);

        // The re-plan: warm from the plan if it is still a route there.
        let replan_seed = derive_seed(settings.seed, run as u64 * 64 + 32 + ai as u64);
        let warm = changed.evaluate(&plan).map(|_| &plan);
        let mut rng = PlannerRng::new(replan_seed);
        auv_core::solver::run(solver.as_mut(), changed, &mut rng, warm, budget);
        let (warm_route, warm_eval) = solver.best();
        let (warm_route, warm_eval) = (warm_route.to_vec(), *warm_eval);
        let mut rng = PlannerRng::new(replan_seed);
        auv_core::solver::run(solver.as_mut(), changed, &mut rng, None, budget);
        let (cold_route, cold_eval) = solver.best();
        let plan_ids = plan.to_vec();
        let replan = Replan {
            warm_start: warm.is_some(),
            edges_changed: edges_changed(&plan_ids, &warm_route),
            edges_changed_cold: edges_changed(&plan_ids, &cold_route.to_vec()),
            weight: warm_eval.weight,
            weight_cold: cold_eval.weight,
            feasible: warm_eval.feasible,
            route: warm_route,
        };
        records.push(RunRecord {
            run,
            algorithm: spec.name,
            seed,
            cost: eval.cost(Objective::PaperCost { phi1, phi2 }, budget_s),
            cpu_ms,
            route_time_s: eval.time_s,
            distance_m: eval.distance_m,
            tasks: eval.tasks,
            weight: eval.weight,
            violation_s: eval.violation_s(budget_s),
            feasible: eval.feasible,
            route: plan_ids,
            replan,
        });
    }
    Ok(records)
}

/// Mean, sample standard deviation, minimum and maximum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Summary {
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (n − 1).
    pub std: f64,
    /// Minimum.
    pub min: f64,
    /// Maximum.
    pub max: f64,
}

impl Summary {
    /// Summary of `values` (NaN everywhere when empty).
    pub fn of(values: impl IntoIterator<Item = f64>) -> Self {
        let v: Vec<f64> = values.into_iter().collect();
        if v.is_empty() {
            return Self {
                mean: f64::NAN,
                std: f64::NAN,
                min: f64::NAN,
                max: f64::NAN,
            };
        }
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let var = if v.len() > 1 {
            v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)
        } else {
            0.0
        };
        Self {
            mean,
            std: var.sqrt(),
            min: v.iter().copied().fold(f64::INFINITY, f64::min),
            max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }
}

/// The metrics of the table, in order: name, unit, accessor. The first
/// eight are the paper's (Fig. 4–7), the rest the re-plan's (Fig. 8).
pub const METRICS: [(&str, &str, Metric); 13] = [
    ("cost", "", |r| r.cost),
    ("cpu_time", "ms", |r| r.cpu_ms),
    ("route_time", "s", |r| r.route_time_s),
    ("distance", "m", |r| r.distance_m),
    ("tasks", "", |r| r.tasks as f64),
    ("weight", "", |r| r.weight),
    ("violation", "s", |r| r.violation_s),
    ("feasible", "rate", |r| if r.feasible { 1.0 } else { 0.0 }),
    ("edges_changed", "re-plan", |r| f64::from(r.replan.edges_changed)),
    ("edges_changed", "cold re-plan", |r| {
        f64::from(r.replan.edges_changed_cold)
    }),
    ("weight", "re-plan", |r| r.replan.weight),
    ("weight", "cold re-plan", |r| r.replan.weight_cold),
    ("warm_start", "rate", |r| if r.replan.warm_start { 1.0 } else { 0.0 }),
];

/// Algorithm names in first-appearance order.
pub fn algorithms_of(records: &[RunRecord]) -> Vec<&'static str> {
    let mut names: Vec<&'static str> = Vec::new();
    for r in records {
        if !names.contains(&r.algorithm) {
            names.push(r.algorithm);
        }
    }
    names
}

/// The summary table as aligned text (one row per metric and algorithm).
pub fn summary_table(records: &[RunRecord]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<28} {:<10} {:>14} {:>14} {:>14} {:>14}",
        "metric", "algorithm", "mean", "std", "min", "max"
    );
    for (name, unit, get) in METRICS {
        let label = if unit.is_empty() {
            name.to_string()
        } else {
            format!("{name} ({unit})")
        };
        for alg in algorithms_of(records) {
            let s = Summary::of(records.iter().filter(|r| r.algorithm == alg).map(get));
            let _ = writeln!(
                out,
                "{:<28} {:<10} {:>14} {:>14} {:>14} {:>14}",
                label,
                alg,
                fmt_num(s.mean),
                fmt_num(s.std),
                fmt_num(s.min),
                fmt_num(s.max)
            );
        }
    }
    out.push_str(&paired_table(records));
    out
}

/// Paired comparisons of the first algorithm with each other one, run by
/// run on the same networks: the mean difference (first − other) of the
/// deterministic figures with a 95 % confidence interval (normal
/// approximation, 1.96 standard errors), and the median ratio of CPU times
/// (a ratio within one run cancels most of a shared machine's drift).
/// Empty with fewer than two algorithms or two runs.
pub fn paired_table(records: &[RunRecord]) -> String {
    use std::fmt::Write;
    let algs = algorithms_of(records);
    let mut out = String::new();
    let Some((&first, others)) = algs.split_first() else {
        return out;
    };
    let of = |alg: &str| -> Vec<&RunRecord> { records.iter().filter(|r| r.algorithm == alg).collect() };
    let a = of(first);
    for &other in others {
        let b = of(other);
        if a.len() < 2 || a.len() != b.len() {
            continue;
        }
        let _ = writeln!(out, "\npaired, {first} − {other} over {} runs (95 % CI):", a.len());
        for (name, unit, get) in METRICS
            .iter()
            .filter(|(n, ..)| !matches!(*n, "cpu_time" | "feasible" | "warm_start"))
        {
            let d = Summary::of(a.iter().zip(&b).map(|(x, y)| get(x) - get(y)));
            let half = 1.96 * d.std / (a.len() as f64).sqrt();
            let label = if unit.is_empty() {
                name.to_string()
            } else {
                format!("{name} ({unit})")
            };
            let _ = writeln!(
                out,
                "  {label:<28} {:>12}  [{}, {}]",
                fmt_num(d.mean),
                fmt_num(d.mean - half),
                fmt_num(d.mean + half)
            );
        }
        let mut ratios: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x.cpu_ms / y.cpu_ms).collect();
        ratios.sort_by(f64::total_cmp);
        let _ = writeln!(
            out,
            "  {:<28} {:>12}  (median of per-run ratios)",
            "cpu_time ratio",
            fmt_num(ratios[ratios.len() / 2])
        );
    }
    out
}

fn fmt_num(v: f64) -> String {
    if v.abs() >= 1e5 || (v != 0.0 && v.abs() < 1e-3) {
        format!("{v:.4e}")
    } else {
        format!("{v:.4}")
    }
}

/// The CSV header: the paper's figures, then the re-plan's.
pub const CSV_HEADER: &str = "run,algorithm,seed,cost,cpu_ms,route_time_s,distance_m,tasks,weight,violation_s,feasible,\
                              edges_changed,edges_changed_cold,replan_weight,replan_weight_cold,replan_feasible,warm_start";

/// The per-run CSV: one row per run and algorithm, columns [`CSV_HEADER`].
pub fn csv(records: &[RunRecord]) -> String {
    let mut out = format!("{CSV_HEADER}\n");
    for r in records {
        out.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            r.run,
            r.algorithm,
            r.seed,
            r.cost,
            r.cpu_ms,
            r.route_time_s,
            r.distance_m,
            r.tasks,
            r.weight,
            r.violation_s,
            r.feasible,
            r.replan.edges_changed,
            r.replan.edges_changed_cold,
            r.replan.weight,
            r.replan.weight_cold,
            r.replan.feasible,
            r.replan.warm_start
        ));
    }
    out
}

fn write(path: &Path, text: &str) -> Result<(), StudyError> {
    std::fs::write(path, text).map_err(|e| StudyError::Write {
        path: path.display().to_string(),
        message: e.to_string(),
    })
}

/// One Fig. 8 panel's texts and lines: title, plan label, re-plan label,
/// plan points, re-plan points.
type Fig8Panel = (String, String, String, Vec<(f64, f64)>, Vec<(f64, f64)>);

/// Writes `runs.csv`, `summary.txt` and the figures into `dir` (which must
/// exist). Returns the files written.
pub fn write_outputs(
    dir: &Path,
    base: &World,
    map: &impl WaterMap,
    records: &[RunRecord],
) -> Result<Vec<std::path::PathBuf>, StudyError> {
    let mut written = Vec::new();
    let csv_path = dir.join("runs.csv");
    write(&csv_path, &csv(records))?;
    written.push(csv_path);
    let table_path = dir.join("summary.txt");
    write(&table_path, &summary_table(records))?;
    written.push(table_path);

    let algs = algorithms_of(records);
    let column =
        |alg: &str, get: Metric| -> Vec<f64> { records.iter().filter(|r| r.algorithm == alg).map(get).collect() };
    let figures: [(&str, &str, &[usize]); 4] = [
        ("fig4-cost-cpu.svg", "Cost and CPU time per run", &[0, 1]),
        ("fig5-time-distance.svg", "Route time and distance per run", &[2, 3]),
        (
            "fig6-tasks-weight.svg",
            "Completed tasks and obtained weight per run",
            &[4, 5],
        ),
        ("fig7-violation.svg", "Time violation per run", &[6]),
    ];
    for (file, title, metric_ids) in figures {
        let data: Vec<Vec<Vec<f64>>> = metric_ids
            .iter()
            .map(|&m| algs.iter().map(|a| column(a, METRICS[m].2)).collect())
            .collect();
        let labels: Vec<String> = metric_ids
            .iter()
            .map(|&m| {
                let (name, unit, _) = METRICS[m];
                if unit.is_empty() {
                    name.replace('_', " ")
                } else {
                    format!("{} ({unit})", name.replace('_', " "))
                }
            })
            .collect();
        let series: Vec<Vec<Series<'_>>> = data
            .iter()
            .map(|per_alg| {
                algs.iter()
                    .zip(per_alg)
                    .map(|(a, v)| Series { label: a, values: v })
                    .collect()
            })
            .collect();
        let panels: Vec<Panel<'_>> = series
            .iter()
            .zip(&labels)
            .map(|(s, l)| Panel { y_label: l, series: s })
            .collect();
        let path = dir.join(file);
        plot::per_run_figure(&path, title, &panels)?;
        written.push(path);
    }

    // Fig. 8: run 1's plan of every algorithm, and its warm re-plan after
    // the dynamic waypoints moved, one map per algorithm.
    let before = world_of_run(base, 1, map);
    let after = changed_world_of_run(base, 1, map);
    let xy = |w: &World| -> Vec<(f64, f64)> { w.positions().iter().map(|p| (p.x, p.y)).collect() };
    let (p_before, p_after) = (xy(&before), xy(&after));
    let line = |pos: &[(f64, f64)], route: &[usize]| -> Vec<(f64, f64)> {
        route.iter().filter_map(|&i| pos.get(i).copied()).collect()
    };
    let bounds: Vec<BoundMarker> = base
        .dynamic_nodes()
        .iter()
        .map(|i| {
            let (nom, b) = (base.nominal_positions()[i], base.bounds()[i]);
            BoundMarker {
                nominal: (nom.x, nom.y),
                bound: (b.x, b.y),
            }
        })
        .collect();
    let moved_from: Vec<(f64, f64)> = base.dynamic_nodes().iter().map(|i| p_before[i]).collect();
    let firsts: Vec<&RunRecord> = algs
        .iter()
        .filter_map(|a| records.iter().find(|r| r.run == 1 && r.algorithm == *a))
        .collect();
    if !firsts.is_empty() {
        let texts: Vec<Fig8Panel> = firsts
            .iter()
            .map(|r| {
                let rp = &r.replan;
                (
                    format!(
                        "{}: {} edges changed by the re-plan ({} by a cold one)",
                        r.algorithm, rp.edges_changed, rp.edges_changed_cold
                    ),
                    format!("{} plan, weight {:.0} (before)", r.algorithm, r.weight),
                    format!(
                        "{} re-plan{}, weight {:.0} (after)",
                        r.algorithm,
                        if rp.warm_start {
                            " (warm)"
                        } else {
                            " (cold: plan broken)"
                        },
                        rp.weight
                    ),
                    line(&p_before, &r.route),
                    line(&p_after, &rp.route),
                )
            })
            .collect();
        let layers: Vec<[RouteLayer<'_>; 2]> = texts
            .iter()
            .map(|(_, lb, la, pb, pa)| {
                [
                    RouteLayer {
                        label: lb,
                        points: pb,
                        dashed: true,
                    },
                    RouteLayer {
                        label: la,
                        points: pa,
                        dashed: false,
                    },
                ]
            })
            .collect();
        let figs: Vec<MapFigure<'_>> = texts
            .iter()
            .zip(&layers)
            .map(|((title, ..), routes)| MapFigure {
                title,
                map,
                waypoints: &p_after,
                start: base.start(),
                goal: base.goal(),
                bounds: &bounds,
                routes,
                markers: &moved_from,
                marker_label: "dynamic waypoint before the change",
            })
            .collect();
        let path = dir.join("fig8-replan.svg");
        plot::map_panels(
            &path,
            Some("Run 1: plan, change of the dynamic waypoints, warm-started re-plan"),
            &figs,
        )?;
        written.push(path);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_core::route::{Route, RouteEval};
    use auv_world::scenario::ScenarioConfig;
    use auv_world::scenario::synthetic::GridMap;

    /// A stand-in solver for the study's own tests: decodes one random
    /// vector per step and keeps the best (the real solvers have their own
    /// conformance suite).
    struct RandomSearch {
        dec: auv_core::decode::Decoder,
        best: Route,
        eval: RouteEval,
        prio: Vec<f64>,
        scratch: Route,
    }

    impl Solver for RandomSearch {
        fn name(&self) -> &'static str {
            "random"
        }
        fn start(&mut self, p: &Problem, rng: &mut PlannerRng, _: Option<&Route>) {
            self.eval = RouteEval::default();
            self.best.clear();
            let _ = self.step(p, rng);
        }
        fn step(&mut self, p: &Problem, rng: &mut PlannerRng) -> bool {
            for x in self.prio.iter_mut() {
                *x = rng.uniform(-200.0, 100.0);
            }
            let e = self.dec.decode(p, &self.prio, &mut self.scratch);
            if self.best.is_empty() || p.better(&e, &self.eval) {
                self.best = self.scratch;
                self.eval = e;
            }
            true
        }
        fn best(&self) -> (&Route, &RouteEval) {
            (&self.best, &self.eval)
        }
    }

    fn spec(name: &'static str) -> AlgorithmSpec {
        AlgorithmSpec {
            name,
            build: Box::new(|| {
                Box::new(RandomSearch {
                    dec: auv_core::decode::Decoder::new(),
                    best: Route::new(),
                    eval: RouteEval::default(),
                    prio: vec![0.0; auv_core::problem::MAX_NODES],
                    scratch: Route::new(),
                })
            }),
            iterations: 20,
        }
    }

    fn study(threads: usize) -> (World, GridMap, Vec<RunRecord>) {
        let map = GridMap::cove();
        let cfg = ScenarioConfig {
            nodes: 20,
            dynamic: 5,
            ..ScenarioConfig::default()
        };
        let world = World::generate(&cfg, 3, &map).unwrap();
        let records = run_study(
            &world,
            &map,
            StudySettings::new(6, 9, threads),
            &[spec("a"), spec("b")],
            &|| {},
        )
        .unwrap();
        (world, map, records)
    }

    #[test]
    fn every_run_and_algorithm_gets_a_valid_row_in_order_whatever_the_threads() {
        let (world, map, one) = study(1);
        let (_, _, two) = study(2);
        assert_eq!(one.len(), 12);
        let strip = |rs: &[RunRecord]| -> Vec<RunRecord> {
            rs.iter()
                .cloned()
                .map(|mut r| {
                    r.cpu_ms = 0.0;
                    r
                })
                .collect()
        };
        assert_eq!(strip(&one), strip(&two), "threads must not change results");
        for (i, r) in one.iter().enumerate() {
            assert_eq!(r.run, i / 2 + 1);
            assert_eq!(r.algorithm, if i % 2 == 0 { "a" } else { "b" });
            let w = world_of_run(&world, r.run, &map);
            let inst = w.snapshot("check");
            let stats = auv_core::route::RouteStats::from_instance(&inst, &r.route).unwrap();
            assert_eq!(stats.weight, r.weight);
            assert_eq!(stats.feasible, r.feasible);
            assert!(r.cpu_ms >= 0.0);
            // The re-plan is a route of the changed network, and its count
            // of changed edges is that of the two routes.
            let changed = changed_world_of_run(&world, r.run, &map).snapshot("changed");
            let stats = auv_core::route::RouteStats::from_instance(&changed, &r.replan.route).unwrap();
            assert_eq!(stats.weight, r.replan.weight);
            assert_eq!(r.replan.edges_changed, edges_changed(&r.route, &r.replan.route));
        }
        // Both algorithms of a run see the same network; different runs differ.
        let inst = |run| world_of_run(&world, run, &map).snapshot("x").to_json();
        assert_ne!(inst(1), inst(2));
    }

    #[test]
    fn summary_and_csv_have_the_documented_shape() {
        let s = Summary::of([1.0, 2.0, 3.0]);
        assert_eq!((s.mean, s.min, s.max), (2.0, 1.0, 3.0));
        assert!((s.std - 1.0).abs() < 1e-12);
        let (_, _, records) = study(1);
        let text = csv(&records);
        let mut lines = text.lines();
        assert_eq!(
            lines.next(),
            Some(
                "run,algorithm,seed,cost,cpu_ms,route_time_s,distance_m,tasks,weight,violation_s,feasible,\
                 edges_changed,edges_changed_cold,replan_weight,replan_weight_cold,replan_feasible,warm_start"
            )
        );
        assert!(lines.clone().all(|l| l.split(',').count() == 17));
        assert_eq!(lines.count(), records.len());
        let table = summary_table(&records);
        for m in [
            "cost",
            "cpu_time (ms)",
            "feasible (rate)",
            "weight",
            "paired, a − b over 6 runs",
        ] {
            assert!(table.contains(m), "{m} missing from\n{table}");
        }
        // The paired mean difference is the difference of the means.
        let mean = |alg: &str| Summary::of(records.iter().filter(|r| r.algorithm == alg).map(|r| r.weight)).mean;
        let line = table
            .lines()
            .find(|l| l.trim_start().starts_with("weight ") && l.contains('['))
            .unwrap();
        let shown: f64 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
        assert!((shown - (mean("a") - mean("b"))).abs() < 1e-3, "{line}");
    }

    #[test]
    fn writes_every_figure() {
        let (world, map, records) = study(2);
        let dir = std::env::temp_dir().join(format!("planner-mc-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let files = write_outputs(&dir, &world, &map, &records).unwrap();
        let names: Vec<String> = files
            .iter()
            .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        for f in [
            "runs.csv",
            "summary.txt",
            "fig4-cost-cpu.svg",
            "fig5-time-distance.svg",
            "fig6-tasks-weight.svg",
            "fig7-violation.svg",
            "fig8-replan.svg",
        ] {
            assert!(names.iter().any(|n| n == f), "{f} not written");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn edges_changed_counts_the_symmetric_difference_of_edge_sets() {
        assert_eq!(edges_changed(&[0, 3, 5, 9], &[0, 3, 5, 9]), 0);
        // One detour: edge 3–5 replaced by 3–7 and 7–5.
        assert_eq!(edges_changed(&[0, 3, 5, 9], &[0, 3, 7, 5, 9]), 3);
        // Edges are unordered pairs: the same legs the other way round.
        assert_eq!(edges_changed(&[0, 3, 5, 9], &[9, 5, 3, 0]), 0);
        // Nothing shared: every edge of both counts.
        assert_eq!(edges_changed(&[0, 1, 9], &[0, 2, 3, 9]), 5);
        assert_eq!(edges_changed(&[], &[0, 9]), 1);
    }

    #[test]
    fn edge_density_keeps_a_fixed_symmetric_share_of_pairs() {
        let pairs = || (0..60).flat_map(|a| (a + 1..60).map(move |b| (a, b)));
        assert!(pairs().all(|(a, b)| keeps_edge(7, 1.0, a, b)));
        let kept = pairs().filter(|&(a, b)| keeps_edge(7, 0.3, a, b)).count() as f64;
        let share = kept / pairs().count() as f64;
        assert!((share - 0.3).abs() < 0.03, "kept {share}");
        assert!(pairs().all(|(a, b)| keeps_edge(7, 0.3, a, b) == keeps_edge(7, 0.3, b, a)));
        // Another world seed thins other pairs.
        assert!(pairs().any(|(a, b)| keeps_edge(7, 0.3, a, b) != keeps_edge(8, 0.3, a, b)));
    }

    fn real_solvers() -> [AlgorithmSpec; 2] {
        use auv_core::solver::bbo::{Bbo, BboSettings};
        use auv_core::solver::pso::{Pso, PsoSettings};
        let pso = PsoSettings {
            particles: 20,
            iterations: 15,
            ..PsoSettings::paper()
        };
        let bbo = BboSettings {
            habitats: 12,
            elites: 3,
            generations: 15,
            ..BboSettings::paper()
        };
        [
            AlgorithmSpec {
                name: "pso",
                build: Box::new(move || Box::new(Pso::new(pso))),
                iterations: pso.iterations,
            },
            AlgorithmSpec {
                name: "bbo",
                build: Box::new(move || Box::new(Bbo::new(bbo))),
                iterations: bbo.generations,
            },
        ]
    }

    #[test]
    fn without_a_change_every_replan_is_warm_and_never_worse_than_the_plan() {
        let map = GridMap::cove();
        let cfg = ScenarioConfig {
            nodes: 18,
            dynamic: 0,
            ..ScenarioConfig::default()
        };
        let world = World::generate(&cfg, 4, &map).unwrap();
        let records = run_study(&world, &map, StudySettings::new(5, 2, 2), &real_solvers(), &|| {}).unwrap();
        for r in &records {
            assert!(r.replan.warm_start, "{r:?}");
            assert!(r.replan.weight >= r.weight, "{r:?}");
            assert!(r.replan.feasible);
            // A re-plan that kept the plan changed nothing.
            if r.replan.route == r.route {
                assert_eq!(r.replan.edges_changed, 0);
            }
        }
        assert_eq!(
            world_of_run(&world, 1, &map).snapshot("a").to_json(),
            changed_world_of_run(&world, 1, &map).snapshot("a").to_json()
        );
    }

    #[test]
    fn the_replan_runs_on_a_changed_network_and_is_a_function_of_the_seed() {
        let map = GridMap::cove();
        let cfg = ScenarioConfig {
            nodes: 20,
            dynamic: 6,
            ..ScenarioConfig::default()
        };
        let world = World::generate(&cfg, 3, &map).unwrap();
        assert_ne!(
            world_of_run(&world, 1, &map).snapshot("a").to_json(),
            changed_world_of_run(&world, 1, &map).snapshot("a").to_json()
        );
        let go = |seed| {
            let mut rs = run_study(&world, &map, StudySettings::new(4, seed, 1), &real_solvers(), &|| {}).unwrap();
            for r in &mut rs {
                r.cpu_ms = 0.0;
            }
            rs
        };
        let (a, b, c) = (go(5), go(5), go(6));
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert!(a.iter().all(|r| r.replan.feasible));
        // A thinner network is a different problem (and still solvable).
        let thin = run_study(
            &world,
            &map,
            StudySettings {
                edge_density: 0.5,
                ..StudySettings::new(2, 5, 1)
            },
            &real_solvers(),
            &|| {},
        )
        .unwrap();
        assert!(thin.iter().all(|r| r.feasible));
        // Both the plan and the re-plan use only the pairs the density keeps.
        for r in &thin {
            for route in [&r.route, &r.replan.route] {
                assert!(
                    route.windows(2).all(|e| keeps_edge(world.seed(), 0.5, e[0], e[1])),
                    "{r:?}"
                );
            }
        }
    }

    #[test]
    fn bad_settings_are_errors() {
        let map = GridMap::cove();
        let world = World::generate(
            &ScenarioConfig {
                nodes: 10,
                dynamic: 2,
                ..ScenarioConfig::default()
            },
            1,
            &map,
        )
        .unwrap();
        let err = run_study(&world, &map, StudySettings::new(0, 1, 1), &[spec("a")], &|| {}).unwrap_err();
        assert!(err.to_string().contains("runs"));
        let err = run_study(&world, &map, StudySettings::new(1, 1, 1), &[], &|| {}).unwrap_err();
        assert!(err.to_string().contains("algorithm"));
        let err = run_study(
            &world,
            &map,
            StudySettings {
                edge_density: 0.0,
                ..StudySettings::new(1, 1, 1)
            },
            &[spec("a")],
            &|| {},
        )
        .unwrap_err();
        assert!(err.to_string().contains("density"));
    }
}
