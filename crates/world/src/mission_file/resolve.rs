//! From mission text to a [`Mission`]: syntax, `format`, the typed document,
//! then every semantic check of the format's error list, in the order a
//! reader fixes them (numbers, names and roles, capacity, positions, chart,
//! geography, tasks, reachability).

use std::collections::HashMap;
use std::path::Path;

use super::model::{ChartDoc, MissionDoc, WaypointDoc};
use super::{MISSION_FORMAT, Mission, Overrides, Problem, Role, Water, WaypointInfo};
use crate::chart::land::LandChart;
use crate::chart::{BAY_OF_ISLANDS, Chart, ClassifySettings, MAX_K, WaterMap};
use crate::frame::{LatLon, LocalFrame};
use crate::scenario::{
    ChartSource, GeneratedNodes, Layout, LayoutNode, STREAM_CHART, ScenarioConfig, Task, TaskRule, UniformRange, Vec3,
    World,
};
use auv_core::capacity::LARGEST_NODES;
use auv_core::instance::Objective;
use auv_core::problem::{NodeSet, ProblemError};
use auv_core::rng::derive_seed;

/// Least water share of a dynamic waypoint's bound box (our choice: below
/// 5 % the drift falls back to the nominal position on most updates; see
/// the module table of [`super`]).
pub const MIN_BOUND_WATER_FRACTION: f64 = 0.05;
/// Samples per side of a bound box's water check.
pub const BOUND_SAMPLE_GRID: usize = 32;
/// Deepest waypoint, m (the planner's depth range, the format's rule).
pub const MAX_DEPTH_M: f64 = 1000.0;
/// `[sensing].period_s` default, s (the paper's model).
pub const DEFAULT_PERIOD_S: f64 = 60.0;
/// `[sensing].sigma_m` default, m (the paper's model).
pub const DEFAULT_SIGMA_M: f64 = 150.0;
/// `[generate].bound_sigma_m` default, m (the paper's σ_b).
pub const DEFAULT_BOUND_SIGMA_M: f64 = 300.0;
/// `seed` default (the format's).
pub const DEFAULT_SEED: u64 = 1;

/// The embedded charts by name, their PNG and scale, and their origin (the
/// south-west corner, `planner/assets/ATTRIBUTION.md`).
struct EmbeddedChart {
    name: &'static str,
    png: &'static [u8],
    metres_per_pixel: f64,
    origin: LatLon,
}

const EMBEDDED: [EmbeddedChart; 2] = [
    EmbeddedChart {
        name: "benoits-cove",
        png: crate::chart::EMBEDDED_CHART_PNG,
        metres_per_pixel: crate::chart::BENOITS_COVE.metres_per_pixel,
        origin: LatLon {
            lat: 48.990,
            lon: -58.1700,
        },
    },
    EmbeddedChart {
        name: "bay-of-islands",
        png: include_bytes!("../../assets/bay-of-islands.png"),
        metres_per_pixel: BAY_OF_ISLANDS.metres_per_pixel,
        origin: LatLon {
            lat: 48.930,
            lon: -58.420,
        },
    },
];

fn bad(field: impl Into<String>, value: f64, rule: &'static str) -> Problem {
    Problem::BadNumber {
        field: field.into(),
        value: value.to_string(),
        rule,
    }
}

/// `value` must be finite and satisfy `ok`.
fn check(field: impl Into<String>, value: f64, ok: impl Fn(f64) -> bool, rule: &'static str) -> Result<f64, Problem> {
    if value.is_finite() && ok(value) {
        Ok(value)
    } else {
        Err(bad(field, value, rule))
    }
}

fn positive(field: impl Into<String>, v: f64) -> Result<f64, Problem> {
    check(field, v, |v| v > 0.0, "finite and > 0")
}

fn non_negative(field: impl Into<String>, v: f64) -> Result<f64, Problem> {
    check(field, v, |v| v >= 0.0, "finite and >= 0")
}

fn shape(field: impl Into<String>, message: impl Into<String>) -> Problem {
    Problem::Shape {
        field: field.into(),
        message: message.into(),
    }
}

