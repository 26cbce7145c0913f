//! `mission.mcap`: the mission as an MCAP file that Foxglove opens with no
//! set-up, written at the end of a run from what the mission already
//! records (the `mission.log` lines, the vehicle's journal, the world),
//! streamed: each message goes to the file as it is made, so memory stays
//! flat however long the run.
//!
//! Contract: topics are `/<vehicle>/…`; every channel is JSON (schema
//! encoding `jsonschema`, message encoding `json`); the well-known ones use
//! Foxglove's schema names so its panels render them. Positions are in the
//! frame [`FRAME`]: x east, y north, z up (the world's depth, negated). Log
//! and publish times are mission time in ns, so the same lockstep mission
//! writes the same bytes; only the optional latency channel carries
//! wall-clock figures (a scaled-time run passes them, a lockstep run does
//! not). [`read_summary`] reads a file back for `planner replay`.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Seek, Write};
use std::path::Path;

use base64::Engine;
use serde_json::{Value, json};

use super::route_geojson::Visit;
use auv_messages::journal::JournalEvent;
use auv_world::chart::WaterMap;
use auv_world::frame::LocalFrame;
use auv_world::load::MissionWorld;
use auv_world::mission_file::Water;
use auv_world::scenario::{Vec3, World};

/// The coordinate frame of every message.
pub const FRAME: &str = "map";

/// Schema name of the planner status channel (ours, not Foxglove's).
pub const STATUS_SCHEMA: &str = "auv.PlannerStatus";
/// Schema name of the mission progress channel (ours).
pub const PROGRESS_SCHEMA: &str = "auv.MissionProgress";
/// Schema name of the latency summary channel (ours).
pub const LATENCY_SCHEMA: &str = "auv.PlannerLatency";

/// Cells along the chart's longer side in the `foxglove.Grid` raster (the
/// same resolution as the SVG plot's land layer).
const CHART_CELLS: f64 = 250.0;

/// What a mission recorded, the input of [`write`] (the `mission.log`
/// text is read as the file is written).
pub struct MissionRecord<'a> {
    /// The world as generated (epoch 0): chart, waypoints, bounds.
    pub world: &'a MissionWorld,
    /// The vehicle's poses, from its journal ([`PoseTrack`]).
    pub poses: &'a [PoseAt],
    /// Where the vehicle was, in order (the route travelled).
    pub visits: &'a [Visit],
    /// Vehicle namespace: topics are `/<vehicle>/…`.
    pub vehicle: &'a str,
    /// Plan latency p50, p99, max, µs (wall clock: leave out for a
    /// reproducible file).
    pub latency_us: Option<(u64, u64, u64)>,
    /// The mission's geographic frame, when it has one: the file then also
    /// holds a `foxglove.LocationFix` for each pose, and the chart and the
    /// route as `foxglove.GeoJSON` (Foxglove's Map panel).
    pub geo: Option<&'a LocalFrame>,
}

/// Why `mission.mcap` could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum McapLogError {
    /// A `mission.log` line is not what the planner writes.
    #[error("mission.log line {line}: {detail}")]
    BadLogLine {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        detail: String,
    },
    /// The MCAP layer failed (write error, or a malformed/truncated file).
    #[error("{0}")]
    Mcap(#[from] mcap::McapError),
    /// The file reads as MCAP but is not a mission log.
    #[error("{0}")]
    NotMission(String),
    /// Writing the file failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
}

/// Mission time, s, as MCAP time, ns (negative and NaN times clamp to 0).
fn ns(t: f64) -> u64 {
    if t.is_finite() && t > 0.0 {
        (t * 1e9).round() as u64
    } else {
        0
    }
}

fn stamp(t_ns: u64) -> Value {
    json!({"sec": t_ns / 1_000_000_000, "nsec": t_ns % 1_000_000_000})
}

fn colour(r: f64, g: f64, b: f64, a: f64) -> Value {
    json!({"r": r, "g": g, "b": b, "a": a})
}

fn point(p: Vec3) -> Value {
    json!({"x": p.x, "y": p.y, "z": -p.z})
}

