//! `planner montecarlo`: the paper's Monte Carlo study from the command line
//! (see [`planner::montecarlo`] for what a run is and how it is seeded).
//!
//! Contract: the scenario is the default one or `--scenario FILE`, with
//! `--nodes` overriding its waypoint count; `--seed` fixes the world and every
//! solver stream. Writes `runs.csv`, `summary.txt` and the figures into
//! `--out DIR` (created if missing), prints the summary table, and shows a
//! progress bar on a terminal.
//!
//! The experiment knobs (`--pso-*`, `--bbo-*`, `--objective`, `--budget-s`,
//! `--edge-density`) each change one thing for controlled comparisons; their
//! defaults are the planner's own settings, so without them the study is
//! exactly the paper-budget study.

use std::path::PathBuf;

use auv_core::instance::Objective;
use auv_core::solver::Algorithm;
use auv_core::solver::bbo::{Bbo, BboSettings};
use auv_core::solver::pso::{Pso, PsoSettings, Walls};
use auv_world::scenario::{ScenarioConfig, load_world};
use clap::ValueEnum;
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
    /// PSO swarm size [default: 150, the paper's].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub pso_particles: Option<u32>,
    /// PSO iterations (also its inertia schedule) [default: `--iterations`,
    /// else 150].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub pso_iterations: Option<u32>,
    /// PSO velocity clamp as a fraction of the priority range, `none` for
    /// no clamp [default: 0.2].
    #[arg(long, value_name = "FRACTION|none", value_parser = parse_clamp)]
    pub pso_velocity_clamp: Option<f64>,
    /// PSO rule at the priority range's edges: absorb (stop, zero velocity),
    /// clamp (stop, keep velocity), free (no walls) [default: absorb].
    #[arg(long, value_enum)]
    pub pso_walls: Option<WallRule>,
    /// BBO population [default: 50, the paper's].
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=100_000))]
    pub bbo_habitats: Option<u32>,
    /// BBO habitats kept unchanged per generation [default: 10, the paper's].
    #[arg(long)]
    pub bbo_elites: Option<u32>,
    /// BBO generations [default: `--iterations`, else 150].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub bbo_generations: Option<u32>,
    /// BBO largest per-dimension mutation probability [default: 0.1, the paper's].
    #[arg(long, value_parser = parse_probability)]
    pub bbo_mutation: Option<f64>,
    /// What the solvers optimise: max-weight, or paper-cost (the paper's
    /// φ1·|T_R − T_available| + φ2·Σ ξ/ρ with `--phi1`, `--phi2`) [default:
    /// the scenario's objective].
    #[arg(long, value_enum, conflicts_with = "mission")]
    pub objective: Option<ObjectiveArg>,
    /// φ1 of `--objective paper-cost`, and of the reported cost [default: 1e-3].
    #[arg(long, value_parser = parse_positive)]
    pub phi1: Option<f64>,
    /// φ2 of `--objective paper-cost`, and of the reported cost [default: 1].
    #[arg(long, value_parser = parse_positive)]
    pub phi2: Option<f64>,
    /// Mission time budget T_available, s [default: the scenario's, 31 000].
    #[arg(long, value_parser = parse_positive)]
    pub budget_s: Option<f64>,
    /// Fraction of the network's edges kept (the same waypoint pairs in every
    /// run), in (0, 1] [default: 1, every edge over water].
    #[arg(long, value_parser = parse_density)]
    pub edge_density: Option<f64>,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// `--pso-walls` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum WallRule {
    /// Stop on the bound with zero velocity.
    Absorb,
    /// Stop on the bound, keep the velocity.
    Clamp,
    /// No walls.
    Free,
}

impl From<WallRule> for Walls {
    fn from(w: WallRule) -> Self {
        match w {
            WallRule::Absorb => Walls::Absorb,
            WallRule::Clamp => Walls::Clamp,
            WallRule::Free => Walls::Free,
        }
    }
}

/// `--objective` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ObjectiveArg {
    /// Σ ρ/ξ within the budget.
    MaxWeight,
    /// The paper's cost.
    PaperCost,
}

