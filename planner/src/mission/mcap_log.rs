//! `mission.mcap`: the mission as an MCAP file that Foxglove opens with no
//! set-up, built once at the end of a run from what the mission already
//! records (the `mission.log` lines, the vehicle's journal, the world).
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
use std::io::{Cursor, Seek, Write};
use std::path::Path;

use base64::Engine;
use serde_json::{Value, json};

use auv_messages::journal::{JournalEvent, JournalSummary};
use auv_world::chart::WaterMap;
use auv_world::load::MissionWorld;
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

/// Maps chart metres to latitude and longitude. A mission with a geographic
/// reference passes one to [`MissionRecord::geo`]; the file then also holds
/// `foxglove.LocationFix` for each pose and a `foxglove.GeoJSON` of the
/// route travelled (Foxglove's Map panel).
pub trait GeoReference {
    /// (latitude, longitude) in degrees of the chart point (x east, y north), m.
    fn lat_lon(&self, x_m: f64, y_m: f64) -> (f64, f64);
}

/// What a mission recorded, the input of [`write`].
pub struct MissionRecord<'a> {
    /// The world as generated (epoch 0): chart, waypoints, bounds.
    pub world: &'a MissionWorld,
    /// The `mission.log` text (one JSON object per line).
    pub log: &'a str,
    /// The vehicle's journal.
    pub journal: &'a JournalSummary,
    /// Vehicle namespace: topics are `/<vehicle>/…`.
    pub vehicle: &'a str,
    /// Plan latency p50, p99, max, µs (wall clock: leave out for a
    /// reproducible file).
    pub latency_us: Option<(u64, u64, u64)>,
    /// Geographic reference, when the mission has one.
    pub geo: Option<&'a dyn GeoReference>,
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

/// The channels of a mission file, in the order they are declared.
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
}

