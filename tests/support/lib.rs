//! Shared helpers for the workspace-level tests in `tests/`: locating (and
//! building) the real binaries, isolated iceoryx2 prefixes, and running the
//! processes under a watchdog.
#![warn(missing_docs)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// The workspace root (where the top-level `Cargo.toml` lives).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `target/<profile>/`, the folder of the binaries built with the same
/// profile as this test (the test runs from `target/<profile>/deps/`).
pub fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test executable has a path");
    let deps = exe.parent().expect("test executables live in target/<profile>/deps");
    deps.parent().expect("deps has a parent").to_path_buf()
}

/// The workspace binaries the multi-process tests start.
pub const BINARIES: [&str; 3] = ["planner", "sensor-sim", "vehicle-sim"];

/// Path of the real binary `name`, built first: once per test process,
/// `cargo build` of the three binary packages with this test's profile, so a
/// stale binary from an older build never answers (iceoryx2 would refuse its
/// message types anyway).
pub fn binary(name: &str) -> PathBuf {
    static BUILT: OnceLock<Result<(), String>> = OnceLock::new();
    let built = BUILT.get_or_init(|| {
        let dir = profile_dir();
        let profile = dir.file_name().and_then(|s| s.to_str()).unwrap_or("debug").to_string();
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.current_dir(workspace_root()).args(["build", "--quiet"]);
        for p in BINARIES {
            cmd.args(["-p", p]);
        }
        match profile.as_str() {
            "debug" => {}
            "release" => {
                cmd.arg("--release");
            }
            other => {
                cmd.args(["--profile", other]);
            }
        }
        let out = cmd.output().map_err(|e| format!("cannot run cargo: {e}"))?;
        if out.status.success() {
            Ok(())
        } else {
            Err(String::from_utf8_lossy(&out.stderr).into_owned())
        }
    });
    if let Err(e) = built {
        panic!("building the binaries failed:\n{e}");
    }
    let p = profile_dir().join(name);
    assert!(p.is_file(), "{} missing after the build", p.display());
    p
}

/// A fresh iceoryx2 isolation prefix for one test (short: socket paths are
/// limited to 108 bytes).
pub fn prefix(tag: &str) -> String {
    auv_transport::unique_prefix(tag)
}

/// A fresh empty folder under the target directory.
pub fn temp_dir(tag: &str) -> PathBuf {
    let d = profile_dir().join("test-runs").join(prefix(tag));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create the test folder");
    d
}

/// A scaled-time `planner mission` of the tests' small network (12
/// waypoints, seed 2) at `scale` mission seconds per second, in domain
/// `prefix`, writing into `out`, with `extra` flags.
pub fn start_scaled_mission(out: &Path, prefix: &str, scale: &str, extra: &[&str]) -> Child {
    Command::new(binary("planner"))
        .args([
            "mission",
            "--quiet",
            "--nodes",
            "12",
            "--seed",
            "2",
            "--time-scale",
            scale,
        ])
        .args(["--ipc-prefix", prefix])
        .args(extra)
        .arg("--out")
        .arg(out)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start the mission")
}

/// Runs `bin args…` to completion, killing it after `limit` (a watchdog, not
/// a timing assertion: a hung process must not hang the test suite).
pub fn run(bin: &Path, args: &[&str], limit: Duration) -> Output {
    let child = Command::new(bin)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("start {}: {e}", bin.display()));
    wait_with_watchdog(child, limit)
}

/// Waits for `child`, killing it after `limit`.
pub fn wait_with_watchdog(mut child: Child, limit: Duration) -> Output {
    let t0 = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(_)) => break,
            Ok(None) if t0.elapsed() > limit => {
                let _ = child.kill();
                let out = child.wait_with_output().expect("collect output");
                panic!(
                    "watchdog: killed after {limit:?}\nstdout:\n{}\nstderr:\n{}",
                    String::from_utf8_lossy(&out.stdout),
                    String::from_utf8_lossy(&out.stderr)
                );
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => panic!("wait: {e}"),
        }
    }
    child.wait_with_output().expect("collect output")
}

/// Reads and parses a JSON file.
pub fn read_json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("parse {}: {e}", path.display()))
}

/// Files of the iceoryx2 domain `prefix` still on the machine.
pub fn leftovers(prefix: &str) -> Vec<PathBuf> {
    auv_transport::ipc::leftover_files(prefix)
}

/// (tasks, weight, route) as the vehicle's journal states them, read line by
/// line here (independently of the planner's own reader): task lines
/// counted and their weights summed in order, the start node then every arrival.
pub fn journal_totals(path: &Path) -> (u64, f64, Vec<u64>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()));
    let (mut tasks, mut weight, mut route) = (0, 0.0, Vec::new());
    for line in text.lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("{line}: {e}"));
        match v["event"].as_str() {
            Some("task") => {
                tasks += 1;
                weight += v["weight"].as_f64().expect("task weight");
            }
            Some("start") if route.is_empty() => route.push(v["node"].as_u64().expect("start node")),
            Some("arrival") => route.push(v["node"].as_u64().expect("arrival node")),
            _ => {}
        }
    }
    (tasks, weight, route)
}

/// Asserts that the report's tasks, weight and route are the journal's
/// (the mission's `out` folder), as [`journal_totals`] reads it.
pub fn assert_report_matches_journal(r: &serde_json::Value, out: &Path) {
    let (tasks, weight, route) = journal_totals(&out.join("journal.jsonl"));
    assert_eq!(r["tasks_completed"].as_u64(), Some(tasks), "{r:#}");
    assert_eq!(r["weight"].as_f64(), Some(weight), "{r:#}");
    let reported: Vec<u64> = r["route"]
        .as_array()
        .expect("the report's route")
        .iter()
        .filter_map(|v| v.as_u64())
        .collect();
    assert_eq!(reported, route, "{r:#}");
}
