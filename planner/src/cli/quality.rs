//! `planner quality`: solves every instance in a folder with each algorithm
//! under a deadline and reports the gap to the optimum (issue 5 §2).
//!
//! Contract: instances are every `*.json` (`auv-route-instance/1`) and
//! every classic orienteering `*.txt` file under `--instances` (recursively,
//! sorted by path, so runs are reproducible). The optimum of an instance is
//! taken from the first `best_known.csv` found in the folder or above it
//! (matched by instance name); else, with `--reference-iterations N`, from
//! a long reference search (the paper PSO and `auto` at N iterations, no
//! deadline, and every measured result: a lower bound on the optimum, so
//! the gap is optimistic); else it is left empty. Gaps are in percent of
//! the optimum: lost weight for `max_weight`, extra cost for `paper_cost`.
//! One CSV row per instance × algorithm; the summary per algorithm goes to
//! standard output.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use planner::instance::{Instance, Objective};
use planner::oplib::{BestKnown, instance_name, parse_op};
use planner::problem::Problem;
use planner::rng::PlannerRng;
use planner::route::RouteEval;
use planner::solver::{self, Algorithm, Budget};

use super::{CliError, DEFAULT_SEED, load_instance, print, read_text, write_text};

/// Arguments of `planner quality`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Folder of instance JSON files and/or classic orienteering `.txt` files.
    #[arg(long, value_name = "DIR")]
    pub instances: PathBuf,
    /// Wall-clock budget of each solve, in milliseconds.
    #[arg(long, value_name = "D", default_value_t = 20, value_parser = clap::value_parser!(u64).range(1..))]
    pub deadline_ms: u64,
    /// Algorithms to compare, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "auto,pso,bbo")]
    pub algorithms: Vec<Algorithm>,
    /// Seed of every solve.
    #[arg(long, default_value_t = DEFAULT_SEED, allow_negative_numbers = true)]
    pub seed: u64,
    /// When an instance has no known optimum: iterations of the reference
    /// searches whose best stands in for it.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub reference_iterations: Option<u32>,
    /// CSV file to write (one row per instance and algorithm).
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
}

/// One solve's figures.
struct Row {
    instance: String,
    algorithm: Algorithm,
    score: f64,
    optimum: Option<f64>,
    source: &'static str,
    gap: Option<f64>,
    solve: Duration,
    feasible: bool,
}

/// The objective's score of `e` as reported: weight or cost.
fn score(inst: &Instance, e: &RouteEval) -> f64 {
    match inst.objective {
        Objective::MaxWeight => e.weight,
        o @ Objective::PaperCost { .. } => e.cost(o, inst.time_available_s),
    }
}

/// Gap of `score` to `optimum` in percent (never negative beyond rounding).
fn gap_percent(objective: Objective, score: f64, optimum: f64, feasible: bool) -> f64 {
    if !feasible {
        return 100.0;
    }
    let lost = match objective {
        Objective::MaxWeight => optimum - score,
        Objective::PaperCost { .. } => score - optimum,
    };
    if optimum.abs() < 1e-12 {
        if lost <= 1e-9 { 0.0 } else { 100.0 }
    } else {
        100.0 * lost / optimum.abs()
    }
}

/// The first `best_known.csv` in `dir` or above it.
fn best_known(dir: &Path) -> Result<Option<BestKnown>, CliError> {
    let start = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    for d in start.ancestors() {
        let path = d.join("best_known.csv");
        if path.is_file() {
            let text = read_text(&path)?;
            return BestKnown::parse(&text)
                .map(Some)
                .map_err(|e| CliError::Usage(format!("{}: {e}", path.display())));
        }
    }
    Ok(None)
}

/// Reads an instance: JSON in the interchange format, or a classic
/// orienteering `.txt` converted on the fly.
fn load(path: &Path) -> Result<(String, Instance), CliError> {
    let stem = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    if path.extension().is_some_and(|e| e == "txt") {
        let name = instance_name(stem).to_owned();
        let text = read_text(path)?;
        let op = parse_op(&text).map_err(|source| CliError::Op {
            path: path.to_path_buf(),
            source,
        })?;
        let inst = op.to_instance(&name);
        Ok((name, inst))
    } else {
        let name = stem.strip_suffix(".json").unwrap_or(stem).to_owned();
        Ok((name, load_instance(path)?))
    }
}

/// The median and the p-th percentile (nearest rank) of `v` (sorted here).
fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    let rank = ((p / 100.0) * v.len() as f64).ceil() as usize;
    v[rank.clamp(1, v.len()) - 1]
}