fn identity_at(p: Vec3) -> Value {
    json!({"position": point(p), "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}})
}

/// A `foxglove.SceneEntity` with every primitive list present (the schema
/// requires them all); `fill` sets the ones it uses.
fn entity(
    t_ns: u64,
    id: &str,
    metadata: &[(&str, String)],
    fill: impl FnOnce(&mut serde_json::Map<String, Value>),
) -> Value {
    let mut e = serde_json::Map::new();
    e.insert("timestamp".into(), stamp(t_ns));
    e.insert("frame_id".into(), FRAME.into());
    e.insert("id".into(), id.into());
    e.insert("lifetime".into(), json!({"sec": 0, "nsec": 0}));
    e.insert("frame_locked".into(), false.into());
    e.insert(
        "metadata".into(),
        metadata.iter().map(|(k, v)| json!({"key": k, "value": v})).collect(),
    );
    for k in [
        "arrows",
        "cubes",
        "spheres",
        "cylinders",
        "lines",
        "triangles",
        "texts",
        "models",
    ] {
        e.insert(k.into(), json!([]));
    }
    fill(&mut e);
    Value::Object(e)
}

fn scene(entities: Vec<Value>) -> Value {
    json!({"deletions": [], "entities": entities})
}

/// `foxglove.LinePrimitive` through `points` (type 0: strip, 1: loop).
fn line(kind: u8, points: impl IntoIterator<Item = Vec3>, thickness: f64, c: Value) -> Value {
    json!({
        "type": kind,
        "pose": identity_at(Vec3::default()),
        "thickness": thickness,
        "scale_invariant": true,
        "points": points.into_iter().map(point).collect::<Vec<_>>(),
        "color": c,
        "colors": [],
        "indices": [],
    })
}

/// The chart's water mask as a `foxglove.Grid` with RGBA cells (water
/// blue, land sand) and a `water` field (1 water, 0 land) to colour by.
fn chart_grid(map: &dyn WaterMap) -> Value {
    let (w, h) = (map.width_m(), map.height_m());
    let cell = w.max(h) / CHART_CELLS;
    let (cols, rows) = ((w / cell).ceil() as usize, (h / cell).ceil() as usize);
    let mut data = Vec::with_capacity(cols * rows * 5);
    for r in 0..rows {
        let y = ((r as f64 + 0.5) * cell).min(h - 1e-9);
        for c in 0..cols {
            let x = ((c as f64 + 0.5) * cell).min(w - 1e-9);
            let water = map.is_water(x, y);
            let rgba: [u8; 4] = if water {
                [70, 130, 200, 255]
            } else {
                [222, 205, 160, 255]
            };
            data.extend_from_slice(&rgba);
            data.push(u8::from(water));
        }
    }
    let field = |name: &str, offset: u8| json!({"name": name, "offset": offset, "type": 1});
    json!({
        "timestamp": stamp(0),
        "frame_id": FRAME,
        "pose": identity_at(Vec3::default()),
        "column_count": cols,
        "cell_size": {"x": cell, "y": cell},
        "row_stride": cols * 5,
        "cell_stride": 5,
        "fields": [field("red", 0), field("green", 1), field("blue", 2), field("alpha", 3), field("water", 4)],
        "data": base64::engine::general_purpose::STANDARD.encode(&data),
    })
}

/// The waypoints at `t_ns` as spheres and labels: start green, goal red,
/// dynamic orange, static grey.
fn waypoints_scene(t_ns: u64, world: &World, epoch: u64) -> Value {
    let size = world.width_m().max(world.height_m()) / 120.0;
    let (start, goal) = (world.start(), world.goal());
    let pos = world.positions();
    entity(t_ns, "waypoints", &[("epoch", epoch.to_string())], |e| {
        let spheres = (0..world.n())
            .map(|i| {
                let c = if i == start {
                    colour(0.1, 0.7, 0.2, 1.0)
                } else if i == goal {
                    colour(0.85, 0.1, 0.1, 1.0)
                } else if world.is_dynamic(i) {
                    colour(0.95, 0.55, 0.1, 1.0)
                } else {
                    colour(0.35, 0.35, 0.35, 1.0)
                };
                json!({"pose": identity_at(pos[i]), "size": {"x": size, "y": size, "z": size}, "color": c})
            })
            .collect();
        let texts = (0..world.n())
            .map(|i| {
                let at = Vec3 {
                    z: pos[i].z - size,
                    ..pos[i]
                };
                json!({
                    "pose": identity_at(at), "billboard": true, "font_size": 12.0,
                    "scale_invariant": true, "color": colour(0.0, 0.0, 0.0, 1.0), "text": i.to_string(),
                })
            })
            .collect();
        e.insert("spheres".into(), Value::Array(spheres));
        e.insert("texts".into(), Value::Array(texts));
    })
}

/// Each dynamic waypoint's bound: the rectangle its reported position stays in.
fn bounds_scene(world: &World) -> Value {
    let (nominal, bound) = (world.nominal_positions(), world.bounds());
    let lines = world
        .dynamic_nodes()
        .iter()
        .map(|i| {
            let (c, b) = (nominal[i], bound[i]);
            let corner = |sx: f64, sy: f64| Vec3 {
                x: c.x + sx * b.x,
                y: c.y + sy * b.y,
                z: c.z,
            };
            let ring = [
                corner(-1.0, -1.0),
                corner(1.0, -1.0),
                corner(1.0, 1.0),
                corner(-1.0, 1.0),
            ];
            line(1, ring, 1.5, colour(0.95, 0.55, 0.1, 0.8))
        })
        .collect();
    scene(vec![entity(0, "bounds", &[], |e| {
        e.insert("lines".into(), Value::Array(lines));
    })])
}

/// A JSON Schema (draft 2020-12 subset) naming `title` with these
/// top-level properties; Foxglove picks the renderer by the schema name.
fn schema(title: &str, props: &[(&str, &str)]) -> Vec<u8> {
    let properties: serde_json::Map<String, Value> = props
        .iter()
        .map(|(k, t)| ((*k).to_string(), json!({ "type": t })))
        .collect();
    let keys: Vec<&str> = props.iter().map(|(k, _)| *k).collect();
    json!({"title": title, "type": "object", "properties": properties, "required": keys})
        .to_string()
        .into_bytes()
}

/// The top-level properties of `foxglove.SceneUpdate`.
const SCENE_PROPS: &[(&str, &str)] = &[("deletions", "array"), ("entities", "array")];
/// The top-level properties of `foxglove.GeoJSON`.
const GEOJSON_PROPS: &[(&str, &str)] = &[("geojson", "string")];

/// The channels of a mission file (`shore.mcap` uses the same ones).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Topic {
    /// `chart`: the water mask (`foxglove.Grid`).
    Chart,
    /// `waypoints/bounds`: the drift bounds (`foxglove.SceneUpdate`).
    Bounds,
    /// `waypoints`: the waypoints as reported (`foxglove.SceneUpdate`).
    Waypoints,
    /// `planner/plan`: each plan (`foxglove.SceneUpdate`).
    Plan,
    /// `vehicle/pose`: the vehicle (`foxglove.PoseInFrame`).
    Pose,
    /// `vehicle/track`: the route travelled (`foxglove.SceneUpdate`).
    Track,
    /// `events`: log lines (`foxglove.Log`).
    Events,
    /// `planner/status`: each plan's figures ([`STATUS_SCHEMA`]).
    Status,
    /// `mission/progress`: each arrival ([`PROGRESS_SCHEMA`]).
    Progress,
    /// `planner/latency`: the latency summary ([`LATENCY_SCHEMA`]).
    Latency,
    /// `vehicle/fix`: lat/lon of the vehicle (`foxglove.LocationFix`).
    Fix,
    /// `vehicle/route_geojson`: the route travelled (`foxglove.GeoJSON`).
    Route,
    /// `chart/geojson`: land and waypoints (`foxglove.GeoJSON`).
    ChartGeo,
}

impl Topic {
    /// The channel name below `/<vehicle>/`.
    pub fn name(self) -> &'static str {
        self.spec().0
    }

    /// Topic name (after `/<vehicle>/`), schema name, and the schema's
    /// top-level properties.
    fn spec(self) -> (&'static str, &'static str, &'static [(&'static str, &'static str)]) {
        match self {
            Topic::Chart => (
                "chart",
                "foxglove.Grid",
                &[
                    ("timestamp", "object"),
                    ("frame_id", "string"),
                    ("pose", "object"),
                    ("column_count", "integer"),
                    ("cell_size", "object"),
                    ("row_stride", "integer"),
                    ("cell_stride", "integer"),
                    ("fields", "array"),
                    ("data", "string"),
                ],
            ),
            Topic::Bounds => ("waypoints/bounds", "foxglove.SceneUpdate", SCENE_PROPS),
            Topic::Waypoints => ("waypoints", "foxglove.SceneUpdate", SCENE_PROPS),
            Topic::Plan => ("planner/plan", "foxglove.SceneUpdate", SCENE_PROPS),
            Topic::Track => ("vehicle/track", "foxglove.SceneUpdate", SCENE_PROPS),
            Topic::Pose => (
                "vehicle/pose",
                "foxglove.PoseInFrame",
                &[("timestamp", "object"), ("frame_id", "string"), ("pose", "object")],
            ),
            Topic::Events => (
                "events",
                "foxglove.Log",
                &[
                    ("timestamp", "object"),
                    ("level", "integer"),
                    ("message", "string"),
                    ("name", "string"),
                    ("file", "string"),
                    ("line", "integer"),
                ],
            ),
            Topic::Status => (
                "planner/status",
                STATUS_SCHEMA,
                &[
                    ("t", "number"),
                    ("replan", "integer"),
                    ("trigger", "string"),
                    ("budget_s", "number"),
                    ("route_len", "integer"),
                    ("time_s", "number"),
                    ("weight", "number"),
                    ("distance_m", "number"),
                    ("feasible", "boolean"),
                    ("iterations", "integer"),
                    ("deadline_cut", "boolean"),
                    ("epoch", "integer"),
                ],
            ),
            Topic::Progress => (
                "mission/progress",
                PROGRESS_SCHEMA,
                &[
                    ("t", "number"),
                    ("node", "integer"),
                    ("tasks", "integer"),
                    ("weight", "number"),
                    ("time_left_s", "number"),
                ],
            ),
            Topic::Latency => (
                "planner/latency",
                LATENCY_SCHEMA,
                &[
                    ("plans", "integer"),
                    ("p50_us", "integer"),
                    ("p99_us", "integer"),
                    ("max_us", "integer"),
                ],
            ),
            Topic::Fix => (
                "vehicle/fix",
                "foxglove.LocationFix",
                &[
                    ("timestamp", "object"),
                    ("frame_id", "string"),
                    ("latitude", "number"),
                    ("longitude", "number"),
                    ("altitude", "number"),
                    ("position_covariance", "array"),
                    ("position_covariance_type", "integer"),
                ],
            ),
            Topic::Route => ("vehicle/route_geojson", "foxglove.GeoJSON", GEOJSON_PROPS),
            Topic::ChartGeo => ("chart/geojson", "foxglove.GeoJSON", GEOJSON_PROPS),
        }
    }
}

