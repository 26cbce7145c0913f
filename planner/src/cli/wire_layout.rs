//! `planner wire-layout`: prints the layout of every message, the enum
//! codes and each topic's service name and QoS as one JSON document
//! ([`auv_transport::layout::wire_layout_json`]), for clients in other
//! languages and the test that keeps their mirrors true.

use std::path::PathBuf;

use auv_transport::layout::wire_layout_json;

use super::{CliError, print, write_text};

/// Arguments of `planner wire-layout`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Write the JSON here instead of standard output.
    #[arg(long, value_name = "FILE.json")]
    pub out: Option<PathBuf>,
}

/// Runs `planner wire-layout`.
pub fn run(args: Args) -> Result<(), CliError> {
    let text = serde_json::to_string_pretty(&wire_layout_json()).unwrap_or_default() + "\n";
    match &args.out {
        Some(path) => write_text(path, &text),
        None => print(&text),
    }
}
