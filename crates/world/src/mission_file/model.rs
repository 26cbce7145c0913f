//! The `auv-mission/1` document as serde types, field for field as the
//! format defines it. Unknown fields are refused at every level
//! (`deny_unknown_fields`); semantic checks (ranges, names, geography) are
//! [`super::resolve`]'s.

use serde::Deserialize;

/// The whole file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MissionDoc {
    /// Always `auv-mission/1` (checked before the rest is read).
    pub format: String,
    /// Free text.
    pub name: Option<String>,
    /// Every random draw of the mission; default 1.
    pub seed: Option<u64>,
    /// The lat/lon origin of the local frame.
    pub frame: Option<FrameDoc>,
    /// Exactly one of embedded, png, land_geojson.
    pub chart: ChartDoc,
    /// Speed, budget, reserve.
    pub vehicle: VehicleDoc,
    /// Default max_weight.
    pub objective: Option<ObjectiveDoc>,
    /// How the sensor simulator moves dynamic waypoints.
    pub sensing: Option<SensingDoc>,
    /// The explicit waypoints, in file order.
    #[serde(default)]
    pub waypoint: Vec<WaypointDoc>,
    /// More waypoints drawn as in the paper.
    pub generate: Option<GenerateDoc>,
    /// Task rules and explicit tasks.
    pub tasks: Option<TasksDoc>,
}

/// `[frame]`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FrameDoc {
    /// The local frame's (0, 0).
    pub origin: LatLonDoc,
}

/// `{ lat = …, lon = … }`, degrees (WGS 84).
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LatLonDoc {
    /// Degrees north.
    pub lat: f64,
    /// Degrees east.
    pub lon: f64,
}

/// `[chart]`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ChartDoc {
    /// `benoits-cove` or `bay-of-islands`.
    pub embedded: Option<String>,
    /// A PNG chart, relative to the mission file.
    pub png: Option<String>,
    /// Required with `png`.
    pub metres_per_pixel: Option<f64>,
    /// k-means clusters of a raster chart (default 3).
    pub k: Option<i64>,
    /// RFC 7946 land polygons, relative to the mission file.
    pub land_geojson: Option<String>,
    /// Required with `land_geojson`: the operating area, x east × y north, m.
    pub extent_m: Option<[f64; 2]>,
}

/// `[vehicle]`.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VehicleDoc {
    /// Through water, m/s, > 0.
    pub speed_mps: f64,
    /// The budget T_available, s, > 0.
    pub time_available_s: f64,
    /// Held back from every plan, s, ≥ 0 (default 0).
    pub reserve_s: Option<f64>,
}

/// `[objective]`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ObjectiveDoc {
    /// `max_weight` or `paper_cost`.
    pub kind: String,
    /// paper_cost's φ1 > 0.
    pub phi1: Option<f64>,
    /// paper_cost's φ2 > 0.
    pub phi2: Option<f64>,
}

/// `[sensing]`.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SensingDoc {
    /// Mission time between two snapshots, s, > 0.
    pub period_s: Option<f64>,
    /// Default drift σ per axis, m, > 0.
    pub sigma_m: Option<f64>,
}

/// One `[[waypoint]]`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WaypointDoc {
    /// Unique, non-empty.
    pub name: String,
    /// With `lon`: a geodetic position (needs a frame origin).
    pub lat: Option<f64>,
    /// With `lat`.
    pub lon: Option<f64>,
    /// With `y_m`: a local position, m east.
    pub x_m: Option<f64>,
    /// With `x_m`: m north.
    pub y_m: Option<f64>,
    /// 0 ≤ depth ≤ 1000 m, positive down.
    pub depth_m: f64,
    /// `start`, `goal`, or absent.
    pub role: Option<String>,
    /// ≥ 0, collected once on a visit (default 0).
    pub prize: Option<f64>,
    /// A drifting sensor.
    pub dynamic: Option<DynamicDoc>,
}

/// `dynamic = { bound_m = [x, y, depth], sigma_m = … }`.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DynamicDoc {
    /// Per-axis bound of the offset from the nominal position, m, ≥ 0.
    pub bound_m: [f64; 3],
    /// Drift σ per axis, m, > 0 (default `[sensing].sigma_m`).
    pub sigma_m: Option<f64>,
}

/// `[generate]`.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GenerateDoc {
    /// Static waypoints to draw (default 0).
    #[serde(rename = "static")]
    pub fixed: Option<i64>,
    /// Dynamic waypoints to draw (default 0).
    pub dynamic: Option<i64>,
    /// σ_b of their bounds, m (default 300).
    pub bound_sigma_m: Option<f64>,
}

/// `[tasks]`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TasksDoc {
    /// Ranges for the edges without an explicit task.
    pub draw: Option<DrawDoc>,
    /// Explicit tasks.
    #[serde(default)]
    pub edge: Vec<EdgeDoc>,
}

/// `draw = { priority = [lo, hi], risk = [lo, hi], task_time_s = [lo, hi] }`.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DrawDoc {
    /// ρ ~ U(lo, hi).
    pub priority: [f64; 2],
    /// ξ ~ U(lo, hi).
    pub risk: [f64; 2],
    /// δ ~ U(lo, hi), s.
    pub task_time_s: [f64; 2],
}

/// One `[[tasks.edge]]`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EdgeDoc {
    /// A waypoint name.
    pub a: String,
    /// Another waypoint name.
    pub b: String,
    /// ρ ≥ 0.
    pub priority: f64,
    /// ξ > 0.
    pub risk: f64,
    /// δ ≥ 0, s.
    pub task_time_s: f64,
}