/// One pose of the vehicle: mission time, position, heading (rad from east).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseAt {
    t: f64,
    p: Vec3,
    yaw: f64,
}

/// The vehicle's poses, built from its journal event by event: where it
/// started, each arrival, and each departure after a task (the journal
/// records no positions in between). The heading points at the next
/// position.
#[derive(Default)]
pub struct PoseTrack {
    track: Vec<(f64, Vec3)>,
}

impl PoseTrack {
    /// Takes the next journal event.
    pub fn push(&mut self, e: &JournalEvent, world: &World) {
        match *e {
            JournalEvent::Start {
                t,
                node,
                resumed: false,
            } => {
                if let Some(&p) = world.positions().get(node) {
                    self.track.push((t, p));
                }
            }
            JournalEvent::Arrival { t, pos, .. } => self.track.push((
                t,
                Vec3 {
                    x: pos[0],
                    y: pos[1],
                    z: pos[2],
                },
            )),
            JournalEvent::Task { t, .. } | JournalEvent::Hold { t, .. } | JournalEvent::End { t, .. } => {
                if let Some(&(_, p)) = self.track.last() {
                    self.track.push((t, p));
                }
            }
            JournalEvent::Start { .. } | JournalEvent::Plan { .. } => {}
        }
    }

    /// The poses, headings filled in.
    pub fn finish(self) -> Vec<PoseAt> {
        let track = self.track;
        let mut out = Vec::with_capacity(track.len());
        let mut yaw = 0.0;
        for (k, &(t, p)) in track.iter().enumerate() {
            if let Some(&(_, q)) = track[k + 1..].iter().find(|(_, q)| (q.x, q.y) != (p.x, p.y)) {
                yaw = (q.y - p.y).atan2(q.x - p.x);
            }
            out.push(PoseAt { t, p, yaw });
        }
        out
    }
}

fn pose_json(p: Vec3, yaw: f64) -> Value {
    let (s, c) = (yaw / 2.0).sin_cos();
    json!({"position": point(p), "orientation": {"x": 0.0, "y": 0.0, "z": s, "w": c}})
}

/// A [`Topic::Pose`] message: the vehicle at `p` heading `yaw` (rad from east).
pub fn pose_message(t_ns: u64, p: Vec3, yaw: f64) -> Value {
    json!({"timestamp": stamp(t_ns), "frame_id": FRAME, "pose": pose_json(p, yaw)})
}

/// A [`Topic::Plan`] message: plan `replan` through `pts` (a mission's first
/// plan blue, later ones purple).
pub fn plan_message(t_ns: u64, replan: u64, route: &[usize], pts: &[Vec3], first: bool) -> Value {
    let ids = route.iter().map(usize::to_string).collect::<Vec<_>>().join(" ");
    let meta = [("replan", replan.to_string()), ("route", ids)];
    let c = if first {
        colour(0.2, 0.3, 0.9, 1.0)
    } else {
        colour(0.6, 0.1, 0.7, 1.0)
    };
    scene(vec![lines_entity(t_ns, "plan", &meta, line_json(pts, c))])
}

/// The figures of one plan on [`Topic::Status`].
#[derive(Clone, Debug, PartialEq)]
pub struct PlanFigures {
    /// Mission time of its trigger, s.
    pub t: f64,
    /// Re-plan counter.
    pub replan: u64,
    /// Trigger name.
    pub trigger: String,
    /// Budget planned for, s.
    pub budget_s: f64,
    /// Waypoints in the route.
    pub route_len: usize,
    /// Predicted time, s.
    pub time_s: f64,
    /// Predicted weight.
    pub weight: f64,
    /// Predicted distance, m.
    pub distance_m: f64,
    /// Fits the budget.
    pub feasible: bool,
    /// Solver iterations.
    pub iterations: u64,
    /// Cut by the deadline.
    pub deadline_cut: bool,
    /// Snapshot epoch.
    pub epoch: u64,
}

impl PlanFigures {
    /// The [`Topic::Status`] message.
    pub fn message(&self) -> Value {
        json!({
            "t": self.t, "replan": self.replan, "trigger": self.trigger, "budget_s": self.budget_s,
            "route_len": self.route_len, "time_s": self.time_s,
            "weight": self.weight, "distance_m": self.distance_m,
            "feasible": self.feasible, "iterations": self.iterations,
            "deadline_cut": self.deadline_cut, "epoch": self.epoch,
        })
    }
}

/// A [`Topic::Progress`] message: an arrival.
pub fn progress_message(t: f64, node: u64, tasks: u64, weight: f64, time_left_s: f64) -> Value {
    json!({"t": t, "node": node, "tasks": tasks, "weight": weight, "time_left_s": time_left_s})
}

