//! `planner replay`: read a `mission.mcap` back and print what it holds
//! (channels with their schemas and message counts, the mission-time span,
//! the plans, the vehicle's final pose, the outcome), so a file can be
//! checked without Foxglove.
//!
//! Contract: the whole file is read; a file that is not MCAP, is truncated
//! or does not hold a mission's channels is one error line, exit 2.

use std::path::PathBuf;

use planner::mission::mcap_log::read_summary;

use super::{CliError, print};

/// Arguments of `planner replay`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The `mission.mcap` a mission wrote.
    #[arg(value_name = "FILE.mcap")]
    pub file: PathBuf,
}

/// Runs `planner replay`.
pub fn run(args: Args) -> Result<(), CliError> {
    let bytes = std::fs::read(&args.file).map_err(|source| CliError::Read {
        path: args.file.clone(),
        source,
    })?;
    let summary = read_summary(&bytes).map_err(|source| CliError::Mcap {
        path: args.file.clone(),
        source,
    })?;
    print(&format!("{}: {}", args.file.display(), summary.render()))
}
