//! One test per error case of the format's list (each asserting the
//! one-line message), and the resolution of good files.
//!
//! The geometry of most cases is a GeoJSON chart written here, so every
//! "on land" or "crosses land" is exact: a 4 km × 3 km area east and north of
//! 48.99 N, 58.17 W with one square island x, y ∈ [1000, 2000] m, which has a
//! 20 m lake at its centre.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use super::*;
use crate::frame::{LatLon, LocalFrame};

const ORIGIN: LatLon = LatLon {
    lat: 48.99,
    lon: -58.17,
};

fn lonlat(f: &LocalFrame, pts: &[(f64, f64)]) -> String {
    let v: Vec<[f64; 2]> = pts
        .iter()
        .map(|&(x, y)| {
            let p = f.to_geodetic(x, y).unwrap();
            [p.lon, p.lat]
        })
        .collect();
    serde_json::to_string(&v).unwrap()
}

/// The folder with the test charts (written once per test process).
fn charts() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("planner-mission-file-tests-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = LocalFrame::new(ORIGIN).unwrap();
        let island = lonlat(
            &f,
            &[
                (1000.0, 1000.0),
                (2000.0, 1000.0),
                (2000.0, 2000.0),
                (1000.0, 2000.0),
                (1000.0, 1000.0),
            ],
        );
        let lake = lonlat(
            &f,
            &[
                (1490.0, 1490.0),
                (1490.0, 1510.0),
                (1510.0, 1510.0),
                (1510.0, 1490.0),
                (1490.0, 1490.0),
            ],
        );
        std::fs::write(
            dir.join("island.geojson"),
            format!(
                r#"{{"type": "FeatureCollection", "features": [{{"type": "Feature", "properties": {{}},
                   "geometry": {{"type": "Polygon", "coordinates": [{island}, {lake}]}}}}]}}"#
            ),
        )
        .unwrap();
        let all = lonlat(
            &f,
            &[
                (-50.0, -50.0),
                (4100.0, -50.0),
                (4100.0, 3100.0),
                (-50.0, 3100.0),
                (-50.0, -50.0),
            ],
        );
        std::fs::write(
            dir.join("all-land.geojson"),
            format!(r#"{{"type": "Polygon", "coordinates": [{all}]}}"#),
        )
        .unwrap();
        std::fs::write(
            dir.join("line.geojson"),
            format!(r#"{{"type": "LineString", "coordinates": {island}}}"#),
        )
        .unwrap();
        dir
    })
}

/// A good mission on the island chart; cases edit its text.
const BASE: &str = r#"format = "auv-mission/1"
name = "island test"
seed = 3

[frame]
origin = { lat = 48.99, lon = -58.17 }

[chart]
land_geojson = "island.geojson"
extent_m = [4000, 3000]

[vehicle]
speed_mps = 1.5
time_available_s = 20000
reserve_s = 100

[sensing]
period_s = 60
sigma_m = 50

[[waypoint]]
name = "dock"
x_m = 500
y_m = 500
depth_m = 5
role = "start"

[[waypoint]]
name = "buoy"
x_m = 3000
y_m = 500
depth_m = 20
prize = 2
dynamic = { bound_m = [200, 200, 10] }

[[waypoint]]
name = "west"
x_m = 500
y_m = 1500
depth_m = 30

[[waypoint]]
name = "east"
x_m = 2500
y_m = 1500
depth_m = 30

[[waypoint]]
name = "recovery"
x_m = 3500
y_m = 2500
depth_m = 10
role = "goal"

[tasks]
draw = { priority = [1, 10], risk = [0.1, 1.0], task_time_s = [60, 300] }

[[tasks.edge]]
a = "dock"
b = "buoy"
priority = 7
risk = 0.35
task_time_s = 240
"#;

fn run(text: &str) -> Result<Mission, MissionError> {
    parse(text, "test.toml", charts(), Overrides::default())
}

/// The one-line error of `text`, which must contain every needle.
fn refused(text: &str, needles: &[&str]) {
    let e = run(text).expect_err("must be refused").to_string();
    assert!(e.starts_with("test.toml: "), "names the file: {e}");
    assert!(!e.contains('\n'), "one line: {e:?}");
    for n in needles {
        assert!(e.contains(n), "{e:?} should contain {n:?}");
    }
}

