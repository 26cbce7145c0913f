//! The short soak CI runs: three missions back to back with random faults
//! (kills and restarts, pauses) and bad messages of every kind, real
//! processes, then the leak and memory checks of `soak.json`.

use std::time::Duration;

use auv_system::{binary, read_json, run, temp_dir};

#[test]
fn a_short_soak_with_faults_completes_every_mission_and_leaks_nothing() {
    let out = temp_dir("s");
    let out_s = out.display().to_string();
    let o = run(
        &binary("planner"),
        &[
            "soak",
            "--missions",
            "3",
            "--faults",
            "--bad-messages",
            "--seed",
            "1",
            "--nodes",
            "10",
            "--time-scale",
            "4000",
            "--stall-timeout-ms",
            "600",
            "--out",
            &out_s,
        ],
        Duration::from_secs(300),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = read_json(&out.join("soak.json"));
    assert_eq!(v["missions"], 3, "{v:#}");
    assert_eq!(v["completed"], 3, "{v:#}");
    let injected = v["faults_injected"].as_u64().unwrap();
    assert!(injected >= 3, "{v:#}");
    assert_eq!(v["faults_survived"], injected, "{v:#}");
    assert_eq!(v["faults_injected_by_kind"], v["faults_survived_by_kind"], "{v:#}");
    // Cleared: restarted processes heard from again, pauses detected; only
    // a fault the mission's end overtook may be missing.
    let cleared = v["faults_cleared"].as_u64().unwrap();
    assert_eq!(
        cleared + v["faults_cut_short_by_mission_end"].as_u64().unwrap(),
        injected,
        "{v:#}"
    );
    assert!(cleared >= 3, "{v:#}");
    assert_eq!(v["shm_files_leaked"], 0, "{v:#}");
    // Bad messages of every kind were sent by all three processes: every
    // kind was rejected, and the missions still completed.
    assert_eq!(v["bad_messages"], true);
    let by_kind = v["rejected_messages_by_kind"].as_object().unwrap();
    assert!(by_kind.len() >= 12, "{v:#}");
    for (kind, n) in by_kind {
        assert!(n.as_u64().unwrap() > 0, "no {kind} rejected: {v:#}");
    }
    for key in [
        "reached_goal",
        "deadline_misses",
        "steady_state_allocations",
        "rejected_messages",
    ] {
        assert!(v[key].as_u64().is_some(), "{key}: {v:#}");
    }
    // Restarted peers are connected from the planner's start-up pool.
    assert_eq!(v["steady_state_allocations"], 0, "{v:#}");
    // Memory: every mission's children peak about the same (same-sized
    // scenarios), and this supervisor does not grow by more than a few MB.
    for p in ["planner", "sensor-sim", "vehicle-sim"] {
        let (start, end) = (
            v["rss_kb"][p]["start"].as_u64().unwrap(),
            v["rss_kb"][p]["end"].as_u64().unwrap(),
        );
        assert!(start > 0 && end <= start + start / 4, "{p}: {v:#}");
    }
    let s = &v["rss_kb"]["supervisor"];
    assert!(
        s["end"].as_u64().unwrap() <= s["after_first"].as_u64().unwrap() + 8 * 1024,
        "{v:#}"
    );
    // The host's steal time, over the soak and per mission (Linux).
    assert!(v["host_steal_ms"].as_f64().is_some_and(|ms| ms >= 0.0), "{v:#}");
    assert!(v["per_mission"][2]["host_steal_ms"].as_f64().is_some(), "{v:#}");
    // The supervisor's size after each mission, for spotting growth.
    assert_eq!(v["per_mission"][0]["supervisor_rss_kb"], s["after_first"], "{v:#}");
    assert_eq!(v["per_mission"][2]["supervisor_rss_kb"], s["end"], "{v:#}");
    for k in 0..3 {
        assert!(out.join(format!("mission-{k}/report.json")).is_file());
    }
}
