//! The scenario configuration and its JSON file format (`auv-scenario/1`).
//!
//! Contract: [`ScenarioConfig::default`] holds every default of the scenario
//! model (the table and sources are in the [parent module](super)).
//! [`ScenarioConfig::from_json`] accepts a JSON object whose fields are all
//! optional (absent ⇒ default) and rejects, with a one-line [`ConfigError`]
//! naming the field's path, anything else: unknown fields, wrong types,
//! out-of-range numbers, more nodes than [`LARGEST_NODES`], more dynamic
//! waypoints than `nodes − 2`. The document is read by serde derive
//! (`deny_unknown_fields`; `serde_path_to_error` gives the path), then
//! [`ScenarioConfig::validate`] checks the ranges. [`ScenarioConfig::to_json`] writes every field, and reads back
//! to an equal config.
//!
//! ```json
//! {"format": "auv-scenario/1", "nodes": 40, "dynamic": 10, "sigma_m": 150,
//!  "bound_sigma_m": 300, "depth_max_m": 1000, "speed_mps": 1.5,
//!  "time_available_s": 31000, "priority": [1, 10], "risk": [0.1, 1.0],
//!  "task_time_s": [120, 900], "objective": {"kind": "max_weight"},
//!  "chart": "benoits-cove", "k": 3, "sensor_period_s": 60,
//!  "position_attempts": 100000, "redraw_attempts": 1000}
//! ```
//! `chart` is either the name of an embedded chart or
//! `{"png": "path/to/chart.png", "metres_per_pixel": 20}`; a relative path is
//! resolved against the scenario file's folder by [`ScenarioConfig::from_file`].

use std::path::{Path, PathBuf};

use serde_json::json;

use auv_core::capacity::LARGEST_NODES;
use auv_core::instance::Objective;

/// The value of the optional `format` field of a scenario file.
pub const SCENARIO_FORMAT: &str = "auv-scenario/1";

/// Largest accepted k-means cluster count (our choice: a chart has a few
/// colour families; more clusters only split them).
pub const MAX_K: usize = 16;

/// Where the chart comes from. The scenario only names it; the chart layer
/// turns it into a [`crate::chart::WaterMap`].
#[derive(Clone, Debug, PartialEq)]
pub enum ChartSource {
    /// A chart embedded in the binary, by name (e.g. `benoits-cove`).
    Embedded(String),
    /// A PNG file and its scale.
    Png {
        /// Path to the image.
        path: PathBuf,
        /// Ground size of one pixel, m.
        metres_per_pixel: f64,
    },
    /// GeoJSON land polygons (lon/lat) over an operating area. Only a mission
    /// file (`auv-mission/1`) names one: its polygons need the mission's
    /// lat/lon frame, which a scenario file does not have.
    LandGeojson {
        /// Path to the GeoJSON file.
        path: PathBuf,
        /// The operating area, m: x east, y north from the frame origin.
        extent_m: [f64; 2],
    },
}

/// A closed interval [lo, hi] that a uniform draw U(lo, hi) comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UniformRange {
    /// Lower end.
    pub lo: f64,
    /// Upper end, ≥ `lo`.
    pub hi: f64,
}

impl UniformRange {
    /// [lo, hi].
    pub const fn new(lo: f64, hi: f64) -> Self {
        Self { lo, hi }
    }
}

