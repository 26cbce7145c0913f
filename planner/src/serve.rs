//! `planner serve`: the re-planning service as a process of its own (the
//! mission runs the same loop in-process; the latency bench starts this).

use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use crate::mission::log::with_log_writer;
use auv_core::capacity::Class;
use auv_core::solver::{Algorithm, Solver};
use auv_messages::msg::{CommandAck, OperatorCommand, Plan, PlannerStatus, VehicleState};
use auv_messages::wire::{FaultCycle, PLAN_FAULTS, WireRules};
use auv_platform::signal;
use auv_service::alloc;
use auv_service::core::{PlannerCore, ServiceConfig, ServiceEvent};
use auv_service::plan_out::FaultyPlans;
use auv_service::run::{ExitReason, PlannerPorts, run_service};
use auv_transport::guard::Guarded;
use auv_transport::ipc::{IpcContext, IpcInbox, IpcOutbox, IpcSnapshotInbox, IpcWaker, Shm, Stamp};
use auv_transport::{IpcArgs, Role, SetupError, TransportError};
use auv_world::load::{MissionWorld, ScenarioArgs, WorldError, load_world};

/// Flags of the planning service (shared by `serve` and `mission`).
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct ServiceArgs {
    /// Trigger → plan-published deadline, ms.
    #[arg(long, default_value_t = 20.0)]
    pub deadline_ms: f64,
    /// Solver iterations per re-plan (cut at the deadline).
    #[arg(long, default_value_t = 150)]
    pub iterations: u32,
    /// Planner: auto (memetic PSO + local search), or the paper's pso or bbo.
    #[arg(long, value_name = "auto|pso|bbo", default_value_t = Algorithm::Auto)]
    pub algorithm: Algorithm,
    /// Re-plan on a sensor update when the plan's remaining time moves by more than this, s.
    #[arg(long, default_value_t = 120.0)]
    pub replan_threshold_s: f64,
    /// Time held back from every plan's budget against drifting waypoints, s
    /// [default: the mission file's `vehicle.reserve_s`; 300 on the paper's
    /// generator].
    #[arg(long)]
    pub reserve_s: Option<f64>,
    /// Scale of the expected time lost chasing each drifting waypoint, added
    /// to the plan's edge times (1 = the simulated expectation, 0 = ignore
    /// drift and plan on the reported positions alone).
    #[arg(long, default_value_t = 1.0)]
    pub drift_allowance: f64,
    /// Seed of the planner's random draws.
    #[arg(long, default_value_t = 1)]
    pub planner_seed: u64,
    /// Run the service thread under SCHED_FIFO with this priority (1..=99;
    /// 0 = normal scheduling), so other work on the machine cannot preempt a
    /// solve past its deadline (needs CAP_SYS_NICE or root). Default: try
    /// priority 10 when deadlines are enforced and the service waits on
    /// events, falling back to normal scheduling with a warning if refused;
    /// normal scheduling with --spin or in lockstep (nothing is cut there).
    #[arg(long, value_name = "PRIO")]
    pub rt_priority: Option<i32>,
    /// Tests: also send a bad plan before each good one, taking these kinds
    /// in turn (non_edge, visited_node, bad_plan, or all); the vehicle must refuse them.
    #[arg(long, value_name = "KIND[,KIND…]")]
    pub inject_plan: Option<String>,
}

/// SCHED_FIFO priority the service asks for by default (our choice: low
/// among RT priorities, so kernel threads and real RT work still come first).
/// Measured under a load average of 8 (four compilers on two cores), the
/// default mission missed 3 of 224 deadlines (max 22.5 ms) under normal
/// scheduling and none (max 6.3 ms) with it.
pub const DEFAULT_RT_PRIORITY: i32 = 10;

/// `planner serve` flags.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct ServeArgs {
    #[command(flatten)]
    #[allow(missing_docs)]
    pub ipc: IpcArgs,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub scenario: ScenarioArgs,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub service: ServiceArgs,
    /// Deterministic solves: run every iteration, never cut at the deadline
    /// (latency is still measured and misses counted).
    #[arg(long)]
    pub lockstep: bool,
    /// Append the mission log (one JSON line per event) to this file.
    #[arg(long, value_name = "FILE")]
    pub log: Option<std::path::PathBuf>,
}

