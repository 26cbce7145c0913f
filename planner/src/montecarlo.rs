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

use auv_platform::clock::thread_cpu_time_s;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::plot::{self, BoundMarker, MapFigure, Panel, PlotError, RouteLayer, Series};
use auv_core::instance::Objective;
use auv_core::problem::{NodeSet, Problem, ProblemError};
use auv_core::rng::{PlannerRng, derive_seed};
use auv_core::route::{Route, RouteEval};
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
    let threads = settings.threads.clamp(1, settings.runs);
    let (phi1, phi2) = cost_weights(base.config().objective);
    let budget_s = base.config().time_available_s;
    let next = AtomicUsize::new(1);
    let results: Mutex<Vec<Option<RunOutcome>>> = Mutex::new((0..settings.runs).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| {
                let mut solvers: Vec<Box<dyn Solver + Send>> = algorithms.iter().map(|a| (a.build)()).collect();
                let mut problem = Problem::new();
                loop {
                    let run = next.fetch_add(1, Ordering::Relaxed);
                    if run > settings.runs {
                        break;
                    }
                    let world = world_of_run(base, run, map);
                    let outcome = world
                        .fill_problem(&mut problem, world.start(), NodeSet::EMPTY, budget_s)
                        .map_err(|source| StudyError::Problem { run, source })
                        .map(|()| {
                            algorithms
                                .iter()
                                .zip(solvers.iter_mut())
                                .enumerate()
                                .map(|(ai, (spec, solver))| {
                                    let seed = derive_seed(settings.seed, run as u64 * 64 + ai as u64);
                                    let mut rng = PlannerRng::new(seed);
                                    let t0 = thread_cpu_time_s();
                                    auv_core::solver::run(
                                        solver.as_mut(),
                                        &problem,
                                        &mut rng,
                                        None,
                                        Budget::iterations(spec.iterations),
                                    );
                                    let cpu_ms = (thread_cpu_time_s() - t0) * 1e3;
                                    let (route, eval) = solver.best();
                                    record(run, spec.name, seed, cpu_ms, route, eval, budget_s, (phi1, phi2))
                                })
                                .collect()
                        });
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

#[allow(clippy::too_many_arguments)]
fn record(
    run: usize,
    algorithm: &'static str,
    seed: u64,
    cpu_ms: f64,
    route: &Route,
    eval: &RouteEval,
    budget_s: f64,
    (phi1, phi2): (f64, f64),
) -> RunRecord {
    RunRecord {
        run,
        algorithm,
        seed,
        cost: eval.cost(Objective::PaperCost { phi1, phi2 }, budget_s),
        cpu_ms,
        route_time_s: eval.time_s,
        distance_m: eval.distance_m,
        tasks: eval.tasks,
        weight: eval.weight,
        violation_s: eval.violation_s(budget_s),
        feasible: eval.feasible,
        route: route.to_vec(),
    }
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

/// The metrics of the table, in order: name, unit, accessor.
pub const METRICS: [(&str, &str, Metric); 8] = [
    ("cost", "", |r| r.cost),
    ("cpu_time", "ms", |r| r.cpu_ms),
    ("route_time", "s", |r| r.route_time_s),
    ("distance", "m", |r| r.distance_m),
    ("tasks", "", |r| r.tasks as f64),
    ("weight", "", |r| r.weight),
    ("violation", "s", |r| r.violation_s),
    ("feasible", "rate", |r| if r.feasible { 1.0 } else { 0.0 }),
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
        "{:<16} {:<10} {:>14} {:>14} {:>14} {:>14}",
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
                "{:<16} {:<10} {:>14} {:>14} {:>14} {:>14}",
                label,
                alg,
                fmt_num(s.mean),
                fmt_num(s.std),
                fmt_num(s.min),
                fmt_num(s.max)
            );
        }
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

/// The CSV the issue fixes: one row per run and algorithm.
pub fn csv(records: &[RunRecord]) -> String {
    let mut out =
        String::from("run,algorithm,seed,cost,cpu_ms,route_time_s,distance_m,tasks,weight,violation_s,feasible\n");
    for r in records {
        out.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{}\n",
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
            r.feasible
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

    // Fig. 8: the network of run 1 and of run 2 with the first algorithm's
    // route on each: the routes before and after a network change.
    if let Some(first) = algs.first() {
        let route_of = |run: usize| records.iter().find(|r| r.run == run && r.algorithm == *first);
        if let (Some(before), Some(after)) = (route_of(1), route_of(2).or_else(|| route_of(1))) {
            let w_before = world_of_run(base, before.run, map);
            let w_after = world_of_run(base, after.run, map);
            let xy = |w: &World| -> Vec<(f64, f64)> { w.positions().iter().map(|p| (p.x, p.y)).collect() };
            let (p_before, p_after) = (xy(&w_before), xy(&w_after));
            let line =
                |pos: &[(f64, f64)], route: &[usize]| -> Vec<(f64, f64)> { route.iter().map(|&i| pos[i]).collect() };
            let (l_before, l_after) = (line(&p_before, &before.route), line(&p_after, &after.route));
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
            let label_before = format!("{first}, run {} (before)", before.run);
            let label_after = format!("{first}, run {} (after the change)", after.run);
            let moved: Vec<(f64, f64)> = base.dynamic_nodes().iter().map(|i| p_after[i]).collect();
            let path = dir.join("fig8-network.svg");
            plot::map_figure(
                &path,
                &MapFigure {
                    title: "Waypoint network and routes before and after a network change",
                    map,
                    waypoints: &p_after,
                    start: base.start(),
                    goal: base.goal(),
                    bounds: &bounds,
                    routes: &[
                        RouteLayer {
                            label: &label_before,
                            points: &l_before,
                            dashed: true,
                        },
                        RouteLayer {
                            label: &label_after,
                            points: &l_after,
                            dashed: false,
                        },
                    ],
                    markers: &moved,
                    marker_label: "dynamic waypoint (after)",
                },
            )?;
            written.push(path);
        }
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
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
            StudySettings {
                runs: 6,
                seed: 9,
                threads,
            },
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
            Some("run,algorithm,seed,cost,cpu_ms,route_time_s,distance_m,tasks,weight,violation_s,feasible")
        );
        assert_eq!(lines.count(), records.len());
        let table = summary_table(&records);
        for m in ["cost", "cpu_time (ms)", "feasible (rate)", "weight"] {
            assert!(table.contains(m), "{m} missing from\n{table}");
        }
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
            "fig8-network.svg",
        ] {
            assert!(names.iter().any(|n| n == f), "{f} not written");
        }
        let _ = std::fs::remove_dir_all(&dir);
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
        let err = run_study(
            &world,
            &map,
            StudySettings {
                runs: 0,
                seed: 1,
                threads: 1,
            },
            &[spec("a")],
            &|| {},
        )
        .unwrap_err();
        assert!(err.to_string().contains("runs"));
        let err = run_study(
            &world,
            &map,
            StudySettings {
                runs: 1,
                seed: 1,
                threads: 1,
            },
            &[],
            &|| {},
        )
        .unwrap_err();
        assert!(err.to_string().contains("algorithm"));
    }
}