fn parse_f64(s: &str) -> Result<f64, String> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("`{s}` is not a finite number"))
}

fn parse_positive(s: &str) -> Result<f64, String> {
    parse_f64(s).and_then(|v| {
        if v > 0.0 {
            Ok(v)
        } else {
            Err(format!("`{s}` must be > 0"))
        }
    })
}

fn parse_probability(s: &str) -> Result<f64, String> {
    parse_f64(s).and_then(|v| {
        if (0.0..=1.0).contains(&v) {
            Ok(v)
        } else {
            Err(format!("`{s}` must be in [0, 1]"))
        }
    })
}

fn parse_density(s: &str) -> Result<f64, String> {
    parse_f64(s).and_then(|v| {
        if v > 0.0 && v <= 1.0 {
            Ok(v)
        } else {
            Err(format!("`{s}` must be in (0, 1]"))
        }
    })
}

fn parse_clamp(s: &str) -> Result<f64, String> {
    if s == "none" {
        return Ok(f64::INFINITY);
    }
    parse_positive(s)
}

/// Fitness evaluations (decodes) of one solve, where the settings fix them:
/// the swarm decoded at the start and every iteration; the population at
/// the start, then every non-elite habitat each generation.
fn decodes(a: Algorithm, pso: &PsoSettings, bbo: &BboSettings) -> Option<u64> {
    match a {
        Algorithm::Pso => Some(pso.particles as u64 * (u64::from(pso.iterations) + 1)),
        Algorithm::Bbo => {
            let (h, e) = (bbo.habitats as u64, bbo.elites.min(bbo.habitats - 1) as u64);
            Some(h + (h - e) * u64::from(bbo.generations))
        }
        Algorithm::Auto => None,
    }
}