/// Why the service could not run.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// A flag out of range.
    #[error("{0}")]
    Usage(String),
    /// The world could not be built.
    #[error(transparent)]
    World(#[from] WorldError),
    /// iceoryx2 set-up failed.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The transport failed while running.
    #[error("transport: {0}")]
    Transport(#[from] TransportError),
    /// The log could not be written.
    #[error("log: {0}")]
    Log(String),
}

impl ServeArgs {
    /// The command line that starts `planner serve` with these flags, from
    /// the subcommand on: the one way a parent (the mission's supervisor, the
    /// latency bench) starts the service, so what it passes and what `serve`
    /// parses cannot drift apart.
    pub fn to_argv(&self) -> Vec<String> {
        let mut v = vec!["serve".to_string()];
        v.extend(self.ipc.to_flags());
        v.extend(self.scenario.to_flags());
        v.extend(self.service.to_flags());
        if self.lockstep {
            v.push("--lockstep".into());
        }
        if let Some(p) = &self.log {
            v.extend(["--log".into(), p.display().to_string()]);
        }
        v
    }
}

impl ServiceArgs {
    /// The flags that give these settings (see [`ServeArgs::to_argv`]).
    pub fn to_flags(&self) -> Vec<String> {
        let mut f = vec![
            "--deadline-ms".to_string(),
            self.deadline_ms.to_string(),
            "--iterations".into(),
            self.iterations.to_string(),
            "--algorithm".into(),
            self.algorithm.to_string(),
            "--drift-allowance".into(),
            self.drift_allowance.to_string(),
            "--replan-threshold-s".into(),
            self.replan_threshold_s.to_string(),
            "--planner-seed".into(),
            self.planner_seed.to_string(),
        ];
        if let Some(r) = self.reserve_s {
            f.extend(["--reserve-s".into(), r.to_string()]);
        }
        if let Some(p) = self.rt_priority {
            f.extend(["--rt-priority".into(), p.to_string()]);
        }
        if let Some(k) = &self.inject_plan {
            f.extend(["--inject-plan".into(), k.clone()]);
        }
        f
    }

    /// The service configuration these flags describe.
    pub fn config(&self, world: &MissionWorld, lockstep: bool) -> Result<ServiceConfig, ServeError> {
        if !(self.deadline_ms.is_finite() && self.deadline_ms > 1.0 && self.deadline_ms <= 60_000.0) {
            return Err(ServeError::Usage(format!(
                "--deadline-ms {}: must be between 1 and 60000",
                self.deadline_ms
            )));
        }
        if !(self.replan_threshold_s.is_finite() && self.replan_threshold_s >= 0.0) {
            return Err(ServeError::Usage(format!(
                "--replan-threshold-s {}: must be >= 0",
                self.replan_threshold_s
            )));
        }
        let reserve_s = self.reserve_s.unwrap_or(world.reserve_s());
        if !(reserve_s.is_finite() && reserve_s >= 0.0) {
            return Err(ServeError::Usage(format!("--reserve-s {reserve_s}: must be >= 0")));
        }
        self.plan_faults()?;
        if let Some(p) = self.rt_priority.filter(|p| !(0..=99).contains(p)) {
            return Err(ServeError::Usage(format!(
                "--rt-priority {p}: must be between 0 and 99"
            )));
        }
        if !(self.drift_allowance.is_finite() && self.drift_allowance >= 0.0) {
            return Err(ServeError::Usage(format!(
                "--drift-allowance {}: must be >= 0",
                self.drift_allowance
            )));
        }
        // A service world holds at most MAX_WIRE_NODES waypoints (checked when loaded).
        let mut arrival_allowance_s = [0.0; auv_messages::msg::MAX_WIRE_NODES];
        for (a, w) in arrival_allowance_s.iter_mut().zip(world.arrival_allowances_s()) {
            *a = w * self.drift_allowance;
        }
        Ok(ServiceConfig {
            deadline: Duration::from_secs_f64(self.deadline_ms / 1000.0),
            reserve_s,
            iterations: self.iterations,
            replan_threshold_s: self.replan_threshold_s,
            cut_at_deadline: !lockstep,
            seed: self.planner_seed,
            fingerprint: world.fingerprint(),
            arrival_allowance_s,
            algorithm: self.algorithm,
            ..ServiceConfig::default()
        })
    }
}

impl ServiceArgs {
    /// The plan faults `--inject-plan` asks for (none without the flag).
    pub fn plan_faults(&self) -> Result<FaultCycle, ServeError> {
        FaultCycle::parse_opt("--inject-plan", self.inject_plan.as_deref(), &PLAN_FAULTS)
            .map_err(|e| ServeError::Usage(e.to_string()))
    }
}

/// The solver the service runs: `auto` by default, or the paper's
/// PSO (150 particles, inertia schedule over the paper's 150 iterations) or
/// BBO. The iteration budget per re-plan comes from the service
/// configuration (default 150), cut at the deadline.
pub fn make_solver<const W: usize>(algorithm: Algorithm) -> Box<dyn Solver<W>> {
    algorithm.build(algorithm.paper_iterations())
}

/// The planner's ports on shared memory.
pub type ShmPlannerPorts = PlannerPorts<
    IpcWaker<Shm>,
    IpcInbox<Shm, VehicleState>,
    IpcSnapshotInbox<Shm>,
    FaultyPlans<IpcOutbox<Shm, Plan>>,
    IpcOutbox<Shm, PlannerStatus>,
    IpcInbox<Shm, OperatorCommand>,
    IpcOutbox<Shm, CommandAck>,
>;

/// Opens the planner's ports in the context's domain; inputs are checked
/// against `rules` (the scenario's world) besides their own validation;
/// `inject_plans` are the bad plans sent before good ones (tests).
pub fn open_ports(
    ctx: &IpcContext<Shm>,
    fingerprint: u64,
    rules: &Arc<WireRules>,
    inject_plans: FaultCycle,
) -> Result<ShmPlannerPorts, SetupError> {
    let stamp = Stamp::new(fingerprint);
    Ok(PlannerPorts {
        waker: ctx.waker(Role::Planner)?,
        states: Guarded::new(ctx.inbox::<VehicleState>()?, fingerprint, "planner").with_check(rules.state_check()),
        snapshots: Guarded::new(ctx.snapshot_inbox()?, fingerprint, "planner").with_check(rules.snapshot_check()),
        plans: FaultyPlans::new(ctx.outbox::<Plan>(stamp)?, inject_plans),
        status: ctx.outbox::<PlannerStatus>(stamp)?,
        commands: Guarded::new(ctx.inbox::<OperatorCommand>()?, fingerprint, "planner"),
        acks: ctx.outbox::<CommandAck>(stamp)?,
    })
}

/// Prepares the calling thread as the service thread: counted by the
/// allocator and served from its pool, and scheduled SCHED_FIFO as
/// `rt_priority` asks (see [`ServiceArgs::rt_priority`]); without a request
/// it tries [`DEFAULT_RT_PRIORITY`] only when `default_rt` (deadlines are
/// enforced, and the service does not spin: an RT spin would starve the
/// machine). Returns the RT priority in force, if any.
pub fn prepare_service_thread(rt_priority: Option<i32>, default_rt: bool) -> Result<Option<i32>, ServeError> {
    alloc::watch_this_thread();
    alloc::reserve_pool();
    let default = default_rt.then_some(DEFAULT_RT_PRIORITY);
    request_fifo(
        "--rt-priority",
        rt_priority,
        default,
        "the service runs on normal scheduling, so other work can push plans past their deadline",
    )
    .map_err(ServeError::Usage)
}

/// Puts the calling thread on SCHED_FIFO: at `requested` if given (0 keeps
/// normal scheduling; a refusal is an error naming `flag`), else at
/// `default` if any (a refusal is a warning that ends with `fallback`, and
/// the thread stays on normal scheduling). Returns the RT priority in force.
///
/// Processes started from this thread afterwards begin on normal scheduling
/// (`SCHED_RESET_ON_FORK`): an inherited RT policy turned `bench-latency
/// --receiver-rt-priority`'s spinning children into RT spinners that the
/// kernel's RT throttle parked for ~50 ms every second.
pub fn request_fifo(
    flag: &str,
    requested: Option<i32>,
    default: Option<i32>,
    fallback: &str,
) -> Result<Option<i32>, String> {
    let (prio, required) = match (requested, default) {
        (Some(0), _) | (None, None) => return Ok(None),
        (Some(p), _) if (1..=99).contains(&p) => (p, true),
        (Some(p), _) => return Err(format!("{flag} {p}: must be between 0 and 99")),
        (None, Some(p)) => (p, false),
    };
    let param = libc::sched_param { sched_priority: prio };
    // SAFETY: pid 0 is the calling thread; `param` is a valid sched_param.
    let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO | libc::SCHED_RESET_ON_FORK, &param) };
    if rc == 0 {
        return Ok(Some(prio));
    }
    let why = std::io::Error::last_os_error();
    if required {
        return Err(format!(
            "{flag} {prio}: SCHED_FIFO refused ({why}); it needs CAP_SYS_NICE or root"
        ));
    }
    eprintln!("planner: warning: SCHED_FIFO refused ({why}); {fallback} ({flag} 0 silences this)");
    Ok(None)
}