/// A [`Topic::Events`] message: line `line` of `file` from `name`
/// (`foxglove.Log` levels: 2 info, 3 warning, 4 error).
pub fn log_message(t_ns: u64, level: u8, text: &str, name: &str, file: &str, line: usize) -> Value {
    json!({
        "timestamp": stamp(t_ns), "level": level, "message": text,
        "name": name, "file": file, "line": line,
    })
}

/// Mission time, s, as MCAP log time, ns.
pub fn log_time_ns(t: f64) -> u64 {
    ns(t)
}

fn field<'v>(v: &'v Value, key: &str, line: usize) -> Result<&'v Value, McapLogError> {
    v.get(key).ok_or_else(|| McapLogError::BadLogLine {
        line,
        detail: format!("no `{key}`"),
    })
}

fn num(v: &Value, key: &str, line: usize) -> Result<f64, McapLogError> {
    field(v, key, line)?.as_f64().ok_or_else(|| McapLogError::BadLogLine {
        line,
        detail: format!("`{key}` is not a number"),
    })
}

/// `foxglove.Log` level of a log line: problems are warnings, an aborted
/// mission an error.
fn level(v: &Value) -> u8 {
    let (info, warning, error) = (2, 3, 4);
    match v["event"].as_str() {
        Some("plan") if v["feasible"] == false || v["deadline_cut"] == true => warning,
        Some("finished") if v["outcome"] == "aborted" => error,
        Some("finished") if v["outcome"] != "goal_reached" => warning,
        _ => info,
    }
}

/// Where the messages go, one at a time, in log-time order.
trait Sink {
    fn put(&mut self, t_ns: u64, topic: Topic, data: &Value) -> Result<(), McapLogError>;
}

/// A `foxglove.GeoJSON` message of `doc`.
fn geojson_msg(doc: &impl std::fmt::Display) -> Value {
    json!({"geojson": doc.to_string()})
}

/// The chart in lon/lat: the land polygons of a vector chart (a raster
/// chart has none to give; its water shows as the grid) and the waypoints
/// at their nominal positions, named as in the mission file.
fn chart_geojson(world: &MissionWorld, frame: &LocalFrame) -> Value {
    let lon_lat = |x: f64, y: f64| frame.to_geodetic(x, y).map(|p| json!([p.lon, p.lat])).ok();
    let mut features = Vec::new();
    if let Water::Land(land) = world.map() {
        for rings in land.rings() {
            let rings: Vec<Vec<Value>> = rings
                .iter()
                .map(|r| r.iter().filter_map(|&(x, y)| lon_lat(x, y)).collect())
                .collect();
            features.push(json!({"type": "Feature", "properties": {"name": "land"},
                "geometry": {"type": "Polygon", "coordinates": rings}}));
        }
    }
    let (wm, hm) = (world.map().width_m(), world.map().height_m());
    let extent: Vec<Value> = [(0.0, 0.0), (wm, 0.0), (wm, hm), (0.0, hm), (0.0, 0.0)]
        .iter()
        .filter_map(|&(x, y)| lon_lat(x, y))
        .collect();
    features.push(json!({"type": "Feature", "properties": {"name": "chart extent"},
        "geometry": {"type": "LineString", "coordinates": extent}}));
    let w = world.world();
    for (i, info) in world.waypoints().iter().enumerate() {
        let p = w.nominal_positions()[i];
        if let Some(at) = lon_lat(p.x, p.y) {
            features.push(json!({"type": "Feature",
                "properties": {"name": info.name, "id": i, "role": info.role.as_str(), "dynamic": w.is_dynamic(i)},
                "geometry": {"type": "Point", "coordinates": at}}));
        }
    }
    geojson_msg(&json!({"type": "FeatureCollection", "features": features}))
}

/// Emits the vehicle's poses in time order, interleaved with the log.
struct PoseStream<'r> {
    rec: &'r MissionRecord<'r>,
    next: usize,
    travelled: Vec<Vec3>,
    /// Latest log time written, ns.
    end: u64,
}

impl PoseStream<'_> {
    /// Writes every pose before `t_ns` (a log line at the same time goes
    /// first, as it was recorded first).
    fn until(&mut self, t_ns: u64, sink: &mut impl Sink) -> Result<(), McapLogError> {
        let rec = self.rec;
        while let Some(p) = rec.poses.get(self.next).filter(|p| ns(p.t) < t_ns) {
            let t_ns = ns(p.t);
            self.end = self.end.max(t_ns);
            self.next += 1;
            sink.put(t_ns, Topic::Pose, &pose_message(t_ns, p.p, p.yaw))?;
            self.travelled.push(p.p);
            let travelled = lines_entity(
                t_ns,
                "travelled",
                &[],
                line_json(&self.travelled, colour(0.1, 0.6, 0.2, 1.0)),
            );
            sink.put(t_ns, Topic::Track, &scene(vec![travelled]))?;
            let Some(frame) = rec.geo else { continue };
            if let Ok(ll) = frame.to_geodetic(p.p.x, p.p.y) {
                sink.put(
                    t_ns,
                    Topic::Fix,
                    &json!({
                        "timestamp": stamp(t_ns), "frame_id": FRAME, "latitude": ll.lat, "longitude": ll.lon,
                        "altitude": -p.p.z, "position_covariance": vec![0.0; 9], "position_covariance_type": 0,
                    }),
                )?;
            }
            if self.next == rec.poses.len() {
                let route = super::route_geojson::route_geojson(rec.world, rec.visits);
                sink.put(t_ns, Topic::Route, &geojson_msg(&route))?;
            }
        }
        Ok(())
    }
}

/// A `foxglove.SceneEntity` holding one line.
fn lines_entity(t_ns: u64, id: &str, metadata: &[(&str, String)], line: Value) -> Value {
    entity(t_ns, id, metadata, |e| {
        e.insert("lines".into(), json!([line]));
    })
}

