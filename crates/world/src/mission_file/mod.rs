//! Mission files (`auv-mission/1`, TOML): the operator's own mission —
//! waypoints in lat/lon or metres, drifting sensors, tasks, chart, vehicle —
//! read and checked, then resolved into the world the three processes share.
//!
//! # Contract
//! - [`load`] / [`parse`] implement `shared/design/mission-format.md`
//!   exactly: serde derive with `deny_unknown_fields` on every table
//!   ([`model`]), then every check of the format's error list
//!   ([`resolve`]). A file that cannot be run is a [`MissionError`]: one
//!   line naming the file, the field (a TOML path such as `waypoint[3].lat`)
//!   or the waypoint by name, and what is wrong.
//! - Resolution ([`Mission`]) gives the world in the format's node ids (0 the
//!   start, the other explicit waypoints in file order, then the generated
//!   ones, n − 1 the goal), its water map (raster chart classified by
//!   k-means, or GeoJSON land polygons), the waypoint names and the frame.
//! - Deterministic: the same file (and seed) gives the same world, bit for
//!   bit; every draw uses the scenario generator's streams by node id.
//!
//! # Choices where the format is silent (ours)
//! | what | choice |
//! | --- | --- |
//! | `[sensing]` defaults | `period_s` 60 s, `sigma_m` 150 m (the paper's model) |
//! | `[generate]` defaults | `static` 0, `dynamic` 0, `bound_sigma_m` 300 m (the paper's σ_b) |
//! | order of generated ids | the generated dynamic waypoints first, then the static ones (so the paper's model, where ids 1..=d drift, is one mission file) |
//! | start or goal dynamic | refused: the vehicle starts at the start's position and the route must end at a fixed goal |
//! | "a dynamic bound that cannot stay over water" | less than [`MIN_BOUND_WATER_FRACTION`] of the bound's box (nominal ± bound, x and y, clipped to the area) is water, sampled on a [`BOUND_SAMPLE_GRID`]² grid: the drift would sit on its fallback (the nominal position) nearly every update |
//! | which positions decide "an explicit task on a pair that is no edge" | the nominal ones (as written in the file) |
//! | "a start with no route to the goal within the budget" | on the first snapshot (the network the planner first sees), with the budget less `reserve_s` |
//! | a `[frame]` with an embedded chart | accepted: the chart's south-west corner sits at the given origin, as for `png` |

pub mod model;
mod resolve;

#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};

use crate::chart::WaterMap;
use crate::chart::land::LandChart;
use crate::chart::mask::WaterMask;
use crate::frame::LocalFrame;
use crate::scenario::World;

pub use resolve::{BOUND_SAMPLE_GRID, MIN_BOUND_WATER_FRACTION};

/// The value of a mission file's `format` field.
pub const MISSION_FORMAT: &str = "auv-mission/1";

/// The embedded default mission: the paper's model on Benoit's Cove, seed 1
/// (`missions/benoits-cove.toml` in the repository).
pub const DEFAULT_MISSION_TOML: &str = include_str!("../../../../missions/benoits-cove.toml");

/// How errors name the embedded default mission.
pub const DEFAULT_MISSION_NAME: &str = "embedded default mission (missions/benoits-cove.toml)";

/// Why a mission file was refused: the file, then what is wrong.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {problem}")]
pub struct MissionError {
    /// The file as the user named it.
    pub file: String,
    /// What is wrong.
    pub problem: Problem,
}

/// What is wrong with a mission file (each message one line, naming the
/// field or waypoint).
#[derive(Debug, thiserror::Error)]
pub enum Problem {
    /// The file could not be read.
    #[error("cannot read: {0}")]
    Io(String),
    /// Not TOML.
    #[error("not TOML: line {line}, column {column}: {message}")]
    NotToml {
        /// 1-based.
        line: usize,
        /// 1-based.
        column: usize,
        /// The parser's reason.
        message: String,
    },
    /// `format` missing.
    #[error("format: missing; the first line should be format = \"{MISSION_FORMAT}\"")]
    MissingFormat,
    /// `format` is not this format.
    #[error("format = {0}: expected \"{MISSION_FORMAT}\"")]
    WrongFormat(String),
    /// An unknown field, a wrong type or a missing field (from serde).
    #[error("{path}: {message}")]
    Field {
        /// TOML path, e.g. `waypoint[3].lat`.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// A number outside its range (NaN and infinities included).
    #[error("{field} = {value}: must be {rule}")]
    BadNumber {
        /// TOML path.
        field: String,
        /// The value.
        value: String,
        /// The rule.
        rule: &'static str,
    },
    /// Fields that must come together or exclude each other.
    #[error("{field}: {message}")]
    Shape {
        /// TOML path.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A waypoint-level problem (names the waypoint).
    #[error("{field} (\"{name}\"): {message}")]
    Waypoint {
        /// TOML path of the waypoint, e.g. `waypoint[2]`.
        field: String,
        /// Its name.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// A task-level problem.
    #[error("{field} ({a} – {b}): {message}")]
    Task {
        /// TOML path, e.g. `tasks.edge[0]`.
        field: String,
        /// First name.
        a: String,
        /// Second name.
        b: String,
        /// What is wrong.
        message: String,
    },
    /// Too many waypoints.
    #[error(
        "{count} waypoints ({explicit} explicit + {generated} generated) exceed the real-time planner's capacity of {max}"
    )]
    Capacity {
        /// Total.
        count: usize,
        /// Listed.
        explicit: usize,
        /// Drawn.
        generated: usize,
        /// [`auv_core::capacity::LARGEST_NODES`].
        max: usize,
    },
    /// The chart cannot be used.
    #[error("chart: {0}")]
    Chart(String),
    /// The world could not be built (generation found no water, …).
    #[error("{0}")]
    World(String),
    /// No route from the start reaches the goal within the budget.
    #[error("no route from the start (\"{start}\") reaches the goal (\"{goal}\") within the budget: {detail}")]
    NoRoute {
        /// Start name.
        start: String,
        /// Goal name.
        goal: String,
        /// Shortest time or "no path".
        detail: String,
    },
}

/// What a waypoint is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Node 0.
    Start,
    /// Node n − 1.
    Goal,
    /// Any other.
    Via,
}

