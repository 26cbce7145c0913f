//! `planner`: the command-line front of the planner library.
//!
//! Contract: every subcommand lives in its own module under [`cli`] with an
//! `Args` struct and a `run` function. Success exits 0. A failure prints one
//! line `planner: error: <what is wrong>` to stderr and exits non-zero (2 for
//! bad input or arguments, 1 when output cannot be written or the planner
//! itself is at fault); clap reports its own usage errors (also exit 2).

mod cli;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Counts the service thread's calls into the system allocator and serves
/// its small blocks from a start-up pool (`auv_service::alloc`): the
/// proof that the re-planning loop is allocation-free in steady state.
#[global_allocator]
static ALLOC: auv_service::alloc::PoolAlloc = auv_service::alloc::PoolAlloc;

/// Real-time task-assign route planner for AUVs (PSO and BBO on a
/// priority-vector encoding).
#[derive(Parser, Debug)]
#[command(name = "planner", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

// Parsed once at start-up: the size of the largest variant does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand, Debug)]
enum Command {
    /// Solve an `auv-route-instance/1` file and print its solution.
    Solve(cli::solve::Args),
    /// Write a scenario's current snapshot as instance JSON.
    Export(cli::export::Args),
    /// Convert classic orienteering benchmark files (Tsiligirides, Chao) into instance JSON.
    ConvertOp(cli::convert_op::Args),
    /// Run the paper's Monte Carlo study: PSO and BBO (and optionally auto) on many network changes.
    Montecarlo(cli::montecarlo::Args),
    /// Gap to the optimum and solve time of each algorithm on a folder of instances.
    Quality(cli::quality::Args),
    /// How decode time, the PSO budget, auto's gap and the exact solver's gap grow with the network's size.
    Scaling(cli::scaling::Args),
    /// Print the layout of every message on the wire (JSON: sizes, offsets, enum codes, topics, QoS).
    WireLayout(cli::wire_layout::Args),
    /// Summarise a mission.mcap: channels, message counts, time span, plans, final pose, outcome.
    Replay(cli::replay::Args),
    /// The three-process system: `mission`, `serve`, `bench-latency`.
    #[command(flatten)]
    Ipc(planner::mission::cli::IpcCommand),
}

fn main() -> ExitCode {
    auv_service::alloc::mark_installed();
    let parsed = Cli::parse();
    let result = match parsed.command {
        // These report their own errors in the same one-line form and keep
        // their documented exit codes (130 when interrupted).
        Command::Ipc(cmd) => return planner::mission::cli::run(&cmd),
        Command::Solve(args) => cli::solve::run(args),
        Command::Export(args) => cli::export::run(args),
        Command::ConvertOp(args) => cli::convert_op::run(args),
        Command::Montecarlo(args) => cli::montecarlo::run(args),
        Command::Quality(args) => cli::quality::run(args),
        Command::Scaling(args) => cli::scaling::run(args),
        Command::WireLayout(args) => cli::wire_layout::run(args),
        Command::Replay(args) => cli::replay::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            cli::report(&e);
            ExitCode::from(e.exit_code())
        }
    }
}