/// Every parameter of the scenario model. Defaults and their sources: see
/// the [module table](super).
#[derive(Clone, Debug, PartialEq)]
pub struct ScenarioConfig {
    /// Waypoint count n (node 0 the start, node n−1 the goal); 2..=[`LARGEST_NODES`].
    pub nodes: usize,
    /// Dynamic waypoint count d ≤ n − 2; they are ids 1..=d.
    pub dynamic: usize,
    /// σ of a dynamic waypoint's actual position around its nominal one,
    /// per axis, m; > 0.
    pub sigma_m: f64,
    /// σ_b of the per-axis bound |N(0, σ_b²)| of a dynamic waypoint, m; ≥ 0.
    pub bound_sigma_m: f64,
    /// Deepest waypoint, m (z ∈ [0, depth_max_m], positive down); ≥ 0.
    pub depth_max_m: f64,
    /// Vehicle speed v through water, m/s; > 0.
    pub speed_mps: f64,
    /// Mission time budget T_available, s; > 0.
    pub time_available_s: f64,
    /// Task priority ρ ~ U(lo, hi); lo ≥ 0.
    pub priority: UniformRange,
    /// Task risk ξ ~ U(lo, hi); lo > 0.
    pub risk: UniformRange,
    /// Task completion time δ ~ U(lo, hi), s; lo ≥ 0.
    pub task_time_s: UniformRange,
    /// Objective written into snapshots.
    pub objective: Objective,
    /// The chart.
    pub chart: ChartSource,
    /// k-means cluster count for the chart; 2..=[`MAX_K`].
    pub k: usize,
    /// Mission time between two sensor redraws of the dynamic waypoints, s; > 0.
    pub sensor_period_s: f64,
    /// Uniform draws allowed per static (or nominal) waypoint before the
    /// chart is declared to have too little water; ≥ 1.
    pub position_attempts: u32,
    /// Truncated-normal draws allowed per dynamic waypoint and redraw before
    /// it falls back to its nominal position (always over water); ≥ 1.
    pub redraw_attempts: u32,
}

impl Default for ScenarioConfig {
    /// The defaults of the module table, in the same order.
    fn default() -> Self {
        Self {
            nodes: 40,
            dynamic: 10,
            sigma_m: 150.0,
            bound_sigma_m: 300.0,
            depth_max_m: 1000.0,
            speed_mps: 1.5,
            time_available_s: 31_000.0,
            priority: UniformRange::new(1.0, 10.0),
            risk: UniformRange::new(0.1, 1.0),
            task_time_s: UniformRange::new(120.0, 900.0),
            objective: Objective::MaxWeight,
            chart: ChartSource::Embedded("benoits-cove".into()),
            k: 3,
            sensor_period_s: 60.0,
            position_attempts: 100_000,
            redraw_attempts: 1_000,
        }
    }
}

/// Why a scenario configuration was rejected. Every variant names the field.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// The scenario file could not be read.
    #[error("scenario file {path}: {message}")]
    Io {
        /// The path.
        path: String,
        /// The system's reason.
        message: String,
    },
    /// Not JSON at all.
    #[error("scenario JSON: {0}")]
    Json(String),
    /// A field that is unknown, of the wrong type, or missing a part
    /// (serde's message, with the field's path).
    #[error("scenario field `{field}`: {message}")]
    Field {
        /// Field path, e.g. `chart.metres_per_pixel` or `priority[0]`.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// `format` is present but not [`SCENARIO_FORMAT`].
    #[error("scenario field `format` = {0:?}: expected \"{SCENARIO_FORMAT}\"")]
    WrongFormat(String),
    /// A field of the wrong JSON type.
    #[error("scenario field `{field}` = {found}: expected {expected}")]
    WrongType {
        /// Field path, e.g. `chart.metres_per_pixel`.
        field: String,
        /// What was expected.
        expected: &'static str,
        /// The JSON found.
        found: String,
    },
    /// A number outside its allowed range (or not finite).
    #[error("scenario field `{field}` = {value}: must be {rule}")]
    BadNumber {
        /// Field path.
        field: String,
        /// The value.
        value: f64,
        /// The rule it breaks.
        rule: &'static str,
    },
    /// `nodes` above the largest capacity class.
    #[error("scenario field `nodes` = {0} exceeds the planner's largest capacity class of {LARGEST_NODES} nodes")]
    TooManyNodes(usize),
    /// `nodes` below 2 (a start and a goal).
    #[error("scenario field `nodes` = {0}: a route needs at least 2 nodes (start and goal)")]
    TooFewNodes(usize),
    /// `dynamic` above `nodes − 2` (start and goal stay static).
    #[error("scenario field `dynamic` = {dynamic}: at most nodes − 2 = {max} (start and goal are static)")]
    TooManyDynamic {
        /// Requested dynamic count.
        dynamic: usize,
        /// Largest allowed.
        max: usize,
    },
    /// A range with lo > hi.
    #[error("scenario field `{field}` = [{lo}, {hi}]: lower end exceeds upper end")]
    BadRange {
        /// Field name.
        field: &'static str,
        /// Lower end.
        lo: f64,
        /// Upper end.
        hi: f64,
    },
}

