//! The one place a scenario's chart becomes a water mask: the chart source
//! named by the configuration is loaded and classified with the
//! configuration's `k` and a seed derived from the scenario seed.

use super::{ChartSource, ScenarioConfig, ScenarioError, World};
use crate::chart::mask::WaterMask;
use crate::chart::{Chart, ChartError, ChartSpec, ClassifySettings, WaterMap};
use auv_core::rng::derive_seed;

/// Stream of the chart classification (k-means seeding and subsample).
pub const STREAM_CHART: u64 = 0x5CE7_0006;

/// Name of the embedded default chart in scenario files.
pub const EMBEDDED_CHART_NAME: &str = "benoits-cove";

/// A scenario's chart and the water mask classified from it.
pub struct ScenarioMap {
    /// The chart image (the plots' backdrop).
    pub chart: Chart,
    /// Navigable water.
    pub mask: WaterMask,
}

impl WaterMap for ScenarioMap {
    fn width_m(&self) -> f64 {
        self.mask.width_m()
    }
    fn height_m(&self) -> f64 {
        self.mask.height_m()
    }
    fn is_water(&self, x: f64, y: f64) -> bool {
        self.mask.is_water(x, y)
    }
    fn segment_over_water(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        self.mask.segment_over_water(a, b)
    }
}

/// The chart layer's name for a scenario's chart source.
pub fn chart_spec(source: &ChartSource) -> Result<ChartSpec, ChartError> {
    match source {
        ChartSource::Embedded(name) if name == EMBEDDED_CHART_NAME => Ok(ChartSpec::Embedded),
        ChartSource::Embedded(name) => Err(ChartError::UnknownEmbedded { name: name.clone() }),
        ChartSource::Png { path, metres_per_pixel } => Ok(ChartSpec::File {
            path: path.clone(),
            metres_per_pixel: Some(*metres_per_pixel),
        }),
        ChartSource::LandGeojson { path, .. } => Err(ChartError::Io {
            path: path.display().to_string(),
            reason: "a GeoJSON land chart needs a mission file's lat/lon frame (auv-mission/1)".into(),
        }),
    }
}

/// Loads and classifies the chart of `config` for scenario `seed`.
pub fn load_map(config: &ScenarioConfig, seed: u64) -> Result<ScenarioMap, ChartError> {
    let chart = Chart::load(&chart_spec(&config.chart)?)?;
    let mask = chart.classify(&ClassifySettings {
        k: config.k,
        seed: derive_seed(seed, STREAM_CHART),
    })?;
    Ok(ScenarioMap { chart, mask })
}

/// Why a world could not be built from a configuration.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The chart failed to load or classify.
    #[error(transparent)]
    Chart(#[from] ChartError),
    /// The network could not be generated.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
}

/// Loads the chart and generates the world: everything a command needs to
/// start from a configuration and a seed.
pub fn load_world(config: &ScenarioConfig, seed: u64) -> Result<(World, ScenarioMap), LoadError> {
    let map = load_map(config, seed)?;
    let world = World::generate(config, seed, &map)?;
    Ok((world, map))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_scenario_builds_on_the_embedded_chart() {
        let cfg = ScenarioConfig::default();
        let (world, map) = load_world(&cfg, 42).unwrap();
        assert_eq!((map.width_m(), map.height_m()), (5000.0, 10_000.0));
        assert_eq!(world.n(), 40);
        for p in world.positions() {
            assert!(map.is_water(p.x, p.y));
        }
        assert!(world.edge_count() > 0);
        // Deterministic per seed.
        let (again, _) = load_world(&cfg, 42).unwrap();
        assert_eq!(world.snapshot("a").to_json(), again.snapshot("a").to_json());
    }

    #[test]
    fn unknown_embedded_chart_and_missing_file_are_named() {
        let mut cfg = ScenarioConfig {
            chart: ChartSource::Embedded("atlantis".into()),
            ..ScenarioConfig::default()
        };
        let err = load_map(&cfg, 1).err().unwrap().to_string();
        assert!(err.contains("atlantis"), "{err}");
        cfg.chart = ChartSource::Png {
            path: "/no/such/chart.png".into(),
            metres_per_pixel: 10.0,
        };
        let err = load_map(&cfg, 1).err().unwrap().to_string();
        assert!(err.contains("/no/such/chart.png"), "{err}");
    }
}