impl Topic {
    /// The channel name below `/<vehicle>/`.
    pub fn name(self) -> &'static str {
        match self {
            Topic::Chart => "chart",
            Topic::Bounds => "waypoints/bounds",
            Topic::Waypoints => "waypoints",
            Topic::Plan => "planner/plan",
            Topic::Pose => "vehicle/pose",
            Topic::Track => "vehicle/track",
            Topic::Events => "events",
            Topic::Status => "planner/status",
            Topic::Progress => "mission/progress",
            Topic::Latency => "planner/latency",
            Topic::Fix => "vehicle/fix",
            Topic::Route => "vehicle/route_geojson",
        }
    }

    fn schema(self) -> Vec<u8> {
        match self {
            Topic::Chart => schema(
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
            Topic::Bounds | Topic::Waypoints | Topic::Plan | Topic::Track => {
                schema("foxglove.SceneUpdate", &[("deletions", "array"), ("entities", "array")])
            }
            Topic::Pose => schema(
                "foxglove.PoseInFrame",
                &[("timestamp", "object"), ("frame_id", "string"), ("pose", "object")],
            ),
            Topic::Events => schema(
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
            Topic::Status => schema(
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
            Topic::Progress => schema(
                PROGRESS_SCHEMA,
                &[
                    ("t", "number"),
                    ("node", "integer"),
                    ("tasks", "integer"),
                    ("weight", "number"),
                    ("time_left_s", "number"),
                ],
            ),
            Topic::Latency => schema(
                LATENCY_SCHEMA,
                &[
                    ("plans", "integer"),
                    ("p50_us", "integer"),
                    ("p99_us", "integer"),
                    ("max_us", "integer"),
                ],
            ),
            Topic::Fix => schema(
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
            Topic::Route => schema("foxglove.GeoJSON", &[("geojson", "string")]),
        }
    }

    /// The schema's title (its name in the file).
    fn schema_name(self) -> String {
        serde_json::from_slice::<Value>(&self.schema())
            .ok()
            .and_then(|v| v["title"].as_str().map(str::to_string))
            .unwrap_or_default()
    }
}

/// One pose of the vehicle: mission time, position, heading (rad from east).
#[derive(Clone, Copy, Debug, PartialEq)]
struct PoseAt {
    t: f64,
    p: Vec3,
    yaw: f64,
}

/// The vehicle's poses from its journal: where it started, each arrival,
/// and each departure after a task (the journal records no positions in
/// between). The heading points at the next position.
fn poses(journal: &JournalSummary, world: &World) -> Vec<PoseAt> {
    let mut track: Vec<(f64, Vec3)> = Vec::new();
    for e in &journal.events {
        match *e {
            JournalEvent::Start {
                t,
                node,
                resumed: false,
            } => {
                if let Some(&p) = world.positions().get(node) {
                    track.push((t, p));
                }
            }
            JournalEvent::Arrival { t, pos, .. } => track.push((
                t,
                Vec3 {
                    x: pos[0],
                    y: pos[1],
                    z: pos[2],
                },
            )),
            JournalEvent::Task { t, .. } | JournalEvent::Hold { t, .. } | JournalEvent::End { t, .. } => {
                if let Some(&(_, p)) = track.last() {
                    track.push((t, p));
                }
            }
            JournalEvent::Start { .. } | JournalEvent::Plan { .. } => {}
        }
    }
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

fn pose_json(p: Vec3, yaw: f64) -> Value {
    let (s, c) = (yaw / 2.0).sin_cos();
    json!({"position": point(p), "orientation": {"x": 0.0, "y": 0.0, "z": s, "w": c}})
}

/// A [`Topic::Pose`] message: the vehicle at `p` heading `yaw` (rad from east).
pub fn pose_message(t_ns: u64, p: Vec3, yaw: f64) -> Value {
    json!({"timestamp": stamp(t_ns), "frame_id": FRAME, "pose": pose_json(p, yaw)})
}

/// A [`Topic::Plan`] message: the plan `replan` through `pts` (the first
/// plan of a mission blue, later ones purple).
pub fn plan_message(t_ns: u64, replan: u64, route: &[usize], pts: &[Vec3], first: bool) -> Value {
    let ids = route.iter().map(usize::to_string).collect::<Vec<_>>().join(" ");
    let meta = [("replan", replan.to_string()), ("route", ids)];
    let c = if first {
        colour(0.2, 0.3, 0.9, 1.0)
    } else {
        colour(0.6, 0.1, 0.7, 1.0)
    };
    let plan = entity(t_ns, "plan", &meta, |e| {
        e.insert("lines".into(), json!([line_json(pts, c)]));
    });
    scene(vec![plan])
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

/// Writes JSON messages to MCAP channels `/<vehicle>/<topic>`, each channel
/// declared with its schema before its first message.
pub struct ChannelWriter<W: Write + Seek> {
    writer: mcap::Writer<W>,
    vehicle: String,
    ids: BTreeMap<Topic, u16>,
    sequence: BTreeMap<Topic, u32>,
}

impl<W: Write + Seek> ChannelWriter<W> {
    /// A writer on `w` with `topics` declared now, in that order (the rest
    /// when first written).
    pub fn new(w: W, vehicle: &str, topics: &[Topic]) -> Result<Self, McapLogError> {
        let writer = mcap::WriteOptions::new().compression(None).profile("").create(w)?;
        let mut cw = Self {
            writer,
            vehicle: vehicle.to_string(),
            ids: BTreeMap::new(),
            sequence: BTreeMap::new(),
        };
        for &t in topics {
            cw.channel(t)?;
        }
        Ok(cw)
    }

    fn channel(&mut self, topic: Topic) -> Result<u16, McapLogError> {
        if let Some(&id) = self.ids.get(&topic) {
            return Ok(id);
        }
        let schema_id = self
            .writer
            .add_schema(&topic.schema_name(), "jsonschema", &topic.schema())?;
        let name = format!("/{}/{}", self.vehicle, topic.name());
        let id = self.writer.add_channel(schema_id, &name, "json", &BTreeMap::new())?;
        self.ids.insert(topic, id);
        Ok(id)
    }

    /// Writes `data` on `topic` at log time `t_ns`.
    pub fn write(&mut self, topic: Topic, t_ns: u64, data: &Value) -> Result<(), McapLogError> {
        let channel_id = self.channel(topic)?;
        let seq = self.sequence.entry(topic).or_insert(0);
        *seq += 1;
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: *seq,
            log_time: t_ns,
            publish_time: t_ns,
        };
        self.writer
            .write_to_known_channel(&header, data.to_string().as_bytes())?;
        Ok(())
    }

    /// Writes the summary and returns the sink.
    pub fn finish(mut self) -> Result<W, McapLogError> {
        self.writer.finish()?;
        Ok(self.writer.into_inner())
    }
}

/// A message waiting to be written, in log-time order.
struct Pending {
    t_ns: u64,
    topic: Topic,
    data: Value,
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

/// Every message of the mission, sorted by log time (stable: same-time
/// messages keep the order they were produced in).
fn messages(rec: &MissionRecord) -> Result<Vec<Pending>, McapLogError> {
    let mut world = rec.world.world().clone();
    let map = rec.world.map();
    let mut out = vec![
        Pending {
            t_ns: 0,
            topic: Topic::Chart,
            data: chart_grid(map),
        },
        Pending {
            t_ns: 0,
            topic: Topic::Bounds,
            data: bounds_scene(&world),
        },
        Pending {
            t_ns: 0,
            topic: Topic::Waypoints,
            data: scene(vec![waypoints_scene(0, &world, 0)]),
        },
    ];
    let mut epoch = 0;
    let mut pending_trigger: Option<(String, f64)> = None;
    let mut plans = 0u64;
    for (k, text) in rec.log.lines().enumerate() {
        let line = k + 1;
        if text.trim().is_empty() {
            continue;
        }
        let v: Value = serde_json::from_str(text).map_err(|e| McapLogError::BadLogLine {
            line,
            detail: e.to_string(),
        })?;
        let t = num(&v, "t", line)?;
        let t_ns = ns(t);
        out.push(Pending {
            t_ns,
            topic: Topic::Events,
            data: log_message(t_ns, level(&v), text, "planner", "mission.log", line),
        });
        match field(&v, "event", line)?.as_str() {
            Some("sensor_update") => {
                let e = num(&v, "epoch", line)? as u64;
                if e > epoch {
                    epoch = e;
                    let mut rng = world.redraw_rng(epoch);
                    world.redraw_dynamic(&mut rng, map);
                    out.push(Pending {
                        t_ns,
                        topic: Topic::Waypoints,
                        data: scene(vec![waypoints_scene(t_ns, &world, epoch)]),
                    });
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
                out.push(Pending {
                    t_ns,
                    topic: Topic::Plan,
                    data: plan_message(t_ns, replan, &route, &pts, plans == 0),
                });
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
                out.push(Pending {
                    t_ns,
                    topic: Topic::Status,
                    data: figures.message(),
                });
                plans += 1;
            }
            Some("arrival") => out.push(Pending {
                t_ns,
                topic: Topic::Progress,
                data: progress_message(
                    t,
                    num(&v, "node", line)? as u64,
                    num(&v, "tasks", line)? as u64,
                    num(&v, "weight", line)?,
                    num(&v, "time_left_s", line)?,
                ),
            }),
            Some("finished" | "command") => {}
            other => {
                return Err(McapLogError::BadLogLine {
                    line,
                    detail: format!("unknown event {other:?}"),
                });
            }
        }
    }
    let track = poses(rec.journal, rec.world.world());
    for (k, p) in track.iter().enumerate() {
        let t_ns = ns(p.t);
        out.push(Pending {
            t_ns,
            topic: Topic::Pose,
            data: pose_message(t_ns, p.p, p.yaw),
        });
        let so_far: Vec<Vec3> = track[..=k].iter().map(|q| q.p).collect();
        let travelled = entity(t_ns, "travelled", &[], |e| {
            e.insert("lines".into(), json!([line_json(&so_far, colour(0.1, 0.6, 0.2, 1.0))]));
        });
        out.push(Pending {
            t_ns,
            topic: Topic::Track,
            data: scene(vec![travelled]),
        });
        if let Some(geo) = rec.geo {
            let (lat, lon) = geo.lat_lon(p.p.x, p.p.y);
            out.push(Pending {
                t_ns,
                topic: Topic::Fix,
                data: json!({
                    "timestamp": stamp(t_ns), "frame_id": FRAME, "latitude": lat, "longitude": lon,
                    "altitude": -p.p.z, "position_covariance": vec![0.0; 9], "position_covariance_type": 0,
                }),
            });
        }
    }
    if let (Some(geo), Some(last)) = (rec.geo, track.last()) {
        let coords: Vec<Value> = track
            .iter()
            .map(|q| {
                let (lat, lon) = geo.lat_lon(q.p.x, q.p.y);
                json!([lon, lat])
            })
            .collect();
        let gj = json!({"type": "Feature", "properties": {"name": "route travelled"},
            "geometry": {"type": "LineString", "coordinates": coords}});
        out.push(Pending {
            t_ns: ns(last.t),
            topic: Topic::Route,
            data: json!({"geojson": gj.to_string()}),
        });
    }
    if let Some((p50, p99, max)) = rec.latency_us {
        let end = out.iter().map(|m| m.t_ns).max().unwrap_or(0);
        out.push(Pending {
            t_ns: end,
            topic: Topic::Latency,
            data: json!({"plans": plans, "p50_us": p50, "p99_us": p99, "max_us": max}),
        });
    }
    out.sort_by_key(|m| m.t_ns);
    Ok(out)
}

fn line_json(pts: &[Vec3], c: Value) -> Value {
    line(0, pts.iter().copied(), 3.0, c)
}

/// Writes the mission's MCAP file to `w`.
pub fn write_to<W: Write + Seek>(rec: &MissionRecord, w: W) -> Result<W, McapLogError> {
    let msgs = messages(rec)?;
    let mut topics: Vec<Topic> = msgs.iter().map(|m| m.topic).collect();
    topics.sort();
    topics.dedup();
    let mut writer = ChannelWriter::new(w, rec.vehicle, &topics)?;
    for m in &msgs {
        writer.write(m.topic, m.t_ns, &m.data)?;
    }
    writer.finish()
}

/// Writes `mission.mcap` at `path`.
pub fn write(path: &Path, rec: &MissionRecord) -> Result<(), McapLogError> {
    let bytes = write_to(rec, Cursor::new(Vec::new()))?.into_inner();
    std::fs::write(path, bytes)?;
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
        let _ = writeln!(o, "outcome: {}", self.outcome.as_deref().unwrap_or("not logged"));
        o
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_messages::msg::Outcome;
    use auv_world::load::{ScenarioArgs, load_world};

    fn world() -> MissionWorld {
        load_world(&ScenarioArgs {
            seed: Some(3),
            mission: None,
            scenario: None,
            nodes: Some(10),
            time_available_s: None,
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

    fn bytes(rec: &MissionRecord) -> Vec<u8> {
        write_to(rec, Cursor::new(Vec::new())).unwrap().into_inner()
    }

    #[test]
    fn the_file_reads_back_with_every_channel_and_the_same_plans_and_pose() {
        let w = world();
        let (log, journal) = records(&w);
        let rec = MissionRecord {
            world: &w,
            log: &log,
            journal: &journal,
            vehicle: "auv7",
            latency_us: None,
            geo: None,
        };
        let s = read_summary(&bytes(&rec)).unwrap();
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
        let rec = MissionRecord {
            world: &w,
            log: &log,
            journal: &journal,
            vehicle: "auv1",
            latency_us: None,
            geo: None,
        };
        assert_eq!(bytes(&rec), bytes(&rec));
    }

    #[test]
    fn messages_are_in_log_time_order_and_poses_head_for_the_next_point() {
        let w = world();
        let (log, journal) = records(&w);
        let rec = MissionRecord {
            world: &w,
            log: &log,
            journal: &journal,
            vehicle: "auv1",
            latency_us: None,
            geo: None,
        };
        let msgs = messages(&rec).unwrap();
        assert!(msgs.windows(2).all(|m| m[0].t_ns <= m[1].t_ns));
        let track = poses(&journal, w.world());
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

    struct Linear;
    impl GeoReference for Linear {
        fn lat_lon(&self, x_m: f64, y_m: f64) -> (f64, f64) {
            (44.0 + y_m * 1e-5, -63.0 + x_m * 1e-5)
        }
    }

    #[test]
    fn a_geographic_reference_adds_location_fixes_and_the_route_as_geojson() {
        let w = world();
        let (log, journal) = records(&w);
        let rec = MissionRecord {
            world: &w,
            log: &log,
            journal: &journal,
            vehicle: "auv1",
            latency_us: Some((10, 20, 30)),
            geo: Some(&Linear),
        };
        let msgs = messages(&rec).unwrap();
        let fixes = msgs.iter().filter(|m| m.topic == Topic::Fix).count();
        assert_eq!(fixes, poses(&journal, w.world()).len());
        let route = msgs.iter().find(|m| m.topic == Topic::Route).unwrap();
        let gj: Value = serde_json::from_str(route.data["geojson"].as_str().unwrap()).unwrap();
        assert_eq!(gj["geometry"]["coordinates"].as_array().unwrap().len(), fixes);
        let lat = msgs.iter().find(|m| m.topic == Topic::Latency).unwrap();
        assert_eq!(lat.data["p99_us"], 20);
        assert_eq!(lat.data["plans"], 2);
    }

    #[test]
    fn a_bad_log_line_is_named() {
        let w = world();
        let journal = JournalSummary::default();
        let log = "{\"event\":\"plan\",\"t\":1.0,\"replan\":0,\"route\":[0,999]}\n";
        let rec = MissionRecord {
            world: &w,
            log,
            journal: &journal,
            vehicle: "auv1",
            latency_us: None,
            geo: None,
        };
        let e = write_to(&rec, Cursor::new(Vec::new())).unwrap_err().to_string();
        assert!(e.starts_with("mission.log line 1: plan visits waypoint 999"), "{e}");
        let rec = MissionRecord {
            log: "not json\n",
            ..rec
        };
        assert!(
            write_to(&rec, Cursor::new(Vec::new()))
                .unwrap_err()
                .to_string()
                .starts_with("mission.log line 1:")
        );
    }

    #[test]
    fn truncated_and_foreign_files_are_errors() {
        let w = world();
        let (log, journal) = records(&w);
        let rec = MissionRecord {
            world: &w,
            log: &log,
            journal: &journal,
            vehicle: "auv1",
            latency_us: None,
            geo: None,
        };
        let b = bytes(&rec);
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