fn bad(field: &str, value: f64, rule: &'static str) -> ConfigError {
    ConfigError::BadNumber {
        field: field.to_string(),
        value,
        rule,
    }
}

/// `value` must be finite and satisfy `ok`.
fn check(field: &str, value: f64, ok: bool, rule: &'static str) -> Result<(), ConfigError> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(bad(field, value, rule))
    }
}

fn check_range(field: &'static str, r: UniformRange, lo_ok: bool, lo_rule: &'static str) -> Result<(), ConfigError> {
    check(&format!("{field}[0]"), r.lo, lo_ok, lo_rule)?;
    check(&format!("{field}[1]"), r.hi, true, "finite")?;
    if r.lo > r.hi {
        return Err(ConfigError::BadRange {
            field,
            lo: r.lo,
            hi: r.hi,
        });
    }
    Ok(())
}

impl ScenarioConfig {
    /// Checks every field; the first violation is returned.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.nodes > LARGEST_NODES {
            return Err(ConfigError::TooManyNodes(self.nodes));
        }
        if self.nodes < 2 {
            return Err(ConfigError::TooFewNodes(self.nodes));
        }
        if self.dynamic > self.nodes - 2 {
            return Err(ConfigError::TooManyDynamic {
                dynamic: self.dynamic,
                max: self.nodes - 2,
            });
        }
        check("sigma_m", self.sigma_m, self.sigma_m > 0.0, "finite and > 0")?;
        check(
            "bound_sigma_m",
            self.bound_sigma_m,
            self.bound_sigma_m >= 0.0,
            "finite and >= 0",
        )?;
        check(
            "depth_max_m",
            self.depth_max_m,
            self.depth_max_m >= 0.0,
            "finite and >= 0",
        )?;
        check("speed_mps", self.speed_mps, self.speed_mps > 0.0, "finite and > 0")?;
        check(
            "time_available_s",
            self.time_available_s,
            self.time_available_s > 0.0,
            "finite and > 0",
        )?;
        check_range("priority", self.priority, self.priority.lo >= 0.0, "finite and >= 0")?;
        check_range("risk", self.risk, self.risk.lo > 0.0, "finite and > 0")?;
        check_range(
            "task_time_s",
            self.task_time_s,
            self.task_time_s.lo >= 0.0,
            "finite and >= 0",
        )?;
        if let Objective::PaperCost { phi1, phi2 } = self.objective {
            check("objective.phi1", phi1, phi1 >= 0.0, "finite and >= 0")?;
            check("objective.phi2", phi2, phi2 >= 0.0, "finite and >= 0")?;
        }
        match &self.chart {
            ChartSource::Embedded(name) if name.is_empty() => {
                return Err(ConfigError::WrongType {
                    field: "chart".into(),
                    expected: CHART_EXPECTED,
                    found: "\"\"".into(),
                });
            }
            ChartSource::Png { path, .. } if path.as_os_str().is_empty() => {
                return Err(ConfigError::WrongType {
                    field: "chart.png".into(),
                    expected: "a non-empty path",
                    found: "\"\"".into(),
                });
            }
            ChartSource::Png { metres_per_pixel, .. } => check(
                "chart.metres_per_pixel",
                *metres_per_pixel,
                *metres_per_pixel > 0.0,
                "finite and > 0",
            )?,
            ChartSource::Embedded(_) | ChartSource::LandGeojson { .. } => {}
        }
        if !(2..=MAX_K).contains(&self.k) {
            return Err(bad("k", self.k as f64, "an integer in 2..=16"));
        }
        check(
            "sensor_period_s",
            self.sensor_period_s,
            self.sensor_period_s > 0.0,
            "finite and > 0",
        )?;
        if self.position_attempts == 0 {
            return Err(bad("position_attempts", 0.0, ">= 1"));
        }
        if self.redraw_attempts == 0 {
            return Err(bad("redraw_attempts", 0.0, ">= 1"));
        }
        Ok(())
    }

    /// Reads and validates a scenario file; a relative `chart.png` path is
    /// taken relative to the file's folder.
    pub fn from_file(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        let mut cfg = Self::from_json(&text)?;
        if let ChartSource::Png { path: png, .. } = &mut cfg.chart
            && png.is_relative()
            && let Some(dir) = path.parent()
        {
            *png = dir.join(&*png);
        }
        Ok(cfg)
    }

    /// Parses and validates a scenario document (fields absent ⇒ defaults).
    pub fn from_json(text: &str) -> Result<Self, ConfigError> {
        let mut de = serde_json::Deserializer::from_str(text);
        let Obj(doc): Obj<ScenarioDoc> = serde_path_to_error::deserialize(&mut de).map_err(|e| {
            let path = e.path().to_string();
            let inner = e.into_inner();
            if inner.is_syntax() || inner.is_eof() {
                ConfigError::Json(inner.to_string())
            } else if path == "." {
                ConfigError::Json(strip_position(&inner.to_string()))
            } else {
                ConfigError::Field {
                    field: path,
                    message: strip_position(&inner.to_string()),
                }
            }
        })?;
        de.end().map_err(|e| ConfigError::Json(e.to_string()))?;
        let cfg = doc.into_config()?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Writes every field as a pretty-printed `auv-scenario/1` document.
    pub fn to_json(&self) -> String {
        let objective = match self.objective {
            Objective::MaxWeight => json!({"kind": "max_weight"}),
            Objective::PaperCost { phi1, phi2 } => json!({"kind": "paper_cost", "phi1": phi1, "phi2": phi2}),
        };
        let chart = match &self.chart {
            ChartSource::Embedded(name) => json!(name),
            ChartSource::Png { path, metres_per_pixel } => {
                json!({"png": path.to_string_lossy(), "metres_per_pixel": metres_per_pixel})
            }
            ChartSource::LandGeojson { path, extent_m } => {
                json!({"land_geojson": path.to_string_lossy(), "extent_m": extent_m})
            }
        };
        let doc = json!({
            "format": SCENARIO_FORMAT,
            "nodes": self.nodes,
            "dynamic": self.dynamic,
            "sigma_m": self.sigma_m,
            "bound_sigma_m": self.bound_sigma_m,
            "depth_max_m": self.depth_max_m,
            "speed_mps": self.speed_mps,
            "time_available_s": self.time_available_s,
            "priority": [self.priority.lo, self.priority.hi],
            "risk": [self.risk.lo, self.risk.hi],
            "task_time_s": [self.task_time_s.lo, self.task_time_s.hi],
            "objective": objective,
            "chart": chart,
            "k": self.k,
            "sensor_period_s": self.sensor_period_s,
            "position_attempts": self.position_attempts,
            "redraw_attempts": self.redraw_attempts,
        });
        // A `Value` built from finite numbers and strings always serialises.
        serde_json::to_string_pretty(&doc).unwrap_or_default()
    }
}