fn serve(args: &ServeArgs) -> Result<ExitReason, ServeError> {
    signal::install();
    let world = load_world(&args.scenario)?;
    let fingerprint = world.fingerprint();
    let rules = Arc::new(WireRules::new(&world));
    let cfg = args.service.config(&world, args.lockstep)?;
    let plan_faults = args.service.plan_faults()?;
    // The solver's buffers are sized for the mission: the smallest class
    // that holds its waypoints (a 40-node mission runs on 64-node tables).
    let class = Class::for_nodes(world.world().n()).map_err(|e| ServeError::Usage(e.to_string()))?;
    drop(world);
    let opts = args.ipc.options()?;
    let rt_priority = prepare_service_thread(args.service.rt_priority, !args.ipc.spin && !args.lockstep)?;
    let ctx = IpcContext::<Shm>::new(&opts, "planner")?;
    let mut ports = open_ports(&ctx, fingerprint, &rules, plan_faults)?;
    let log = args.log.as_deref();
    auv_core::with_class!(class, W => serve_in::<W>(cfg, rt_priority, log, &mut ports))
}

/// The service loop on a core of the class of `W` words.
fn serve_in<const W: usize>(
    cfg: ServiceConfig,
    rt_priority: Option<i32>,
    log: Option<&Path>,
    ports: &mut ShmPlannerPorts,
) -> Result<ExitReason, ServeError> {
    let mut core = PlannerCore::<W>::new(cfg, make_solver(cfg.algorithm));
    core.set_rt_priority(rt_priority);
    let exit = with_log_writer(log, |events: &mut dyn FnMut(&ServiceEvent)| {
        run_service(&mut core, ports, events, &mut |_| true)
    })
    .map_err(|e| ServeError::Log(format!("{}: {e}", log.unwrap_or(Path::new("")).display())))??;
    let c = core.counters();
    let a = alloc::counters();
    let h = core.latency_us();
    eprintln!(
        "planner: {} plans, latency p50 {} µs p99 {} µs max {} µs, {} deadline misses, \
         steady-state system allocations {} (pool blocks {}, pool high water {})",
        c.plans,
        h.value_at_quantile(0.5),
        h.value_at_quantile(0.99),
        h.max(),
        c.deadline_misses,
        a.sys_allocs_steady,
        a.pool_allocs_steady,
        a.pool_high_water
    );
    let r = ports.rejected();
    if r.total() > 0 {
        eprintln!("planner: rejected {} input message(s) in all: {r}", r.total());
    }
    Ok(exit)
}