fn edited(from: &str, to: &str) -> String {
    assert!(BASE.contains(from), "{from}");
    BASE.replacen(from, to, 1)
}

#[test]
fn the_base_mission_resolves_with_the_formats_ids_names_and_tasks() {
    let m = run(BASE).unwrap();
    let w = &m.world;
    assert_eq!(w.n(), 5);
    let names: Vec<&str> = m.waypoints.iter().map(|w| w.name.as_str()).collect();
    assert_eq!(names, ["dock", "buoy", "west", "east", "recovery"]);
    assert_eq!(m.waypoints[0].role, Role::Start);
    assert_eq!(m.waypoints[4].role, Role::Goal);
    assert!(w.is_dynamic(1) && w.dynamic_nodes().len() == 1);
    assert_eq!(w.bounds()[1].x, 200.0);
    assert_eq!(w.drift_sigmas_m()[1], 50.0, "the [sensing] default σ");
    assert_eq!(w.prizes()[1], 2.0);
    assert_eq!((m.seed, m.reserve_s), (3, 100.0));
    let t = w.task(0, 1).unwrap();
    assert_eq!((t.priority, t.risk, t.task_time_s), (7.0, 0.35, 240.0));
    assert!(!w.has_edge(2, 3), "west – east crosses the island");
    assert!(w.has_edge(0, 2));
    let drawn = w.task(2, 4).unwrap();
    assert!((1.0..=10.0).contains(&drawn.priority) && (60.0..=300.0).contains(&drawn.task_time_s));
    // Deterministic, and the seed override changes the draws.
    assert_eq!(run(BASE).unwrap().world.snapshot("a"), w.snapshot("a"));
    let other = parse(
        BASE,
        "test.toml",
        charts(),
        Overrides {
            seed: Some(4),
            time_available_s: None,
            start_at: None,
        },
    )
    .unwrap();
    assert_eq!(other.seed, 4);
    assert_ne!(other.world.task(2, 4), w.task(2, 4));
    assert_eq!(
        other.world.task(0, 1),
        w.task(0, 1),
        "explicit tasks do not depend on the seed"
    );
}

#[test]
fn lat_lon_positions_convert_through_the_frame() {
    let f = LocalFrame::new(ORIGIN).unwrap();
    let p = f.to_geodetic(500.0, 1500.0).unwrap();
    let text = edited(
        "name = \"west\"\nx_m = 500\ny_m = 1500",
        &format!("name = \"west\"\nlat = {}\nlon = {}", p.lat, p.lon),
    );
    let m = run(&text).unwrap();
    let q = m.world.nominal_positions()[2];
    assert!((q.x - 500.0).abs() < 1e-6 && (q.y - 1500.0).abs() < 1e-6, "{q:?}");
}

// ---- the format's error list, one case each ----

#[test]
fn error_not_toml() {
    refused("format = \"auv-mission/1\"\n[vehicle\n", &["not TOML", "line 2"]);
}

#[test]
fn error_wrong_or_missing_format() {
    refused(
        &edited("format = \"auv-mission/1\"", "format = \"auv-mission/2\""),
        &["format = \"auv-mission/2\": expected \"auv-mission/1\""],
    );
    refused(
        &edited("format = \"auv-mission/1\"", "format = 1"),
        &["format = 1: expected"],
    );
    refused(&edited("format = \"auv-mission/1\"\n", ""), &["format: missing"]);
}

#[test]
fn error_unknown_field() {
    refused(
        &edited("reserve_s = 100", "reserve_s = 100\ncolour = \"red\""),
        &["vehicle", "unknown field `colour`"],
    );
    refused(
        &edited("depth_m = 5", "depth_m = 5\ndepht_m = 5"),
        &["waypoint[0]", "unknown field `depht_m`"],
    );
    refused(&edited("seed = 3", "seed = 3\nspeed = 2"), &["unknown field `speed`"]);
}

#[test]
fn error_wrong_type() {
    refused(
        &edited("speed_mps = 1.5", "speed_mps = \"fast\""),
        &["vehicle.speed_mps", "invalid type"],
    );
    refused(&edited("seed = 3", "seed = -3"), &["seed", "invalid value"]);
    refused(
        &edited("bound_m = [200, 200, 10]", "bound_m = [200, 200]"),
        &["waypoint[1].dynamic.bound_m"],
    );
}

