//! The subcommands of the three-process system, ready for the `planner`
//! command line to mount: `serve`, `mission`, `bench-latency` and the
//! bench's hidden helper `bench-echo`.

use std::process::ExitCode;

use super::bench::{BenchArgs, EchoArgs, run_bench, run_echo};
use super::run::{MissionArgs, run_mission};
use super::soak::{SoakArgs, run_soak};
use crate::serve::{ServeArgs, run_serve};

/// The three-process system's subcommands.
#[derive(Clone, Debug, clap::Subcommand)]
pub enum IpcCommand {
    /// Run a whole mission: sensor-sim and vehicle-sim as child processes,
    /// the re-planning service here; writes report.json, mission.log, mission.svg, mission.mcap.
    Mission(MissionArgs),
    /// Run N missions back to back (with random faults) and report on
    /// survival, leaks and memory: DIR/soak.json.
    Soak(SoakArgs),
    /// Run the re-planning service as a process of its own.
    Serve(ServeArgs),
    /// Measure trigger → plan latency across processes next to a raw iceoryx2 ping-pong.
    BenchLatency(BenchArgs),
    /// The onboard end of the shore link: the vehicle's topics on Zenoh,
    /// operator commands to the planner (`mission --shore` starts it).
    #[cfg(feature = "shore")]
    Link(crate::shore::link::LinkArgs),
    /// The operator's console: watch a vehicle over its shore link, record
    /// it, send a command.
    #[cfg(feature = "shore")]
    Shore(crate::shore::console::ShoreArgs),
    /// (Used by bench-latency) answer raw pings.
    #[command(hide = true)]
    BenchEcho(EchoArgs),
}

/// Runs one of the subcommands.
pub fn run(cmd: &IpcCommand) -> ExitCode {
    match cmd {
        IpcCommand::Mission(a) => run_mission(a),
        IpcCommand::Serve(a) => run_serve(a),
        IpcCommand::Soak(a) => run_soak(a),
        IpcCommand::BenchLatency(a) => run_bench(a),
        IpcCommand::BenchEcho(a) => run_echo(a),
        #[cfg(feature = "shore")]
        IpcCommand::Link(a) => crate::shore::link::run_link(a),
        #[cfg(feature = "shore")]
        IpcCommand::Shore(a) => crate::shore::console::run_shore(a),
    }
}