/// Every message of the mission, in log-time order, to `sink`: the world
/// first, then each `mission.log` line as it is read, the vehicle's poses
/// merged in by time, the latency summary last.
fn emit(rec: &MissionRecord, log: impl BufRead, sink: &mut impl Sink) -> Result<(), McapLogError> {
    let mut world = rec.world.world().clone();
    let map = rec.world.map();
    sink.put(0, Topic::Chart, &chart_grid(map))?;
    sink.put(0, Topic::Bounds, &bounds_scene(&world))?;
    sink.put(0, Topic::Waypoints, &scene(vec![waypoints_scene(0, &world, 0)]))?;
    if let Some(frame) = rec.geo {
        sink.put(0, Topic::ChartGeo, &chart_geojson(rec.world, frame))?;
    }
    let mut poses = PoseStream {
        rec,
        next: 0,
        travelled: Vec::new(),
        end: 0,
    };
    let mut epoch = 0;
    let mut pending_trigger: Option<(String, f64)> = None;
    let mut plans = 0u64;
    for (k, text) in log.lines().enumerate() {
        let line = k + 1;
        let text = text?;
        if text.trim().is_empty() {
            continue;
        }
        let v: Value = serde_json::from_str(&text).map_err(|e| McapLogError::BadLogLine {
            line,
            detail: e.to_string(),
        })?;
        let t = num(&v, "t", line)?;
        let t_ns = ns(t);
        poses.until(t_ns, sink)?;
        poses.end = poses.end.max(t_ns);
        sink.put(
            t_ns,
            Topic::Events,
            &log_message(t_ns, level(&v), &text, "planner", "mission.log", line),
        )?;
        match field(&v, "event", line)?.as_str() {
            Some("sensor_update") => {
                let e = num(&v, "epoch", line)? as u64;
                if e > epoch {
                    epoch = e;
                    let mut rng = world.redraw_rng(epoch);
                    world.redraw_dynamic(&mut rng, map);
                    sink.put(
                        t_ns,
                        Topic::Waypoints,
                        &scene(vec![waypoints_scene(t_ns, &world, epoch)]),
                    )?;
                }
            }
            Some("trigger") => {
                let kind = field(&v, "kind", line)?.as_str().unwrap_or_default().to_string();
                pending_trigger = Some((kind, num(&v, "budget_s", line)?));
            }
            Some("plan") => {
                let route: Vec<usize> = field(&v, "route", line)?
                    .as_array()
                    .map(|r| r.iter().filter_map(|n| n.as_u64().map(|n| n as usize)).collect())
                    .unwrap_or_default();
                let pos = world.positions();
                if let Some(bad) = route.iter().find(|&&n| n >= pos.len()) {
                    return Err(McapLogError::BadLogLine {
                        line,
                        detail: format!("plan visits waypoint {bad}, the world has {}", pos.len()),
                    });
                }
                let replan = num(&v, "replan", line)? as u64;
                let pts: Vec<Vec3> = route.iter().map(|&n| pos[n]).collect();
                sink.put(t_ns, Topic::Plan, &plan_message(t_ns, replan, &route, &pts, plans == 0))?;
                let (trigger, budget_s) = pending_trigger.take().unwrap_or_default();
                let figures = PlanFigures {
                    t,
                    replan,
                    trigger,
                    budget_s,
                    route_len: route.len(),
                    time_s: num(&v, "time_s", line)?,
                    weight: num(&v, "weight", line)?,
                    distance_m: num(&v, "distance_m", line)?,
                    feasible: v["feasible"] == true,
                    iterations: num(&v, "iterations", line)? as u64,
                    deadline_cut: v["deadline_cut"] == true,
                    epoch,
                };
                sink.put(t_ns, Topic::Status, &figures.message())?;
                plans += 1;
            }
            Some("arrival") => sink.put(
                t_ns,
                Topic::Progress,
                &progress_message(
                    t,
                    num(&v, "node", line)? as u64,
                    num(&v, "tasks", line)? as u64,
                    num(&v, "weight", line)?,
                    num(&v, "time_left_s", line)?,
                ),
            )?,
            Some("finished" | "command") => {}
            other => {
                return Err(McapLogError::BadLogLine {
                    line,
                    detail: format!("unknown event {other:?}"),
                });
            }
        }
    }
    poses.until(u64::MAX, sink)?;
    if let Some((p50, p99, max)) = rec.latency_us {
        sink.put(
            poses.end,
            Topic::Latency,
            &json!({"plans": plans, "p50_us": p50, "p99_us": p99, "max_us": max}),
        )?;
    }
    Ok(())
}

fn line_json(pts: &[Vec3], c: Value) -> Value {
    line(0, pts.iter().copied(), 3.0, c)
}

/// Writes JSON messages to MCAP channels `/<vehicle>/<topic>` as they come:
/// a channel is declared with its schema when its first message arrives (or
/// up front), nothing of the run is held but the writer's current chunk.
pub struct ChannelWriter<W: Write + Seek> {
    writer: mcap::Writer<W>,
    vehicle: String,
    /// Channel id and last sequence number, by topic.
    channels: BTreeMap<Topic, (u16, u32)>,
    buf: Vec<u8>,
}

impl<W: Write + Seek> ChannelWriter<W> {
    /// A writer on `w` with `topics` declared now, in that order (the rest
    /// when first written).
    pub fn new(w: W, vehicle: &str, topics: &[Topic]) -> Result<Self, McapLogError> {
        let mut cw = Self {
            writer: mcap::WriteOptions::new().compression(None).profile("").create(w)?,
            vehicle: vehicle.to_string(),
            channels: BTreeMap::new(),
            buf: Vec::new(),
        };
        for &t in topics {
            cw.channel(t)?;
        }
        Ok(cw)
    }

    fn channel(&mut self, topic: Topic) -> Result<&mut (u16, u32), McapLogError> {
        let Self {
            writer,
            vehicle,
            channels,
            ..
        } = self;
        Ok(match channels.entry(topic) {
            std::collections::btree_map::Entry::Occupied(o) => o.into_mut(),
            std::collections::btree_map::Entry::Vacant(v) => {
                let (name, schema_name, props) = topic.spec();
                let schema_id = writer.add_schema(schema_name, "jsonschema", &schema(schema_name, props))?;
                let id = writer.add_channel(schema_id, &format!("/{vehicle}/{name}"), "json", &BTreeMap::new())?;
                v.insert((id, 0))
            }
        })
    }

    /// Writes `data` on `topic` at log time `t_ns`.
    pub fn write(&mut self, topic: Topic, t_ns: u64, data: &Value) -> Result<(), McapLogError> {
        let (channel_id, seq) = *self.channel(topic)?;
        self.channels.insert(topic, (channel_id, seq + 1));
        self.buf.clear();
        serde_json::to_writer(&mut self.buf, data).map_err(|e| McapLogError::Io(e.into()))?;
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: seq + 1,
            log_time: t_ns,
            publish_time: t_ns,
        };
        self.writer.write_to_known_channel(&header, &self.buf)?;
        Ok(())
    }

    /// Writes the summary and returns the sink.
    pub fn finish(mut self) -> Result<W, McapLogError> {
        self.writer.finish()?;
        Ok(self.writer.into_inner())
    }
}

