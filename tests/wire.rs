//! Bad input on the wire, with the real binaries: every kind of bad message
//! a process can inject is rejected by its receivers, counted under its
//! kind in `report.json`, logged without flooding, and the mission still
//! runs exactly as without it. Lockstep, a small scenario, each mission in
//! its own iceoryx2 prefix; two missions in all.

use std::time::Duration;

use auv_system::{binary, leftovers, prefix, read_json, run, temp_dir};
use serde_json::Value;

const LIMIT: Duration = Duration::from_secs(240);

/// Kinds sensor-sim injects (snapshots, refused by the planner and the
/// vehicle); the first seven are the issue's, the last two the remaining
/// validator kinds.
const SENSOR: [&str; 9] = [
    "non_finite",
    "node_out_of_range",
    "off_water",
    "outside_bound",
    "out_of_order",
    "repeated",
    "foreign_scenario",
    "malformed",
    "out_of_range",
];
/// Kinds vehicle-sim injects (states, refused by the planner); the issue's
/// first, then the remaining validator kinds.
const VEHICLE: [&str; 7] = [
    "non_finite",
    "node_out_of_range",
    "out_of_order",
    "repeated",
    "foreign_scenario",
    "malformed",
    "out_of_range",
];
/// Kinds the planner injects (plans, refused by the vehicle); the first.
const PLAN: [&str; 3] = ["non_edge", "visited_node", "bad_plan"];

/// Runs a lockstep mission on 12 waypoints; returns (report, the planner's stderr, prefix).
fn mission(extra: &[&str]) -> (Value, String, String) {
    mission_with(true, extra)
}

/// Runs a mission on 12 waypoints, lockstep or not; returns (report, the
/// planner process's stderr, prefix).
fn mission_with(lockstep: bool, extra: &[&str]) -> (Value, String, String) {
    let out = temp_dir("w");
    let p = prefix("w");
    let out_s = out.display().to_string();
    let mut args = vec![
        "mission",
        "--quiet",
        "--seed",
        "1",
        "--nodes",
        "12",
        "--out",
        &out_s,
        "--ipc-prefix",
        &p,
    ];
    if lockstep {
        args.push("--lockstep");
    }
    args.extend_from_slice(extra);
    let o = run(&binary("planner"), &args, LIMIT);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "mission failed ({:?}):\n{err}", o.status.code());
    // The planner runs as a child of the mission; its stderr is its log.
    let planner = std::fs::read_to_string(out.join("planner.log")).expect("planner.log");
    (read_json(&out.join("report.json")), planner, p)
}

fn count(r: &Value, receiver: &str, kind: &str) -> u64 {
    r["rejected_by_receiver"][receiver][kind]
        .as_u64()
        .unwrap_or_else(|| panic!("no count for {receiver}/{kind}: {r:#}"))
}