/// serde_json's message without its " at line L column C" suffix (the
/// field path says where).
fn strip_position(message: &str) -> String {
    match message.rfind(" at line ") {
        Some(k) => message[..k].to_string(),
        None => message.to_string(),
    }
}

/// The scenario document as written: every field optional, nothing else
/// accepted.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ScenarioDoc {
    format: Option<String>,
    nodes: Option<usize>,
    dynamic: Option<usize>,
    sigma_m: Option<f64>,
    bound_sigma_m: Option<f64>,
    depth_max_m: Option<f64>,
    speed_mps: Option<f64>,
    time_available_s: Option<f64>,
    priority: Option<[f64; 2]>,
    risk: Option<[f64; 2]>,
    task_time_s: Option<[f64; 2]>,
    objective: Option<Obj<ObjectiveDoc>>,
    chart: Option<ChartDoc>,
    k: Option<usize>,
    sensor_period_s: Option<f64>,
    position_attempts: Option<u32>,
    redraw_attempts: Option<u32>,
}

#[derive(serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
enum ObjectiveDoc {
    // A struct variant, so that stray fields next to the kind are refused.
    MaxWeight {},
    PaperCost { phi1: f64, phi2: f64 },
}

/// A `T` that must be written as a JSON object (a derived struct would also
/// take an array of its fields in order).
struct Obj<T>(T);