/// Runs `planner serve`; the exit code follows the binaries' convention
/// (0 done, 1 error, 2 bad arguments or a scenario it cannot build, 130
/// signal).
pub fn run_serve(args: &ServeArgs) -> ExitCode {
    match serve(args) {
        Ok(ExitReason::Shutdown) => ExitCode::from(130),
        Ok(_) => ExitCode::SUCCESS,
        Err(e @ (ServeError::Usage(_) | ServeError::World(_))) => {
            eprintln!("planner: error: {e}");
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("planner: error: {e}");
            ExitCode::from(1)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::cli::IpcCommand;
    use clap::{CommandFactory, Parser};

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        service: ServiceArgs,
    }

    /// The `planner` command line as far as `serve` goes.
    #[derive(Parser)]
    struct Planner {
        #[command(subcommand)]
        cmd: IpcCommand,
    }

    fn parse_serve(argv: &[String]) -> ServeArgs {
        let cli = Planner::try_parse_from(std::iter::once("planner".to_string()).chain(argv.iter().cloned()));
        match cli.map(|c| c.cmd) {
            Ok(IpcCommand::Serve(a)) => a,
            Ok(other) => panic!("not serve: {other:?}"),
            Err(e) => panic!("{argv:?}: {e}"),
        }
    }

    #[test]
    fn serve_args_survive_the_trip_to_a_child_command_line() {
        let mission = std::env::current_dir().unwrap().join("missions/benoits-cove.toml");
        let every = |scenario: &[&str]| -> Vec<String> {
            [
                "serve",
                "--ipc-prefix",
                "rt_x_",
                "--vehicle",
                "auv7",
                "--spin",
                "--deadline-ms",
                "12.5",
                "--iterations",
                "77",
                "--algorithm",
                "bbo",
                "--replan-threshold-s",
                "0.1",
                "--reserve-s",
                "250.25",
                "--drift-allowance",
                "0.3",
                "--planner-seed",
                "18446744073709551615",
                "--rt-priority",
                "0",
                "--inject-plan",
                "non_edge,bad_plan",
                "--lockstep",
                "--log",
                "/tmp/some where/mission.log",
                "--time-available-s",
                "9000.5",
            ]
            .iter()
            .chain(scenario)
            .map(|s| s.to_string())
            .collect()
        };
        let with_mission = every(&[
            "--seed",
            "4",
            "--mission",
            mission.to_str().unwrap(),
            "--start-at",
            "120.5,80.25,3",
        ]);
        let with_generator = every(&["--scenario", "some.toml", "--nodes", "12"]);
        let defaults = vec!["serve".to_string()];
        let mut passed = std::collections::BTreeSet::new();
        for argv in [with_mission, with_generator, defaults] {
            let a = parse_serve(&argv);
            let child = a.to_argv();
            assert_eq!(parse_serve(&child), a, "{argv:?} → {child:?}");
            passed.extend(child.into_iter().filter(|f| f.starts_with("--")));
        }
        // Every flag `serve` takes is one the child command line can carry.
        let cmd = Planner::command();
        let serve = cmd.find_subcommand("serve").unwrap();
        for arg in serve.get_arguments() {
            let Some(long) = arg.get_long() else { continue };
            if long != "help" {
                assert!(passed.contains(&format!("--{long}")), "--{long} is never passed on");
            }
        }
    }

    #[test]
    fn the_service_plans_with_auto_unless_told_otherwise() {
        let world = auv_world::load::load_world(&auv_world::load::ScenarioArgs {
            seed: Some(1),
            nodes: Some(12),
            ..Default::default()
        })
        .unwrap();
        let default = Cli::try_parse_from(["x"]).unwrap().service;
        assert_eq!(default.algorithm, Algorithm::Auto);
        let cfg = default.config(&world, false).unwrap();
        assert_eq!(cfg.algorithm, Algorithm::Auto);
        assert_eq!(make_solver::<2>(cfg.algorithm).name(), "auto");
        for (flag, name) in [("pso", "pso"), ("bbo", "bbo"), ("auto", "auto")] {
            let args = Cli::try_parse_from(["x", "--algorithm", flag]).unwrap().service;
            assert_eq!(
                make_solver::<2>(args.config(&world, true).unwrap().algorithm).name(),
                name
            );
        }
        assert!(Cli::try_parse_from(["x", "--algorithm", "exact"]).is_err());
    }

    /// Field 41 (`policy`) of `/proc/<pid>/stat` as the process sees itself.
    fn policy_of_child() -> i32 {
        let out = std::process::Command::new("cat")
            .arg("/proc/self/stat")
            .output()
            .unwrap();
        let stat = String::from_utf8(out.stdout).unwrap();
        // Fields after the parenthesised command name start at field 3.
        let rest = &stat[stat.rfind(')').unwrap() + 2..];
        rest.split(' ').nth(41 - 3).unwrap().parse().unwrap()
    }

    #[test]
    fn children_of_an_rt_thread_start_on_normal_scheduling() {
        // A thread of its own: the policy must not leak into other tests.
        std::thread::spawn(|| match request_fifo("--x", Some(1), None, "") {
            Ok(Some(1)) => {
                let mut policy = 0;
                let mut param = libc::sched_param { sched_priority: 0 };
                // SAFETY: this thread's id and a valid out-parameter.
                unsafe { libc::pthread_getschedparam(libc::pthread_self(), &mut policy, &mut param) };
                assert_eq!(policy & !libc::SCHED_RESET_ON_FORK, libc::SCHED_FIFO);
                assert_eq!(param.sched_priority, 1);
                assert_eq!(policy_of_child(), libc::SCHED_OTHER);
            }
            Err(e) if e.contains("refused") => eprintln!("note: SCHED_FIFO not permitted here: {e}"),
            other => panic!("unexpected {other:?}"),
        })
        .join()
        .unwrap();
    }
}
