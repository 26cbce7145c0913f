//! `planner scaling`: how the planner's figures grow with the network's
//! size, on instances the user names (generated paper-model networks, OPLib
//! or classic files): per instance the stream decode per vector, the
//! paper's PSO budget, `auto`'s gap at two deadlines, the exact solver's
//! proof time or certified gap after a time limit, and the size of the
//! snapshot message that carries the network to the service.
//!
//! Contract: every time is the solving thread's CPU time (steady on a shared
//! machine; wall time also counts waiting for a core), the median of
//! `--repeats` runs for the decode and the PSO budget. Gaps are in percent
//! of the reference: the instance's `best_known.csv` entry (the first found
//! in its folder or above), else the best route any of these runs found
//! (so a gap is then a lower bound and the exact column says whether that
//! reference is proved). The exact solver starts from `auto`'s route at the
//! longest deadline and proves the objective value only (what the gaps
//! compare). Each instance runs on the smallest capacity class that holds
//! it. The seed fixes the decoded vectors and the PSO budget's routes;
//! `auto`'s route at a deadline depends on how many steps fit in it, so its
//! score (like every time) may move between runs.
//! One CSV row per instance; `--plot` draws the columns against the node
//! count.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Duration;

use auv_core::capacity::nodes_of;
use auv_core::decode::{Decoder, PRIORITY_MAX, PRIORITY_MIN};
use auv_core::instance::Instance;
use auv_core::problem::Problem;
use auv_core::rng::PlannerRng;
use auv_core::route::RouteEval;
use auv_core::solver::exact::{ExactSettings, solve_exact};
use auv_core::solver::pso::{Pso, PsoSettings};
use auv_core::solver::{Algorithm, Budget, Solver, run as run_solver};
use auv_messages::msg::{MAX_WIRE_NODES, SnapshotHead, WireEdge};
use auv_platform::clock::thread_cpu_time_s;
use planner::plot::{XyPanel, XySeries, xy_figure};

use super::quality::{Clock, best_known, gap_percent, load, parse_seconds, score, solve_timed};
use super::{CliError, DEFAULT_SEED, print, write_text};

/// Arguments of `planner scaling`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Instance files (`*.json`, OPLib `*.oplib`, classic `*.txt`) or folders
    /// of them, comma-separated.
    #[arg(long, value_name = "PATH", value_delimiter = ',', required = true)]
    pub instances: Vec<PathBuf>,
    /// The two `auto` deadlines, ms of thread CPU time.
    #[arg(long, value_name = "D", value_delimiter = ',', default_value = "20,100",
          value_parser = clap::value_parser!(u64).range(1..=60_000))]
    pub deadline_ms: Vec<u64>,
    /// Seconds of the exact solver per instance (> 0).
    #[arg(long, value_name = "S", default_value = "60", allow_negative_numbers = true)]
    pub exact_time_limit: String,
    /// Runs of the decode stream and of the PSO budget per instance (the
    /// median is reported).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeats: u32,
    /// Seed of every solve and of the random vectors decoded.
    #[arg(long, default_value_t = DEFAULT_SEED, allow_negative_numbers = true)]
    pub seed: u64,
    /// CSV file to write (one row per instance).
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
    /// Also draw every column against the node count (SVG).
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
}

/// Vectors per decode stream: the paper's swarm.
const SWARM: usize = 150;

/// One instance's figures.
struct Row {
    name: String,
    /// Which kind of file it came from (the figure draws each kind apart).
    source: &'static str,
    nodes: usize,
    class_nodes: usize,
    edges: usize,
    decode_ns: f64,
    pso_ms: f64,
    /// Per deadline: the score and the gap to the reference, %.
    auto: Vec<(u64, f64, f64)>,
    reference: f64,
    reference_source: &'static str,
    exact_proved: bool,
    exact_s: f64,
    /// Certified gap of the best route known to the exact solver's bound, %.
    exact_gap: f64,
    /// Bytes of the snapshot message, when the messages carry the network.
    snapshot_bytes: Option<usize>,
}