#[test]
fn error_nan_infinite_or_out_of_range_numbers() {
    refused(
        &edited("speed_mps = 1.5", "speed_mps = nan"),
        &["vehicle.speed_mps = NaN: must be finite and > 0"],
    );
    refused(
        &edited("time_available_s = 20000", "time_available_s = inf"),
        &["vehicle.time_available_s = inf: must be finite and > 0"],
    );
    refused(
        &edited("depth_m = 20", "depth_m = 1200"),
        &["waypoint[1].depth_m = 1200: must be finite and in [0, 1000]"],
    );
    refused(
        &edited("risk = 0.35", "risk = 0"),
        &["tasks.edge[0].risk = 0: must be finite and > 0"],
    );
    refused(
        &edited("risk = [0.1, 1.0]", "risk = [1.0, 0.1]"),
        &["tasks.draw.risk: [1, 0.1]: the lower end exceeds"],
    );
    refused(
        &edited("prize = 2", "prize = -2"),
        &["waypoint[1].prize = -2: must be finite and >= 0"],
    );
    refused(&edited("sigma_m = 50", "sigma_m = 0"), &["sensing.sigma_m = 0"]);
    refused(
        &edited("lat = 48.99", "lat = 98.99"),
        &["frame.origin.lat = 98.99: must be a latitude in [-90, 90]"],
    );
}

#[test]
fn error_position_given_both_ways_or_neither() {
    refused(
        &edited(
            "x_m = 500\ny_m = 1500",
            "x_m = 500\ny_m = 1500\nlat = 49.0\nlon = -58.1",
        ),
        &["waypoint[2] (\"west\"): position given both ways"],
    );
    refused(
        &edited("x_m = 500\ny_m = 1500\n", ""),
        &["waypoint[2] (\"west\"): no position"],
    );
    refused(
        &edited("x_m = 500\ny_m = 1500", "x_m = 500"),
        &["waypoint[2] (\"west\"): x_m without y_m"],
    );
}

#[test]
fn error_lat_lon_without_an_origin() {
    let png = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/benoits-cove.png");
    let text = BASE
        .replacen("[frame]\norigin = { lat = 48.99, lon = -58.17 }\n", "", 1)
        .replacen(
            "land_geojson = \"island.geojson\"\nextent_m = [4000, 3000]",
            &format!("png = {:?}\nmetres_per_pixel = 10", png.display().to_string()),
            1,
        )
        .replacen("x_m = 500\ny_m = 1500", "lat = 49.0\nlon = -58.1", 1);
    refused(&text, &["waypoint[2] (\"west\"): lat/lon needs a frame origin"]);
    // A GeoJSON chart needs the origin too.
    let text = BASE.replacen("[frame]\norigin = { lat = 48.99, lon = -58.17 }\n", "", 1);
    refused(&text, &["chart.land_geojson: needs [frame] origin"]);
}

#[test]
fn error_duplicate_names() {
    refused(
        &edited("name = \"east\"", "name = \"west\""),
        &["waypoint[3] (\"west\"): duplicate name (also waypoint[2])"],
    );
    refused(&edited("name = \"east\"", "name = \"\""), &["waypoint[3].name: empty"]);
}

#[test]
fn error_not_exactly_one_start_and_one_goal() {
    refused(&edited("role = \"start\"\n", ""), &["no waypoint has role = \"start\""]);
    refused(
        &edited("name = \"east\"", "name = \"east\"\nrole = \"goal\""),
        &["2 waypoints have role = \"goal\" (\"east\", \"recovery\")"],
    );
    refused(
        &edited("role = \"start\"", "role = \"begin\""),
        &["waypoint[0].role (\"dock\"): \"begin\""],
    );
}

#[test]
fn error_start_equals_goal() {
    let text = edited(
        "x_m = 3500\ny_m = 2500\ndepth_m = 10",
        "x_m = 500\ny_m = 500\ndepth_m = 5",
    );
    refused(
        &text,
        &["the start (\"dock\") and the goal (\"recovery\") are at the same position"],
    );
}

