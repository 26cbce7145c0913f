//! `planner montecarlo`: the paper's Monte Carlo study from the command line
//! (see [`planner::montecarlo`] for what a run is and how it is seeded).
//!
//! Contract: the scenario is the default one or `--scenario FILE`, with
//! `--nodes` overriding its waypoint count; `--seed` fixes the world and every
//! solver stream. Writes `runs.csv`, `summary.txt` and the figures into
//! `--out DIR` (created if missing), prints the summary table, and shows a
//! progress bar on a terminal.

use std::path::PathBuf;

use auv_core::solver::Algorithm;
use auv_world::scenario::{ScenarioConfig, load_world};
use planner::montecarlo::{self, AlgorithmSpec, StudySettings};

use super::export::load_scenario;
use super::{CliError, DEFAULT_SEED, print};

/// Arguments of `planner montecarlo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Network changes to run (the paper: 200).
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub runs: u32,
    /// Waypoints in the network (overrides the scenario's `nodes`).
    #[arg(long)]
    pub nodes: Option<usize>,
    /// Seed of the world and of every solver stream [default: 1, or the
    /// mission file's seed].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Scenario file (`auv-scenario/1`) [default: the built-in scenario].
    #[arg(long, value_name = "FILE")]
    pub scenario: Option<PathBuf>,
    /// Mission file (`auv-mission/1`): its network, dynamic waypoints
    /// redrawn each run by the file's drift model.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["scenario", "nodes"])]
    pub mission: Option<PathBuf>,
    /// Algorithms to compare, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "pso,bbo")]
    pub algorithms: Vec<Algorithm>,
    /// Iterations per solve [default: each algorithm's paper budget].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub iterations: Option<u32>,
    /// Worker threads for independent runs [default: the machine's cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=256))]
    pub threads: Option<u32>,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// Runs `planner montecarlo`.
pub fn run(args: Args) -> Result<(), CliError> {
    let mission = match &args.mission {
        Some(path) => Some(auv_world::mission_file::load(
            path,
            auv_world::mission_file::Overrides {
                seed: args.seed,
                time_available_s: None,
            },
        )?),
        None => None,
    };
    let (mut config, origin) = match &args.scenario {
        Some(path) => (load_scenario(path)?, path.display().to_string()),
        None => (ScenarioConfig::default(), "default scenario".to_string()),
    };
    if let Some(nodes) = args.nodes {
        config.nodes = nodes;
        config
            .validate()
            .map_err(|e| CliError::Usage(format!("--nodes {nodes}: {e}")))?;
    }
    let seed = mission.as_ref().map_or(args.seed.unwrap_or(DEFAULT_SEED), |m| m.seed);
    let mut algorithms = args.algorithms.clone();
    algorithms.dedup();
    if algorithms.is_empty() {
        return Err(CliError::Usage(
            "--algorithms: name at least one of pso, bbo, auto".into(),
        ));
    }
    std::fs::create_dir_all(&args.out).map_err(|source| CliError::Write {
        path: args.out.clone(),
        source,
    })?;
    let (world, map, chart_name) = match mission {
        Some(m) => (m.world, m.water, m.chart),
        None => {
            let (world, map) = load_world(&config, seed).map_err(|source| CliError::World { origin, source })?;
            (
                world,
                auv_world::mission_file::Water::Mask(map.mask),
                map.chart.name().to_string(),
            )
        }
    };

    let specs: Vec<AlgorithmSpec> = algorithms
        .iter()
        .map(|&a| {
            let iterations = args.iterations.unwrap_or_else(|| a.paper_iterations());
            AlgorithmSpec {
                name: a.as_str(),
                build: Box::new(move || a.build(iterations)),
                iterations,
            }
        })
        .collect();
    let threads = args
        .threads
        .map(|t| t as usize)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    eprintln!(
        "montecarlo: {} runs × {} on {} ({} waypoints, {} dynamic, {} edges), seed {}, {} threads",
        args.runs,
        algorithms.iter().map(|a| a.as_str()).collect::<Vec<_>>().join("+"),
        chart_name,
        world.n(),
        world.dynamic_nodes().len(),
        world.edge_count(),
        seed,
        threads
    );
    let bar = indicatif::ProgressBar::new(u64::from(args.runs));
    bar.set_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} runs ({eta} left)")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let settings = StudySettings {
        runs: args.runs as usize,
        seed,
        threads,
    };
    let records = montecarlo::run_study(&world, &map, settings, &specs, &|| bar.inc(1))
        .map_err(|e| CliError::Internal(e.to_string()))?;
    bar.finish_and_clear();
    let files =
        montecarlo::write_outputs(&args.out, &world, &map, &records).map_err(|e| CliError::Internal(e.to_string()))?;
    let mut text = format!(
        "Monte Carlo study: {} runs, seed {}, {} waypoints (scenario fingerprint {:016x})\n\n",
        args.runs,
        seed,
        world.n(),
        world.fingerprint()
    );
    text.push_str(&montecarlo::summary_table(&records));
    text.push_str("\nwrote:\n");
    for f in files {
        text.push_str(&format!("  {}\n", f.display()));
    }
    print(&text)
}