/// Runs `planner scaling`.
pub fn run(args: Args) -> Result<(), CliError> {
    let exact_limit = parse_seconds("--exact-time-limit", &args.exact_time_limit)?;
    let mut deadlines = args.deadline_ms.clone();
    deadlines.sort_unstable();
    deadlines.dedup();
    let mut files = Vec::new();
    for p in &args.instances {
        if p.is_dir() {
            super::collect_files(p, &["json", "txt", "oplib"], &mut files)?;
        } else if p.is_file() {
            files.push(p.clone());
        } else {
            return Err(CliError::Usage(format!(
                "--instances {}: no such file or folder",
                p.display()
            )));
        }
    }
    if files.is_empty() {
        return Err(CliError::Usage(
            "--instances: no instance files (*.json, *.txt, *.oplib) given".into(),
        ));
    }
    let mut rows = Vec::new();
    for path in &files {
        let (name, inst) = load(path)?;
        let source = match path.extension().and_then(|e| e.to_str()) {
            Some("oplib") => "OPLib",
            Some("txt") => "classic",
            _ => "instance files",
        };
        let dir = path.parent().unwrap_or(path);
        let known = best_known(dir)?.and_then(|k| k.get(&name).map(|e| e.score));
        let class = super::capacity_class(&inst, path)?;
        let mut row = auv_core::with_class!(class, W => measure::<W>(&args, &deadlines, exact_limit, &name, &inst, known)
            .map_err(|source| CliError::Problem { path: path.clone(), source }))?;
        row.source = source;
        eprintln!(
            "{:<28} n {:>3}: decode {:>6.0} ns, PSO {:>7.2} ms, exact {}",
            row.name,
            row.nodes,
            row.decode_ns,
            row.pso_ms,
            if row.exact_proved {
                format!("proved in {:.2} s", row.exact_s)
            } else {
                format!("gap {:.2} %", row.exact_gap)
            }
        );
        rows.push(row);
    }
    rows.sort_by_key(|r| r.nodes);
    write_text(&args.out, &csv(&rows, &deadlines))?;
    let mut text = table(&rows, &deadlines);
    if let Some(plot) = &args.plot {
        draw(plot, &rows, &deadlines).map_err(|e| CliError::Internal(e.to_string()))?;
        let _ = writeln!(text, "wrote {}", plot.display());
    }
    print(&text)
}

