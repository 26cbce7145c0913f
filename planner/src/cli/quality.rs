//! `planner quality`: solves every instance in a folder with each algorithm
//! under each deadline and reports the gap to the optimum.
//!
//! Contract: instances are every `*.json` (`auv-route-instance/1`), every
//! classic orienteering `*.txt` and every OPLib `*.oplib` file under
//! `--instances` (recursively, sorted by path, so runs are reproducible);
//! an instance's family is its folder under `--instances`. The optimum of an instance is
//! taken from the first `best_known.csv` found in the folder or above it
//! (matched by instance name); else the exact solver computes it
//! (score-only order, `--exact-time-limit` per instance, warm-started from
//! the best measured route). When the exact search is stopped before its
//! proof, the row says `exact_unproved`, `optimum` is the best route known
//! (so `gap` is a lower bound on the true gap) and `gap_bound` is the
//! certified upper bound on the gap from the search's bound. Gaps are in
//! percent of the optimum: lost weight for `max_weight`, extra cost for
//! `paper_cost`. One CSV row per instance × deadline × algorithm, with the
//! solve time at which the best-so-far first reached the optimum's score
//! (`time_to_best_ms`); the summary per deadline and algorithm, then per
//! family and deadline for the first algorithm (with the median time to the
//! best-known score at the longest deadline), goes to standard output, and
//! `--plot` draws each family's mean gap against the deadline.
//!
//! Every algorithm gets the same seed; `auto` runs until the deadline, PSO
//! and BBO run the paper's budget cut at the deadline. `--clock cpu`
//! measures deadlines and solve times in the solving thread's CPU time
//! (steadier on a shared machine than wall-clock time, the default).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use auv_core::instance::{Instance, Objective};
use auv_core::oplib::{BestKnown, BestKnownEntry, instance_name};
use auv_core::problem::Problem;
use auv_core::rng::PlannerRng;
use auv_core::route::{Route, RouteEval};
use auv_core::solver::exact::{ExactSettings, solve_exact};
use auv_core::solver::{Algorithm, Solver};
use auv_platform::clock::thread_cpu_time_s;
use clap::ValueEnum;
use planner::plot_quality::{GapCurve, gap_curves};

use super::{CliError, DEFAULT_SEED, load_instance, print, read_text, write_text};

/// Which clock deadlines and solve times are measured on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Clock {
    /// Wall-clock time (what a deadline means in service).
    Wall,
    /// CPU time of the solving thread (insensitive to other load).
    Cpu,
}

/// Arguments of `planner quality`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Folder of instance JSON files and/or classic orienteering `.txt` files.
    #[arg(long, value_name = "DIR")]
    pub instances: PathBuf,
    /// Budget of each solve in milliseconds; a comma-separated list runs
    /// every algorithm once per deadline.
    #[arg(long, value_name = "D", value_delimiter = ',', default_value = "20,5",
          value_parser = clap::value_parser!(u64).range(1..=60_000))]
    pub deadline_ms: Vec<u64>,
    /// Algorithms to compare, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "auto,pso,bbo")]
    pub algorithms: Vec<Algorithm>,
    /// Seed of every solve.
    #[arg(long, default_value_t = DEFAULT_SEED, allow_negative_numbers = true)]
    pub seed: u64,
    /// Seconds the exact solver may spend on an instance without a known
    /// optimum (> 0); past it the gap is certified by its bound only.
    #[arg(long, value_name = "S", default_value = "30", allow_negative_numbers = true)]
    pub exact_time_limit: String,
    /// Clock of deadlines and solve times.
    #[arg(long, value_enum, default_value_t = Clock::Wall)]
    pub clock: Clock,
    /// CSV file to write (one row per instance, deadline and algorithm).
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
    /// Also draw the mean gap of each family (sub-folder) against the
    /// deadline for the first algorithm (SVG).
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
}

/// Where an instance's optimum comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Optimum {
    /// A `best_known.csv` entry.
    Known(f64),
    /// Proved by the exact solver.
    Proved(f64),
    /// The exact search stopped early: the best route known and the bound.
    Unproved { best: f64, bound: f64 },
    /// No optimum (no feasible route at all).
    None,
}

