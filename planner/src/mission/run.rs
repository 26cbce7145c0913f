//! `planner mission`: the planner service (`planner serve`), sensor-sim and
//! vehicle-sim as supervised child processes ([`super::supervisor`]), in
//! scaled time or lockstep alike; shows progress and writes `report.json`,
//! `mission.log` (written by the planner process), `mission.svg`, `mission.png`, `route.geojson`, `mission.mcap`,
//! `journal.jsonl` (the vehicle's), `faults.log`, `pids.json` and a summary.
//!
//! Shutdown: Ctrl-C reaches all three processes (one process group); each
//! stops its loop and drops its ports. A SIGINT/SIGTERM sent to this process
//! alone is forwarded to the children. Afterwards the run's iceoryx2 domain
//! is retired (dead nodes cleaned, the per-domain management segment
//! removed) and the files it left, if any, are counted in the report. The
//! domains of earlier runs whose supervisor was killed are cleaned at start.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use super::external::{ExternalArgs, VehicleFigures, announce, wait_for_outside_nodes};
use super::mcap_log::{PoseAt, PoseTrack};
use super::report::Report;
use super::route_geojson::Visit;
use super::stale::{RunMark, clean_stale_runs};
use super::supervise::{Announced, FaultReport, PlannerTotals};
use super::supervisor::{SupervisionReport, SupervisorArgs, supervise};
use crate::plot::PlotError;
use crate::serve::{ServeError, ServiceArgs};
use auv_messages::journal::{JournalEvent, JournalSummary};
use auv_messages::msg::{Outcome, RejectCounters, VehicleState};
use auv_messages::wire::{FaultCycle, SENSOR_FAULTS, VEHICLE_FAULTS};
use auv_platform::signal;
use auv_transport::ipc::{cleanup_dead_nodes, domain_config, leftover_files, retire_domain};
use auv_transport::{IpcArgs, IpcOptions, SetupError, WaitMode, unique_prefix};
use auv_world::load::{MissionWorld, ScenarioArgs, WorldError, load_world};

/// `planner mission` flags.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct MissionArgs {
    #[command(flatten)]
    #[allow(missing_docs)]
    pub scenario: ScenarioArgs,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub service: ServiceArgs,
    /// As fast as possible and deterministic: the vehicle moves on only after
    /// the planner answered; solves are never cut (same seeds → same log).
    #[arg(long)]
    pub lockstep: bool,
    /// With --lockstep: cut solves at the deadline anyway (the log is then
    /// no longer reproducible).
    #[arg(long, requires = "lockstep")]
    pub enforce_deadline: bool,
    /// Mission seconds per real second (without --lockstep).
    #[arg(long, default_value_t = 1000.0)]
    pub time_scale: f64,
    /// Output folder (default: a fresh `mission-<seed>-<time>` folder here).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// iceoryx2 isolation prefix (default: a fresh one per run).
    #[arg(long, value_name = "PREFIX")]
    pub ipc_prefix: Option<String>,
    /// Vehicle namespace in service names.
    #[arg(long, default_value = "auv1")]
    pub vehicle: String,
    /// No progress bar and no summary.
    #[arg(long)]
    pub quiet: bool,
    /// Give up when a peer stays silent this long, real s.
    #[arg(long, default_value_t = 60.0)]
    pub answer_timeout_s: f64,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub supervisor: SupervisorArgs,
    /// Inject this many faults at random mission times (SIGKILL or
    /// SIGSTOP/SIGCONT of a random process; scaled time). Drawn from
    /// --fault-seed.
    #[arg(long, default_value_t = 0, conflicts_with = "lockstep")]
    pub faults: usize,
    /// Seed of the fault draws (default: the scenario seed).
    #[arg(long)]
    pub fault_seed: Option<u64>,
    /// A process silent for longer than this is reported as stalled, real
    /// ms (the sensor gets at least three of its periods; scaled time only).
    #[arg(long, default_value_t = 1000.0)]
    pub stall_timeout_ms: f64,
    /// Tests: passed to sensor-sim as `--inject` (bad snapshots next to good ones).
    #[arg(long, value_name = "KIND[,KIND…]")]
    pub inject_sensor: Option<String>,
    /// Tests: passed to vehicle-sim as `--inject` (bad vehicle states next to good ones).
    #[arg(long, value_name = "KIND[,KIND…]")]
    pub inject_vehicle: Option<String>,
    /// Print the embedded default mission file (`auv-mission/1`) and exit:
    /// a starting point for your own.
    #[arg(long)]
    pub print_default: bool,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub external: ExternalArgs,
    /// Listen for the shore on this Zenoh endpoint: `planner link` runs as a
    /// supervised child that forwards the vehicle's topics and takes
    /// operator commands (`planner shore --connect` on the other side).
    #[arg(long, value_name = "tcp/ADDR:PORT")]
    pub shore: Option<String>,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub link: crate::shore::LinkOptions,
}