/// Runs `planner quality`.
pub fn run(args: Args) -> Result<(), CliError> {
    if !args.instances.is_dir() {
        return Err(CliError::Usage(format!(
            "--instances {}: not a folder",
            args.instances.display()
        )));
    }
    let mut algorithms = Vec::new();
    for a in &args.algorithms {
        if !algorithms.contains(a) {
            algorithms.push(*a);
        }
    }
    if algorithms.is_empty() {
        return Err(CliError::Usage(
            "--algorithms: name at least one of auto, pso, bbo".into(),
        ));
    }
    let mut files = Vec::new();
    super::collect_files(&args.instances, &["json", "txt"], &mut files)?;
    if files.is_empty() {
        return Err(CliError::Usage(format!(
            "--instances {}: no instance files (*.json, *.txt) in the folder",
            args.instances.display()
        )));
    }
    let known = best_known(&args.instances)?;
    let mut solvers: Vec<_> = algorithms.iter().map(|&a| (a, a.build(a.paper_iterations()))).collect();
    let deadline = Duration::from_millis(args.deadline_ms);
    let mut rows = Vec::new();
    for path in &files {
        let (name, inst) = load(path)?;
        let problem = Problem::from_instance(&inst).map_err(|source| CliError::Problem {
            path: path.clone(),
            source,
        })?;
        let mut results = Vec::new();
        for (a, s) in &mut solvers {
            let mut rng = PlannerRng::new(args.seed);
            // Auto spends the whole deadline (issue 5 §2); PSO and BBO keep
            // the paper's budget, cut by the deadline.
            let iterations = if *a == Algorithm::Auto {
                u32::MAX
            } else {
                a.paper_iterations()
            };
            let budget = Budget {
                iterations,
                deadline: Some(Instant::now() + deadline),
            };
            let out = solver::run(s.as_mut(), &problem, &mut rng, None, budget);
            let e = *s.best().1;
            results.push((*a, e, out.elapsed));
        }
        let (optimum, source) = match known.as_ref().and_then(|k| k.get(&name)) {
            Some(entry) => (Some(entry.score), "best_known"),
            None => match args.reference_iterations {
                Some(n) => {
                    let mut best = results
                        .iter()
                        .map(|r| r.1)
                        .fold(solver_worst(), |b, e| if problem.better(&e, &b) { e } else { b });
                    for (a, seed) in [(Algorithm::Pso, 1), (Algorithm::Auto, 1), (Algorithm::Auto, 2)] {
                        let mut s = a.build(n);
                        solver::run(
                            s.as_mut(),
                            &problem,
                            &mut PlannerRng::new(seed),
                            None,
                            Budget::iterations(n),
                        );
                        if problem.better(s.best().1, &best) {
                            best = *s.best().1;
                        }
                    }
                    (best.feasible.then(|| score(&inst, &best)), "reference")
                }
                None => (None, ""),
            },
        };
        for (a, e, elapsed) in results {
            let sc = score(&inst, &e);
            rows.push(Row {
                instance: name.clone(),
                algorithm: a,
                score: sc,
                optimum,
                source,
                gap: optimum.map(|o| gap_percent(inst.objective, sc, o, e.feasible)),
                solve: elapsed,
                feasible: e.feasible,
            });
        }
    }
    let mut csv = String::from("instance,algorithm,score,optimum,gap,solve_ms,feasible,optimum_source\n");
    for r in &rows {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{:.3},{},{}",
            r.instance,
            r.algorithm,
            r.score,
            r.optimum.map_or(String::new(), |o| o.to_string()),
            r.gap.map_or(String::new(), |g| format!("{g:.4}")),
            r.solve.as_secs_f64() * 1e3,
            r.feasible,
            r.source
        );
    }
    write_text(&args.out, &csv)?;
    print(&summary(&rows, &algorithms, files.len(), args.deadline_ms))
}

fn solver_worst() -> RouteEval {
    RouteEval {
        time_s: f64::INFINITY,
        ..RouteEval::default()
    }
}

/// The per-algorithm table.
fn summary(rows: &[Row], algorithms: &[Algorithm], instances: usize, deadline_ms: u64) -> String {
    let mut text = format!("{instances} instances, deadline {deadline_ms} ms\n");
    let _ = writeln!(
        text,
        "{:<6} {:>9} {:>9} {:>9} {:>9} {:>11} {:>11}",
        "algo", "mean gap%", "med gap%", "worst%", "at opt", "median ms", "p99 ms"
    );
    for &a in algorithms {
        let mine: Vec<&Row> = rows.iter().filter(|r| r.algorithm == a).collect();
        let mut gaps: Vec<f64> = mine.iter().filter_map(|r| r.gap).collect();
        let mut ms: Vec<f64> = mine.iter().map(|r| r.solve.as_secs_f64() * 1e3).collect();
        let (mean, median, worst, at_opt) = if gaps.is_empty() {
            ("-".to_owned(), "-".to_owned(), "-".to_owned(), "-".to_owned())
        } else {
            let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
            let hits = gaps.iter().filter(|&&g| g <= 1e-6).count();
            let at = format!("{hits}/{}", gaps.len());
            (
                format!("{mean:.3}"),
                format!("{:.3}", percentile(&mut gaps, 50.0)),
                format!("{:.3}", percentile(&mut gaps, 100.0)),
                at,
            )
        };
        let _ = writeln!(
            text,
            "{:<6} {:>9} {:>9} {:>9} {:>9} {:>11.3} {:>11.3}",
            a.as_str(),
            mean,
            median,
            worst,
            at_opt,
            percentile(&mut ms, 50.0),
            percentile(&mut ms, 99.0)
        );
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_follow_the_objective() {
        assert_eq!(gap_percent(Objective::MaxWeight, 90.0, 100.0, true), 10.0);
        let cost = Objective::PaperCost { phi1: 1.0, phi2: 1.0 };
        assert_eq!(gap_percent(cost, 110.0, 100.0, true), 10.0);
        assert_eq!(gap_percent(Objective::MaxWeight, 100.0, 100.0, false), 100.0);
        assert_eq!(gap_percent(Objective::MaxWeight, 0.0, 0.0, true), 0.0);
    }

    #[test]
    fn percentiles_use_nearest_rank() {
        let mut v = vec![5.0, 1.0, 3.0, 2.0, 4.0];
        assert_eq!(percentile(&mut v, 50.0), 3.0);
        assert_eq!(percentile(&mut v, 99.0), 5.0);
        assert_eq!(percentile(&mut v, 100.0), 5.0);
    }
}