impl Optimum {
    fn value(self) -> Option<f64> {
        match self {
            Self::Known(v) | Self::Proved(v) | Self::Unproved { best: v, .. } => Some(v),
            Self::None => None,
        }
    }

    /// The value the certified gap is measured against.
    fn bound(self) -> Option<f64> {
        match self {
            Self::Known(v) | Self::Proved(v) | Self::Unproved { bound: v, .. } => Some(v),
            Self::None => None,
        }
    }

    fn source(self) -> &'static str {
        match self {
            Self::Known(_) => "best_known",
            Self::Proved(_) => "exact",
            Self::Unproved { .. } => "exact_unproved",
            Self::None => "none",
        }
    }
}

/// One solve's figures.
struct Row {
    instance: String,
    /// The instance's folder under `--instances` (`.` for the folder itself).
    family: String,
    /// Solve time at which the best-so-far first reached the optimum's
    /// score, if it did.
    time_to_best: Option<Duration>,
    deadline_ms: u64,
    algorithm: Algorithm,
    score: f64,
    optimum: Optimum,
    gap: Option<f64>,
    gap_bound: Option<f64>,
    solve: Duration,
    feasible: bool,
}

/// The objective's score of `e` as reported: weight or cost.
pub(crate) fn score(inst: &Instance, e: &RouteEval) -> f64 {
    match inst.objective {
        Objective::MaxWeight => e.weight,
        o @ Objective::PaperCost { .. } => e.cost(o, inst.time_available_s),
    }
}

