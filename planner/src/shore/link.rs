//! `planner link`: the onboard end of the shore link, a process of its own
//! (`planner mission --shore` supervises it like the other children). See
//! `auv_link::bridge`.

use std::path::PathBuf;
use std::process::ExitCode;

use super::LinkOptions;
use auv_link::bridge::{BridgeConfig, run_bridge};
use auv_platform::signal;
use auv_transport::IpcArgs;
use auv_transport::ipc::{IpcContext, Shm};
use auv_world::load::{ScenarioArgs, load_world};

/// `planner link` flags.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct LinkArgs {
    #[command(flatten)]
    #[allow(missing_docs)]
    pub ipc: IpcArgs,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub scenario: ScenarioArgs,
    /// Zenoh endpoint to listen on for the shore.
    #[arg(long, value_name = "tcp/ADDR:PORT")]
    pub listen: String,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub link: LinkOptions,
    /// Append the link's events (connected, lost, restored, commands) to
    /// this file, one JSON line each.
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Keep the plans forwarded in this file (read back when the link
    /// restarts, so a console catching up still gets them).
    #[arg(long, value_name = "FILE")]
    pub plan_history: Option<PathBuf>,
    /// File replace-mission commands in this folder for the mission's
    /// supervisor (without it, they are refused as unsupported).
    #[arg(long, value_name = "DIR")]
    pub requests: Option<PathBuf>,
    /// This mission is the one replace-mission command ID brought: the
    /// command's ack goes out with its first plan.
    #[arg(long, value_name = "ID")]
    pub replaced_by: Option<u64>,
}

fn link(a: &LinkArgs) -> Result<(), (u8, String)> {
    let usage = |e: String| (2, e);
    let timeout = a.link.timeout().map_err(usage)?;
    auv_link::session::check_endpoint(&a.listen).map_err(|e| usage(format!("--listen: {e}")))?;
    signal::install();
    let world = load_world(&a.scenario).map_err(|e| usage(e.to_string()))?;
    let names = world
        .waypoints()
        .iter()
        .enumerate()
        .map(|(i, w)| if w.generated { i.to_string() } else { w.name.clone() })
        .collect();
    let cfg = BridgeConfig {
        vehicle: a.ipc.vehicle.clone(),
        link_timeout: timeout,
        fingerprint: world.fingerprint(),
        names,
        log: a.log.clone(),
        endpoint: a.listen.clone(),
        plan_history: a.plan_history.clone(),
        requests: a.requests.clone().map(auv_link::replace::Requests::new),
        replaced_by: a.replaced_by,
    };
    drop(world);
    let opts = a.ipc.options().map_err(|e| usage(e.to_string()))?;
    let ctx = IpcContext::<Shm>::new(&opts, "link").map_err(|e| (1, e.to_string()))?;
    let session = auv_link::session::open(
        auv_link::session::Side::Onboard,
        &a.listen,
        a.link.zenoh_config.as_deref(),
    )
    .map_err(|e| (1, e.to_string()))?;
    let s = run_bridge(&ctx, &session, &cfg).map_err(|e| (1, e.to_string()))?;
    eprintln!(
        "planner link: forwarded {} messages; link lost {} times, restored {} times; commands applied {}, refused {}",
        s.forwarded, s.losses, s.restores, s.commands_applied, s.commands_refused
    );
    Ok(())
}

/// Runs `planner link`: 0 when the mission ended (or on a signal), 1 on a
/// failure, 2 on bad arguments.
pub fn run_link(a: &LinkArgs) -> ExitCode {
    match link(a) {
        Ok(()) => ExitCode::SUCCESS,
        Err((code, e)) => {
            eprintln!("planner: error: link: {e}");
            ExitCode::from(code)
        }
    }
}
