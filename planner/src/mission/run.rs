//! `planner mission`: starts sensor-sim and vehicle-sim as child processes,
//! runs the re-planning service on a thread of its own, shows progress, and
//! writes `report.json`, `mission.log`, `mission.svg`, `mission.mcap` and a summary.
//!
//! Threads: the service thread owns every iceoryx2 port of this process and
//! is the only one the allocator counts; it hands its events to the main
//! thread through a fixed-size lock-free queue (no allocation), and the main
//! thread formats the log, draws the progress bar and watches the children.
//!
//! Shutdown: Ctrl-C reaches all three processes (one process group); each
//! stops its loop and drops its ports. A SIGINT/SIGTERM sent to this process
//! alone is forwarded to the children. Afterwards the run's iceoryx2 domain
//! is retired (dead nodes cleaned, the per-domain management segment
//! removed) and the files it left, if any, are counted in the report.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitCode, ExitStatus, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use heapless::spsc::Queue;

use super::external::{ExternalArgs, VehicleFigures, announce, wait_for_outside_nodes};
use super::log::lines;
use super::report::Report;
use super::supervise::{
    FaultKind, FaultReport, LATEST_INJECTION, LivenessEvent, Monitor, PlannerTotals, Proc, plan_faults,
};
use crate::plot::{BoundMarker, MapFigure, PlotError, RouteLayer, map_figure};
use crate::serve::{ServeError, ServiceArgs, make_solver, open_ports, prepare_service_thread};
use auv_messages::journal::{JournalEvent, JournalSummary};
use auv_messages::msg::{Outcome, RejectCounters, VehicleState};
use auv_messages::wire::{FaultCycle, SENSOR_FAULTS, VEHICLE_FAULTS, WireRules};
use auv_platform::signal;
use auv_service::alloc;
use auv_service::core::{PlannerCore, ServiceConfig, ServiceCounters, ServiceEvent};
use auv_service::run::{ExitReason, run_service};
use auv_transport::ipc::{IpcContext, Shm, cleanup_dead_nodes, domain_config, leftover_files, retire_domain};
use auv_transport::{IpcOptions, SetupError, WaitMode, unique_prefix};
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
    /// Run the planner as a child process (`planner serve`) supervised like
    /// the simulators, instead of on a thread of this process: any of the
    /// three can then be killed and restarted.
    #[arg(long)]
    pub planner_process: bool,
    /// Inject this many faults at random mission times (SIGKILL + restart or
    /// SIGSTOP/SIGCONT of a random process; scaled time; implies
    /// --planner-process). Drawn from --fault-seed.
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
    #[command(flatten)]
    #[allow(missing_docs)]
    pub external: ExternalArgs,
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