/// Gap of `score` to `optimum` in percent (never negative beyond rounding).
pub(crate) fn gap_percent(objective: Objective, score: f64, optimum: f64, feasible: bool) -> f64 {
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
pub(crate) fn best_known(dir: &Path) -> Result<Option<BestKnown>, CliError> {
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
/// orienteering `.txt` or OPLib `.oplib` file converted on the fly.
pub(crate) fn load(path: &Path) -> Result<(String, Instance), CliError> {
    let file = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    if let Some(inst) = super::load_benchmark(path) {
        Ok((instance_name(file).to_owned(), inst?))
    } else {
        let name = file.strip_suffix(".json").unwrap_or(file).to_owned();
        Ok((name, load_instance(path)?))
    }
}

/// The p-th percentile (nearest rank) of `v` (sorted here).
fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    let rank = ((p / 100.0) * v.len() as f64).ceil() as usize;
    v[rank.clamp(1, v.len()) - 1]
}

/// Parses `--exact-time-limit` (seconds, finite, > 0, at most a day).
pub(crate) fn parse_seconds(flag: &str, text: &str) -> Result<Duration, CliError> {
    match text.trim().parse::<f64>() {
        Ok(s) if s.is_finite() && s > 0.0 && s <= 86_400.0 => Ok(Duration::from_secs_f64(s)),
        _ => Err(CliError::Usage(format!(
            "{flag} {text}: must be a number of seconds > 0 and at most 86400"
        ))),
    }
}

/// What one instance gave: per (deadline, algorithm) the figures, the
/// solve time and the anytime trace; and the optimum it is compared with.
type Measured = (
    Vec<(u64, Algorithm, RouteEval, Duration, Vec<(Duration, RouteEval)>)>,
    Optimum,
);

/// Runs every algorithm at every deadline on `inst` (read from `path`) on
/// the capacity class of `W` words, and finds the optimum to compare with:
/// the best known entry `known`, else an exact run of `exact_limit`
/// (recorded in `exact_runs`).
#[allow(clippy::too_many_arguments)] // one call site, the loop of `run`
fn measure<const W: usize>(
    path: &Path,
    inst: &Instance,
    known: Option<&BestKnownEntry>,
    algorithms: &[Algorithm],
    deadlines: &[u64],
    (seed, clock, exact_limit): (u64, Clock, Duration),
    trace: &mut Vec<(Duration, RouteEval)>,
    exact_runs: &mut Vec<(bool, Duration)>,
) -> Result<Measured, CliError> {
    let mut solvers: Vec<_> = algorithms
        .iter()
        .map(|&a| (a, a.build::<W>(a.paper_iterations())))
        .collect();
    let problem = Problem::<W>::from_instance(inst).map_err(|source| CliError::Problem {
        path: path.to_path_buf(),
        source,
    })?;
    let mut results = Vec::new();
    let mut best: Option<(Route<W>, RouteEval)> = None;
    for &d in deadlines {
        for (a, s) in &mut solvers {
            let mut rng = PlannerRng::new(seed);
            // Auto spends the whole deadline; PSO and BBO
            // keep the paper's budget, cut by the deadline.
            let iterations = if *a == Algorithm::Auto {
                u32::MAX
            } else {
                a.paper_iterations()
            };
            let t = solve_timed(
                s.as_mut(),
                &problem,
                &mut rng,
                iterations,
                Duration::from_millis(d),
                clock,
                trace,
            );
            let (r, e) = s.best();
            if e.feasible && best.as_ref().is_none_or(|(_, b)| problem.better(e, b)) {
                best = Some((*r, *e));
            }
            results.push((d, *a, *e, t, trace.clone()));
        }
    }
    let optimum = match known {
        Some(entry) => Optimum::Known(entry.score),
        None => {
            let settings = ExactSettings {
                time_limit: Some(exact_limit),
                warm_start: best.map(|b| b.0),
                // Gaps compare objective values only.
                break_ties: false,
                ..ExactSettings::default()
            };
            match solve_exact(&problem, &settings) {
                Ok(out) => {
                    exact_runs.push((out.proved_optimal, out.elapsed));
                    let mut value = score(inst, &out.eval);
                    if let Some((_, e)) = best
                        && problem.better(&e, &out.eval)
                    {
                        value = score(inst, &e);
                    }
                    if out.proved_optimal {
                        Optimum::Proved(value)
                    } else {
                        Optimum::Unproved {
                            best: value,
                            bound: out.bound,
                        }
                    }
                }
                Err(_) => Optimum::None,
            }
        }
    };
    Ok((results, optimum))
}

/// Runs `solver` within `deadline` on `clock` (the loop of
/// [`solver::run`], the clock chosen here); returns the solve time on that
/// clock and, in `trace`, the time of every improvement of the best-so-far
/// with its figures (the anytime curve).
pub(crate) fn solve_timed<const W: usize>(
    s: &mut dyn Solver<W>,
    problem: &Problem<W>,
    rng: &mut PlannerRng,
    iterations: u32,
    deadline: Duration,
    clock: Clock,
    trace: &mut Vec<(Duration, RouteEval)>,
) -> Duration {
    let wall0 = Instant::now();
    let cpu0 = thread_cpu_time_s();
    let now = || match clock {
        Clock::Wall => wall0.elapsed(),
        Clock::Cpu => Duration::from_secs_f64((thread_cpu_time_s() - cpu0).max(0.0)),
    };
    trace.clear();
    s.start(problem, rng, None);
    trace.push((now(), *s.best().1));
    let mut done = 0;
    while done < iterations && now() < deadline {
        done += 1;
        let go_on = s.step(problem, rng);
        let e = *s.best().1;
        if trace.last().is_none_or(|(_, b)| problem.better(&e, b)) {
            trace.push((now(), e));
        }
        if !go_on {
            break;
        }
    }
    now()
}

/// Runs `planner quality`.
pub fn run(args: Args) -> Result<(), CliError> {
    let exact_limit = parse_seconds("--exact-time-limit", &args.exact_time_limit)?;
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
    let mut deadlines = Vec::new();
    for d in &args.deadline_ms {
        if !deadlines.contains(d) {
            deadlines.push(*d);
        }
    }
    if deadlines.is_empty() {
        return Err(CliError::Usage("--deadline-ms: give at least one deadline".into()));
    }
    let mut files = Vec::new();
    super::collect_files(&args.instances, &["json", "txt", "oplib"], &mut files)?;
    if files.is_empty() {
        return Err(CliError::Usage(format!(
            "--instances {}: no instance files (*.json, *.txt, *.oplib) in the folder",
            args.instances.display()
        )));
    }
    let known = best_known(&args.instances)?;
    let mut rows = Vec::new();
    let mut trace = Vec::with_capacity(4096);
    let mut exact_runs: Vec<(bool, Duration)> = Vec::new();
    for path in &files {
        let (name, inst) = load(path)?;
        let family = path
            .parent()
            .and_then(|d| d.strip_prefix(&args.instances).ok())
            .map(|d| d.display().to_string())
            .filter(|d| !d.is_empty())
            .unwrap_or_else(|| ".".to_owned());
        let class = super::capacity_class(&inst, path)?;
        let (results, optimum) = auv_core::with_class!(class, W => measure::<W>(
            path,
            &inst,
            known.as_ref().and_then(|k| k.get(&name)),
            &algorithms,
            &deadlines,
            (args.seed, args.clock, exact_limit),
            &mut trace,
            &mut exact_runs,
        ))?;
        for (d, a, e, t, tr) in results {
            let sc = score(&inst, &e);
            let time_to_best = optimum.value().and_then(|o| {
                tr.iter()
                    .find(|(_, x)| {
                        x.feasible && gap_percent(inst.objective, score(&inst, x), o, true) <= AT_OPT_PERCENT
                    })
                    .map(|(at, _)| *at)
            });
            rows.push(Row {
                instance: name.clone(),
                family: family.clone(),
                time_to_best,
                deadline_ms: d,
                algorithm: a,
                score: sc,
                optimum,
                gap: optimum.value().map(|o| gap_percent(inst.objective, sc, o, e.feasible)),
                gap_bound: optimum.bound().map(|o| gap_percent(inst.objective, sc, o, e.feasible)),
                solve: t,
                feasible: e.feasible,
            });
        }
    }
    let mut csv = String::from(
        "instance,deadline_ms,algorithm,score,optimum,gap,gap_bound,solve_ms,feasible,optimum_source,family,time_to_best_ms\n",
    );
    for r in &rows {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{:.3},{},{},{},{}",
            r.instance,
            r.deadline_ms,
            r.algorithm,
            r.score,
            r.optimum.value().map_or(String::new(), |o| o.to_string()),
            r.gap.map_or(String::new(), |g| format!("{g:.4}")),
            r.gap_bound.map_or(String::new(), |g| format!("{g:.4}")),
            r.solve.as_secs_f64() * 1e3,
            r.feasible,
            r.optimum.source(),
            r.family,
            r.time_to_best
                .map_or(String::new(), |t| format!("{:.3}", t.as_secs_f64() * 1e3))
        );
    }
    write_text(&args.out, &csv)?;
    let mut text = format!(
        "{} instances, seed {}, {} clock\n",
        files.len(),
        args.seed,
        match args.clock {
            Clock::Wall => "wall",
            Clock::Cpu => "thread CPU",
        }
    );
    if !exact_runs.is_empty() {
        let proved = exact_runs.iter().filter(|r| r.0).count();
        let mut secs: Vec<f64> = exact_runs.iter().map(|r| r.1.as_secs_f64()).collect();
        let _ = writeln!(
            text,
            "optimum by the exact solver on {} instances: {proved} proved, {} not proved within {} s \
             (their gaps are lower bounds; `worst ub%` is certified); exact time median {:.3} s, max {:.3} s",
            exact_runs.len(),
            exact_runs.len() - proved,
            exact_limit.as_secs_f64(),
            percentile(&mut secs, 50.0),
            percentile(&mut secs, 100.0),
        );
    }
    for &d in &deadlines {
        let mine: Vec<&Row> = rows.iter().filter(|r| r.deadline_ms == d).collect();
        text.push_str(&summary(&mine, &algorithms, d));
    }
    let families = family_table(&rows, algorithms[0], &deadlines);
    text.push_str(&families.0);
    if let Some(plot) = &args.plot {
        let curves: Vec<GapCurve<'_>> = families
            .1
            .iter()
            .map(|(f, pts)| GapCurve {
                family: f,
                points: pts.clone(),
            })
            .collect();
        let title = format!("{}: mean gap per family against the deadline", algorithms[0]);
        gap_curves(plot, &title, &curves).map_err(|e| CliError::Usage(e.to_string()))?;
        let _ = writeln!(text, "wrote {}", plot.display());
    }
    print(&text)
}