#[test]
fn error_waypoint_on_land_or_outside_the_area() {
    refused(
        &edited("x_m = 2500\ny_m = 1500", "x_m = 1500\ny_m = 1200"),
        &["waypoint[3] (\"east\"): on land at (1500.0, 1200.0) m"],
    );
    refused(
        &edited("x_m = 2500\ny_m = 1500", "x_m = 4500\ny_m = 1500"),
        &["waypoint[3] (\"east\"): outside the area: at (4500.0, 1500.0) m, the chart covers [0, 4000) × [0, 3000) m"],
    );
    // On the raster chart too: deep in Benoit's Cove's western land.
    let text = "format = \"auv-mission/1\"\n[chart]\nembedded = \"benoits-cove\"\n[vehicle]\nspeed_mps = 1.5\n\
                time_available_s = 30000\n[[waypoint]]\nname = \"a\"\nx_m = 1000\ny_m = 2000\ndepth_m = 1\nrole = \"start\"\n\
                [[waypoint]]\nname = \"b\"\nx_m = 2700\ny_m = 6000\ndepth_m = 1\nrole = \"goal\"\n";
    refused(text, &["waypoint[0] (\"a\"): on land at (1000.0, 2000.0) m"]);
}

#[test]
fn error_dynamic_bound_that_cannot_stay_over_water() {
    // A buoy in the island's 20 m lake with a 400 m bound: almost all land.
    let text = edited(
        "x_m = 3000\ny_m = 500\ndepth_m = 20",
        "x_m = 1500\ny_m = 1500\ndepth_m = 20",
    )
    .replacen("bound_m = [200, 200, 10]", "bound_m = [400, 400, 10]", 1);
    refused(
        &text,
        &[
            "waypoint[1] (\"buoy\"): dynamic bound cannot stay over water",
            "% of its box",
        ],
    );
    // The start and the goal cannot drift at all.
    refused(
        &edited(
            "role = \"start\"",
            "role = \"start\"\ndynamic = { bound_m = [10, 10, 1] }",
        ),
        &["waypoint[0] (\"dock\"): the start and the goal cannot be dynamic"],
    );
}

#[test]
fn error_explicit_task_on_a_pair_that_is_no_edge_or_named_twice() {
    let no_edge =
        format!("{BASE}\n[[tasks.edge]]\na = \"west\"\nb = \"east\"\npriority = 1\nrisk = 1\ntask_time_s = 0\n");
    refused(
        &no_edge,
        &["tasks.edge[1] (west – east): no edge: the straight segment between the two waypoints crosses land"],
    );
    let twice =
        format!("{BASE}\n[[tasks.edge]]\na = \"buoy\"\nb = \"dock\"\npriority = 1\nrisk = 1\ntask_time_s = 0\n");
    refused(
        &twice,
        &["tasks.edge[1] (buoy – dock): this pair already has a task (tasks.edge[0])"],
    );
    let self_loop =
        format!("{BASE}\n[[tasks.edge]]\na = \"buoy\"\nb = \"buoy\"\npriority = 1\nrisk = 1\ntask_time_s = 0\n");
    refused(
        &self_loop,
        &["tasks.edge[1] (buoy – buoy): a task joins two different waypoints"],
    );
}

#[test]
fn error_unknown_waypoint_name_in_a_task() {
    refused(
        &edited("b = \"buoy\"", "b = \"bouy\""),
        &["tasks.edge[0] (dock – bouy): unknown waypoint \"bouy\""],
    );
}

#[test]
fn error_more_waypoints_than_the_planners_capacity() {
    let text = format!("{BASE}\n[generate]\nstatic = 500\ndynamic = 30\n");
    refused(
        &text,
        &["535 waypoints (5 explicit + 530 generated) exceed the real-time planner's capacity of 512"],
    );
    refused(
        &format!("{BASE}\n[generate]\nstatic = -1\n"),
        &["generate.static = -1: must be an integer in 0..=512"],
    );
}