/// Every figure of one instance on the capacity class of `W` words.
fn measure<const W: usize>(
    args: &Args,
    deadlines: &[u64],
    exact_limit: Duration,
    name: &str,
    inst: &Instance,
    known: Option<f64>,
) -> Result<Row, auv_core::problem::ProblemError> {
    let problem = Problem::<W>::from_instance(inst)?;
    let cap = nodes_of(W);
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };

    // The decode as the swarms run it: a stream of the swarm's vectors.
    let mut rng = PlannerRng::new(args.seed);
    let pool: Vec<f32> = (0..SWARM * cap)
        .map(|_| rng.uniform(PRIORITY_MIN, PRIORITY_MAX) as f32)
        .collect();
    let mut decoder = Decoder::<W>::new();
    let mut stream = |weight: &mut f64| {
        decoder.decode_stream(&problem, SWARM, &|i| &pool[i * cap..(i + 1) * cap], &mut |_, w| {
            *weight += w.ranked().weight
        })
    };
    let mut sink = 0.0;
    stream(&mut sink); // warm the tables into cache
    let mut decode_ns: Vec<f64> = (0..args.repeats)
        .map(|_| {
            let t0 = thread_cpu_time_s();
            stream(&mut sink);
            (thread_cpu_time_s() - t0) * 1e9 / SWARM as f64
        })
        .collect();
    std::hint::black_box(sink);

    let settings = PsoSettings::paper();
    let mut pso = Pso::<W>::new(settings);
    let mut pso_ms: Vec<f64> = (0..args.repeats)
        .map(|k| {
            let mut rng = PlannerRng::new(args.seed.wrapping_add(u64::from(k)));
            let t0 = thread_cpu_time_s();
            run_solver(
                &mut pso,
                &problem,
                &mut rng,
                None,
                Budget::iterations(settings.iterations),
            );
            (thread_cpu_time_s() - t0) * 1e3
        })
        .collect();

    let mut auto = Algorithm::Auto.build::<W>(u32::MAX);
    let mut trace = Vec::with_capacity(4096);
    let mut solves: Vec<(u64, RouteEval)> = Vec::new();
    for &d in deadlines {
        let mut rng = PlannerRng::new(args.seed);
        solve_timed(
            auto.as_mut(),
            &problem,
            &mut rng,
            u32::MAX,
            Duration::from_millis(d),
            Clock::Cpu,
            &mut trace,
        );
        solves.push((d, *auto.best().1));
    }
    let warm = *auto.best().0;
    let exact = solve_exact(
        &problem,
        &ExactSettings {
            time_limit: Some(exact_limit),
            warm_start: Some(warm),
            break_ties: false,
            ..ExactSettings::default()
        },
    );
    // The best route any run found, and the exact solver's verdict on it.
    let mut best: Option<RouteEval> = None;
    let mut offer = |e: &RouteEval| {
        if e.feasible && best.is_none_or(|b| problem.better(e, &b)) {
            best = Some(*e);
        }
    };
    solves.iter().for_each(|s| offer(&s.1));
    let (exact_proved, exact_s, bound) = match &exact {
        Ok(out) => {
            offer(&out.eval);
            (out.proved_optimal, out.elapsed.as_secs_f64(), Some(out.bound))
        }
        Err(_) => (false, exact_limit.as_secs_f64(), None),
    };
    let found = best.map(|e| score(inst, &e));
    let (reference, reference_source) = match (known, found) {
        (Some(k), _) => (k, "best_known"),
        (None, Some(f)) if exact_proved => (f, "exact"),
        (None, Some(f)) => (f, "best_found"),
        (None, None) => (f64::NAN, "none"),
    };
    let exact_gap = match (found, bound) {
        (Some(f), Some(b)) => gap_percent(inst.objective, f, b, true),
        _ => f64::NAN,
    };
    let edges = (0..problem.n())
        .map(|a| (a + 1..problem.n()).filter(|&b| problem.has_edge(a, b)).count())
        .sum();
    Ok(Row {
        name: name.to_owned(),
        source: "",
        nodes: problem.n(),
        class_nodes: cap,
        edges,
        decode_ns: median(&mut decode_ns),
        pso_ms: median(&mut pso_ms),
        auto: solves
            .iter()
            .map(|&(d, e)| {
                let s = score(inst, &e);
                (d, s, gap_percent(inst.objective, s, reference, e.feasible))
            })
            .collect(),
        reference,
        reference_source,
        exact_proved,
        exact_s,
        exact_gap,
        // The head (every waypoint slot) and one 32-byte record per edge.
        snapshot_bytes: (problem.n() <= MAX_WIRE_NODES)
            .then_some(core::mem::size_of::<SnapshotHead>() + edges * core::mem::size_of::<WireEdge>()),
    })
}

/// The snapshot column: bytes, or "not carried" beyond the messages' capacity.
fn snapshot_text(bytes: Option<usize>) -> String {
    bytes.map_or_else(|| "not carried".to_owned(), |b| b.to_string())
}

fn csv(rows: &[Row], deadlines: &[u64]) -> String {
    let mut s = String::from("instance,nodes,class_nodes,edges,decode_ns,pso_ms");
    for d in deadlines {
        let _ = write!(s, ",auto_{d}ms_score,auto_{d}ms_gap");
    }
    s.push_str(",reference,reference_source,exact_proved,exact_s,exact_gap,snapshot_bytes\n");
    for r in rows {
        let _ = write!(
            s,
            "{},{},{},{},{:.1},{:.4}",
            r.name, r.nodes, r.class_nodes, r.edges, r.decode_ns, r.pso_ms
        );
        for (_, score, gap) in &r.auto {
            let _ = write!(s, ",{score:.6},{gap:.4}");
        }
        let _ = writeln!(
            s,
            ",{:.6},{},{},{:.3},{:.4},{}",
            r.reference,
            r.reference_source,
            r.exact_proved,
            r.exact_s,
            r.exact_gap,
            snapshot_text(r.snapshot_bytes)
        );
    }
    s
}