/// Why a mission failed.
#[derive(Debug, thiserror::Error)]
pub enum MissionError {
    /// A flag out of range.
    #[error("{0}")]
    Usage(String),
    /// The world could not be built.
    #[error(transparent)]
    World(#[from] WorldError),
    /// iceoryx2 set-up failed.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The service failed.
    #[error(transparent)]
    Serve(#[from] ServeError),
    /// A file could not be written.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// A child process failed.
    #[error("{0}")]
    Child(String),
    /// The plot failed.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

pub(super) fn io_err(path: &Path, e: impl std::fmt::Display) -> MissionError {
    MissionError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// A sibling binary of this executable (`sensor-sim`, `vehicle-sim`).
pub fn sibling_binary(name: &str) -> Result<PathBuf, MissionError> {
    let exe = std::env::current_exe().map_err(|e| MissionError::Child(format!("cannot locate planner: {e}")))?;
    let dir = exe.parent().unwrap_or(Path::new("."));
    let p = dir.join(name);
    if p.is_file() {
        Ok(p)
    } else {
        Err(MissionError::Child(format!(
            "{name} not found next to {} (build the workspace: cargo build --release)",
            exe.display()
        )))
    }
}

fn fresh_out_dir(seed: u64) -> PathBuf {
    let secs = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let base = format!("mission-{seed}-{secs}");
    let mut p = PathBuf::from(&base);
    let mut k = 1;
    while p.exists() {
        p = PathBuf::from(format!("{base}-{k}"));
        k += 1;
    }
    p
}

/// What the plot, `route.geojson` and `mission.mcap` show of the run, read
/// back from the vehicle's journal in one pass.
#[derive(Default)]
pub(super) struct Trace {
    /// Where the vehicle was, in order: the start (at its nominal
    /// position), then every arrival.
    visits: Vec<Visit>,
    /// The vehicle's poses over time.
    poses: Vec<PoseAt>,
    arrivals: Vec<(f64, f64)>,
    /// Where re-plans were accepted: at the waypoint the vehicle last reached.
    replans_at: Vec<(f64, f64)>,
    /// Where a re-plan changed the route (a re-plan that confirms the plan
    /// in force is not drawn).
    changed_at: Vec<(f64, f64)>,
    first_plan: Vec<usize>,
    last_plan: Vec<usize>,
    last_epoch: u64,
}

impl Trace {
    /// The trace of `journal`; `last_epoch`: the latest snapshot epoch seen
    /// (the plot draws the waypoints where they were last reported).
    pub(super) fn from_journal(journal: &JournalSummary, world: &MissionWorld, last_epoch: u64) -> Self {
        let mut t = Self {
            last_epoch,
            ..Self::default()
        };
        let w = world.world();
        let mut poses = PoseTrack::default();
        let mut here: Option<(f64, f64)> = None;
        for e in &journal.events {
            poses.push(e, w);
            match e {
                JournalEvent::Start { t: at, node, .. } if t.visits.is_empty() => {
                    let p = w.nominal_positions().get(*node).copied().unwrap_or_default();
                    t.visits.push(Visit {
                        t: *at,
                        node: *node,
                        at: (p.x, p.y),
                    });
                }
                JournalEvent::Arrival { t: at, node, pos, .. } => {
                    t.arrivals.push((pos[0], pos[1]));
                    here = Some((pos[0], pos[1]));
                    t.visits.push(Visit {
                        t: *at,
                        node: *node,
                        at: (pos[0], pos[1]),
                    });
                }
                JournalEvent::Plan { route, .. } => {
                    if t.first_plan.is_empty() {
                        t.first_plan = route.clone();
                    } else {
                        if let Some(at) = here {
                            t.replans_at.push(at);
                        }
                        // The journal says when, not where: the vehicle takes
                        // a plan on at a waypoint, its last arrival.
                        if changes_route(&t.last_plan, route) {
                            t.changed_at.extend(here);
                        }
                    }
                    t.last_plan = route.clone();
                }
                _ => {}
            }
        }
        t.poses = poses.finish();
        t
    }
}

/// Whether plan `new` changes the route of plan `old`: a plan that is the
/// rest of the old one from where the vehicle now is (it only dropped the
/// waypoints already passed) changes nothing.
fn changes_route(old: &[usize], new: &[usize]) -> bool {
    match new.first().and_then(|&here| old.iter().position(|&i| i == here)) {
        Some(k) => old[k..] != *new,
        None => true,
    }
}

/// Draws `mission.svg` and `mission.png` (see [`super::picture`]).
fn plot(stem: &Path, world: &mut MissionWorld, trace: &Trace, report: &Report) -> Result<(), MissionError> {
    use super::picture::{PicDrift, PicKind, PicWaypoint, Picture};
    let start = world.snapshot();
    let w = world.world().clone();
    let nominal = |i: usize| (w.nominal_positions()[i].x, w.nominal_positions()[i].y);
    let dynamic: Vec<usize> = w.dynamic_nodes().iter().collect();
    let mut drifts: Vec<PicDrift> = dynamic
        .iter()
        .map(|&i| PicDrift {
            nominal: nominal(i),
            bound: (w.bounds()[i].x, w.bounds()[i].y),
            reported: vec![(w.positions()[i].x, w.positions()[i].y)],
        })
        .collect();
    // The sensor's snapshots are a function of the seed and the epoch: redraw
    // them here (at most about 300 per waypoint, evenly spaced, to keep the
    // picture light).
    let step = (trace.last_epoch / 300).max(1);
    let mut epoch = step;
    while epoch <= trace.last_epoch {
        world.redraw(epoch);
        for (d, &i) in drifts.iter_mut().zip(&dynamic) {
            let p = world.world().positions()[i];
            d.reported.push((p.x, p.y));
        }
        epoch += step;
    }
    let waypoints = world
        .waypoints()
        .iter()
        .enumerate()
        .map(|(i, info)| PicWaypoint {
            at: nominal(i),
            label: if info.generated {
                i.to_string()
            } else {
                info.name.clone()
            },
            kind: match info.role {
                auv_world::mission_file::Role::Start => PicKind::Start,
                auv_world::mission_file::Role::Goal => PicKind::Goal,
                auv_world::mission_file::Role::Via => PicKind::Via,
            },
        })
        .collect();
    let first_plan = trace
        .first_plan
        .iter()
        .map(|&i| (start.nodes[i].x, start.nodes[i].y))
        .collect();
    let (p50, p99, _) = report.latency_us;
    let summary = vec![
        format!("outcome: {}", auv_messages::msg::outcome_name(report.outcome)),
        format!(
            "time used: {:.0} of {:.0} s ({:.0} %)",
            report.time_used_s,
            report.time_available_s,
            100.0 * report.time_used_s / report.time_available_s.max(1e-9)
        ),
        format!("tasks: {}, weight {:.1}", report.tasks_completed, report.weight),
        format!("distance: {:.1} km", report.distance_m / 1000.0),
        format!("plans: {} ({} changed the route)", report.plans, trace.changed_at.len()),
        format!(
            "plan latency p50 {:.1} ms, p99 {:.1} ms",
            p50 as f64 / 1000.0,
            p99 as f64 / 1000.0
        ),
        format!(
            "deadline misses: {} (deadline {} ms{})",
            report.deadline_misses,
            report.deadline_ms,
            if report.lockstep { ", lockstep" } else { "" }
        ),
        format!("seed {}; {} waypoints, {} drifting", world.seed(), w.n(), dynamic.len()),
    ];
    let pic = Picture {
        title: format!(
            "{}, seed {}: {}",
            world.title(),
            world.seed(),
            auv_messages::msg::outcome_name(report.outcome).replace('_', " ")
        ),
        map: world.map(),
        waypoints,
        drifts,
        first_plan,
        travelled: trace.visits.iter().map(|v| (v.at, v.t)).collect(),
        changes: trace.changed_at.clone(),
        budget_s: report.time_available_s,
        summary,
    };
    super::picture::write(stem, &pic)?;
    Ok(())
}

/// What a run of the three processes produced.
pub(super) struct RunOut {
    pub(super) totals: PlannerTotals,
    pub(super) allocator_installed: bool,
    pub(super) last_state: Option<VehicleState>,
    /// The vehicle's journal records the end of the mission.
    pub(super) finished: bool,
    /// The vehicle's journal as the run left it.
    pub(super) journal: JournalSummary,
    /// The latest snapshot epoch seen.
    pub(super) last_epoch: u64,
    pub(super) faults: Option<FaultReport>,
    pub(super) supervision: SupervisionReport,
    /// What the vehicle announced on the wire, to check the journal against.
    pub(super) announced: Announced,
    /// Peak resident set size of each child (planner, sensor, vehicle), kB.
    pub(super) rss_kb: [u64; 3],
    /// Restarts of the shore link's process (`None`: no `--shore`).
    pub(super) link_restarts: Option<u64>,
    /// The mission the shore replaced this one with.
    pub(super) replaced: Option<super::replace::Replacement>,
}

/// How to start the simulators, where to write, and the mission's budget.
pub(super) struct Launch<'a> {
    pub(super) out: &'a Path,
    /// The domain's and the scenario's flags every child shares.
    pub(super) common: &'a [String],
    pub(super) sensor_args: &'a [String],
    pub(super) vehicle_args: &'a [String],
    /// Mission time budget, s.
    pub(super) budget: f64,
    /// The world's seed (the default fault seed).
    pub(super) seed: u64,
    /// The flags that build this world.
    pub(super) scenario: &'a ScenarioArgs,
    /// The world's geographic frame, if it has one.
    #[cfg_attr(not(feature = "shore"), allow(dead_code))]
    pub(super) frame: Option<&'a auv_world::frame::LocalFrame>,
    /// Where the shore link files new missions (with `--shore`).
    pub(super) requests: Option<&'a Path>,
    /// The shore command whose mission this is.
    pub(super) replaced_by: Option<u64>,
}

/// Runs one mission; returns its report and output folder.
pub fn mission(a: &MissionArgs) -> Result<(Report, PathBuf), MissionError> {
    let scale_ok = a.time_scale.is_finite() && a.time_scale > 0.0;
    if !a.lockstep && !scale_ok {
        return Err(MissionError::Usage(format!(
            "--time-scale {}: must be > 0",
            a.time_scale
        )));
    }
    if !(a.answer_timeout_s.is_finite() && a.answer_timeout_s > 0.0) {
        return Err(MissionError::Usage(format!(
            "--answer-timeout-s {}: must be > 0",
            a.answer_timeout_s
        )));
    }
    if !(a.stall_timeout_ms.is_finite() && a.stall_timeout_ms >= 10.0) {
        return Err(MissionError::Usage(format!(
            "--stall-timeout-ms {}: must be >= 10",
            a.stall_timeout_ms
        )));
    }
    let wall = Instant::now();
    let world = load_world(&a.scenario)?;
    let usage = |e: auv_messages::wire::FaultListError| MissionError::Usage(e.to_string());
    let sensor_faults =
        FaultCycle::parse_opt("--inject-sensor", a.inject_sensor.as_deref(), &SENSOR_FAULTS).map_err(usage)?;
    let vehicle_faults =
        FaultCycle::parse_opt("--inject-vehicle", a.inject_vehicle.as_deref(), &VEHICLE_FAULTS).map_err(usage)?;
    a.supervisor.policy().map_err(MissionError::Usage)?;
    if let Some(ep) = &a.shore {
        if !cfg!(feature = "shore") {
            return Err(MissionError::Usage(
                "--shore: this planner was built without the shore link (cargo feature `shore`)".into(),
            ));
        }
        a.link.timeout().map_err(MissionError::Usage)?;
        check_shore_endpoint(ep)?;
    }
    let prefix = a.ipc_prefix.clone().unwrap_or_else(|| unique_prefix("m"));
    let opts = IpcOptions::new(Some(&prefix), &a.vehicle, WaitMode::Event)?;
    let out = a.out.clone().unwrap_or_else(|| fresh_out_dir(world.seed()));
    std::fs::create_dir_all(&out).map_err(|e| io_err(&out, e))?;
    signal::install();
    // What killed supervisors left behind.
    clean_stale_runs();
    // The shore's new missions arrive here (the link files them).
    let requests = a.shore.as_ref().map(|_| out.join("requests"));
    let mut leg = Leg {
        number: 1,
        scenario: a.scenario.clone(),
        world,
        out: out.clone(),
        replaced_by: None,
    };
    let faults = (&sensor_faults, &vehicle_faults);
    loop {
        let (report, replaced) = run_leg(a, &opts, &prefix, &mut leg, requests.as_deref(), faults, wall)?;
        let Some(r) = replaced else {
            return Ok((report, leg.out));
        };
        let next = leg.number + 1;
        let next_out = out.join(format!("leg-{next}"));
        note_replacement(&leg.out, &next_out, &r)?;
        if !a.quiet {
            println!(
                "leg {}: replaced at t {:.0} s by the shore's mission (command {}); report in {}",
                leg.number,
                r.t,
                r.command_id,
                leg.out.join("report.json").display()
            );
        }
        std::fs::create_dir_all(&next_out).map_err(|e| io_err(&next_out, e))?;
        leg = Leg {
            number: next,
            scenario: r.scenario,
            world: r.world,
            out: next_out,
            replaced_by: Some(r.command_id),
        };
    }
}

/// One leg of a run: the mission the processes run from start to end, or
/// until the shore replaces it with another.
struct Leg {
    /// 1 for the mission the run started with.
    number: u32,
    scenario: ScenarioArgs,
    world: MissionWorld,
    /// Its output folder (`<out>` for the first, `<out>/leg-<n>` after).
    out: PathBuf,
    /// The shore command that brought this mission.
    replaced_by: Option<u64>,
}

/// Records in the ended leg's `report.json` that, when and by what it was
/// replaced, and where the run went on.
fn note_replacement(out: &Path, next: &Path, r: &super::replace::Replacement) -> Result<(), MissionError> {
    let path = out.join("report.json");
    let text = std::fs::read_to_string(&path).map_err(|e| io_err(&path, e))?;
    let mut v: serde_json::Value = serde_json::from_str(&text).map_err(|e| io_err(&path, e))?;
    v["outcome"] = "replaced".into();
    v["reason"] = format!(
        "the shore replaced the mission at t {:.0} s (command {})",
        r.t, r.command_id
    )
    .into();
    v["replaced"] = serde_json::json!({
        "command_id": r.command_id,
        "t": r.t,
        "mission": r.mission.display().to_string(),
        "start_at": r.start_at,
        "continued_in": next.file_name().map(|n| n.to_string_lossy().into_owned()),
    });
    let text = serde_json::to_string_pretty(&v).unwrap_or_default();
    std::fs::write(&path, text + "\n").map_err(|e| io_err(&path, e))
}

/// Runs one leg in domain `prefix` and writes its outputs into `leg.out`;
/// its report, and the mission that replaced it, if one did.
fn run_leg(
    a: &MissionArgs,
    opts: &IpcOptions,
    prefix: &str,
    leg: &mut Leg,
    requests: Option<&Path>,
    (sensor_faults, vehicle_faults): (&FaultCycle, &FaultCycle),
    wall: Instant,
) -> Result<(Report, Option<super::replace::Replacement>), MissionError> {
    let world = &mut leg.world;
    let out = leg.out.as_path();
    let fingerprint = world.fingerprint();
    let cfg = a
        .service
        .config(world, a.lockstep && !a.enforce_deadline)
        .map_err(|e| match e {
            ServeError::Usage(u) => MissionError::Usage(u),
            other => MissionError::Serve(other),
        })?;
    // This domain's dead nodes; each leg starts on services of its own world.
    let mark = RunMark::new(prefix);
    cleanup_dead_nodes(&domain_config(prefix)?);

    let mut common = IpcArgs::of(opts).to_flags();
    common.extend(leg.scenario.to_flags());
    let mut vehicle_args = common.clone();
    let mut sensor_args = common.clone();
    if !sensor_faults.is_empty() {
        sensor_args.extend(["--inject".into(), sensor_faults.to_flag_value()]);
    }
    if !vehicle_faults.is_empty() {
        vehicle_args.extend(["--inject".into(), vehicle_faults.to_flag_value()]);
    }
    if a.lockstep {
        vehicle_args.push("--lockstep".into());
    } else {
        vehicle_args.extend(["--time-scale".into(), a.time_scale.to_string()]);
    }
    vehicle_args.extend(["--answer-timeout-s".into(), a.answer_timeout_s.to_string()]);
    // The vehicle's journal is the record of what happened; a fresh run
    // starts a fresh one (an old one would be resumed).
    let journal_path = out.join("journal.jsonl");
    match std::fs::remove_file(&journal_path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io_err(&journal_path, e)),
        _ => {}
    }
    vehicle_args.extend(["--journal".into(), journal_path.display().to_string()]);
    let budget = world.snapshot().time_available_s;
    let launch = Launch {
        out,
        common: &common,
        sensor_args: &sensor_args,
        vehicle_args: &vehicle_args,
        budget,
        seed: world.seed(),
        scenario: &leg.scenario,
        frame: world.frame(),
        requests,
        replaced_by: leg.replaced_by,
    };
    if a.external.any() {
        announce(a.external, prefix, &a.vehicle, fingerprint, a.lockstep, out);
    }
    let run = supervise(a, opts, &launch, world.sensor_period_s(), fingerprint);
    // Outside processes leave when they see the end; the domain is retired
    // once they have.
    if a.external.any() && !wait_for_outside_nodes(prefix, std::time::Duration::from_secs(10))? {
        eprintln!("planner: outside processes are still attached to domain {prefix}");
    }
    let retired = retire_domain(prefix)?;
    let left = leftover_files(prefix);
    if retired {
        drop(mark);
    } else {
        // The mark stays, so a later run cleans the domain once it is dead.
        eprintln!("planner: iceoryx2 domain {prefix} still has live nodes; not removed");
        std::mem::forget(mark);
    }
    let mut run = run?;
    let replaced = run.replaced.take();
    let last = run.last_state;
    // What happened is what the vehicle's journal says.
    let journal = &run.journal;
    let figures = VehicleFigures::of(journal, last.as_ref(), run.finished);
    let outcome = figures.outcome;
    let reason = match outcome {
        Outcome::GoalReached => None,
        Outcome::TimedOut => Some("the time budget ran out before the goal".to_string()),
        Outcome::SafeHold => run
            .supervision
            .safe_hold
            .clone()
            .or_else(|| Some("the vehicle was told to hold".into())),
        Outcome::Aborted | Outcome::Running if signal::shutdown_requested() => Some(format!(
            "stopped by signal {} to the supervisor",
            signal_name(signal::received_signal())
        )),
        Outcome::Aborted | Outcome::Running => Some("the vehicle stopped before the mission's end".into()),
    };
    let stale_plans = last.map_or(0, |s| s.stale_plans);
    let rejected_vehicle = RejectCounters(last.map_or([0; auv_messages::msg::REJECT_KINDS], |s| s.rejected));
    let c = run.totals;
    let trace = Trace::from_journal(journal, world, run.last_epoch);
    let report = Report {
        outcome,
        reason,
        time_used_s: figures.time_s,
        time_available_s: budget,
        tasks_completed: figures.tasks,
        weight: figures.weight,
        distance_m: figures.distance_m,
        route: figures.route,
        plans: c.plans,
        latency_us: c.latency_us,
        deadline_ms: cfg.deadline.as_secs_f64() * 1000.0,
        deadline_misses: c.deadline_misses,
        deadline_cuts: c.deadline_cuts,
        fallbacks: c.fallbacks,
        iterations_total: c.iterations_total,
        alloc: c.alloc,
        allocator_installed: run.allocator_installed,
        sensor_updates: c.sensor_updates,
        rejected: c.rejected,
        rejected_vehicle,
        stale_plans,
        seed: world.seed(),
        planner_seed: a.service.planner_seed,
        fingerprint,
        scenario: world.describe(),
        lockstep: a.lockstep,
        time_scale: a.time_scale,
        wall_time_s: wall.elapsed().as_secs_f64(),
        shm_files_left: left.len(),
        supervision: run.supervision,
        announced_arrivals: run.announced.route.len().saturating_sub(1),
        announced_tasks: run.announced.tasks,
        lost_journal_events: run.announced.missing_from(&journal.route(), journal.tasks()),
        latency_sessions: c.latency_sessions,
        faults: run.faults,
        vehicle_restarts: journal.restarts(),
        iterations_budget: cfg.iterations,
        cut: c.cut,
        rss_kb: run.rss_kb,
        rt_priority: run.totals.rt_priority,
    };
    let report_path = out.join("report.json");
    let mut report_json = report.to_json();
    if let Some(ep) = &a.shore {
        let link =
            super::shore_report::shore_link_json(out, ep, a.link.link_timeout_ms, run.link_restarts.unwrap_or(0));
        report_json["shore_link"] = link;
    }
    let text = serde_json::to_string_pretty(&report_json).unwrap_or_default();
    std::fs::write(&report_path, text + "\n").map_err(|e| io_err(&report_path, e))?;
    let geojson_path = out.join("route.geojson");
    let collection = super::route_geojson::route_geojson(world, &trace.visits);
    std::fs::write(&geojson_path, collection.to_string() + "\n").map_err(|e| io_err(&geojson_path, e))?;
    write_mcap(out, world, &trace, a, report.latency_us)?;
    plot(&out.join("mission"), world, &trace, &report)?;
    Ok((report, replaced))
}

/// Writes `mission.mcap` (see [`super::mcap_log`]) from what the run
/// recorded: the log, the journal and the world.
fn write_mcap(
    out: &Path,
    world: &MissionWorld,
    trace: &Trace,
    a: &MissionArgs,
    latency_us: (u64, u64, u64),
) -> Result<(), MissionError> {
    let path = out.join("mission.mcap");
    let record = super::mcap_log::MissionRecord {
        world,
        poses: &trace.poses,
        visits: &trace.visits,
        vehicle: &a.vehicle,
        latency_us: (!a.lockstep).then_some(latency_us),
        geo: world.frame(),
    };
    super::mcap_log::write(&path, &record, &out.join("mission.log")).map_err(|e| io_err(&path, e))
}

fn check_shore_endpoint(ep: &str) -> Result<(), MissionError> {
    #[cfg(feature = "shore")]
    auv_link::session::check_endpoint(ep).map_err(|e| MissionError::Usage(format!("--shore: {e}")))?;
    let _ = ep;
    Ok(())
}

fn signal_name(sig: i32) -> String {
    match sig {
        libc::SIGINT => "SIGINT".into(),
        libc::SIGTERM => "SIGTERM".into(),
        other => other.to_string(),
    }
}

/// Exit code of a mission that stopped in a safe hold.
pub const EXIT_SAFE_HOLD: u8 = 3;

/// Runs `planner mission`: 0 when the mission ran to its end (goal or time
/// out: see the report), 1 on an error, 2 on bad arguments, 3 when it
/// stopped in a safe hold, 130 when stopped by a signal.
pub fn run_mission(a: &MissionArgs) -> ExitCode {
    if a.print_default {
        print!("{}", auv_world::mission_file::DEFAULT_MISSION_TOML);
        return ExitCode::SUCCESS;
    }
    match mission(a) {
        Ok((report, out)) => {
            if !a.quiet {
                println!("{}", report.summary());
                if a.shore.is_some() {
                    let written = std::fs::read_to_string(out.join("report.json")).unwrap_or_default();
                    let v: serde_json::Value = serde_json::from_str(&written).unwrap_or_default();
                    println!("{}", super::shore_report::summary_line(&v["shore_link"]));
                }
                println!(
                    "wrote {}/report.json, mission.log, mission.svg, mission.png, route.geojson, mission.mcap",
                    out.display()
                );
            }
            match report.outcome {
                Outcome::Aborted => ExitCode::from(130),
                Outcome::SafeHold => ExitCode::from(EXIT_SAFE_HOLD),
                _ => ExitCode::SUCCESS,
            }
        }
        // A world that cannot be built is bad input (a file or a flag),
        // refused before any process starts.
        Err(e @ (MissionError::Usage(_) | MissionError::World(_))) => {
            eprintln!("planner: error: {e}");
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("planner: error: mission: {e}");
            ExitCode::from(1)
        }
    }
}