/// A gap at most this (percent) counts as reaching the optimum (rounding).
const AT_OPT_PERCENT: f64 = 1e-6;

/// Per family (sub-folder) and deadline, for `algorithm`: mean and worst
/// gap and the instances at the optimum; then the time to reach the
/// optimum's score within the longest deadline (median over the instances
/// that reached it, and how many did). Returns the table and each family's
/// (deadline, mean gap) curve.
#[allow(clippy::type_complexity)]
fn family_table(rows: &[Row], algorithm: Algorithm, deadlines: &[u64]) -> (String, Vec<(String, Vec<(f64, f64)>)>) {
    let mut families: Vec<&str> = rows.iter().map(|r| r.family.as_str()).collect();
    families.sort_unstable();
    families.dedup();
    let mut sorted = deadlines.to_vec();
    sorted.sort_unstable();
    let longest = sorted.last().copied().unwrap_or(0);
    let mut text = format!("per family, {algorithm}: mean gap % / worst gap % / at optimum, per deadline\n");
    let _ = write!(text, "{:<28}", "family");
    for d in &sorted {
        let _ = write!(text, " {:>22}", format!("{d} ms"));
    }
    let _ = writeln!(text, " {:>18}", "to best (median)");
    let mut curves = Vec::new();
    for f in families {
        let _ = write!(text, "{f:<28}");
        let mut pts = Vec::new();
        for &d in &sorted {
            let gaps: Vec<f64> = rows
                .iter()
                .filter(|r| r.family == f && r.deadline_ms == d && r.algorithm == algorithm)
                .filter_map(|r| r.gap)
                .collect();
            if gaps.is_empty() {
                let _ = write!(text, " {:>22}", "-");
                continue;
            }
            let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
            let worst = gaps.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let hits = gaps.iter().filter(|&&g| g <= AT_OPT_PERCENT).count();
            let _ = write!(
                text,
                " {:>22}",
                format!("{mean:.3} / {worst:.2} / {hits}/{}", gaps.len())
            );
            pts.push((d as f64, mean));
        }
        let mut times: Vec<f64> = rows
            .iter()
            .filter(|r| r.family == f && r.deadline_ms == longest && r.algorithm == algorithm)
            .filter_map(|r| r.time_to_best.map(|t| t.as_secs_f64() * 1e3))
            .collect();
        let total = rows
            .iter()
            .filter(|r| r.family == f && r.deadline_ms == longest && r.algorithm == algorithm && r.gap.is_some())
            .count();
        let reached = times.len();
        let med = if times.is_empty() {
            "-".to_owned()
        } else {
            format!("{:.2} ms", percentile(&mut times, 50.0))
        };
        let _ = writeln!(text, " {:>18}", format!("{med} ({reached}/{total})"));
        curves.push((f.to_owned(), pts));
    }
    (text, curves)
}

