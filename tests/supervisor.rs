//! The supervisor against faults it did not cause: the real `planner
//! mission` in scaled time, its children killed from here (the way an
//! operator or the OOM killer would) by the pids it publishes in
//! `pids.json`; the restart budget and its safe hold; SIGTERM to the
//! supervisor; and a supervisor killed with SIGKILL.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use auv_system::{assert_report_matches_journal, binary, leftovers, prefix, read_json, temp_dir, wait_with_watchdog};

/// Watchdog of one mission (not a timing assertion).
const LIMIT: Duration = Duration::from_secs(240);

/// One mission at a time: several scaled-time missions at once on a small
/// machine would starve each other into stalls.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn alone() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// Starts a scaled-time mission writing into `out`.
fn start_mission(out: &Path, p: &str, extra: &[&str]) -> Child {
    auv_system::start_scaled_mission(out, p, "1500", extra)
}

/// Waits until the planner has published a plan and `name`'s pid in
/// `pids.json` is a running process other than `not`; returns it.
fn running_pid(out: &Path, name: &str, not: Option<u64>) -> u64 {
    let t0 = Instant::now();
    loop {
        assert!(t0.elapsed() < LIMIT, "no running {name} within {LIMIT:?}");
        let planned = std::fs::read_to_string(out.join("mission.log")).is_ok_and(|l| l.contains("\"plan\""));
        let pid = std::fs::read_to_string(out.join("pids.json"))
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
            .and_then(|v| v[name].as_u64());
        if let Some(pid) = pid
            && planned
            && Some(pid) != not
            && Path::new(&format!("/proc/{pid}")).exists()
        {
            return pid;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn sigkill(pid: u64) {
    // SAFETY: a signal to a pid the mission's supervisor published as its child.
    unsafe { libc::kill(pid as libc::pid_t, libc::SIGKILL) };
}

/// The report's tasks, weight and route are the journal's; nothing the
/// vehicle announced is missing from it; nothing leaked.
fn assert_report_adds_up(r: &serde_json::Value, out: &Path, p: &str) {
    assert_report_matches_journal(r, out);
    assert_eq!(r["journal_check"]["lost_events"], 0, "{r:#}");
    assert_eq!(r["shm_files_left"], 0, "{r:#}");
    assert!(leftovers(p).is_empty(), "{:?}", leftovers(p));
}

fn killed_from_outside_the_mission_reaches_the_goal(name: &str) {
    let _alone = alone();
    let out = temp_dir("x");
    let p = prefix("x");
    let child = start_mission(&out, &p, &[]);
    let pid = running_pid(&out, name, None);
    sigkill(pid);
    // The supervisor publishes the restarted process's new pid.
    running_pid(&out, name, Some(pid));
    let o = wait_with_watchdog(child, LIMIT);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = read_json(&out.join("report.json"));
    assert_eq!(r["outcome"], "goal_reached", "{r:#}");
    assert_eq!(r["reason"], serde_json::Value::Null, "{r:#}");
    let s = &r["supervision"];
    assert!(s["restarts"][name]["external"].as_u64().unwrap() >= 1, "{s:#}");
    assert_eq!(s["restarts_total"]["injected"], 0, "{s:#}");
    if name == "vehicle-sim" {
        assert!(r["vehicle_restarts"].as_u64().unwrap() >= 1, "{r:#}");
    }
    assert_report_adds_up(&r, &out, &p);
}

#[test]
fn a_planner_killed_from_outside_is_restarted_and_the_mission_reaches_the_goal() {
    killed_from_outside_the_mission_reaches_the_goal("planner");
}

#[test]
fn a_sensor_killed_from_outside_is_restarted_and_the_mission_reaches_the_goal() {
    killed_from_outside_the_mission_reaches_the_goal("sensor-sim");
}

#[test]
fn a_vehicle_killed_from_outside_resumes_from_its_journal_and_reaches_the_goal() {
    killed_from_outside_the_mission_reaches_the_goal("vehicle-sim");
}

/// The same in a `--lockstep` mission (the default mission: long enough
/// for the kill to land mid-run), where the vehicle waits for every answer:
/// the restarted process picks up where the dead one was.
fn killed_in_lockstep_the_mission_reaches_the_goal(name: &str) {
    let _alone = alone();
    let out = temp_dir("l");
    let p = prefix("l");
    let child = Command::new(binary("planner"))
        .args(["mission", "--quiet", "--lockstep", "--seed", "2", "--ipc-prefix", &p])
        .arg("--out")
        .arg(&out)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start the mission");
    let pid = running_pid(&out, name, None);
    sigkill(pid);
    let o = wait_with_watchdog(child, LIMIT);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = read_json(&out.join("report.json"));
    assert_eq!(r["outcome"], "goal_reached", "{r:#}");
    assert_eq!(r["lockstep"], true, "{r:#}");
    let s = &r["supervision"];
    assert_eq!(s["restarts"][name]["external"], 1, "{s:#}");
    assert_eq!(s["restarts_total"]["injected"], 0, "{s:#}");
    assert_report_adds_up(&r, &out, &p);
}

#[test]
fn in_lockstep_a_killed_planner_is_restarted_and_the_mission_reaches_the_goal() {
    killed_in_lockstep_the_mission_reaches_the_goal("planner");
}

#[test]
fn in_lockstep_a_killed_sensor_is_restarted_and_the_mission_reaches_the_goal() {
    killed_in_lockstep_the_mission_reaches_the_goal("sensor-sim");
}

#[test]
fn in_lockstep_a_killed_vehicle_resumes_and_the_mission_reaches_the_goal() {
    killed_in_lockstep_the_mission_reaches_the_goal("vehicle-sim");
}

#[test]
fn a_process_killed_again_and_again_spends_its_budget_and_the_vehicle_holds() {
    let _alone = alone();
    let out = temp_dir("b");
    let p = prefix("b");
    let child = start_mission(&out, &p, &["--max-restarts", "2", "--restart-window-s", "600"]);
    let mut last = None;
    for _ in 0..3 {
        let pid = running_pid(&out, "sensor-sim", last);
        sigkill(pid);
        last = Some(pid);
    }
    let o = wait_with_watchdog(child, LIMIT);
    assert_eq!(o.status.code(), Some(3), "{}", String::from_utf8_lossy(&o.stderr));
    let r = read_json(&out.join("report.json"));
    assert_eq!(r["outcome"], "safe_hold", "{r:#}");
    let why = r["reason"].as_str().unwrap_or_default();
    assert!(why.contains("sensor-sim") && why.contains("2 restarts"), "{r:#}");
    assert_eq!(r["supervision"]["restarts"]["sensor-sim"]["external"], 2, "{r:#}");
    // The vehicle said so: it journaled its hold at a waypoint, then the end.
    let journal = std::fs::read_to_string(out.join("journal.jsonl")).unwrap();
    let tail: Vec<&str> = journal.lines().rev().take(2).collect();
    assert!(
        tail[1].contains("\"hold\"") && tail[0].contains("\"safe_hold\""),
        "{journal}"
    );
    assert_report_adds_up(&r, &out, &p);
}

#[test]
fn sigterm_to_the_supervisor_ends_the_run_cleanly_with_a_report() {
    let _alone = alone();
    let out = temp_dir("t");
    let p = prefix("t");
    let child = start_mission(&out, &p, &[]);
    running_pid(&out, "vehicle-sim", None);
    // SAFETY: SIGTERM to the mission we started.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) };
    let o = wait_with_watchdog(child, LIMIT);
    assert_eq!(o.status.code(), Some(130), "{}", String::from_utf8_lossy(&o.stderr));
    let r = read_json(&out.join("report.json"));
    assert_eq!(r["outcome"], "aborted", "{r:#}");
    assert!(r["reason"].as_str().is_some_and(|w| w.contains("SIGTERM")), "{r:#}");
    assert_eq!(r["supervision"]["restarts_total"]["external"], 0, "{r:#}");
    assert_report_adds_up(&r, &out, &p);
}

/// Whether a process of the domain `p` still runs (its command line names it).
fn any_child_of_domain(pids: &[u64], p: &str) -> bool {
    pids.iter().any(|pid| {
        std::fs::read(format!("/proc/{pid}/cmdline")).is_ok_and(|c| {
            String::from_utf8_lossy(&c).contains(p)
                && !std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|s| s.contains(") Z "))
        })
    })
}

#[test]
fn a_supervisor_killed_with_sigkill_leaves_no_child_and_the_next_run_cleans_its_domain() {
    let _alone = alone();
    let out = temp_dir("k");
    let p = prefix("k");
    let mut child = start_mission(&out, &p, &[]);
    running_pid(&out, "vehicle-sim", None);
    let v = read_json(&out.join("pids.json"));
    let pids: Vec<u64> = ["planner", "sensor-sim", "vehicle-sim"]
        .iter()
        .filter_map(|n| v[*n].as_u64())
        .collect();
    assert_eq!(pids.len(), 3, "{v:#}");
    child.kill().expect("SIGKILL the supervisor");
    child.wait().expect("reap it");
    // The children get SIGTERM from the kernel and stop; bounded wait, no
    // claim on how fast.
    let t0 = Instant::now();
    while any_child_of_domain(&pids, &p) {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "children still running: {pids:?}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    // The supervisor's own node and the domain remain, until the next run
    // (in another domain) cleans the dead supervisor's domain.
    let next_out = temp_dir("k");
    let o = auv_system::run(
        &binary("planner"),
        &[
            "mission",
            "--lockstep",
            "--quiet",
            "--nodes",
            "8",
            "--out",
            next_out.to_str().unwrap(),
        ],
        LIMIT,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(leftovers(&p).is_empty(), "{:?}", leftovers(&p));
}