fn range(
    field: &str,
    r: [f64; 2],
    lo_ok: impl Fn(f64) -> bool,
    lo_rule: &'static str,
) -> Result<UniformRange, Problem> {
    check(format!("{field}[0]"), r[0], lo_ok, lo_rule)?;
    check(format!("{field}[1]"), r[1], |_| true, "finite")?;
    if r[0] > r[1] {
        return Err(shape(
            field,
            format!("[{}, {}]: the lower end exceeds the upper end", r[0], r[1]),
        ));
    }
    Ok(UniformRange::new(r[0], r[1]))
}

/// 1-based line and column of byte `offset` in `text`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

/// Syntax, `format`, then the typed document.
pub(super) fn read_doc(text: &str) -> Result<MissionDoc, Problem> {
    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let (line, column) = e.span().map_or((0, 0), |s| line_column(text, s.start));
        Problem::NotToml {
            line,
            column,
            message: e.message().trim().replace('\n', " "),
        }
    })?;
    match table.get("format") {
        None => return Err(Problem::MissingFormat),
        Some(toml::Value::String(s)) if s == MISSION_FORMAT => {}
        Some(other) => return Err(Problem::WrongFormat(other.to_string())),
    }
    let de = toml::Deserializer::parse(text).map_err(|e| Problem::NotToml {
        line: 0,
        column: 0,
        message: e.message().to_string(),
    })?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        Problem::Field {
            path: if path == "." { "(top level)".into() } else { path },
            message: e.inner().message().trim().replace('\n', " "),
        }
    })
}

/// A waypoint's horizontal position, in the local frame.
fn position(i: usize, w: &WaypointDoc, frame: Option<&LocalFrame>) -> Result<(f64, f64), Problem> {
    let field = format!("waypoint[{i}]");
    let err = |message: String| Problem::Waypoint {
        field: field.clone(),
        name: w.name.clone(),
        message,
    };
    let geo = w.lat.is_some() || w.lon.is_some();
    let local = w.x_m.is_some() || w.y_m.is_some();
    if geo && local {
        return Err(err(
            "position given both ways: give either lat + lon or x_m + y_m".into()
        ));
    }
    match (w.lat, w.lon, w.x_m, w.y_m) {
        (Some(lat), Some(lon), None, None) => {
            let Some(frame) = frame else {
                return Err(err(
                    "lat/lon needs a frame origin: add [frame] origin = { lat = …, lon = … } (or use an embedded chart)"
                        .into(),
                ));
            };
            check(
                format!("{field}.lat"),
                lat,
                |v| (-90.0..=90.0).contains(&v),
                "a latitude in [-90, 90]",
            )?;
            check(
                format!("{field}.lon"),
                lon,
                |v| (-180.0..=180.0).contains(&v),
                "a longitude in [-180, 180]",
            )?;
            frame.to_local(LatLon { lat, lon }).map_err(|e| err(e.to_string()))
        }
        (None, None, Some(x), Some(y)) => Ok((
            check(format!("{field}.x_m"), x, |_| true, "finite")?,
            check(format!("{field}.y_m"), y, |_| true, "finite")?,
        )),
        (None, None, None, None) => Err(err("no position: give lat + lon or x_m + y_m".into())),
        (Some(_), None, ..) => Err(err("lat without lon".into())),
        (None, Some(_), ..) => Err(err("lon without lat".into())),
        (.., Some(_), None) => Err(err("x_m without y_m".into())),
        _ => Err(err("y_m without x_m".into())),
    }
}

