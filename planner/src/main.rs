//! `planner`: the command-line front of the planner library.
use std::process::ExitCode;

fn main() -> ExitCode {
    eprintln!("planner: no commands yet");
    ExitCode::from(2)
}