#[test]
fn error_chart_missing_unreadable_without_water_or_not_polygons() {
    refused(
        &edited("\"island.geojson\"", "\"nowhere.geojson\""),
        &["chart: cannot read chart file", "nowhere.geojson"],
    );
    // A folder is not a readable file.
    refused(
        &edited("\"island.geojson\"", "\".\""),
        &["chart: cannot read chart file"],
    );
    refused(
        &edited("\"island.geojson\"", "\"all-land.geojson\""),
        &["chart: ", "all-land.geojson", "no water"],
    );
    refused(
        &edited("\"island.geojson\"", "\"line.geojson\""),
        &["chart: ", "a LineString is not a land polygon"],
    );
    refused(
        &edited(
            "land_geojson = \"island.geojson\"\nextent_m = [4000, 3000]",
            "png = \"missing.png\"\nmetres_per_pixel = 10",
        ),
        &["chart: cannot read chart file", "missing.png"],
    );
    refused(
        &edited(
            "extent_m = [4000, 3000]",
            "extent_m = [4000, 3000]\nembedded = \"benoits-cove\"",
        ),
        &["chart: give exactly one of embedded, png, land_geojson (2 given)"],
    );
    refused(
        &edited(
            "land_geojson = \"island.geojson\"\nextent_m = [4000, 3000]",
            "embedded = \"atlantis\"",
        ),
        &["chart.embedded: \"atlantis\" is not an embedded chart"],
    );
    refused(
        &edited("extent_m = [4000, 3000]\n", ""),
        &["chart.extent_m: required with chart.land_geojson"],
    );
}

#[test]
fn error_start_with_no_route_to_the_goal_within_the_budget() {
    refused(
        &edited("time_available_s = 20000", "time_available_s = 1000"),
        &["no route from the start (\"dock\") reaches the goal (\"recovery\") within the budget: the quickest takes"],
    );
    // The goal in the island's lake: no chain of edges reaches it.
    let text = edited(
        "x_m = 3500\ny_m = 2500\ndepth_m = 10",
        "x_m = 1500\ny_m = 1500\ndepth_m = 10",
    );
    refused(&text, &["within the budget: no chain of edges over water joins them"]);
    refused(
        &edited("reserve_s = 100", "reserve_s = 20000"),
        &["vehicle.reserve_s = 20000 leaves nothing"],
    );
}

#[test]
fn missing_files_are_named() {
    let e = load(Path::new("/no/such/mission.toml"), Overrides::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("/no/such/mission.toml: cannot read"), "{e}");
}

// ---- the shipped missions ----

fn repo_file(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(rel)
}

#[test]
fn the_embedded_default_is_the_generators_seed_1_world() {
    let m = load_default(Overrides::default()).unwrap();
    let (generated, _) = crate::scenario::load_world(&crate::scenario::ScenarioConfig::default(), 1).unwrap();
    assert_eq!(m.world.snapshot("x"), generated.snapshot("x"));
    assert_eq!(m.world.bounds(), generated.bounds());
    assert_eq!(m.world.dynamic_nodes(), generated.dynamic_nodes());
    assert_eq!(m.world.config().sensor_period_s, 60.0);
    // The service's own default reserve, written into the file.
    assert_eq!(m.reserve_s, 300.0);
    // The file in the repository is the embedded one.
    let text = std::fs::read_to_string(repo_file("missions/benoits-cove.toml")).unwrap();
    assert_eq!(text, DEFAULT_MISSION_TOML);
}

#[test]
fn the_shipped_example_missions_resolve() {
    for (file, n_min) in [
        ("missions/bay-of-islands-survey.toml", 8),
        ("missions/benoits-cove-geojson.toml", 6),
    ] {
        let m = load(&repo_file(file), Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
        assert!(m.world.n() >= n_min, "{file}");
        assert!(m.frame.is_some(), "{file} has an origin");
    }
}

#[test]
fn a_chart_file_is_named_as_the_mission_path_gives_it_and_fingerprinted_by_its_absolute_path() {
    // Unit tests run in the crate's folder: a relative path, as a user types one.
    let relative = Path::new("../../missions/benoits-cove-geojson.toml");
    let m = load(relative, Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(m.chart, "../../missions/charts/benoits-cove-land.geojson");
    let absolute = load(&repo_file("missions/benoits-cove-geojson.toml"), Overrides::default()).unwrap();
    assert!(Path::new(&absolute.chart).is_absolute());
    assert_eq!(m.world.fingerprint(), absolute.world.fingerprint());
}