/// What the chart table names, checked for shape.
enum ChartChoice<'a> {
    Embedded(&'a EmbeddedChart, usize),
    Png(&'a str, f64, usize),
    Land(&'a str, [f64; 2]),
}

fn chart_choice(c: &ChartDoc) -> Result<ChartChoice<'_>, Problem> {
    let given = [c.embedded.is_some(), c.png.is_some(), c.land_geojson.is_some()]
        .iter()
        .filter(|&&b| b)
        .count();
    if given != 1 {
        return Err(shape(
            "chart",
            format!("give exactly one of embedded, png, land_geojson ({given} given)"),
        ));
    }
    let k = match c.k {
        None => crate::chart::DEFAULT_K,
        Some(_) if c.land_geojson.is_some() => {
            return Err(shape("chart.k", "only a raster chart (embedded or png) is clustered"));
        }
        Some(k) if (2..=MAX_K as i64).contains(&k) => k as usize,
        Some(k) => return Err(bad("chart.k", k as f64, "an integer in 2..=16")),
    };
    if c.metres_per_pixel.is_some() && c.png.is_none() {
        return Err(shape("chart.metres_per_pixel", "only with chart.png"));
    }
    if c.extent_m.is_some() && c.land_geojson.is_none() {
        return Err(shape("chart.extent_m", "only with chart.land_geojson"));
    }
    if let Some(name) = &c.embedded {
        let chart = EMBEDDED.iter().find(|e| e.name == name).ok_or_else(|| {
            shape(
                "chart.embedded",
                format!("\"{name}\" is not an embedded chart (benoits-cove, bay-of-islands)"),
            )
        })?;
        return Ok(ChartChoice::Embedded(chart, k));
    }
    if let Some(png) = &c.png {
        let mpp = c
            .metres_per_pixel
            .ok_or_else(|| shape("chart.metres_per_pixel", "required with chart.png"))?;
        let mpp = check(
            "chart.metres_per_pixel",
            mpp,
            |v| v > 0.0 && v <= 1e6,
            "finite, > 0 and <= 1e6",
        )?;
        if png.is_empty() {
            return Err(shape("chart.png", "an empty path"));
        }
        return Ok(ChartChoice::Png(png, mpp, k));
    }
    let path = c.land_geojson.as_deref().unwrap_or_default();
    if path.is_empty() {
        return Err(shape("chart.land_geojson", "an empty path"));
    }
    let extent = c
        .extent_m
        .ok_or_else(|| shape("chart.extent_m", "required with chart.land_geojson"))?;
    positive("chart.extent_m[0]", extent[0])?;
    positive("chart.extent_m[1]", extent[1])?;
    Ok(ChartChoice::Land(path, extent))
}

/// The absolute form of a chart path, so every process of a run names (and
/// fingerprints) the chart alike wherever it was started from; a path that
/// does not resolve stays as given (reading it then reports the error).
fn canonical(path: &Path) -> std::path::PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

/// Loads the chart: the water map, its source (absolute path: the
/// fingerprint's) and the scenario's name for it (the path as the mission
/// file's own path and the file's chart entry give it, for reports).
fn load_chart(
    choice: &ChartChoice<'_>,
    dir: &Path,
    seed: u64,
    frame: Option<&LocalFrame>,
) -> Result<(Water, ChartSource, String), Problem> {
    let classify = |chart: Chart, k: usize| {
        chart
            .classify(&ClassifySettings {
                k,
                seed: derive_seed(seed, STREAM_CHART),
            })
            .map_err(|e| Problem::Chart(e.to_string()))
    };
    match *choice {
        ChartChoice::Embedded(e, k) => {
            let chart = Chart::from_png_bytes(e.png, e.metres_per_pixel)
                .map_err(|err| Problem::Chart(err.to_string()))?
                .named(format!("embedded chart {}", e.name));
            Ok((
                Water::Mask(classify(chart, k)?),
                ChartSource::Embedded(e.name.to_string()),
                e.name.to_string(),
            ))
        }
        ChartChoice::Png(png, mpp, k) => {
            let given = dir.join(png);
            let path = canonical(&given);
            let chart = Chart::from_png_file(&path, Some(mpp)).map_err(|e| Problem::Chart(e.to_string()))?;
            Ok((
                Water::Mask(classify(chart, k)?),
                ChartSource::Png {
                    path,
                    metres_per_pixel: mpp,
                },
                given.display().to_string(),
            ))
        }
        ChartChoice::Land(file, extent) => {
            let frame = frame.ok_or_else(|| {
                shape(
                    "chart.land_geojson",
                    "needs [frame] origin = { lat = …, lon = … }: GeoJSON positions are lon/lat",
                )
            })?;
            let given = dir.join(file);
            let path = canonical(&given);
            let shown = path.display().to_string();
            let text = std::fs::read_to_string(&path)
                .map_err(|e| Problem::Chart(format!("cannot read chart file `{shown}`: {e}")))?;
            let land = LandChart::from_geojson(&text, frame, extent[0], extent[1])
                .map_err(|e| Problem::Chart(format!("`{shown}`: {e}")))?;
            Ok((
                Water::Land(land),
                ChartSource::LandGeojson { path, extent_m: extent },
                given.display().to_string(),
            ))
        }
    }
}

/// Share of water in a dynamic waypoint's bound box (x, y; clipped to the area).
fn bound_water_fraction(water: &Water, p: Vec3, b: Vec3) -> f64 {
    let (w, h) = (water.width_m(), water.height_m());
    let (x0, x1) = crate::scenario::bound_interval(p.x, b.x, w);
    let (y0, y1) = crate::scenario::bound_interval(p.y, b.y, h);
    let g = BOUND_SAMPLE_GRID;
    let wet = (0..g * g)
        .filter(|k| {
            let (c, r) = ((k % g) as f64 + 0.5, (k / g) as f64 + 0.5);
            water.is_water(x0 + (x1 - x0) * c / g as f64, y0 + (y1 - y0) * r / g as f64)
        })
        .count();
    wet as f64 / (g * g) as f64
}

/// The whole resolution.
pub(super) fn resolve(text: &str, dir: &Path, overrides: Overrides) -> Result<Mission, Problem> {
    let doc = read_doc(text)?;
    let seed = overrides.seed.or(doc.seed).unwrap_or(DEFAULT_SEED);

    // Numbers.
    let v = doc.vehicle;
    let speed_mps = positive("vehicle.speed_mps", v.speed_mps)?;
    let time_available_s = positive(
        "vehicle.time_available_s",
        overrides.time_available_s.unwrap_or(v.time_available_s),
    )?;
    let reserve_s = non_negative("vehicle.reserve_s", v.reserve_s.unwrap_or(0.0))?;
    let objective = match &doc.objective {
        None => Objective::MaxWeight,
        Some(o) => match o.kind.as_str() {
            "max_weight" if o.phi1.is_some() || o.phi2.is_some() => {
                return Err(shape("objective", "phi1 and phi2 belong to kind = \"paper_cost\""));
            }
            "max_weight" => Objective::MaxWeight,
            "paper_cost" => {
                let phi = |name: &str, v: Option<f64>| {
                    v.ok_or_else(|| shape(format!("objective.{name}"), "required with kind = \"paper_cost\""))
                        .and_then(|v| positive(format!("objective.{name}"), v))
                };
                Objective::PaperCost {
                    phi1: phi("phi1", o.phi1)?,
                    phi2: phi("phi2", o.phi2)?,
                }
            }
            other => {
                return Err(shape(
                    "objective.kind",
                    format!("\"{other}\": expected \"max_weight\" or \"paper_cost\""),
                ));
            }
        },
    };
    let sensing = doc.sensing.unwrap_or(super::model::SensingDoc {
        period_s: None,
        sigma_m: None,
    });
    let period_s = positive("sensing.period_s", sensing.period_s.unwrap_or(DEFAULT_PERIOD_S))?;
    let sigma_m = positive("sensing.sigma_m", sensing.sigma_m.unwrap_or(DEFAULT_SIGMA_M))?;
    let generate = doc.generate.unwrap_or(super::model::GenerateDoc {
        fixed: None,
        dynamic: None,
        bound_sigma_m: None,
    });
    let count = |field: &str, v: Option<i64>| -> Result<usize, Problem> {
        match v.unwrap_or(0) {
            c if (0..=LARGEST_NODES as i64).contains(&c) => Ok(c as usize),
            c => Err(bad(field, c as f64, "an integer in 0..=512")),
        }
    };
    let gen_static = count("generate.static", generate.fixed)?;
    let gen_dynamic = count("generate.dynamic", generate.dynamic)?;
    let bound_sigma_m = non_negative(
        "generate.bound_sigma_m",
        generate.bound_sigma_m.unwrap_or(DEFAULT_BOUND_SIGMA_M),
    )?;
    let task_rule = match doc.tasks.as_ref().and_then(|t| t.draw) {
        None => TaskRule::Transit,
        Some(d) => TaskRule::Draw {
            priority: range("tasks.draw.priority", d.priority, |v| v >= 0.0, "finite and >= 0")?,
            risk: range("tasks.draw.risk", d.risk, |v| v > 0.0, "finite and > 0")?,
            task_time_s: range("tasks.draw.task_time_s", d.task_time_s, |v| v >= 0.0, "finite and >= 0")?,
        },
    };
    for (i, w) in doc.waypoint.iter().enumerate() {
        let f = format!("waypoint[{i}]");
        check(
            format!("{f}.depth_m"),
            w.depth_m,
            |v| (0.0..=MAX_DEPTH_M).contains(&v),
            "finite and in [0, 1000] (m, positive down)",
        )?;
        non_negative(format!("{f}.prize"), w.prize.unwrap_or(0.0))?;
        if let Some(d) = &w.dynamic {
            for (axis, b) in d.bound_m.iter().enumerate() {
                non_negative(format!("{f}.dynamic.bound_m[{axis}]"), *b)?;
            }
            if let Some(s) = d.sigma_m {
                positive(format!("{f}.dynamic.sigma_m"), s)?;
            }
        }
    }
    let edges = doc.tasks.as_ref().map_or(&[][..], |t| &t.edge[..]);
    for (k, e) in edges.iter().enumerate() {
        let f = format!("tasks.edge[{k}]");
        non_negative(format!("{f}.priority"), e.priority)?;
        positive(format!("{f}.risk"), e.risk)?;
        non_negative(format!("{f}.task_time_s"), e.task_time_s)?;
    }

    // Names and roles.
    let mut by_name: HashMap<&str, usize> = HashMap::new();
    let (mut starts, mut goals) = (Vec::new(), Vec::new());
    for (i, w) in doc.waypoint.iter().enumerate() {
        let field = format!("waypoint[{i}]");
        if w.name.trim().is_empty() {
            return Err(shape(format!("{field}.name"), "empty; every waypoint needs a name"));
        }
        if let Some(first) = by_name.insert(&w.name, i) {
            return Err(Problem::Waypoint {
                field,
                name: w.name.clone(),
                message: format!("duplicate name (also waypoint[{first}])"),
            });
        }
        match w.role.as_deref() {
            None => {}
            Some("start") => starts.push(i),
            Some("goal") => goals.push(i),
            Some(other) => {
                return Err(Problem::Waypoint {
                    field: format!("{field}.role"),
                    name: w.name.clone(),
                    message: format!("\"{other}\": a role is \"start\" or \"goal\" (or absent)"),
                });
            }
        }
    }
    let names = |ids: &[usize]| {
        ids.iter()
            .map(|&i| format!("\"{}\"", doc.waypoint[i].name))
            .collect::<Vec<_>>()
            .join(", ")
    };
    for (role, ids) in [("start", &starts), ("goal", &goals)] {
        match ids.len() {
            1 => {}
            0 => {
                return Err(shape(
                    "waypoint",
                    format!("no waypoint has role = \"{role}\" (exactly one must)"),
                ));
            }
            c => {
                return Err(shape(
                    "waypoint",
                    format!(
                        "{c} waypoints have role = \"{role}\" ({}); exactly one must",
                        names(ids)
                    ),
                ));
            }
        }
    }
    let (start_i, goal_i) = (starts[0], goals[0]);
    let count = doc.waypoint.len() + gen_static + gen_dynamic;
    if count > LARGEST_NODES {
        return Err(Problem::Capacity {
            count,
            explicit: doc.waypoint.len(),
            generated: gen_static + gen_dynamic,
            max: LARGEST_NODES,
        });
    }

    // Frame, positions, chart.
    let choice = chart_choice(&doc.chart)?;
    let origin = match (&doc.frame, &choice) {
        (Some(f), _) => Some(LatLon {
            lat: check(
                "frame.origin.lat",
                f.origin.lat,
                |v| (-90.0..=90.0).contains(&v),
                "a latitude in [-90, 90]",
            )?,
            lon: check(
                "frame.origin.lon",
                f.origin.lon,
                |v| (-180.0..=180.0).contains(&v),
                "a longitude in [-180, 180]",
            )?,
        }),
        (None, ChartChoice::Embedded(e, _)) => Some(e.origin),
        (None, _) => None,
    };
    let frame = origin
        .map(LocalFrame::new)
        .transpose()
        .map_err(|e| shape("frame.origin", e.to_string()))?;
    let mut xy = Vec::with_capacity(doc.waypoint.len());
    for (i, w) in doc.waypoint.iter().enumerate() {
        xy.push(position(i, w, frame.as_ref())?);
    }
    let mut depth: Vec<f64> = doc.waypoint.iter().map(|w| w.depth_m).collect();
    // A vehicle that takes this mission on where it is: the start is its
    // position, checked below like any waypoint's.
    if let Some([x, y, z]) = overrides.start_at {
        xy[start_i] = (x, y);
        depth[start_i] = z.clamp(0.0, MAX_DEPTH_M);
    }
    let (water, chart_source, chart_name) = load_chart(&choice, dir, seed, frame.as_ref())?;
    let (width, height) = (water.width_m(), water.height_m());
    let nominal = |i: usize| Vec3 {
        x: xy[i].0,
        y: xy[i].1,
        z: depth[i],
    };
    for (i, w) in doc.waypoint.iter().enumerate() {
        let err = |message: String| Problem::Waypoint {
            field: format!("waypoint[{i}]"),
            name: w.name.clone(),
            message,
        };
        let (x, y) = xy[i];
        if !((0.0..width).contains(&x) && (0.0..height).contains(&y)) {
            return Err(err(format!(
                "outside the area: at ({x:.1}, {y:.1}) m, the chart covers [0, {width}) × [0, {height}) m"
            )));
        }
        if !water.is_water(x, y) {
            return Err(err(format!("on land at ({x:.1}, {y:.1}) m")));
        }
        if let Some(d) = &w.dynamic {
            if i == start_i || i == goal_i {
                return Err(err(
                    "the start and the goal cannot be dynamic (the vehicle starts at the start, the route ends at the goal)"
                        .into(),
                ));
            }
            let b = Vec3 {
                x: d.bound_m[0],
                y: d.bound_m[1],
                z: d.bound_m[2],
            };
            let share = bound_water_fraction(&water, nominal(i), b);
            if share < MIN_BOUND_WATER_FRACTION {
                return Err(err(format!(
                    "dynamic bound cannot stay over water: only {:.1} % of its box ±({}, {}) m is water (at least {:.0} % must be)",
                    share * 100.0,
                    b.x,
                    b.y,
                    MIN_BOUND_WATER_FRACTION * 100.0
                )));
            }
        }
    }
    if nominal(start_i) == nominal(goal_i) {
        return Err(shape(
            "waypoint",
            format!(
                "the start (\"{}\") and the goal (\"{}\") are at the same position",
                doc.waypoint[start_i].name, doc.waypoint[goal_i].name
            ),
        ));
    }

    // Node ids: start, the other explicit ones in file order, generated, goal.
    let middle: Vec<usize> = (0..doc.waypoint.len())
        .filter(|&i| i != start_i && i != goal_i)
        .collect();
    let first_generated = 1 + middle.len();
    let mut id_of = vec![0usize; doc.waypoint.len()];
    id_of[start_i] = 0;
    for (k, &i) in middle.iter().enumerate() {
        id_of[i] = k + 1;
    }
    let n = count;
    id_of[goal_i] = n - 1;
    let node = |i: usize| {
        let w = &doc.waypoint[i];
        LayoutNode {
            nominal: nominal(i),
            prize: w.prize.unwrap_or(0.0),
            drift: w.dynamic.map(|d| {
                (
                    Vec3 {
                        x: d.bound_m[0],
                        y: d.bound_m[1],
                        z: d.bound_m[2],
                    },
                    d.sigma_m.unwrap_or(sigma_m),
                )
            }),
        }
    };

    // Explicit tasks.
    let mut explicit_tasks = Vec::with_capacity(edges.len());
    let mut named: HashMap<(usize, usize), usize> = HashMap::new();
    for (k, e) in edges.iter().enumerate() {
        let field = format!("tasks.edge[{k}]");
        let err = |message: String| Problem::Task {
            field: field.clone(),
            a: e.a.clone(),
            b: e.b.clone(),
            message,
        };
        let look = |name: &str| {
            by_name
                .get(name)
                .copied()
                .ok_or_else(|| err(format!("unknown waypoint \"{name}\"")))
        };
        let (ia, ib) = (look(&e.a)?, look(&e.b)?);
        if ia == ib {
            return Err(err("a task joins two different waypoints".into()));
        }
        let pair = (id_of[ia].min(id_of[ib]), id_of[ia].max(id_of[ib]));
        if let Some(first) = named.insert(pair, k) {
            return Err(err(format!(
                "this pair already has a task (tasks.edge[{first}]); at most one per pair"
            )));
        }
        let (pa, pb) = (xy[ia], xy[ib]);
        if !water.segment_over_water(pa, pb) {
            return Err(err(
                "no edge: the straight segment between the two waypoints crosses land".into(),
            ));
        }
        explicit_tasks.push((
            pair.0,
            pair.1,
            Task {
                priority: e.priority,
                risk: e.risk,
                task_time_s: e.task_time_s,
            },
        ));
    }

    // The world.
    let layout = Layout {
        head: std::iter::once(start_i)
            .chain(middle.iter().copied())
            .map(node)
            .collect(),
        generated: GeneratedNodes {
            dynamic: gen_dynamic,
            fixed: gen_static,
            bound_sigma_m,
        },
        goal: node(goal_i),
        tasks: task_rule,
        explicit_tasks,
    };
    let config = ScenarioConfig {
        sigma_m,
        bound_sigma_m,
        depth_max_m: MAX_DEPTH_M,
        speed_mps,
        time_available_s,
        objective,
        chart: chart_source,
        k: match choice {
            ChartChoice::Embedded(_, k) | ChartChoice::Png(_, _, k) => k,
            ChartChoice::Land(..) => crate::chart::DEFAULT_K,
        },
        sensor_period_s: period_s,
        ..ScenarioConfig::default()
    };
    let world = World::from_layout(&config, seed, &layout, &water).map_err(|e| Problem::World(e.to_string()))?;

    let mut waypoints = vec![
        WaypointInfo {
            name: String::new(),
            role: Role::Via,
            generated: true,
        };
        n
    ];
    for (i, w) in doc.waypoint.iter().enumerate() {
        waypoints[id_of[i]] = WaypointInfo {
            name: w.name.clone(),
            role: match w.role.as_deref() {
                Some("start") => Role::Start,
                Some("goal") => Role::Goal,
                _ => Role::Via,
            },
            generated: false,
        };
    }
    for (id, w) in waypoints
        .iter_mut()
        .enumerate()
        .skip(first_generated)
        .take(gen_dynamic + gen_static)
    {
        w.name = format!("gen-{id}");
    }

    // Reachability on the first snapshot.
    let (start_name, goal_name) = (doc.waypoint[start_i].name.clone(), doc.waypoint[goal_i].name.clone());
    let no_route = |detail: String| Problem::NoRoute {
        start: start_name.clone(),
        goal: goal_name.clone(),
        detail,
    };
    let plan_budget = time_available_s - reserve_s;
    if plan_budget <= 0.0 {
        return Err(no_route(format!(
            "vehicle.reserve_s = {reserve_s} leaves nothing of time_available_s = {time_available_s}"
        )));
    }
    // The quickest time to the goal, on a problem of the smallest class that holds the network.
    let quickest = match auv_core::capacity::Class::for_nodes(world.n()) {
        Ok(class) => auv_core::with_class!(class, W => {
            let mut problem = auv_core::problem::Problem::<W>::new();
            world
                .fill_problem(&mut problem, world.start(), NodeSet::EMPTY, plan_budget)
                .map(|()| problem.to_goal_s(world.start()))
        }),
        Err(e) => return Err(Problem::World(e.to_string())),
    };
    match quickest {
        Ok(shortest) => {
            if shortest > plan_budget {
                return Err(no_route(format!(
                    "the quickest takes {shortest:.0} s, the budget less the reserve is {plan_budget:.0} s"
                )));
            }
        }
        Err(ProblemError::GoalUnreachable { .. }) => {
            return Err(no_route("no chain of edges over water joins them".into()));
        }
        Err(e) => return Err(Problem::World(e.to_string())),
    }

    let name = doc.name.clone().unwrap_or_else(|| "mission".to_string());
    Ok(Mission {
        name,
        seed,
        world,
        water,
        chart: chart_name,
        frame,
        waypoints,
        reserve_s,
    })
}
