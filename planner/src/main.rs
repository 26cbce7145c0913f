//! `planner`: the command-line front of the planner library.
//!
//! (Interim wiring of the three-process subcommands until the CLI lands.)
use std::process::ExitCode;

use clap::Parser;

#[global_allocator]
static ALLOC: planner::service::alloc::PoolAlloc = planner::service::alloc::PoolAlloc;

#[derive(Parser)]
#[command(name = "planner")]
struct Cli {
    #[command(subcommand)]
    cmd: planner::mission::cli::IpcCommand,
}

fn main() -> ExitCode {
    planner::service::alloc::mark_installed();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    planner::mission::cli::run(&cli.cmd)
}