fn table(rows: &[Row], deadlines: &[u64]) -> String {
    let mut s = format!(
        "{} instances, thread CPU clock\n{:<28} {:>5} {:>6} {:>7} {:>10} {:>9}",
        rows.len(),
        "instance",
        "n",
        "class",
        "edges",
        "decode ns",
        "PSO ms"
    );
    for d in deadlines {
        let _ = write!(s, " {:>10}", format!("gap@{d}ms"));
    }
    let _ = writeln!(s, "  {:<22} {:>12}", "exact", "snapshot B");
    for r in rows {
        let _ = write!(
            s,
            "{:<28} {:>5} {:>6} {:>7} {:>10.0} {:>9.2}",
            r.name, r.nodes, r.class_nodes, r.edges, r.decode_ns, r.pso_ms
        );
        for (_, _, gap) in &r.auto {
            let _ = write!(s, " {:>9.2}%", gap);
        }
        let exact = if r.exact_proved {
            format!("proved {:.2} s", r.exact_s)
        } else {
            format!("gap {:.1} % ({:.0} s)", r.exact_gap, r.exact_s)
        };
        let _ = writeln!(s, "  {:<22} {:>12}", exact, snapshot_text(r.snapshot_bytes));
    }
    s
}

fn draw(path: &std::path::Path, rows: &[Row], deadlines: &[u64]) -> Result<(), planner::plot::PlotError> {
    let mut sources: Vec<&str> = rows.iter().map(|r| r.source).collect();
    sources.sort_unstable();
    sources.dedup();
    // One series per kind of file and figure, labelled "<figure>, <kind>".
    let labels = |what: &str| -> Vec<String> { sources.iter().map(|k| format!("{what}, {k}")).collect() };
    let decode_labels = labels("stream of 150");
    let pso_labels = labels("paper budget");
    let exact_labels = labels("after the time limit (0: proved)");
    let auto_labels: Vec<Vec<String>> = deadlines.iter().map(|d| labels(&format!("auto at {d} ms"))).collect();
    fn series<'a>(sources: &[&str], rows: &[Row], names: &'a [String], f: &dyn Fn(&Row) -> f64) -> Vec<XySeries<'a>> {
        sources
            .iter()
            .zip(names)
            .map(|(k, label)| XySeries {
                label,
                points: rows
                    .iter()
                    .filter(|r| r.source == *k)
                    .map(|r| (r.nodes as f64, f(r)))
                    .filter(|p| p.1.is_finite())
                    .collect(),
            })
            .collect()
    }
    let panels = [
        XyPanel {
            y_label: "decode per vector (ns)",
            series: series(&sources, rows, &decode_labels, &|r| r.decode_ns),
        },
        XyPanel {
            y_label: "PSO 150 x 150 (ms)",
            series: series(&sources, rows, &pso_labels, &|r| r.pso_ms),
        },
        XyPanel {
            y_label: "gap to reference (%)",
            series: auto_labels
                .iter()
                .enumerate()
                .flat_map(|(k, names)| series(&sources, rows, names, &move |r: &Row| r.auto[k].2))
                .collect(),
        },
        XyPanel {
            y_label: "exact: certified gap (%)",
            series: series(&sources, rows, &exact_labels, &|r| {
                if r.exact_proved { 0.0 } else { r.exact_gap }
            }),
        },
    ];
    xy_figure(
        path,
        "Scaling with the number of waypoints",
        "waypoints (nodes)",
        &panels,
    )
}