/// Runs `planner montecarlo`.
pub fn run(args: Args) -> Result<(), CliError> {
    let mission = match &args.mission {
        Some(path) => Some(auv_world::mission_file::load(
            path,
            auv_world::mission_file::Overrides {
                seed: args.seed,
                time_available_s: args.budget_s,
                start_at: None,
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
    if let Some(budget) = args.budget_s {
        config.time_available_s = budget;
    }
    match args.objective {
        Some(ObjectiveArg::PaperCost) => {
            config.objective = Objective::PaperCost {
                phi1: args.phi1.unwrap_or(montecarlo::DEFAULT_PHI1),
                phi2: args.phi2.unwrap_or(montecarlo::DEFAULT_PHI2),
            }
        }
        Some(ObjectiveArg::MaxWeight) => config.objective = Objective::MaxWeight,
        None => {}
    }
    let seed = mission.as_ref().map_or(args.seed.unwrap_or(DEFAULT_SEED), |m| m.seed);
    let mut algorithms = args.algorithms.clone();
    algorithms.dedup();
    if algorithms.is_empty() {
        return Err(CliError::Usage(
            "--algorithms: name at least one of pso, bbo, auto".into(),
        ));
    }
    let pso = PsoSettings {
        particles: args
            .pso_particles
            .map_or(PsoSettings::paper().particles, |p| p as usize),
        iterations: args
            .pso_iterations
            .or(args.iterations)
            .unwrap_or(PsoSettings::paper().iterations),
        velocity_clamp: args.pso_velocity_clamp.unwrap_or(PsoSettings::paper().velocity_clamp),
        walls: args.pso_walls.map_or(PsoSettings::paper().walls, Walls::from),
        ..PsoSettings::paper()
    };
    let bbo = BboSettings {
        habitats: args.bbo_habitats.map_or(BboSettings::paper().habitats, |h| h as usize),
        elites: args.bbo_elites.map_or(BboSettings::paper().elites, |e| e as usize),
        generations: args
            .bbo_generations
            .or(args.iterations)
            .unwrap_or(BboSettings::paper().generations),
        max_mutation_rate: args.bbo_mutation.unwrap_or(BboSettings::paper().max_mutation_rate),
    };
    if bbo.elites >= bbo.habitats {
        return Err(CliError::Usage(format!(
            "--bbo-elites {}: must be below the population ({} habitats)",
            bbo.elites, bbo.habitats
        )));
    }
    if mission.is_none() && config.nodes > auv_core::problem::MAX_NODES {
        let origin = match args.nodes {
            Some(n) => format!("--nodes {n}"),
            None => format!("scenario field `nodes` = {}", config.nodes),
        };
        return Err(CliError::Usage(format!(
            "{origin}: the Monte Carlo study runs networks of up to {} waypoints; \
             a larger generated network goes through `planner export`, then `solve`, `quality` or `scaling`",
            auv_core::problem::MAX_NODES
        )));
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
            let (iterations, build): (u32, Box<dyn Fn() -> Box<dyn auv_core::solver::Solver + Send> + Sync>) = match a {
                Algorithm::Pso => (pso.iterations, Box::new(move || Box::new(Pso::new(pso)))),
                Algorithm::Bbo => (bbo.generations, Box::new(move || Box::new(Bbo::new(bbo)))),
                Algorithm::Auto => {
                    let it = args.iterations.unwrap_or_else(|| a.paper_iterations());
                    (it, Box::new(move || a.build(it)))
                }
            };
            AlgorithmSpec {
                name: a.as_str(),
                build,
                iterations,
            }
        })
        .collect();
    let decode_counts: Vec<String> = algorithms
        .iter()
        .filter_map(|&a| decodes(a, &pso, &bbo).map(|d| format!("{} {d}", a.as_str())))
        .collect();
    let threads = args
        .threads
        .map(|t| t as usize)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let edge_density = args.edge_density.unwrap_or(1.0);
    eprintln!(
        "montecarlo: {} runs × {} on {} ({} waypoints, {} dynamic, {} edges, density {}), seed {}, {} threads; \
         decodes per solve: {}",
        args.runs,
        algorithms.iter().map(|a| a.as_str()).collect::<Vec<_>>().join("+"),
        chart_name,
        world.n(),
        world.dynamic_nodes().len(),
        world.edge_count(),
        edge_density,
        seed,
        threads,
        if decode_counts.is_empty() {
            "-".to_string()
        } else {
            decode_counts.join(", ")
        }
    );
    let bar = indicatif::ProgressBar::new(u64::from(args.runs));
    bar.set_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} runs ({eta} left)")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let (phi1, phi2) = montecarlo::cost_weights(world.config().objective);
    let settings = StudySettings {
        edge_density,
        cost_phi: (args.phi1.unwrap_or(phi1), args.phi2.unwrap_or(phi2)),
        ..StudySettings::new(args.runs as usize, seed, threads)
    };
    let records = montecarlo::run_study(&world, &map, settings, &specs, &|| bar.inc(1))
        .map_err(|e| CliError::Internal(e.to_string()))?;
    bar.finish_and_clear();
    let files =
        montecarlo::write_outputs(&args.out, &world, &map, &records).map_err(|e| CliError::Internal(e.to_string()))?;
    let (phi1, phi2) = settings.cost_phi;
    let objective = match world.config().objective {
        Objective::MaxWeight => "max_weight".to_string(),
        Objective::PaperCost { phi1, phi2 } => format!("paper_cost (phi1 {phi1}, phi2 {phi2})"),
    };
    let mut text = format!(
        "Monte Carlo study: {} runs, seed {}, {} waypoints (scenario fingerprint {:016x})\n\
         objective {objective}, cost reported with phi1 {phi1}, phi2 {phi2}; budget {} s; edge density {edge_density}\n\
         pso {} particles x {} iterations, velocity clamp {}, walls {:?}; bbo {} habitats ({} elites) x {} generations, \
         mutation {}\n\n",
        args.runs,
        seed,
        world.n(),
        world.fingerprint(),
        world.config().time_available_s,
        pso.particles,
        pso.iterations,
        pso.velocity_clamp,
        pso.walls,
        bbo.habitats,
        bbo.elites,
        bbo.generations,
        bbo.max_mutation_rate,
    );
    text.push_str(&montecarlo::summary_table(&records));
    text.push_str("\nwrote:\n");
    for f in files {
        text.push_str(&format!("  {}\n", f.display()));
    }
    print(&text)
}