impl<W: Write + Seek> Sink for ChannelWriter<W> {
    fn put(&mut self, t_ns: u64, topic: Topic, data: &Value) -> Result<(), McapLogError> {
        self.write(topic, t_ns, data)
    }
}

/// Writes the mission's MCAP file to `w`, reading `log` (the
/// `mission.log` text) line by line.
pub fn write_to<W: Write + Seek>(rec: &MissionRecord, log: impl BufRead, w: W) -> Result<W, McapLogError> {
    let mut writer = ChannelWriter::new(w, rec.vehicle, &[])?;
    emit(rec, log, &mut writer)?;
    writer.finish()
}

/// Writes `mission.mcap` at `path`, streaming: `log` (`mission.log`) is
/// read line by line and each message goes through a buffered file.
pub fn write(path: &Path, rec: &MissionRecord, log: &Path) -> Result<(), McapLogError> {
    let log = BufReader::new(File::open(log)?);
    let file = BufWriter::new(File::create(path)?);
    let mut file = write_to(rec, log, file)?;
    file.flush()?;
    Ok(())
}

/// One channel of a file read back.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelSummary {
    /// Topic name.
    pub topic: String,
    /// Schema name.
    pub schema: String,
    /// Messages on it.
    pub messages: u64,
}

/// What `planner replay` prints: a mission file read back.
#[derive(Clone, Debug, PartialEq)]
pub struct McapSummary {
    /// Channels by topic.
    pub channels: Vec<ChannelSummary>,
    /// First and last log time, s (None: no messages).
    pub span_s: Option<(f64, f64)>,
    /// Routes of the plans, in order.
    pub plans: Vec<Vec<usize>>,
    /// Last vehicle pose: x, y, z (up), m, and heading, degrees from east.
    pub final_pose: Option<(f64, f64, f64, f64)>,
    /// Last location fix: latitude, longitude, degrees (lat/lon missions).
    pub final_fix: Option<(f64, f64)>,
    /// Outcome of the `finished` event, if logged.
    pub outcome: Option<String>,
}

fn not_mission(topic: &str, what: &str) -> McapLogError {
    McapLogError::NotMission(format!("{topic}: {what}"))
}

/// Reads a mission MCAP file back (every record, so a truncated or
/// corrupted file is an error, not a short summary).
pub fn read_summary(bytes: &[u8]) -> Result<McapSummary, McapLogError> {
    // The summary section sits at the end: reading it first rejects a
    // truncated file even when its messages still parse.
    mcap::Summary::read(bytes)?.ok_or_else(|| McapLogError::NotMission("no summary section".into()))?;
    let mut channels: BTreeMap<String, ChannelSummary> = BTreeMap::new();
    let mut span: Option<(u64, u64)> = None;
    let mut plans = Vec::new();
    let mut final_pose = None;
    let mut final_fix = None;
    let mut outcome = None;
    for m in mcap::MessageStream::new(bytes)? {
        let m = m?;
        let topic = m.channel.topic.clone();
        let schema = m.channel.schema.as_ref().map(|s| s.name.clone()).unwrap_or_default();
        channels
            .entry(topic.clone())
            .or_insert_with(|| ChannelSummary {
                topic: topic.clone(),
                schema: schema.clone(),
                messages: 0,
            })
            .messages += 1;
        span = Some(span.map_or((m.log_time, m.log_time), |(a, b)| {
            (a.min(m.log_time), b.max(m.log_time))
        }));
        let data: Cow<[u8]> = m.data;
        let parse = || serde_json::from_slice::<Value>(&data).map_err(|e| not_mission(&topic, &e.to_string()));
        if topic.ends_with("/planner/plan") {
            let v = parse()?;
            let route = v["entities"][0]["metadata"]
                .as_array()
                .and_then(|kv| kv.iter().find(|p| p["key"] == "route"))
                .and_then(|p| p["value"].as_str())
                .ok_or_else(|| not_mission(&topic, "a plan without its route"))?;
            let ids: Result<Vec<usize>, _> = route.split_whitespace().map(str::parse).collect();
            plans.push(ids.map_err(|_| not_mission(&topic, "a route that is not waypoint ids"))?);
        } else if schema == "foxglove.PoseInFrame" {
            let v = parse()?;
            let (p, q) = (&v["pose"]["position"], &v["pose"]["orientation"]);
            let f = |x: &Value| {
                x.as_f64()
                    .ok_or_else(|| not_mission(&topic, "a pose that is not numbers"))
            };
            let yaw = 2.0 * f(&q["z"])?.atan2(f(&q["w"])?);
            final_pose = Some((f(&p["x"])?, f(&p["y"])?, f(&p["z"])?, yaw.to_degrees()));
        } else if schema == "foxglove.LocationFix" {
            let v = parse()?;
            match (v["latitude"].as_f64(), v["longitude"].as_f64()) {
                (Some(lat), Some(lon)) => final_fix = Some((lat, lon)),
                _ => return Err(not_mission(&topic, "a fix without latitude and longitude")),
            }
        } else if schema == "foxglove.Log" {
            let v = parse()?;
            if let Some(text) = v["message"].as_str()
                && let Ok(line) = serde_json::from_str::<Value>(text)
                && line["event"] == "finished"
            {
                outcome = line["outcome"].as_str().map(str::to_string);
            }
        }
    }
    let s = |t: u64| t as f64 / 1e9;
    Ok(McapSummary {
        channels: channels.into_values().collect(),
        span_s: span.map(|(a, b)| (s(a), s(b))),
        plans,
        final_pose,
        final_fix,
        outcome,
    })
}

