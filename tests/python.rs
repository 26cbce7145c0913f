//! The Python client's suite (`clients/python/run-tests.sh`: a virtual
//! environment under target/, `pip install ./clients/python`, pytest) run
//! against the binaries of this build, so `cargo test --workspace` covers
//! it: the layout check of the ctypes mirrors, a lockstep mission with the
//! Python vehicle, the watcher on a scaled-time mission, and bad messages
//! from Python. It fails when pytest fails; it never skips quietly: without
//! python3 it fails too, unless `AUV_SKIP_PYTHON_TESTS=1` says to skip.

use std::process::Command;
use std::time::Duration;

use auv_system::{binary, profile_dir, wait_with_watchdog, workspace_root};

#[test]
fn the_python_client_suite_passes() {
    let python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
    let found = Command::new(&python)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !found {
        if std::env::var("AUV_SKIP_PYTHON_TESTS").as_deref() == Ok("1") {
            eprintln!("SKIPPED: {python} not found and AUV_SKIP_PYTHON_TESTS=1");
            return;
        }
        panic!("{python} not found: install Python 3.9+ (or set AUV_SKIP_PYTHON_TESTS=1 to skip explicitly)");
    }
    // Builds planner, sensor-sim and vehicle-sim with this test's profile.
    binary("planner");
    let script = workspace_root().join("clients/python/run-tests.sh");
    let child = Command::new("sh")
        .arg(&script)
        .env("AUV_BIN_DIR", profile_dir())
        .env("PYTHON", &python)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("start {}: {e}", script.display()));
    let out = wait_with_watchdog(child, Duration::from_secs(1200));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "the Python suite failed ({:?}):\n{stdout}\n{stderr}",
        out.status.code()
    );
    // Show pytest's summary in `cargo test -- --nocapture`.
    println!("{stdout}");
}