impl Role {
    /// As in the file (`start`, `goal`) or `""`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Start => "start",
            Self::Goal => "goal",
            Self::Via => "",
        }
    }
}

/// One waypoint of the resolved mission, by node id.
#[derive(Clone, Debug, PartialEq)]
pub struct WaypointInfo {
    /// As in the file; generated ones are `gen-<id>`.
    pub name: String,
    /// Start, goal or neither.
    pub role: Role,
    /// Whether it was drawn by `[generate]`.
    pub generated: bool,
}

/// Where water is: a classified raster or land polygons. Cheap to clone
/// for the wire checks of each receiver.
#[derive(Clone, Debug, PartialEq)]
pub enum Water {
    /// A raster chart's water mask.
    Mask(WaterMask),
    /// GeoJSON land polygons over a rectangular area.
    Land(LandChart),
}

impl WaterMap for Water {
    fn width_m(&self) -> f64 {
        match self {
            Self::Mask(m) => m.width_m(),
            Self::Land(l) => l.width_m(),
        }
    }
    fn height_m(&self) -> f64 {
        match self {
            Self::Mask(m) => m.height_m(),
            Self::Land(l) => l.height_m(),
        }
    }
    fn is_water(&self, x: f64, y: f64) -> bool {
        match self {
            Self::Mask(m) => m.is_water(x, y),
            Self::Land(l) => l.is_water(x, y),
        }
    }
    fn segment_over_water(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        match self {
            Self::Mask(m) => m.segment_over_water(a, b),
            Self::Land(l) => l.segment_over_water(a, b),
        }
    }
}

/// A resolved mission: the world and everything the outputs need to name
/// and place its waypoints.
#[derive(Clone, Debug)]
pub struct Mission {
    /// `name`, or the file's stem.
    pub name: String,
    /// The seed in force.
    pub seed: u64,
    /// The world, in the format's node ids.
    pub world: World,
    /// Where water is.
    pub water: Water,
    /// How the chart is described (embedded name or path).
    pub chart: String,
    /// The lat/lon frame, when the mission has an origin.
    pub frame: Option<LocalFrame>,
    /// By node id.
    pub waypoints: Vec<WaypointInfo>,
    /// Held back from every plan, s.
    pub reserve_s: f64,
}

/// Overrides from the command line.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Overrides {
    /// Replaces the file's `seed`.
    pub seed: Option<u64>,
    /// Replaces `vehicle.time_available_s`.
    pub time_available_s: Option<f64>,
    /// Replaces the start waypoint's position: x, y (m, local frame) and
    /// depth (m).
    pub start_at: Option<[f64; 3]>,
}

/// `name` as a lowercase, dash-separated token (for snapshot names).
pub fn slug(name: &str) -> String {
    let mut s = String::with_capacity(name.len());
    for c in name.chars() {
        if c.is_ascii_alphanumeric() {
            s.push(c.to_ascii_lowercase());
        } else if !s.ends_with('-') && !s.is_empty() {
            s.push('-');
        }
    }
    let s = s.trim_end_matches('-').to_string();
    if s.is_empty() { "mission".into() } else { s }
}

/// Reads, checks and resolves a mission file (relative chart paths are
/// relative to its folder).
pub fn load(path: &Path, overrides: Overrides) -> Result<Mission, MissionError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| MissionError {
        file: file.clone(),
        problem: Problem::Io(e.to_string()),
    })?;
    let dir = path.parent().map_or_else(|| PathBuf::from("."), Path::to_path_buf);
    parse(&text, &file, &dir, overrides)
}

/// The chart file a mission file names (`chart.png` or `chart.land_geojson`),
/// as written; `None` for an embedded chart or a text that is no mission file.
pub fn chart_file(text: &str) -> Option<PathBuf> {
    let chart = resolve::read_doc(text).ok()?.chart;
    chart.png.or(chart.land_geojson).map(PathBuf::from)
}

/// The embedded default mission, resolved.
pub fn load_default(overrides: Overrides) -> Result<Mission, MissionError> {
    parse(DEFAULT_MISSION_TOML, DEFAULT_MISSION_NAME, Path::new("."), overrides)
}

/// Checks and resolves mission text; `file` names it in errors, `dir` is
/// where relative chart paths start.
pub fn parse(text: &str, file: &str, dir: &Path, overrides: Overrides) -> Result<Mission, MissionError> {
    resolve::resolve(text, dir, overrides).map_err(|problem| MissionError {
        file: file.to_string(),
        problem,
    })
}