impl McapSummary {
    /// The summary as `planner replay` prints it.
    pub fn render(&self) -> String {
        use std::fmt::Write as _;
        let mut o = String::new();
        let total: u64 = self.channels.iter().map(|c| c.messages).sum();
        let _ = write!(o, "{total} messages on {} channels", self.channels.len());
        if let Some((a, b)) = self.span_s {
            let _ = write!(o, ", mission time {a:.3} s to {b:.3} s");
        }
        o.push('\n');
        let width = self.channels.iter().map(|c| c.topic.len()).max().unwrap_or(0);
        for c in &self.channels {
            let _ = writeln!(o, "  {:width$}  {:22} {:>6}", c.topic, c.schema, c.messages);
        }
        let _ = write!(o, "plans: {}", self.plans.len());
        if let Some(last) = self.plans.last() {
            let ids: Vec<String> = last.iter().map(usize::to_string).collect();
            let _ = write!(o, " (last: {})", ids.join(" "));
        }
        o.push('\n');
        match self.final_pose {
            Some((x, y, z, h)) => {
                let _ = writeln!(
                    o,
                    "final pose: x {x:.1} m, y {y:.1} m, z {z:.1} m, heading {h:.1}° from east"
                );
            }
            None => o.push_str("final pose: none\n"),
        }
        if let Some((lat, lon)) = self.final_fix {
            let (ns, ew) = (if lat < 0.0 { 'S' } else { 'N' }, if lon < 0.0 { 'W' } else { 'E' });
            let _ = writeln!(o, "final fix: {:.5}° {ns}, {:.5}° {ew}", lat.abs(), lon.abs());
        }
        let _ = writeln!(o, "outcome: {}", self.outcome.as_deref().unwrap_or("not logged"));
        o
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_messages::journal::JournalSummary;
    use auv_messages::msg::Outcome;
    use auv_world::load::{ScenarioArgs, load_world};
    use std::io::Cursor;

    fn world() -> MissionWorld {
        load_world(&ScenarioArgs {
            seed: Some(3),
            nodes: Some(10),
            ..Default::default()
        })
        .unwrap()
    }

    /// A short mission's records: a plan, a sensor update with a re-plan,
    /// an arrival, the end.
    fn records(w: &MissionWorld) -> (String, JournalSummary) {
        let p = w.world().positions();
        let log = [
            r#"{"event":"trigger","t":0.0,"kind":"initial","from":0,"budget_s":3000.0}"#,
            r#"{"event":"plan","t":0.0,"replan":0,"route":[0,3,9],"time_s":900.0,"weight":5.0,"distance_m":800.0,"feasible":true,"iterations":100,"deadline_cut":false}"#,
            r#"{"event":"sensor_update","t":60.0,"epoch":1,"edges":20,"replan":"time_changed"}"#,
            r#"{"event":"trigger","t":60.0,"kind":"time_changed","from":3,"budget_s":2940.0}"#,
            r#"{"event":"plan","t":60.0,"replan":1,"route":[3,9],"time_s":700.0,"weight":4.0,"distance_m":600.0,"feasible":false,"iterations":100,"deadline_cut":false}"#,
            r#"{"event":"arrival","t":120.5,"node":3,"x":1.0,"y":2.0,"tasks":1,"weight":2.0,"time_left_s":2879.5}"#,
            r#"{"event":"finished","t":400.0,"outcome":"goal_reached"}"#,
        ]
        .join("\n")
            + "\n";
        let journal = JournalSummary {
            events: vec![
                JournalEvent::Start {
                    t: 0.0,
                    node: 0,
                    resumed: false,
                },
                JournalEvent::Arrival {
                    t: 120.5,
                    node: 3,
                    pos: [p[3].x, p[3].y, p[3].z],
                    distance_m: 100.0,
                    task_s: 10.0,
                    task_weight: 2.0,
                },
                JournalEvent::Task {
                    t: 130.5,
                    node: 3,
                    weight: 2.0,
                },
                JournalEvent::Arrival {
                    t: 400.0,
                    node: 9,
                    pos: [p[9].x, p[9].y, p[9].z],
                    distance_m: 300.0,
                    task_s: 0.0,
                    task_weight: 0.0,
                },
                JournalEvent::End {
                    t: 400.0,
                    outcome: Outcome::GoalReached,
                },
            ],
        };
        (log, journal)
    }

    /// The record of a reproducible mission of vehicle `auv1` in local metres.
    fn record<'a>(w: &'a MissionWorld, poses: &'a [PoseAt], visits: &'a [Visit]) -> MissionRecord<'a> {
        MissionRecord {
            world: w,
            poses,
            visits,
            vehicle: "auv1",
            latency_us: None,
            geo: None,
        }
    }

    fn bytes(rec: &MissionRecord, log: &str) -> Vec<u8> {
        write_to(rec, log.as_bytes(), Cursor::new(Vec::new()))
            .unwrap()
            .into_inner()
    }

    fn poses(journal: &JournalSummary, world: &World) -> Vec<PoseAt> {
        let mut track = PoseTrack::default();
        for e in &journal.events {
            track.push(e, world);
        }
        track.finish()
    }

    /// The start and each arrival, as the mission's trace finds them.
    fn visits(journal: &JournalSummary) -> Vec<Visit> {
        journal
            .events
            .iter()
            .filter_map(|e| match *e {
                JournalEvent::Start { t, node, .. } => Some(Visit {
                    t,
                    node,
                    at: (0.0, 0.0),
                }),
                JournalEvent::Arrival { t, node, pos, .. } => Some(Visit {
                    t,
                    node,
                    at: (pos[0], pos[1]),
                }),
                _ => None,
            })
            .collect()
    }

    /// Every message of `rec`, in the order they would be written.
    fn messages(rec: &MissionRecord, log: &str) -> Result<Vec<Pending>, McapLogError> {
        let mut out = Vec::new();
        emit(rec, log.as_bytes(), &mut out)?;
        Ok(out)
    }

    struct Pending {
        t_ns: u64,
        topic: Topic,
        data: Value,
    }

    impl Sink for Vec<Pending> {
        fn put(&mut self, t_ns: u64, topic: Topic, data: &Value) -> Result<(), McapLogError> {
            self.push(Pending {
                t_ns,
                topic,
                data: data.clone(),
            });
            Ok(())
        }
    }

    #[test]
    fn the_file_reads_back_with_every_channel_and_the_same_plans_and_pose() {
        let w = world();
        let (log, journal) = records(&w);
        let (track, visits) = (poses(&journal, w.world()), visits(&journal));
        let rec = MissionRecord {
            vehicle: "auv7",
            ..record(&w, &track, &visits)
        };
        let s = read_summary(&bytes(&rec, &log)).unwrap();
        let topics: Vec<&str> = s.channels.iter().map(|c| c.topic.as_str()).collect();
        for t in [
            "/auv7/chart",
            "/auv7/waypoints",
            "/auv7/waypoints/bounds",
            "/auv7/planner/plan",
            "/auv7/vehicle/pose",
            "/auv7/events",
            "/auv7/planner/status",
            "/auv7/mission/progress",
        ] {
            assert!(topics.contains(&t), "{t} missing from {topics:?}");
        }
        assert!(!topics.iter().any(|t| t.ends_with("latency") || t.ends_with("fix")));
        let count = |t: &str| s.channels.iter().find(|c| c.topic == t).map_or(0, |c| c.messages);
        assert_eq!(count("/auv7/events"), 7, "one Log per mission.log line");
        assert_eq!(count("/auv7/waypoints"), 2, "the initial positions and epoch 1");
        // Start, arrival, departure, arrival at the goal, end.
        assert_eq!(count("/auv7/vehicle/pose"), 5);
        assert_eq!(s.plans, vec![vec![0, 3, 9], vec![3, 9]]);
        assert_eq!(s.outcome.as_deref(), Some("goal_reached"));
        assert_eq!(s.span_s, Some((0.0, 400.0)));
        let p9 = w.world().positions()[9];
        let (x, y, z, _) = s.final_pose.unwrap();
        assert_eq!((x, y, z), (p9.x, p9.y, -p9.z));
        let schema_of = |t: &str| s.channels.iter().find(|c| c.topic == t).map(|c| c.schema.clone());
        assert_eq!(schema_of("/auv7/chart").as_deref(), Some("foxglove.Grid"));
        assert_eq!(schema_of("/auv7/vehicle/pose").as_deref(), Some("foxglove.PoseInFrame"));
        assert_eq!(schema_of("/auv7/planner/status").as_deref(), Some(STATUS_SCHEMA));
    }

    #[test]
    fn the_same_records_give_the_same_bytes() {
        let w = world();
        let (log, journal) = records(&w);
        let (track, visits) = (poses(&journal, w.world()), visits(&journal));
        let rec = record(&w, &track, &visits);
        assert_eq!(bytes(&rec, &log), bytes(&rec, &log));
    }

    #[test]
    fn messages_are_in_log_time_order_and_poses_head_for_the_next_point() {
        let w = world();
        let (log, journal) = records(&w);
        let (track, visits) = (poses(&journal, w.world()), visits(&journal));
        let rec = record(&w, &track, &visits);
        let msgs = messages(&rec, &log).unwrap();
        assert!(msgs.windows(2).all(|m| m[0].t_ns <= m[1].t_ns));
        let (a, b) = (track[0].p, track[1].p);
        assert!((track[0].yaw - (b.y - a.y).atan2(b.x - a.x)).abs() < 1e-12);
        // The last pose keeps the heading it arrived with.
        assert_eq!(track[track.len() - 1].yaw, track[track.len() - 2].yaw);
    }

    #[test]
    fn the_chart_grid_covers_the_chart_and_marks_water() {
        let w = world();
        let g = chart_grid(w.map());
        let data = base64::engine::general_purpose::STANDARD
            .decode(g["data"].as_str().unwrap())
            .unwrap();
        let cols = g["column_count"].as_u64().unwrap() as usize;
        let cell = g["cell_size"]["x"].as_f64().unwrap();
        assert_eq!(data.len() % (cols * 5), 0);
        let rows = data.len() / (cols * 5);
        assert!(cols as f64 * cell >= w.map().width_m() && rows as f64 * cell >= w.map().height_m());
        let water = data.chunks(5).filter(|c| c[4] == 1).count();
        assert!(water > 0 && water < cols * rows, "a chart has both water and land");
    }

    #[test]
    fn a_geographic_frame_adds_location_fixes_and_the_chart_and_route_as_geojson() {
        let w = world();
        let frame = w.frame().expect("the embedded chart has an origin");
        let (log, journal) = records(&w);
        let (track, visits) = (poses(&journal, w.world()), visits(&journal));
        let rec = MissionRecord {
            latency_us: Some((10, 20, 30)),
            geo: Some(frame),
            ..record(&w, &track, &visits)
        };
        let msgs = messages(&rec, &log).unwrap();
        assert!(msgs.windows(2).all(|m| m[0].t_ns <= m[1].t_ns));
        let fixes: Vec<&Pending> = msgs.iter().filter(|m| m.topic == Topic::Fix).collect();
        assert_eq!(fixes.len(), track.len());
        // Each fix is its pose converted by the frame, independently of the writer.
        for (f, p) in fixes.iter().zip(&track) {
            let ll = frame.to_geodetic(p.p.x, p.p.y).unwrap();
            assert_eq!(
                (f.data["latitude"].as_f64(), f.data["longitude"].as_f64()),
                (Some(ll.lat), Some(ll.lon))
            );
            assert_eq!(f.t_ns, ns(p.t));
        }
        let route: Vec<&Pending> = msgs.iter().filter(|m| m.topic == Topic::Route).collect();
        assert_eq!(route.len(), 1, "the route once, when it is complete");
        let gj: Value = serde_json::from_str(route[0].data["geojson"].as_str().unwrap()).unwrap();
        let line = &gj["features"][0]["geometry"];
        assert_eq!(line["type"], "LineString");
        assert_eq!(line["coordinates"].as_array().unwrap().len(), visits.len());
        let chart: Vec<&Pending> = msgs.iter().filter(|m| m.topic == Topic::ChartGeo).collect();
        assert_eq!((chart.len(), chart[0].t_ns), (1, 0));
        let gj: Value = serde_json::from_str(chart[0].data["geojson"].as_str().unwrap()).unwrap();
        let points = gj["features"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|f| f["geometry"]["type"] == "Point")
            .count();
        assert_eq!(points, w.world().n(), "every waypoint on the map");
        let summary = read_summary(&bytes(&rec, &log)).unwrap();
        let last = frame
            .to_geodetic(track[track.len() - 1].p.x, track[track.len() - 1].p.y)
            .unwrap();
        assert_eq!(summary.final_fix, Some((last.lat, last.lon)));
        assert!(summary.render().contains("final fix: "), "{}", summary.render());
        let lat = msgs.iter().find(|m| m.topic == Topic::Latency).unwrap();
        assert_eq!(lat.data["p99_us"], 20);
        assert_eq!(lat.data["plans"], 2);
        assert_eq!(lat.t_ns, msgs.iter().map(|m| m.t_ns).max().unwrap());
    }

    #[test]
    fn a_bad_log_line_is_named() {
        let w = world();
        let log = "{\"event\":\"plan\",\"t\":1.0,\"replan\":0,\"route\":[0,999]}\n";
        let rec = record(&w, &[], &[]);
        let e = write_to(&rec, log.as_bytes(), Cursor::new(Vec::new()))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("mission.log line 1: plan visits waypoint 999"), "{e}");
        assert!(
            write_to(&rec, "not json\n".as_bytes(), Cursor::new(Vec::new()))
                .unwrap_err()
                .to_string()
                .starts_with("mission.log line 1:")
        );
    }

    #[test]
    fn truncated_and_foreign_files_are_errors() {
        let w = world();
        let (log, journal) = records(&w);
        let (track, visits) = (poses(&journal, w.world()), visits(&journal));
        let rec = record(&w, &track, &visits);
        let b = bytes(&rec, &log);
        for cut in [0, 4, b.len() / 3, b.len() - 1] {
            assert!(
                read_summary(&b[..cut]).is_err(),
                "a file cut at {cut} of {} bytes reads",
                b.len()
            );
        }
        assert!(read_summary(b"{\"not\": \"mcap\"}").is_err());
    }
}