impl<'de, T: serde::Deserialize<'de>> serde::Deserialize<'de> for Obj<T> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<T>(std::marker::PhantomData<T>);
        impl<'de, T: serde::Deserialize<'de>> serde::de::Visitor<'de> for V<T> {
            type Value = Obj<T>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a JSON object")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, m: A) -> Result<Obj<T>, A::Error> {
                T::deserialize(serde::de::value::MapAccessDeserializer::new(m)).map(Obj)
            }
        }
        d.deserialize_map(V(std::marker::PhantomData))
    }
}

/// `chart`: an embedded chart's name, or a PNG and its scale.
enum ChartDoc {
    Name(String),
    Png(PngDoc),
}

const CHART_EXPECTED: &str = "a chart name or {\"png\": path, \"metres_per_pixel\": m}";

impl<'de> serde::Deserialize<'de> for ChartDoc {
    // By hand rather than `untagged`, so that an error inside the PNG form
    // keeps its field path.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = ChartDoc;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str(CHART_EXPECTED)
            }
            fn visit_str<E: serde::de::Error>(self, s: &str) -> Result<ChartDoc, E> {
                Ok(ChartDoc::Name(s.to_string()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, m: A) -> Result<ChartDoc, A::Error> {
                use serde::Deserialize as _;
                PngDoc::deserialize(serde::de::value::MapAccessDeserializer::new(m)).map(ChartDoc::Png)
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PngDoc {
    png: PathBuf,
    metres_per_pixel: f64,
}

impl ScenarioDoc {
    /// The configuration: the defaults with the fields given replaced.
    fn into_config(self) -> Result<ScenarioConfig, ConfigError> {
        if let Some(f) = self.format
            && f != SCENARIO_FORMAT
        {
            return Err(ConfigError::WrongFormat(f));
        }
        let d = ScenarioConfig::default();
        let range = |r: Option<[f64; 2]>, def: UniformRange| r.map_or(def, |[lo, hi]| UniformRange::new(lo, hi));
        Ok(ScenarioConfig {
            nodes: self.nodes.unwrap_or(d.nodes),
            dynamic: self.dynamic.unwrap_or(d.dynamic),
            sigma_m: self.sigma_m.unwrap_or(d.sigma_m),
            bound_sigma_m: self.bound_sigma_m.unwrap_or(d.bound_sigma_m),
            depth_max_m: self.depth_max_m.unwrap_or(d.depth_max_m),
            speed_mps: self.speed_mps.unwrap_or(d.speed_mps),
            time_available_s: self.time_available_s.unwrap_or(d.time_available_s),
            priority: range(self.priority, d.priority),
            risk: range(self.risk, d.risk),
            task_time_s: range(self.task_time_s, d.task_time_s),
            objective: match self.objective {
                None => d.objective,
                Some(Obj(ObjectiveDoc::MaxWeight {})) => Objective::MaxWeight,
                Some(Obj(ObjectiveDoc::PaperCost { phi1, phi2 })) => Objective::PaperCost { phi1, phi2 },
            },
            chart: match self.chart {
                None => d.chart,
                Some(ChartDoc::Name(name)) => ChartSource::Embedded(name),
                Some(ChartDoc::Png(p)) => ChartSource::Png {
                    path: p.png,
                    metres_per_pixel: p.metres_per_pixel,
                },
            },
            k: self.k.unwrap_or(d.k),
            sensor_period_s: self.sensor_period_s.unwrap_or(d.sensor_period_s),
            position_attempts: self.position_attempts.unwrap_or(d.position_attempts),
            redraw_attempts: self.redraw_attempts.unwrap_or(d.redraw_attempts),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_object_is_the_default_and_defaults_validate() {
        assert_eq!(ScenarioConfig::from_json("{}").unwrap(), ScenarioConfig::default());
        ScenarioConfig::default().validate().unwrap();
    }

    #[test]
    fn the_documented_example_parses() {
        let text = r#"{"nodes": 40, "dynamic": 10, "sigma_m": 150, "bound_sigma_m": 300,
            "speed_mps": 1.5, "time_available_s": 31000,
            "chart": {"png": "maps/bay.png", "metres_per_pixel": 20}, "k": 3}"#;
        let cfg = ScenarioConfig::from_json(text).unwrap();
        assert_eq!(
            cfg.chart,
            ChartSource::Png {
                path: "maps/bay.png".into(),
                metres_per_pixel: 20.0
            }
        );
    }

    #[test]
    fn round_trips_every_field() {
        let cfg = ScenarioConfig {
            nodes: 77,
            dynamic: 20,
            sigma_m: 0.1 + 0.2,
            bound_sigma_m: 0.0,
            depth_max_m: 250.5,
            speed_mps: 2.25,
            time_available_s: 12_345.6,
            priority: UniformRange::new(0.0, 3.0),
            risk: UniformRange::new(0.5, 0.5),
            task_time_s: UniformRange::new(0.0, 10.0),
            objective: Objective::PaperCost { phi1: 0.3, phi2: 1e-3 },
            chart: ChartSource::Png {
                path: "a/b.png".into(),
                metres_per_pixel: 12.5,
            },
            k: 5,
            sensor_period_s: 30.0,
            position_attempts: 7,
            redraw_attempts: 9,
        };
        assert_eq!(ScenarioConfig::from_json(&cfg.to_json()).unwrap(), cfg);
        let def = ScenarioConfig::default();
        assert_eq!(ScenarioConfig::from_json(&def.to_json()).unwrap(), def);
    }

    #[test]
    fn relative_chart_paths_follow_the_scenario_file() {
        let dir = std::env::temp_dir().join(format!("planner-scenario-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("s.json");
        std::fs::write(&file, r#"{"chart": {"png": "c.png", "metres_per_pixel": 10}}"#).unwrap();
        let cfg = ScenarioConfig::from_file(&file).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(
            cfg.chart,
            ChartSource::Png {
                path: dir.join("c.png"),
                metres_per_pixel: 10.0
            }
        );
        let err = ScenarioConfig::from_file(&dir.join("missing.json")).unwrap_err();
        assert!(err.to_string().contains("missing.json"), "{err}");
    }

    #[test]
    fn every_bad_field_is_named_in_the_error() {
        let cases: &[(&str, &str)] = &[
            ("[1, 2]", "expected a JSON object"),
            ("{", "scenario JSON"),
            (r#"{"nodez": 40}"#, "unknown field `nodez`"),
            (r#"{"format": "auv-scenario/2"}"#, "`format`"),
            (
                r#"{"nodes": 513}"#,
                "`nodes` = 513 exceeds the planner's largest capacity class of 512",
            ),
            (r#"{"nodes": 1, "dynamic": 0}"#, "`nodes` = 1"),
            (r#"{"nodes": -3}"#, "`nodes`: invalid value: integer `-3`"),
            (r#"{"nodes": 40.5}"#, "`nodes`: invalid type: floating point `40.5`"),
            (r#"{"nodes": "40"}"#, "`nodes`"),
            (
                r#"{"nodes": 12, "dynamic": 11}"#,
                "`dynamic` = 11: at most nodes − 2 = 10",
            ),
            (r#"{"sigma_m": -150}"#, "`sigma_m` = -150"),
            (r#"{"sigma_m": 0}"#, "`sigma_m` = 0"),
            (r#"{"bound_sigma_m": -1}"#, "`bound_sigma_m`"),
            (r#"{"depth_max_m": -1}"#, "`depth_max_m`"),
            (r#"{"speed_mps": 0}"#, "`speed_mps`"),
            (r#"{"speed_mps": 1e999}"#, "scenario JSON"),
            (r#"{"time_available_s": -31000}"#, "`time_available_s`"),
            (r#"{"priority": [10, 1]}"#, "`priority` = [10, 1]"),
            (r#"{"priority": [-1, 1]}"#, "`priority[0]`"),
            (r#"{"priority": [1]}"#, "`priority`: invalid length 1"),
            (r#"{"risk": [0, 1]}"#, "`risk[0]`"),
            (r#"{"task_time_s": [-5, 1]}"#, "`task_time_s[0]`"),
            (r#"{"task_time_s": [1, "x"]}"#, "`task_time_s[1]`"),
            (
                r#"{"objective": {"kind": "min_time"}}"#,
                "`objective.kind`: unknown variant `min_time`",
            ),
            (
                r#"{"objective": {"kind": "paper_cost"}}"#,
                "`objective`: missing field `phi1`",
            ),
            (
                r#"{"objective": {"kind": "paper_cost", "phi1": -1, "phi2": 1}}"#,
                "`objective.phi1`",
            ),
            (
                r#"{"objective": {"kind": "max_weight", "phi3": 1}}"#,
                "unknown field `phi3`",
            ),
            (
                r#"{"chart": 3}"#,
                "`chart`: invalid type: integer `3`, expected a chart name",
            ),
            (r#"{"chart": ["a.png", 2]}"#, "`chart`: invalid type: sequence"),
            (
                r#"{"objective": ["max_weight"]}"#,
                "`objective`: invalid type: sequence, expected a JSON object",
            ),
            (r#"{"nodes": 10} {}"#, "trailing characters"),
            (r#"{"chart": ""}"#, "`chart`"),
            (
                r#"{"chart": {"png": "a.png"}}"#,
                "`chart`: missing field `metres_per_pixel`",
            ),
            (
                r#"{"chart": {"png": "a.png", "metres_per_pixel": -2}}"#,
                "`chart.metres_per_pixel`",
            ),
            (r#"{"chart": {"metres_per_pixel": 2}}"#, "missing field `png`"),
            (
                r#"{"chart": {"png": "a.png", "metres_per_pixel": 2, "dpi": 3}}"#,
                "unknown field `dpi`",
            ),
            (r#"{"k": 1}"#, "`k` = 1"),
            (r#"{"k": 17}"#, "`k` = 17"),
            (r#"{"sensor_period_s": 0}"#, "`sensor_period_s`"),
            (r#"{"position_attempts": 0}"#, "`position_attempts`"),
            (r#"{"redraw_attempts": 5000000000}"#, "`redraw_attempts`"),
        ];
        for (text, needle) in cases {
            let err = ScenarioConfig::from_json(text).expect_err(text).to_string();
            assert!(err.contains(needle), "{text}: error {err:?} should mention {needle:?}");
            assert!(!err.contains('\n'), "one-line errors: {err:?}");
        }
    }

    #[test]
    fn nan_and_infinity_set_in_code_are_rejected_too() {
        for edit in [
            (|c: &mut ScenarioConfig| c.sigma_m = f64::NAN) as fn(&mut ScenarioConfig),
            |c| c.speed_mps = f64::INFINITY,
            |c| c.risk.hi = f64::NAN,
            |c| c.time_available_s = f64::NEG_INFINITY,
        ] {
            let mut cfg = ScenarioConfig::default();
            edit(&mut cfg);
            assert!(matches!(cfg.validate(), Err(ConfigError::BadNumber { .. })), "{cfg:?}");
        }
    }
}