fn io_err(path: &Path, e: impl std::fmt::Display) -> MissionError {
    MissionError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Events the queue holds; the main thread drains it every few ms.
const QUEUE_LEN: usize = 1024;

/// What the service thread shares with the main thread.
struct Shared {
    mission_time_bits: AtomicU64,
    plans: AtomicU64,
    stop: AtomicBool,
}

/// What the service thread hands back.
struct ServiceResult {
    exit: ExitReason,
    counters: ServiceCounters,
    latency_us: (u64, u64, u64),
    rejected: RejectCounters,
    last_state: Option<VehicleState>,
    rt_priority: Option<i32>,
}

#[allow(clippy::too_many_arguments)]
fn service_thread(
    opts: &IpcOptions,
    fingerprint: u64,
    rules: &Arc<WireRules>,
    plan_faults: FaultCycle,
    cfg: ServiceConfig,
    events: &mut dyn FnMut(&ServiceEvent),
    shared: &Shared,
    rt_priority: Option<i32>,
) -> Result<ServiceResult, ServeError> {
    let rt_priority = prepare_service_thread(rt_priority, cfg.cut_at_deadline)?;
    let ctx = IpcContext::<Shm>::new(opts, "planner")?;
    let mut ports = open_ports(&ctx, fingerprint, rules, plan_faults)?;
    let mut core = PlannerCore::new(cfg, make_solver(cfg.algorithm));
    core.set_rt_priority(rt_priority);
    let exit = run_service(&mut core, &mut ports, events, &mut |c: &PlannerCore| {
        shared
            .mission_time_bits
            .store(c.mission_time_s().to_bits(), Ordering::Relaxed);
        shared.plans.store(c.counters().plans, Ordering::Relaxed);
        !shared.stop.load(Ordering::Relaxed)
    })?;
    let h = core.latency_us();
    Ok(ServiceResult {
        exit,
        counters: *core.counters(),
        latency_us: (h.value_at_quantile(0.5), h.value_at_quantile(0.99), h.max()),
        rejected: ports.rejected(),
        last_state: core.last_state().copied(),
        rt_priority,
    })
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

/// A child process and where its stderr goes.
struct Kid {
    name: &'static str,
    child: Option<Child>,
    log: PathBuf,
    status: Option<ExitStatus>,
    bin: PathBuf,
    args: Vec<String>,
}

impl Kid {
    fn spawn(name: &'static str, args: &[String], out: &Path) -> Result<Self, MissionError> {
        Self::spawn_bin(name, name, args, out)
    }

    /// `bin_name` started as `name` (the planner runs as `planner serve`).
    fn spawn_bin(name: &'static str, bin_name: &str, args: &[String], out: &Path) -> Result<Self, MissionError> {
        let bin = if bin_name == "planner" {
            std::env::current_exe().map_err(|e| MissionError::Child(format!("cannot locate planner: {e}")))?
        } else {
            sibling_binary(bin_name)?
        };
        let log = out.join(format!("{name}.log"));
        File::create(&log).map_err(|e| io_err(&log, e))?;
        let mut k = Self {
            name,
            child: None,
            log,
            status: None,
            bin,
            args: args.to_vec(),
        };
        k.start(&[])?;
        Ok(k)
    }

    /// Starts the process (again), with `extra` flags; stderr appends to its log.
    fn start(&mut self, extra: &[String]) -> Result<(), MissionError> {
        let err = File::options()
            .append(true)
            .open(&self.log)
            .map_err(|e| io_err(&self.log, e))?;
        let child = Command::new(&self.bin)
            .args(&self.args)
            .args(extra)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(err)
            .spawn()
            .map_err(|e| MissionError::Child(format!("cannot start {}: {e}", self.bin.display())))?;
        self.child = Some(child);
        self.status = None;
        Ok(())
    }

    /// SIGKILL and reap (a crash, as far as everyone else can tell).
    fn kill_now(&mut self) {
        if let Some(c) = &mut self.child {
            let _ = c.kill();
            let _ = c.wait();
        }
        self.child = None;
    }

    /// Whether it has exited (reaps it).
    fn poll(&mut self) -> bool {
        if self.status.is_some() {
            return true;
        }
        if let Some(c) = &mut self.child
            && let Ok(Some(st)) = c.try_wait()
        {
            self.status = Some(st);
            self.child = None;
        }
        self.status.is_some()
    }

    /// Resident set size now, kB (`None`: not running).
    fn rss_kb(&self) -> Option<u64> {
        rss_kb_of(self.child.as_ref()?.id())
    }

    fn signal(&self, sig: i32) {
        if let Some(c) = &self.child {
            // SAFETY: a signal to our own child's pid.
            unsafe { libc::kill(c.id() as libc::pid_t, sig) };
        }
    }

    /// Waits up to `t`, then SIGTERM, then SIGKILL.
    fn finish(&mut self, t: Duration) {
        let t0 = Instant::now();
        while !self.poll() && t0.elapsed() < t {
            std::thread::sleep(Duration::from_millis(10));
        }
        if !self.poll() {
            self.signal(libc::SIGTERM);
            let t1 = Instant::now();
            while !self.poll() && t1.elapsed() < Duration::from_secs(2) {
                std::thread::sleep(Duration::from_millis(10));
            }
        }
        if !self.poll()
            && let Some(c) = &mut self.child
        {
            let _ = c.kill();
            self.status = c.wait().ok();
            self.child = None;
        }
    }

    fn failed(&self) -> Option<String> {
        let st = self.status?;
        if st.success() || st.code() == Some(130) {
            return None;
        }
        let tail = std::fs::read_to_string(&self.log).unwrap_or_default();
        let last = tail.lines().rev().take(3).collect::<Vec<_>>().join(" | ");
        Some(format!("{} exited with {st}: {last}", self.name))
    }
}

impl Drop for Kid {
    fn drop(&mut self) {
        if self.child.is_some() {
            self.finish(Duration::ZERO);
        }
    }
}

/// Resident set size of process `pid`, kB (`VmRSS` in `/proc/<pid>/status`).
pub fn rss_kb_of(pid: u32) -> Option<u64> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    text.lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
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

/// What the main thread collects from the events for the plot.
#[derive(Default)]
struct Trace {
    arrivals: Vec<(f64, f64)>,
    replans_at: Vec<(f64, f64)>,
    first_plan: Vec<usize>,
    last_plan: Vec<usize>,
    last_epoch: u64,
}

impl Trace {
    fn add(&mut self, e: &ServiceEvent) {
        match *e {
            ServiceEvent::Arrival { at, .. } => self.arrivals.push(at),
            ServiceEvent::Plan { route, at, .. } => {
                if self.first_plan.is_empty() {
                    self.first_plan = route.to_vec();
                } else {
                    self.replans_at.push(at);
                }
                self.last_plan = route.to_vec();
            }
            ServiceEvent::SensorUpdate { epoch, .. } => self.last_epoch = epoch,
            ServiceEvent::Finished { .. } => {}
        }
    }
}

fn plot(path: &Path, world: &mut MissionWorld, trace: &Trace, title: &str) -> Result<(), MissionError> {
    let start = world.snapshot();
    let start_xy = (start.nodes[start.start].x, start.nodes[start.start].y);
    if trace.last_epoch > 0 {
        world.redraw(trace.last_epoch);
    }
    let inst = world.snapshot();
    let w = world.world();
    let waypoints: Vec<(f64, f64)> = inst.nodes.iter().map(|n| (n.x, n.y)).collect();
    let bounds: Vec<BoundMarker> = w
        .dynamic_nodes()
        .iter()
        .map(|i| BoundMarker {
            nominal: (w.nominal_positions()[i].x, w.nominal_positions()[i].y),
            bound: (w.bounds()[i].x, w.bounds()[i].y),
        })
        .collect();
    let mut travelled = vec![start_xy];
    travelled.extend(&trace.arrivals);
    let first: Vec<(f64, f64)> = trace
        .first_plan
        .iter()
        .map(|&i| (start.nodes[i].x, start.nodes[i].y))
        .collect();
    let routes = [
        RouteLayer {
            label: "first plan",
            points: &first,
            dashed: true,
        },
        RouteLayer {
            label: "route travelled",
            points: &travelled,
            dashed: false,
        },
    ];
    map_figure(
        path,
        &MapFigure {
            title,
            map: world.map(),
            waypoints: &waypoints,
            start: inst.start,
            goal: inst.goal,
            bounds: &bounds,
            routes: &routes,
            markers: &trace.replans_at,
            marker_label: "re-plan",
        },
    )?;
    Ok(())
}

/// What a run of the three processes produced, whichever way the planner ran.
struct RunOut {
    totals: PlannerTotals,
    allocator_installed: bool,
    last_state: Option<VehicleState>,
    /// The vehicle reported the end of the mission to the planner.
    finished: bool,
    trace: Trace,
    faults: Option<FaultReport>,
    /// Peak resident set size of each child (planner, sensor, vehicle), kB
    /// (0: not measured).
    rss_kb: [u64; 3],
}

/// How to start the simulators, where to write, and the mission's budget.
struct Launch<'a> {
    out: &'a Path,
    /// Flags every process gets.
    common: &'a [String],
    sensor_args: &'a [String],
    vehicle_args: &'a [String],
    /// Mission time budget, s.
    budget: f64,
}

/// Runs the mission with the service on a thread of this process.
fn threaded(
    a: &MissionArgs,
    opts: IpcOptions,
    fingerprint: u64,
    cfg: ServiceConfig,
    l: &Launch,
    rules: Arc<WireRules>,
    plan_faults: FaultCycle,
) -> Result<RunOut, MissionError> {
    let (out, vehicle_args, budget) = (l.out.to_path_buf(), l.vehicle_args, l.budget);
    // An outside vehicle or sensor takes the place of the simulator.
    let mut kids = Vec::with_capacity(2);
    if !a.external.external_sensor {
        kids.push(Kid::spawn("sensor-sim", l.sensor_args, &out)?);
    }
    if !a.external.external_vehicle {
        kids.push(Kid::spawn("vehicle-sim", vehicle_args, &out)?);
    }

    let log_path = out.join("mission.log");
    let mut log = BufWriter::new(File::create(&log_path).map_err(|e| io_err(&log_path, e))?);
    let bar = if a.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        let b = indicatif::ProgressBar::new(budget as u64);
        if let Ok(style) =
            indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} s mission time · {msg}")
        {
            b.set_style(style.progress_chars("=> "));
        }
        b
    };
    let shared = Shared {
        mission_time_bits: AtomicU64::new(0),
        plans: AtomicU64::new(0),
        stop: AtomicBool::new(false),
    };
    let mut queue: Box<Queue<ServiceEvent, QUEUE_LEN>> = Box::new(Queue::new());
    let (mut producer, mut consumer) = queue.split();
    let mut trace = Trace::default();
    let mut log_error = None;
    let mut child_error = None;

    let rt_priority = a.service.rt_priority;
    let opts = &opts;
    let result = std::thread::scope(|scope| {
        let shared = &shared;
        let rules = &rules;
        let handle = scope.spawn(move || {
            let mut events = |e: &ServiceEvent| {
                // Never drop an event (the log must be complete): wait for room.
                while producer.enqueue(*e).is_err() {
                    if shared.stop.load(Ordering::Relaxed) {
                        return;
                    }
                    std::thread::yield_now();
                }
            };
            let r = service_thread(
                opts,
                fingerprint,
                rules,
                plan_faults,
                cfg,
                &mut events,
                shared,
                rt_priority,
            );
            alloc::end_steady_state();
            r
        });
        let mut silent_since: Option<Instant> = None;
        let mut forwarded = false;
        loop {
            let mut drained = 0;
            while let Some(e) = consumer.dequeue() {
                drained += 1;
                trace.add(&e);
                for line in lines(&e) {
                    if let Err(err) = writeln!(log, "{line}") {
                        log_error.get_or_insert_with(|| io_err(&log_path, err));
                    }
                }
            }
            let t = f64::from_bits(shared.mission_time_bits.load(Ordering::Relaxed));
            bar.set_position(t.clamp(0.0, budget) as u64);
            bar.set_message(format!(
                "{} plans, {} arrivals",
                shared.plans.load(Ordering::Relaxed),
                trace.arrivals.len()
            ));
            if handle.is_finished() && drained == 0 {
                break;
            }
            if signal::shutdown_requested() && !forwarded {
                forwarded = true;
                shared.stop.store(true, Ordering::Relaxed);
                for k in &kids {
                    k.signal(signal::received_signal());
                }
            }
            // A child that died early leaves the service waiting: stop it
            // after a grace period (the vehicle exits at the mission's end).
            let dead = kids.iter_mut().any(|k| k.poll() && k.failed().is_some());
            if dead {
                let since = *silent_since.get_or_insert_with(Instant::now);
                if since.elapsed() > Duration::from_secs(2) {
                    shared.stop.store(true, Ordering::Relaxed);
                    child_error = kids.iter().find_map(|k| k.failed());
                }
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        handle.join()
    });
    bar.finish_and_clear();
    for k in &mut kids {
        k.finish(Duration::from_secs(10));
    }
    if let Err(e) = log.flush() {
        log_error.get_or_insert_with(|| io_err(&log_path, e));
    }
    let service = match result {
        Ok(r) => r?,
        Err(_) => return Err(MissionError::Child("the service thread panicked".into())),
    };
    if let Some(e) = log_error {
        return Err(e);
    }
    if let Some(e) = child_error.or_else(|| kids.iter().find_map(|k| k.failed())) {
        return Err(MissionError::Child(e));
    }
    let c = service.counters;
    Ok(RunOut {
        totals: PlannerTotals {
            plans: c.plans,
            sensor_updates: c.sensor_updates,
            deadline_misses: c.deadline_misses,
            deadline_cuts: c.deadline_cuts,
            fallbacks: c.fallbacks,
            iterations_total: c.iterations_total,
            max_latency_us: service.latency_us.2,
            latency_us: service.latency_us,
            rejected: service.rejected,
            alloc: alloc::counters(),
            cut: Some(c.cut),
            rt_priority: service.rt_priority,
        },
        allocator_installed: alloc::installed(),
        last_state: service.last_state,
        finished: service.exit == ExitReason::Finished,
        trace,
        faults: None,
        rss_kb: [0; 3],
    })
}

/// The fault being handled now.
#[derive(Clone, Copy, Debug)]
enum Active {
    /// A killed process was restarted: cleared when it is heard from again.
    Restarting {
        p: Proc,
        key_idx: usize,
        since: Instant,
        attempts: u32,
    },
    /// A process is stopped until `until`.
    Paused {
        p: Proc,
        key_idx: usize,
        since: Instant,
        until: Instant,
        detected: bool,
    },
    /// A paused process was continued: cleared when it is heard from again.
    Continued { p: Proc, key_idx: usize, detected: bool },
}

/// Longest wait for a restarted or continued process to be heard from
/// again before the fault counts as not cleared, real s.
const CLEAR_LIMIT: Duration = Duration::from_secs(30);

/// Starts of a killed process before giving up: a start can fail on a race
/// with the dead node's cleanup (iceoryx2 #1578; notes §5 say retry).
const RESTART_ATTEMPTS: u32 = 3;

/// Extra flags of a restarted process: a sensor starts from the vehicle's
/// mission time, not from epoch 0 (the vehicle resumes from its journal,
/// the planner from the topics' history, with their usual flags).
fn restart_flags(p: Proc) -> Vec<String> {
    if p == Proc::Sensor {
        vec!["--resume-wait-s".into(), "5".into()]
    } else {
        Vec::new()
    }
}

/// Runs the mission with all three as supervised child processes, injecting
/// the faults `--faults` asks for.
fn supervised(
    a: &MissionArgs,
    opts: &IpcOptions,
    l: &Launch,
    sensor_period_s: f64,
    fingerprint: u64,
) -> Result<RunOut, MissionError> {
    let (out, common, vehicle_args, budget) = (l.out, l.common, l.vehicle_args, l.budget);
    let stall = Duration::from_secs_f64(a.stall_timeout_ms / 1000.0);
    let sensor_stall = if a.lockstep {
        stall
    } else {
        stall.max(Duration::from_secs_f64(3.0 * sensor_period_s / a.time_scale))
    };
    let timeouts = [stall, sensor_stall, stall];
    // The monitor subscribes before anyone publishes: it sees every status.
    let mut monitor = Monitor::new(opts, timeouts, fingerprint)?;
    let mut planner_args = vec!["serve".to_string()];
    planner_args.extend(common.iter().cloned());
    planner_args.extend(a.service.to_flags());
    if a.lockstep && !a.enforce_deadline {
        planner_args.push("--lockstep".into());
    }
    let log_path = out.join("mission.log");
    File::create(&log_path).map_err(|e| io_err(&log_path, e))?;
    planner_args.extend(["--log".into(), log_path.display().to_string()]);
    let mut kids = [
        Kid::spawn_bin("planner", "planner", &planner_args, out)?,
        Kid::spawn("sensor-sim", l.sensor_args, out)?,
        Kid::spawn("vehicle-sim", vehicle_args, out)?,
    ];
    let fault_seed = a.fault_seed.unwrap_or(a.scenario.seed);
    let faults = plan_faults(fault_seed, a.faults, budget, &Proc::ALL);
    let mut report = FaultReport {
        planned: faults.clone(),
        timeouts_ms: timeouts.map(|t| t.as_secs_f64() * 1000.0),
        ..FaultReport::default()
    };
    let keys: Vec<String> = faults.iter().map(|f| f.key()).collect();
    let faults_path = out.join("faults.log");
    let mut flog = BufWriter::new(File::create(&faults_path).map_err(|e| io_err(&faults_path, e))?);
    let wall0 = Instant::now();
    let note = |flog: &mut BufWriter<File>, t: f64, v: serde_json::Value| {
        let mut v = v;
        v["t"] = serde_json::json!(t);
        v["wall_s"] = serde_json::json!(wall0.elapsed().as_secs_f64());
        let _ = writeln!(flog, "{v}");
        let _ = flog.flush();
    };
    let bar = if a.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(budget as u64)
    };
    let mut next = 0;
    let mut active: Option<Active> = None;
    let mut events = Vec::new();
    let mut forwarded = false;
    let mut failed_since: Option<Instant> = None;
    let mut child_error = None;
    let mut rss_kb = [0u64; 3];
    let mut rss_at = Instant::now();
    loop {
        if rss_at.elapsed() >= Duration::from_millis(100) {
            rss_at = Instant::now();
            for (peak, k) in rss_kb.iter_mut().zip(&kids) {
                *peak = (*peak).max(k.rss_kb().unwrap_or(0));
            }
        }
        let vehicle_done = kids[Proc::Vehicle as usize].poll()
            || monitor
                .last_state()
                .is_some_and(|s| s.outcome != Outcome::Running as u32);
        let mut watch = [false; 3];
        for p in Proc::ALL {
            let restarting = matches!(active, Some(Active::Restarting { p: q, .. }) if q == p);
            watch[p as usize] = !a.lockstep && !vehicle_done && !restarting && !kids[p as usize].poll();
        }
        events.clear();
        monitor.poll(watch, &mut events);
        let t = monitor.last_state().map_or(0.0, |s| s.header.mission_time_s);
        bar.set_position(t.clamp(0.0, budget) as u64);
        for e in &events {
            match *e {
                LivenessEvent::Stalled { proc, silent } => {
                    *report.stalls.entry(proc.name().to_string()).or_default() += 1;
                    if let Some(Active::Paused { p, since, detected, .. }) = &mut active
                        && *p == proc
                        && !*detected
                    {
                        *detected = true;
                        report.detect_ms_max = report.detect_ms_max.max(since.elapsed().as_secs_f64() * 1000.0);
                    }
                    eprintln!("planner: {} silent for {} ms: stalled", proc.name(), silent.as_millis());
                    note(
                        &mut flog,
                        t,
                        serde_json::json!({"event": "stall_detected", "process": proc.name(), "silent_ms": silent.as_millis() as u64}),
                    );
                }
                LivenessEvent::Recovered { proc, silent } => note(
                    &mut flog,
                    t,
                    serde_json::json!({"event": "recovered", "process": proc.name(), "silent_ms": silent.as_millis() as u64}),
                ),
            }
        }
        // The fault in hand, then the next one.
        match active {
            Some(Active::Restarting {
                p,
                key_idx,
                since,
                attempts,
            }) => {
                if monitor.heard(p) {
                    *report.cleared.entry(keys[key_idx].clone()).or_default() += 1;
                    note(
                        &mut flog,
                        t,
                        serde_json::json!({"event": "cleared", "fault": keys[key_idx]}),
                    );
                    active = None;
                } else if since.elapsed() > CLEAR_LIMIT || vehicle_done {
                    active = None;
                } else if attempts < RESTART_ATTEMPTS && kids[p as usize].poll() && kids[p as usize].failed().is_some()
                {
                    let why = kids[p as usize].failed().unwrap_or_default();
                    note(
                        &mut flog,
                        t,
                        serde_json::json!({"event": "restart_failed", "process": p.name(), "why": why}),
                    );
                    kids[p as usize].start(&restart_flags(p))?;
                    active = Some(Active::Restarting {
                        p,
                        key_idx,
                        since,
                        attempts: attempts + 1,
                    });
                }
            }
            Some(Active::Paused {
                p,
                key_idx,
                until,
                detected,
                ..
            }) => {
                if Instant::now() >= until || vehicle_done && p != Proc::Vehicle {
                    kids[p as usize].signal(libc::SIGCONT);
                    note(
                        &mut flog,
                        t,
                        serde_json::json!({"event": "continued", "process": p.name()}),
                    );
                    active = Some(Active::Continued { p, key_idx, detected });
                }
            }
            Some(Active::Continued { p, key_idx, detected }) => {
                if !monitor.stalled(p) || vehicle_done {
                    if detected {
                        *report.cleared.entry(keys[key_idx].clone()).or_default() += 1;
                        note(
                            &mut flog,
                            t,
                            serde_json::json!({"event": "cleared", "fault": keys[key_idx]}),
                        );
                    }
                    active = None;
                }
            }
            None => {
                if next < faults.len() && t >= faults[next].at_s && t > LATEST_INJECTION * budget {
                    report.skipped_late += 1;
                    note(
                        &mut flog,
                        t,
                        serde_json::json!({"event": "skipped_late", "fault": keys[next]}),
                    );
                    next += 1;
                } else if next < faults.len() && !vehicle_done && !forwarded && t >= faults[next].at_s {
                    let f = faults[next];
                    let p = f.target;
                    *report.injected.entry(keys[next].clone()).or_default() += 1;
                    note(
                        &mut flog,
                        t,
                        serde_json::json!({"event": "inject", "fault": keys[next], "planned_t": f.at_s}),
                    );
                    let now = Instant::now();
                    match f.kind {
                        FaultKind::Kill => {
                            kids[p as usize].kill_now();
                            monitor.forget(p);
                            kids[p as usize].start(&restart_flags(p))?;
                            *report.restarts.entry(p.name().to_string()).or_default() += 1;
                            active = Some(Active::Restarting {
                                p,
                                key_idx: next,
                                since: now,
                                attempts: 1,
                            });
                        }
                        FaultKind::Pause => {
                            kids[p as usize].signal(libc::SIGSTOP);
                            active = Some(Active::Paused {
                                p,
                                key_idx: next,
                                since: now,
                                until: now + timeouts[p as usize] + Duration::from_millis(500),
                                detected: false,
                            });
                        }
                    }
                    next += 1;
                }
            }
        }
        if signal::shutdown_requested() && !forwarded {
            forwarded = true;
            for k in &kids {
                k.signal(libc::SIGCONT);
                k.signal(signal::received_signal());
            }
        }
        if kids[Proc::Vehicle as usize].poll() {
            break;
        }
        // A child that failed on its own (not one we killed, nor one being
        // restarted) ends the run after a grace period.
        let restarting = match active {
            Some(Active::Restarting { p, .. }) => Some(p as usize),
            _ => None,
        };
        if kids
            .iter_mut()
            .enumerate()
            .any(|(i, k)| Some(i) != restarting && k.poll() && k.failed().is_some())
        {
            let since = *failed_since.get_or_insert_with(Instant::now);
            if since.elapsed() > Duration::from_secs(2) {
                child_error = kids.iter().find_map(|k| k.failed());
                break;
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    bar.finish_and_clear();
    for k in &kids {
        k.signal(libc::SIGCONT);
    }
    // The planner and the sensor end when they see the vehicle's last state.
    for k in &mut kids {
        k.finish(Duration::from_secs(10));
    }
    events.clear();
    monitor.poll([false; 3], &mut events);
    let _ = flog.flush();
    if let Some(e) = child_error.or_else(|| kids.iter().find_map(|k| k.failed())) {
        return Err(MissionError::Child(e));
    }
    let totals = monitor.planner_totals();
    let last_state = monitor.last_state().copied();
    let mut trace = Trace {
        last_epoch: monitor.last_epoch(),
        ..Trace::default()
    };
    drop(monitor);
    // The plot's trace comes from the journal (the planner's events are in
    // its own process).
    let journal = JournalSummary::read(&out.join("journal.jsonl")).map_err(|e| MissionError::Child(e.to_string()))?;
    for e in &journal.events {
        match e {
            JournalEvent::Arrival { pos, .. } => trace.arrivals.push((pos[0], pos[1])),
            JournalEvent::Plan { route, .. } => {
                if trace.first_plan.is_empty() {
                    trace.first_plan = route.clone();
                }
                trace.last_plan = route.clone();
            }
            _ => {}
        }
    }
    Ok(RunOut {
        totals,
        allocator_installed: true,
        finished: journal.outcome().is_some_and(|o| o != Outcome::Aborted),
        last_state,
        trace,
        faults: Some(report),
        rss_kb,
    })
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
    let mut world = load_world(&a.scenario)?;
    let fingerprint = world.fingerprint();
    let cfg = a
        .service
        .config(&world, a.lockstep && !a.enforce_deadline)
        .map_err(|e| match e {
            ServeError::Usage(u) => MissionError::Usage(u),
            other => MissionError::Serve(other),
        })?;
    let usage = |e: auv_messages::wire::FaultListError| MissionError::Usage(e.to_string());
    let sensor_faults =
        FaultCycle::parse_opt("--inject-sensor", a.inject_sensor.as_deref(), &SENSOR_FAULTS).map_err(usage)?;
    let vehicle_faults =
        FaultCycle::parse_opt("--inject-vehicle", a.inject_vehicle.as_deref(), &VEHICLE_FAULTS).map_err(usage)?;
    let plan_faults = a
        .service
        .plan_faults()
        .map_err(|e| MissionError::Usage(e.to_string()))?;
    let rules = Arc::new(WireRules::new(&world));
    let prefix = a.ipc_prefix.clone().unwrap_or_else(|| unique_prefix("m"));
    let opts = IpcOptions::new(Some(&prefix), &a.vehicle, WaitMode::Event)?;
    let out = a.out.clone().unwrap_or_else(|| fresh_out_dir(a.scenario.seed));
    std::fs::create_dir_all(&out).map_err(|e| io_err(&out, e))?;
    signal::install();
    cleanup_dead_nodes(&domain_config(&prefix)?);

    let mut common = vec![
        "--ipc-prefix".to_string(),
        prefix.clone(),
        "--vehicle".into(),
        a.vehicle.clone(),
    ];
    common.extend(a.scenario.to_flags());
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
        out: &out,
        common: &common,
        sensor_args: &sensor_args,
        vehicle_args: &vehicle_args,
        budget,
    };
    if a.external.any() {
        announce(a.external, &prefix, &a.vehicle, fingerprint, a.lockstep, &out);
    }
    let run = if a.planner_process || a.faults > 0 {
        supervised(a, &opts, &launch, world.sensor_period_s(), fingerprint)
    } else {
        threaded(a, opts, fingerprint, cfg, &launch, rules, plan_faults)
    };
    if a.external.any() && !wait_for_outside_nodes(&prefix, Duration::from_secs(10))? {
        eprintln!("planner: outside processes are still attached to domain {prefix}");
    }
    let retired = retire_domain(&prefix)?;
    let left = leftover_files(&prefix);
    if !retired {
        eprintln!("planner: iceoryx2 domain {prefix} still has live nodes; not removed");
    }
    let run = run?;
    let last = run.last_state;
    // What happened is what the vehicle's journal says.
    let journal = JournalSummary::read(&journal_path).map_err(|e| MissionError::Child(e.to_string()))?;
    let figures = VehicleFigures::of(&journal, last.as_ref(), run.finished);
    let outcome = figures.outcome;
    let stale_plans = last.map_or(0, |s| s.stale_plans);
    let rejected_vehicle = RejectCounters(last.map_or([0; auv_messages::msg::REJECT_KINDS], |s| s.rejected));
    let c = run.totals;
    let trace = run.trace;
    let report = Report {
        outcome,
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
        seed: a.scenario.seed,
        planner_seed: a.service.planner_seed,
        fingerprint,
        scenario: world.describe(),
        lockstep: a.lockstep,
        time_scale: a.time_scale,
        wall_time_s: wall.elapsed().as_secs_f64(),
        shm_files_left: left.len(),
        planner_process: a.planner_process,
        faults: run.faults,
        vehicle_restarts: journal.restarts(),
        iterations_budget: cfg.iterations,
        cut: c.cut,
        rss_kb: run.rss_kb,
        rt_priority: run.totals.rt_priority,
    };
    let report_path = out.join("report.json");
    let text = serde_json::to_string_pretty(&report.to_json()).unwrap_or_default();
    std::fs::write(&report_path, text + "\n").map_err(|e| io_err(&report_path, e))?;
    let title = format!(
        "Mission, seed {}: {}",
        a.scenario.seed,
        auv_messages::msg::outcome_name(outcome)
    );
    // Before the plot: the plot redraws the world to its last epoch, the
    // MCAP file starts from the world as generated.
    write_mcap(&out, &world, &journal, a, report.latency_us)?;
    plot(&out.join("mission.svg"), &mut world, &trace, &title)?;
    Ok((report, out))
}

/// Writes `out/mission.mcap` from `out/mission.log`, the journal and the
/// world; a lockstep run leaves the wall-clock latency out so the file is
/// reproducible.
fn write_mcap(
    out: &Path,
    world: &MissionWorld,
    journal: &JournalSummary,
    a: &MissionArgs,
    latency_us: (u64, u64, u64),
) -> Result<(), MissionError> {
    let log_path = out.join("mission.log");
    let log = std::fs::read_to_string(&log_path).map_err(|e| io_err(&log_path, e))?;
    let path = out.join("mission.mcap");
    let record = super::mcap_log::MissionRecord {
        world,
        log: &log,
        journal,
        vehicle: &a.vehicle,
        latency_us: (!a.lockstep).then_some(latency_us),
        geo: None,
    };
    super::mcap_log::write(&path, &record).map_err(|e| io_err(&path, e))
}

/// Runs `planner mission`: 0 when the mission ran to its end (goal or time
/// out: see the report), 1 on an error, 2 on bad arguments, 130 when stopped.
pub fn run_mission(a: &MissionArgs) -> ExitCode {
    match mission(a) {
        Ok((report, out)) => {
            if !a.quiet {
                println!("{}", report.summary());
                println!(
                    "wrote {}/report.json, mission.log, mission.svg, mission.mcap",
                    out.display()
                );
            }
            if report.outcome == Outcome::Aborted {
                ExitCode::from(130)
            } else {
                ExitCode::SUCCESS
            }
        }
        Err(e @ MissionError::Usage(_)) => {
            eprintln!("planner: error: {e}");
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("planner: error: mission: {e}");
            ExitCode::from(1)
        }
    }
}
