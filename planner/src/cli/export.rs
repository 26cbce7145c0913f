//! `planner export`: write the current snapshot of a scenario as an
//! `auv-route-instance/1` file, so it can be re-solved here or elsewhere.
//!
//! Contract: the world is a mission file (`--mission FILE`, `auv-mission/1`,
//! node ids as the format orders them; `--seed` replaces the file's seed), or
//! the paper's generator (`--seed`, `--scenario`: the `auv-scenario/1` file,
//! defaults otherwise; [`auv_world::scenario::load_world`]), or with neither
//! the embedded default mission; either fixes the world bit for bit. The
//! snapshot is the world at time 0, named `<chart>-seed-<S>-t0` (generator)
//! or `<mission name>-seed-<S>-t0`. The file written reads back through
//! [`Instance::from_json`] to the same instance (checked before it is
//! written).

use std::path::{Path, PathBuf};

use auv_core::instance::Instance;
use auv_world::scenario::{ChartSource, EMBEDDED_CHART_NAME, ScenarioConfig, load_world};

use super::{CliError, check_json, print, read_text, write_text};

/// Arguments of `planner export`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scenario seed: with the scenario it fixes the waypoints, tasks and
    /// edges (with --mission it replaces the file's seed).
    #[arg(long, allow_negative_numbers = true)]
    pub seed: Option<u64>,
    /// Scenario file (`auv-scenario/1` JSON; absent fields take their
    /// defaults) [default: the built-in scenario on the embedded chart].
    #[arg(long, value_name = "FILE")]
    pub scenario: Option<PathBuf>,
    /// Mission file (`auv-mission/1`) [default without --seed and
    /// --scenario: the embedded default mission].
    #[arg(long, value_name = "FILE", conflicts_with = "scenario")]
    pub mission: Option<PathBuf>,
    /// Where to write the instance JSON.
    #[arg(long, value_name = "FILE.json")]
    pub out: PathBuf,
}

/// Reads and validates a scenario file.
pub fn load_scenario(path: &Path) -> Result<ScenarioConfig, CliError> {
    // Read and syntax-check here first so a missing file and a NaN get the
    // same wording as for instance files.
    let text = read_text(path)?;
    check_json(path, &text)?;
    ScenarioConfig::from_file(path).map_err(|source| CliError::ScenarioConfig {
        path: path.to_path_buf(),
        source,
    })
}

/// The snapshot name: `<chart>-seed-<S>-t0`.
pub fn snapshot_name(config: &ScenarioConfig, seed: u64) -> String {
    let chart = match &config.chart {
        ChartSource::Embedded(name) => name.clone(),
        ChartSource::Png { path, .. } | ChartSource::LandGeojson { path, .. } => path
            .file_stem()
            .map_or_else(|| EMBEDDED_CHART_NAME.to_string(), |s| s.to_string_lossy().into_owned()),
    };
    format!("{chart}-seed-{seed}-t0")
}

/// Runs `planner export`.
pub fn run(args: Args) -> Result<(), CliError> {
    let (world, inst) = if args.mission.is_some() || (args.seed.is_none() && args.scenario.is_none()) {
        let overrides = auv_world::mission_file::Overrides {
            seed: args.seed,
            time_available_s: None,
            start_at: None,
        };
        let m = match &args.mission {
            Some(path) => auv_world::mission_file::load(path, overrides)?,
            None => auv_world::mission_file::load_default(overrides)?,
        };
        let name = format!("{}-seed-{}-t0", auv_world::mission_file::slug(&m.name), m.seed);
        let inst = m.world.snapshot(&name);
        (m.world, inst)
    } else {
        let seed = args.seed.unwrap_or(super::DEFAULT_SEED);
        let (config, origin) = match &args.scenario {
            Some(path) => (load_scenario(path)?, path.display().to_string()),
            None => (ScenarioConfig::default(), "default scenario".to_string()),
        };
        let (world, _map) = load_world(&config, seed).map_err(|source| CliError::World { origin, source })?;
        let inst = world.snapshot(&snapshot_name(&config, seed));
        (world, inst)
    };
    let text = inst.to_json();
    match Instance::from_json(&text) {
        Ok(back) if back == inst => {}
        Ok(_) => return Err(CliError::Internal("the snapshot does not read back identically".into())),
        Err(e) => return Err(CliError::Internal(format!("the snapshot does not read back: {e}"))),
    }
    write_text(&args.out, &(text + "\n"))?;
    print(&format!(
        "wrote {} ({}: {} nodes, {} edges, scenario fingerprint {:016x})\n",
        args.out.display(),
        inst.name,
        inst.nodes.len(),
        inst.edges.len(),
        world.fingerprint()
    ))
}
