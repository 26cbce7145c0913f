//! `sensor-sim`: moves the drifting waypoints and publishes snapshots.
//! The iceoryx2 process arrives with the three-process system; until then this
//! binary only reports that it is not wired yet.
fn main() {
    eprintln!("sensor-sim: the three-process system is not built yet (see the planner's `mission` command)");
    std::process::exit(2);
}
