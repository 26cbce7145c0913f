//! The world the three processes share, built by each from the same
//! scenario flags and identified by its fingerprint.
//!
//! Contract: [`load_world`] gives every process the same [`MissionWorld`]
//! for the same [`ScenarioArgs`] (the scenario generator is deterministic per
//! configuration, seed and chart), with the same fingerprint; any other seed,
//! configuration or chart gives another fingerprint, so processes of
//! different runs refuse each other's messages. Only sensor-sim moves
//! waypoints ([`MissionWorld::redraw`], a function of the seed and the epoch
//! alone); the planner and the vehicle learn the network from its snapshots.
//!
//! Where the world comes from: `--mission FILE` (an `auv-mission/1` file,
//! [`crate::mission_file`]); else, when any of `--seed`, `--scenario`,
//! `--nodes` is given, the paper's generator with those settings (as before
//! mission files existed); else the embedded default mission
//! (`missions/benoits-cove.toml`, the same network as `--seed 1`).

use std::path::PathBuf;

use crate::frame::LocalFrame;
use crate::mission_file::{self, MissionError, Overrides, Role, Water, WaypointInfo};
use crate::scenario::{ChartSource, ConfigError, LoadError, RedrawReport, ScenarioConfig, World};
use auv_core::capacity::LARGEST_NODES;
use auv_core::instance::Instance;
use auv_core::problem::DEFAULT_RESERVE_S;

/// How a process picks its world (flags shared by all three binaries).
#[derive(Clone, Debug, Default, PartialEq, clap::Args)]
pub struct ScenarioArgs {
    /// Scenario seed: the same in every process of a run (with --mission it
    /// replaces the file's `seed`) [default: the mission file's, or 1].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Mission file (`auv-mission/1`, TOML) [default: the embedded
    /// missions/benoits-cove.toml, unless --seed, --scenario or --nodes ask
    /// for the paper's generator].
    #[arg(long, value_name = "FILE", conflicts_with_all = ["scenario", "nodes"])]
    pub mission: Option<PathBuf>,
    /// Scenario file (`auv-scenario/1`, the paper's generator's settings).
    #[arg(long, value_name = "FILE")]
    pub scenario: Option<PathBuf>,
    /// Override the number of waypoints (2..=128; dynamic ones are capped at n − 2).
    #[arg(long, value_name = "N")]
    pub nodes: Option<usize>,
    /// Override the mission time budget, s.
    #[arg(long, value_name = "S")]
    pub time_available_s: Option<f64>,
    /// Put the mission file's start waypoint here: x and y in the mission's
    /// local frame and depth, m (how a vehicle takes on a new mission where
    /// it is).
    #[arg(long, value_name = "X,Y,DEPTH", value_parser = parse_start_at, conflicts_with_all = ["scenario", "nodes"])]
    pub start_at: Option<[f64; 3]>,
}

/// `X,Y,DEPTH` as three finite numbers.
fn parse_start_at(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>().map_err(|_| format!("{p:?} is not a number")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        _ => Err("expected X,Y,DEPTH: three finite numbers, m".into()),
    }
}

impl ScenarioArgs {
    /// The flags that rebuild this world in a child process.
    pub fn to_flags(&self) -> Vec<String> {
        let mut v = Vec::new();
        if let Some(seed) = self.seed {
            v.extend(["--seed".to_string(), seed.to_string()]);
        }
        if let Some(p) = &self.mission {
            // Absolute, so a child started in another folder finds it.
            let p = std::path::absolute(p).unwrap_or_else(|_| p.clone());
            v.push("--mission".into());
            v.push(p.display().to_string());
        }
        if let Some(p) = &self.scenario {
            v.push("--scenario".into());
            v.push(p.display().to_string());
        }
        if let Some(n) = self.nodes {
            v.push("--nodes".into());
            v.push(n.to_string());
        }
        if let Some(t) = self.time_available_s {
            v.push("--time-available-s".into());
            v.push(t.to_string());
        }
        if let Some([x, y, z]) = self.start_at {
            v.push("--start-at".into());
            v.push(format!("{x},{y},{z}"));
        }
        v
    }