#[test]
fn every_injected_kind_is_rejected_counted_by_kind_and_the_mission_runs_as_without_it() {
    let (clean, _, _) = mission(&[]);
    assert_eq!(clean["rejected_messages"], 0, "{clean:#}");
    // The kinds; the other three stay clean here, so a good message
    // refused (or a bad one misfiled) under them would show.
    let (sensor, vehicle, plan) = (SENSOR[..7].join(","), VEHICLE[..5].join(","), PLAN[..2].join(","));
    let (r, stderr, p) = mission(&[
        "--inject-sensor",
        &sensor,
        "--inject-vehicle",
        &vehicle,
        "--inject-plan",
        &plan,
    ]);
    // Each kind is refused by the receivers it was sent to, under its name.
    for kind in &SENSOR[..7] {
        assert!(count(&r, "planner", kind) > 0, "planner never refused {kind}: {r:#}");
        assert!(count(&r, "vehicle", kind) > 0, "vehicle never refused {kind}: {r:#}");
    }
    for kind in &VEHICLE[..5] {
        assert!(
            count(&r, "planner", kind) > 0,
            "planner never refused state {kind}: {r:#}"
        );
    }
    for kind in &PLAN[..2] {
        assert!(
            count(&r, "vehicle", kind) > 0,
            "vehicle never refused plan {kind}: {r:#}"
        );
        assert_eq!(count(&r, "planner", kind), 0, "the planner receives no plans");
    }
    // Nothing good was refused and nothing bad misfiled under another kind.
    for receiver in ["planner", "vehicle"] {
        for kind in ["malformed", "out_of_range", "bad_plan"] {
            assert_eq!(count(&r, receiver, kind), 0, "{receiver}/{kind}: {r:#}");
        }
    }
    let plan_refusals = count(&r, "vehicle", "non_edge") + count(&r, "vehicle", "visited_node");
    // Lockstep: every plan answers the vehicle's current state, so none is stale.
    assert_eq!(r["stale_plans"].as_u64(), Some(0), "{r:#}");
    let by_kind_total: u64 = r["rejected_by_kind"]
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert_eq!(r["rejected_messages"].as_u64(), Some(by_kind_total));
    // The good flow was untouched: the same mission as without injection.
    assert_eq!(r["goal_reached"], true, "{r:#}");
    for key in [
        "route",
        "time_used_s",
        "weight",
        "tasks_completed",
        "plans",
        "sensor_updates",
    ] {
        assert_eq!(r[key], clean[key], "{key} changed under injection");
    }
    assert!(r["time_used_s"].as_f64().unwrap() <= r["time_available_s"].as_f64().unwrap());
    // Logged without flooding: per kind, the first refusal and then at most
    // one line a second.
    let lines = stderr
        .lines()
        .filter(|l| l.starts_with("planner: rejected") || l.starts_with("planner: refusing"))
        .count() as f64;
    let kinds = 12.0;
    let wall = r["wall_time_s"].as_f64().unwrap();
    let refused = (r["rejected_messages"].as_u64().unwrap() - plan_refusals) as f64;
    assert!(lines >= 1.0, "no refusal logged:\n{stderr}");
    assert!(
        lines <= kinds * (wall + 1.0) * 2.0 && lines < refused,
        "{lines} lines for {refused} refusals in {wall} s"
    );
    // Refusing costs the planner no allocation either.
    assert_eq!(r["steady_state_allocations"], 0, "{:#}", r["allocations"]);
    assert_eq!(r["shm_files_left"], 0);
    assert!(leftovers(&p).is_empty(), "{:?}", leftovers(&p));
}

#[test]
fn scaled_time_missions_refuse_bad_input_too() {
    // Scaled time (what a soak runs): the pacing is the machine's, so only
    // the outcome-independent facts are asserted.
    let (r, stderr, p) = mission_with(
        false,
        &[
            "--time-scale",
            "10000",
            "--inject-sensor",
            "all",
            "--inject-vehicle",
            "all",
            "--inject-plan",
            "all",
        ],
    );
    // `all`: every one of the twelve kinds, each refused by its receiver.
    for kind in SENSOR.iter().chain(&VEHICLE) {
        assert!(
            count(&r, "planner", kind) > 0,
            "planner never refused {kind}: {r:#}\n{stderr}"
        );
    }
    for kind in SENSOR.iter().chain(&PLAN) {
        assert!(
            count(&r, "vehicle", kind) > 0,
            "vehicle never refused {kind}: {r:#}\n{stderr}"
        );
    }
    assert!(r["outcome"] == "goal_reached" || r["outcome"] == "timed_out", "{r:#}");
    assert!(r["time_used_s"].as_f64().unwrap() <= r["time_available_s"].as_f64().unwrap());
    assert_eq!(r["shm_files_left"], 0);
    assert!(leftovers(&p).is_empty(), "{:?}", leftovers(&p));
}

/// Exit code and stderr of a run that must fail at once.
fn refused(bin: &str, args: &[&str]) -> (Option<i32>, String) {
    let o = run(&binary(bin), args, Duration::from_secs(60));
    (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
}

#[test]
fn unknown_inject_kinds_are_one_line_usage_errors() {
    let p = prefix("w");
    let cases: [(&str, Vec<&str>, &str); 5] = [
        ("sensor-sim", vec!["--inject", "non_finite,bogus"], "bogus"),
        ("vehicle-sim", vec!["--inject", "off_water"], "off_water"),
        ("planner", vec!["mission", "--inject-sensor", "nope"], "nope"),
        ("planner", vec!["mission", "--inject-vehicle", "non_edge"], "non_edge"),
        ("planner", vec!["serve", "--inject-plan", "repeated"], "repeated"),
    ];
    for (bin, mut args, bad) in cases {
        args.extend(["--nodes", "12", "--ipc-prefix", &p]);
        let (code, err) = refused(bin, &args);
        assert_eq!(code, Some(2), "{bin} {args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{bin} {args:?}: {err}");
        assert!(err.contains(bad) && err.contains("unknown kind"), "{bin}: {err}");
    }
    assert!(leftovers(&p).is_empty(), "{:?}", leftovers(&p));
}
