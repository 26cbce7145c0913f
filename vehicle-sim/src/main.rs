//! `vehicle-sim`: follows the latest plan edge by edge and publishes its state.
//! The iceoryx2 process arrives with the three-process system; until then this
//! binary only reports that it is not wired yet.
fn main() {
    eprintln!("vehicle-sim: the three-process system is not built yet (see the planner's `mission` command)");
    std::process::exit(2);
}