    /// Whether these flags ask for the paper's generator rather than a
    /// mission file.
    pub fn uses_generator(&self) -> bool {
        self.mission.is_none() && (self.seed.is_some() || self.scenario.is_some() || self.nodes.is_some())
    }

    /// The scenario seed of the generator path (1 when not given).
    pub fn generator_seed(&self) -> u64 {
        self.seed.unwrap_or(1)
    }

    /// The scenario configuration these flags describe (generator path).
    pub fn config(&self) -> Result<ScenarioConfig, WorldError> {
        let mut cfg = match &self.scenario {
            Some(p) => ScenarioConfig::from_file(p)?,
            None => ScenarioConfig::default(),
        };
        if let Some(n) = self.nodes {
            if !(2..=LARGEST_NODES).contains(&n) {
                return Err(WorldError::BadNodeCount(n));
            }
            cfg.nodes = n;
            cfg.dynamic = cfg.dynamic.min(n - 2);
        }
        if let Some(t) = self.time_available_s {
            cfg.time_available_s = t;
        }
        cfg.validate()?;
        Ok(cfg)
    }
}

/// Why a world could not be built.
#[derive(Debug, thiserror::Error)]
pub enum WorldError {
    /// Bad node count.
    #[error("--nodes {0}: must be between 2 and {LARGEST_NODES}")]
    BadNodeCount(usize),
    /// The scenario file or an override is invalid.
    #[error("scenario: {0}")]
    Config(#[from] ConfigError),
    /// The chart or the generator failed.
    #[error("scenario: {0}")]
    Load(#[from] LoadError),
    /// `--start-at` with the paper's generator.
    #[error("--start-at: moves a mission file's start; the generator (--seed without --mission) has none")]
    StartAtNeedsMission,
    /// A mission file that cannot be run.
    #[error("mission file {0}")]
    Mission(#[from] MissionError),
}

/// A scenario world with its chart.
pub struct MissionWorld {
    world: World,
    water: Water,
    chart: String,
    name: String,
    waypoints: Vec<WaypointInfo>,
    frame: Option<LocalFrame>,
    reserve_s: f64,
    source: String,
    title: String,
}

/// Origin of the embedded default chart (its south-west corner), the frame
/// of generator worlds on it.
fn embedded_origin(chart: &ChartSource) -> Option<LocalFrame> {
    match chart {
        ChartSource::Embedded(name) if name == crate::scenario::EMBEDDED_CHART_NAME => {
            LocalFrame::new(crate::frame::LatLon {
                lat: 48.990,
                lon: -58.1700,
            })
            .ok()
        }
        _ => None,
    }
}

/// Builds the world the flags name: a mission file, the generator, or the
/// embedded default mission (see the module doc).
pub fn load_world(args: &ScenarioArgs) -> Result<MissionWorld, WorldError> {
    if args.uses_generator() {
        if args.start_at.is_some() {
            return Err(WorldError::StartAtNeedsMission);
        }
        return load_generated(args);
    }
    let overrides = Overrides {
        seed: args.seed,
        time_available_s: args.time_available_s,
        start_at: args.start_at,
    };
    let (m, source) = match &args.mission {
        Some(path) => (mission_file::load(path, overrides)?, path.display().to_string()),
        None => (
            mission_file::load_default(overrides)?,
            mission_file::DEFAULT_MISSION_NAME.to_string(),
        ),
    };
    Ok(MissionWorld {
        name: format!("{}-seed-{}", mission_file::slug(&m.name), m.seed),
        title: m.name.clone(),
        world: m.world,
        water: m.water,
        chart: m.chart,
        waypoints: m.waypoints,
        frame: m.frame,
        reserve_s: m.reserve_s,
        source,
    })
}

/// The paper's generator (chart loaded and classified by
/// [`crate::scenario::load_world`], the one place that does it).
fn load_generated(args: &ScenarioArgs) -> Result<MissionWorld, WorldError> {
    let cfg = args.config()?;
    let seed = args.generator_seed();
    let (world, map) = crate::scenario::load_world(&cfg, seed)?;
    let chart = match &cfg.chart {
        ChartSource::Embedded(name) => name.clone(),
        ChartSource::Png { path, .. } | ChartSource::LandGeojson { path, .. } => path.display().to_string(),
    };
    let n = world.n();
    let waypoints = (0..n)
        .map(|i| WaypointInfo {
            name: i.to_string(),
            role: if i == 0 {
                Role::Start
            } else if i == n - 1 {
                Role::Goal
            } else {
                Role::Via
            },
            generated: i != 0 && i != n - 1,
        })
        .collect();
    Ok(MissionWorld {
        name: format!("mission-seed-{seed}"),
        title: format!("The paper's model on {chart}"),
        frame: embedded_origin(&cfg.chart),
        world,
        water: Water::Mask(map.mask),
        chart,
        waypoints,
        reserve_s: DEFAULT_RESERVE_S,
        source: match &args.scenario {
            Some(p) => p.display().to_string(),
            None => "the paper's generator".into(),
        },
    })
}

impl MissionWorld {
    /// Identifies the scenario (configuration, seed and chart).
    pub fn fingerprint(&self) -> u64 {
        self.world.fingerprint()
    }

    /// Redraws the dynamic waypoints for sensor update `epoch` (≥ 1); the draw
    /// depends on the seed and the epoch only.
    pub fn redraw(&mut self, epoch: u64) -> RedrawReport {
        let mut rng = self.world.redraw_rng(epoch);
        self.world.redraw_dynamic(&mut rng, &self.water)
    }

    /// Expected time lost reaching each drifting waypoint, s, by node id.
    pub fn arrival_allowances_s(&self) -> Vec<f64> {
        self.world.arrival_allowances_s(&self.water)
    }

    /// The network as it stands.
    pub fn snapshot(&self) -> Instance {
        self.world.snapshot(&self.name)
    }

    /// The generator's world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// Where water is (the chart's mask or its land polygons).
    pub fn map(&self) -> &Water {
        &self.water
    }

    /// The waypoints' names and roles, by node id.
    pub fn waypoints(&self) -> &[WaypointInfo] {
        &self.waypoints
    }

    /// The lat/lon frame, when the mission has an origin.
    pub fn frame(&self) -> Option<&LocalFrame> {
        self.frame.as_ref()
    }

    /// The reserve held back from every plan unless `--reserve-s` says
    /// otherwise, s: the mission file's, or the service default.
    pub fn reserve_s(&self) -> f64 {
        self.reserve_s
    }

    /// The scenario seed.
    pub fn seed(&self) -> u64 {
        self.world.seed()
    }

    /// The mission's name as its file gives it (for titles).
    pub fn title(&self) -> &str {
        &self.title
    }

    /// Where the world came from (a file, or the generator).
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Mission time between sensor updates, s (from the scenario).
    pub fn sensor_period_s(&self) -> f64 {
        self.world.config().sensor_period_s
    }

    /// Short description for logs and reports.
    pub fn describe(&self) -> String {
        format!(
            "{} waypoints ({} dynamic) on {}, seed {}",
            self.world.n(),
            self.world.dynamic_nodes().len(),
            self.chart,
            self.world.seed()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(seed: u64, nodes: usize) -> ScenarioArgs {
        ScenarioArgs {
            seed: Some(seed),
            nodes: Some(nodes),
            ..Default::default()
        }
    }

    #[test]
    fn same_flags_same_world_and_fingerprint() {
        let a = load_world(&args(3, 12)).unwrap();
        let b = load_world(&args(3, 12)).unwrap();
        assert_eq!(a.fingerprint(), b.fingerprint());
        assert_eq!(a.snapshot(), b.snapshot());
        assert_ne!(a.fingerprint(), load_world(&args(4, 12)).unwrap().fingerprint());
        assert_ne!(a.fingerprint(), load_world(&args(3, 13)).unwrap().fingerprint());
    }

    #[test]
    fn redraws_depend_on_the_epoch_only() {
        let mut a = load_world(&args(5, 16)).unwrap();
        let mut b = load_world(&args(5, 16)).unwrap();
        a.redraw(3);
        b.redraw(1);
        b.redraw(3);
        assert_eq!(a.snapshot(), b.snapshot());
    }

    #[test]
    fn a_scenario_beyond_the_largest_class_is_a_clear_error_and_one_within_it_loads() {
        let path = std::env::temp_dir().join(format!("auv-load-n513-{}.json", std::process::id()));
        std::fs::write(&path, r#"{"format": "auv-scenario/1", "nodes": 513}"#).unwrap();
        let e = load_world(&ScenarioArgs {
            scenario: Some(path.clone()),
            ..Default::default()
        })
        .err()
        .unwrap();
        let _ = std::fs::remove_file(&path);
        assert!(e.to_string().contains("513"), "{e}");
        assert!(!e.to_string().contains('\n'), "{e}");
        let e = ScenarioArgs {
            nodes: Some(513),
            ..Default::default()
        }
        .config()
        .unwrap_err();
        assert!(matches!(e, WorldError::BadNodeCount(513)), "{e}");
        let w = load_world(&ScenarioArgs {
            nodes: Some(200),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(w.world().n(), 200);
    }

    #[test]
    fn flags_round_trip_and_bad_values_are_errors() {
        let a = ScenarioArgs {
            seed: Some(9),
            nodes: Some(20),
            time_available_s: Some(9000.0),
            ..Default::default()
        };
        #[derive(clap::Parser)]
        struct P {
            #[command(flatten)]
            s: ScenarioArgs,
        }
        let mut argv = vec!["x".to_string()];
        argv.extend(a.to_flags());
        let back = <P as clap::Parser>::try_parse_from(argv).unwrap().s;
        assert_eq!(back, a);
        assert!(matches!(load_world(&args(1, 1)), Err(WorldError::BadNodeCount(1))));
        assert!(matches!(load_world(&args(1, 513)), Err(WorldError::BadNodeCount(513))));
        let mut neg = args(1, 10);
        neg.time_available_s = Some(-1.0);
        assert!(matches!(load_world(&neg), Err(WorldError::Config(_))));
        let mut moved = args(1, 10);
        moved.start_at = Some([1.0, 2.0, 3.0]);
        assert!(matches!(load_world(&moved), Err(WorldError::StartAtNeedsMission)));
        for bad in ["1,2", "1,2,x", "1,2,inf", ""] {
            let e = <P as clap::Parser>::try_parse_from(["x", "--start-at", bad])
                .err()
                .unwrap();
            assert!(e.to_string().contains("--start-at"), "{e}");
        }
    }

    #[test]
    fn start_at_moves_the_start_of_a_mission_file_and_is_checked_like_a_waypoint() {
        let default = ScenarioArgs::default();
        let w = load_world(&default).unwrap();
        let s0 = w.snapshot();
        // Halfway along the first edge out of the start: over water.
        let next = s0.edges.iter().find(|e| e.a == s0.start || e.b == s0.start).unwrap();
        let (a, b) = (s0.nodes[next.a], s0.nodes[next.b]);
        let mid = [(a.x + b.x) / 2.0, (a.y + b.y) / 2.0, (a.z + b.z) / 2.0];
        let moved = load_world(&ScenarioArgs {
            start_at: Some(mid),
            ..default.clone()
        })
        .unwrap();
        let p = moved.snapshot().nodes[0];
        assert_eq!([p.x, p.y, p.z], mid);
        assert_ne!(moved.fingerprint(), w.fingerprint());
        // On land (the chart's land is somewhere; a corner far out is outside the area).
        let e = load_world(&ScenarioArgs {
            start_at: Some([-10.0, -10.0, 5.0]),
            ..default
        })
        .err()
        .unwrap()
        .to_string();
        assert!(e.contains("start") && e.contains("outside the area"), "{e}");
    }
}