/// The per-algorithm table of one deadline.
fn summary(rows: &[&Row], algorithms: &[Algorithm], deadline_ms: u64) -> String {
    let mut text = format!("deadline {deadline_ms} ms\n");
    let _ = writeln!(
        text,
        "{:<6} {:>9} {:>9} {:>9} {:>9} {:>9} {:>11} {:>11}",
        "algo", "mean gap%", "med gap%", "worst%", "worst ub%", "at opt", "median ms", "p99 ms"
    );
    for &a in algorithms {
        let mine: Vec<&&Row> = rows.iter().filter(|r| r.algorithm == a).collect();
        let mut gaps: Vec<f64> = mine.iter().filter_map(|r| r.gap).collect();
        let mut ubs: Vec<f64> = mine.iter().filter_map(|r| r.gap_bound).collect();
        let mut ms: Vec<f64> = mine.iter().map(|r| r.solve.as_secs_f64() * 1e3).collect();
        let (mean, median, worst, worst_ub, at_opt) = if gaps.is_empty() {
            let dash = || "-".to_owned();
            (dash(), dash(), dash(), dash(), dash())
        } else {
            let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
            let hits = gaps.iter().filter(|&&g| g <= 1e-6).count();
            let at = format!("{hits}/{}", gaps.len());
            (
                format!("{mean:.3}"),
                format!("{:.3}", percentile(&mut gaps, 50.0)),
                format!("{:.3}", percentile(&mut gaps, 100.0)),
                format!("{:.3}", percentile(&mut ubs, 100.0)),
                at,
            )
        };
        let _ = writeln!(
            text,
            "{:<6} {:>9} {:>9} {:>9} {:>9} {:>9} {:>11.3} {:>11.3}",
            a.as_str(),
            mean,
            median,
            worst,
            worst_ub,
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
