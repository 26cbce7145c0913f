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

use std::path::PathBuf;

use crate::scenario::{ChartSource, ConfigError, LoadError, RedrawReport, ScenarioConfig, ScenarioMap, World};
use auv_core::instance::Instance;
use auv_core::problem::MAX_NODES;

/// How a process picks its world (flags shared by all three binaries).
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct ScenarioArgs {
    /// Scenario seed: the same in every process of a run.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Scenario file (`auv-scenario/1`); the defaults when absent.
    #[arg(long, value_name = "FILE")]
    pub scenario: Option<PathBuf>,
    /// Override the number of waypoints (2..=128; dynamic ones are capped at n − 2).
    #[arg(long, value_name = "N")]
    pub nodes: Option<usize>,
    /// Override the mission time budget, s.
    #[arg(long, value_name = "S")]
    pub time_available_s: Option<f64>,
}

impl ScenarioArgs {
    /// The flags that rebuild this world in a child process.
    pub fn to_flags(&self) -> Vec<String> {
        let mut v = vec!["--seed".to_string(), self.seed.to_string()];
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
        v
    }

    /// The scenario configuration these flags describe.
    pub fn config(&self) -> Result<ScenarioConfig, WorldError> {
        let mut cfg = match &self.scenario {
            Some(p) => ScenarioConfig::from_file(p)?,
            None => ScenarioConfig::default(),
        };
        if let Some(n) = self.nodes {
            if !(2..=MAX_NODES).contains(&n) {
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
    #[error("--nodes {0}: must be between 2 and {MAX_NODES}")]
    BadNodeCount(usize),
    /// The scenario file or an override is invalid.
    #[error("scenario: {0}")]
    Config(#[from] ConfigError),
    /// The chart or the generator failed.
    #[error("scenario: {0}")]
    Load(#[from] LoadError),
}

/// A scenario world with its chart.
pub struct MissionWorld {
    world: World,
    map: ScenarioMap,
    chart: String,
    name: String,
}

/// Builds the world the flags name (chart loaded and classified by
/// [`crate::scenario::load_world`], the one place that does it).
pub fn load_world(args: &ScenarioArgs) -> Result<MissionWorld, WorldError> {
    let cfg = args.config()?;
    let (world, map) = crate::scenario::load_world(&cfg, args.seed)?;
    let chart = match &cfg.chart {
        ChartSource::Embedded(name) => name.clone(),
        ChartSource::Png { path, .. } => path.display().to_string(),
    };
    Ok(MissionWorld {
        name: format!("mission-seed-{}", args.seed),
        world,
        map,
        chart,
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
        self.world.redraw_dynamic(&mut rng, &self.map)
    }

    /// Expected time lost reaching each drifting waypoint, s, by node id.
    pub fn arrival_allowances_s(&self) -> [f64; auv_core::problem::MAX_NODES] {
        self.world.arrival_allowances_s(&self.map)
    }

    /// The network as it stands.
    pub fn snapshot(&self) -> Instance {
        self.world.snapshot(&self.name)
    }

    /// The generator's world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The chart and its water mask.
    pub fn map(&self) -> &ScenarioMap {
        &self.map
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
            seed,
            scenario: None,
            nodes: Some(nodes),
            time_available_s: None,
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
    fn flags_round_trip_and_bad_values_are_errors() {
        let a = ScenarioArgs {
            seed: 9,
            scenario: None,
            nodes: Some(20),
            time_available_s: Some(9000.0),
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
        let mut neg = args(1, 10);
        neg.time_available_s = Some(-1.0);
        assert!(matches!(load_world(&neg), Err(WorldError::Config(_))));
    }
}
