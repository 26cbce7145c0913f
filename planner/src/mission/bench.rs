//! `planner bench-latency`: trigger → plan latency through iceoryx2 across
//! real processes, next to a raw iceoryx2 ping-pong of the same payload sizes
//! in the same run.
//!
//! Method. This process plays sensor and vehicle. (1) Raw: it starts
//! `planner bench-echo` and measures the round trip of a ping the size of a
//! vehicle state answered by a pong the size of a plan, with the same wait
//! mode and the same wake-up notifications as the service. (2) Planner: it
//! starts `planner serve` on a fixture network, publishes one waypoint
//! snapshot, then sends `--triggers` arrival states one at a time (closed
//! loop: the next trigger leaves when the plan for the previous one is in)
//! and records, per plan, the end-to-end latency (trigger stamped → plan
//! received), the planner's own part (trigger taken off the transport →
//! plan stamped), the transport part (the rest: both wires and wake-ups), and
//! the plan's wire time alone (plan stamped → received). All stamps read the
//! host's one `CLOCK_MONOTONIC`, so cross-process differences are exact.
//! Every trigger is a full re-plan from the start with the whole budget.
//!
//! A deadline miss is a plan *published* later than the deadline after its
//! trigger *arrived* at the planner (the service's contract); plans
//! *received* by the trigger's sender later than the deadline after it sent
//! the trigger are counted separately (`late_received`).
//!
//! On a virtual machine the host can take a CPU away for milliseconds, which
//! nothing inside the guest can prevent. The bench reads the guest's steal
//! time (`/proc/stat`, both CPUs) just before each trigger and just after its
//! plan arrives, outside every timed interval, and reports the steal during
//! the measured triggers and how many misses had some in their window.

use std::process::{Child, Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

use hdrhistogram::Histogram;
use serde_json::json;

use crate::serve::{DEFAULT_RT_PRIORITY, ServeArgs, ServiceArgs, request_fifo};
use auv_messages::msg::{Outcome, Plan, PlannerStatus, RawPing, RawPong, VehicleEvent, VehicleMode, VehicleState};
use auv_messages::network::write_snapshot;
use auv_platform::clock::mono_now_ns;
use auv_platform::host::{host_steal_ticks, ms_per_tick};
use auv_platform::signal;
use auv_transport::ipc::{IpcContext, Shm, Stamp, retire_domain};
use auv_transport::unique_prefix;
use auv_transport::{Inbox, IpcArgs, IpcOptions, Outbox, Role, SetupError, TransportError, WaitMode, Wake, Waker};
use auv_world::load::{ScenarioArgs, load_world};

/// `planner bench-latency` flags.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct BenchArgs {
    /// Triggers measured (after the warm-up).
    #[arg(long, default_value_t = 10_000)]
    pub triggers: u32,
    /// Triggers sent first and not measured.
    #[arg(long, default_value_t = 100)]
    pub warmup: u32,
    /// Busy-poll in both processes instead of blocking on events.
    #[arg(long)]
    pub spin: bool,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Real time between a plan's arrival and the next trigger, ms. Missions
    /// trigger sparsely (about one arrival per real second at 1000×); a
    /// back-to-back loop would keep an RT planner busy above the kernel's RT
    /// throttle (`sched_rt_runtime_us`, 95 % by default), which then parks it
    /// for ~50 ms and turns the bench into a test of the throttle.
    #[arg(long, default_value_t = 2.0)]
    pub pause_ms: f64,
    /// SCHED_FIFO priority of this bench's measuring thread (the receiving
    /// end of every plan and pong); 0 = normal scheduling. Default: try
    /// priority 10 (as a real-time consumer of plans would run), falling
    /// back to normal scheduling with a warning if refused. On normal
    /// scheduling a spinning receiver shares its core with whatever else
    /// wakes, which shows in the wire tail (2-core VM, 10 000 triggers, same
    /// hour: plan wire p99 13.4 µs on normal scheduling, 4.9–5.1 µs on
    /// SCHED_FIFO 10). The processes the bench starts do not inherit it (the
    /// service's own policy is `--rt-priority`'s).
    #[arg(long, value_name = "PRIO")]
    pub receiver_rt_priority: Option<i32>,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub scenario: ScenarioArgs,
    /// The measured planner's flags, passed on to its `planner serve`.
    #[command(flatten)]
    pub service: ServiceArgs,
}

/// `planner bench-echo` flags (started by the bench).
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct EchoArgs {
    #[command(flatten)]
    #[allow(missing_docs)]
    pub ipc: IpcArgs,
}

/// Why the bench failed.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A flag out of range.
    #[error("{0}")]
    Usage(String),
    /// iceoryx2 set-up failed.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The transport failed.
    #[error("transport: {0}")]
    Transport(#[from] TransportError),
    /// A child process could not be started or failed.
    #[error("{0}")]
    Child(String),
    /// No answer in time.
    #[error("no answer from {0} within {1} s")]
    Timeout(&'static str, u64),
    /// Interrupted.
    #[error("interrupted")]
    Interrupted,
}

/// Body byte that tells the echo to exit.
const STOP: u8 = 0xFF;
/// Longest wait for one answer.
const ANSWER_TIMEOUT: Duration = Duration::from_secs(10);

/// Starts a child `planner` with `args`, its stderr captured.
fn spawn(args: &[String]) -> Result<Child, BenchError> {
    let exe = std::env::current_exe().map_err(|e| BenchError::Child(format!("cannot locate planner: {e}")))?;
    Command::new(exe)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| BenchError::Child(format!("cannot start planner {}: {e}", args.join(" "))))
}

/// Kills a child that is still running (on an error path) and reaps it.
struct Reaper(Option<Child>);

impl Reaper {
    fn wait(mut self, what: &str) -> Result<String, BenchError> {
        let Some(child) = self.0.take() else {
            return Ok(String::new());
        };
        let out = child
            .wait_with_output()
            .map_err(|e| BenchError::Child(format!("{what}: {e}")))?;
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        if !out.status.success() {
            return Err(BenchError::Child(format!(
                "{what} failed ({}): {}",
                out.status,
                err.trim()
            )));
        }
        Ok(err)
    }
}

impl Drop for Reaper {
    fn drop(&mut self) {
        if let Some(c) = &mut self.0 {
            // SAFETY: sending SIGTERM to our own child's pid.
            unsafe { libc::kill(c.id() as libc::pid_t, libc::SIGTERM) };
            let _ = c.wait();
        }
    }
}

fn histogram() -> Histogram<u64> {
    // ns, 3 significant digits, 1 ns .. 60 s; never resized.
    Histogram::new_with_bounds(1, 60_000_000_000, 3).unwrap_or_else(|_| Histogram::new(3).unwrap())
}

fn record(h: &mut Histogram<u64>, ns: u64) {
    let _ = h.record(ns.clamp(1, 60_000_000_000));
}

/// {p50, p99, p999, max, mean} in µs.
fn summary_us(h: &Histogram<u64>) -> serde_json::Value {
    let us = |ns: u64| (ns as f64 / 100.0).round() / 10.0;
    json!({
        "p50": us(h.value_at_quantile(0.5)),
        "p99": us(h.value_at_quantile(0.99)),
        "p999": us(h.value_at_quantile(0.999)),
        "max": us(h.max()),
        "mean": (h.mean() / 100.0).round() / 10.0,
        "count": h.len(),
    })
}

/// Waits for input; `Err(Interrupted)` on a signal.
fn wait(waker: &mut dyn Waker, t: Duration) -> Result<(), BenchError> {
    match waker.wait(t)? {
        Wake::Shutdown => Err(BenchError::Interrupted),
        _ => Ok(()),
    }
}

fn raw_pingpong(opts: &IpcOptions, rounds: u32, warmup: u32) -> Result<Histogram<u64>, BenchError> {
    let mut args = vec!["bench-echo".to_string()];
    args.extend(IpcArgs::of(opts).to_flags());
    let echo = Reaper(Some(spawn(&args)?));
    let ctx = IpcContext::<Shm>::new(opts, "bench")?;
    let mut ping = ctx.outbox::<RawPing>(Stamp::new(0))?;
    let mut pong = ctx.inbox::<RawPong>()?;
    let mut waker = ctx.waker(Role::Vehicle)?;
    let mut h = histogram();
    for round in 0..warmup + rounds {
        let seq = ping.publish(&mut |_| {})?;
        let t0 = Instant::now();
        let mut got = None;
        while got.is_none() {
            pong.drain(&mut |p: &RawPong| {
                if p.ping_seq >= seq {
                    got = Some(mono_now_ns().saturating_sub(p.ping_sent_mono_ns));
                }
            })?;
            if got.is_some() {
                break;
            }
            if t0.elapsed() > ANSWER_TIMEOUT {
                return Err(BenchError::Timeout("bench-echo", ANSWER_TIMEOUT.as_secs()));
            }
            if round == 0 && t0.elapsed() > Duration::from_millis(20) {
                // The echo may not have subscribed yet: send the first ping again.
                ping.publish(&mut |_| {})?;
            }
            wait(&mut waker, Duration::from_millis(20))?;
        }
        if round >= warmup
            && let Some(ns) = got
        {
            record(&mut h, ns);
        }
    }
    ping.publish(&mut |m: &mut RawPing| m.body[0] = STOP)?;
    echo.wait("bench-echo")?;
    Ok(h)
}

/// Per-plan measurements of the planner run.
struct PlannerRun {
    end_to_end: Histogram<u64>,
    planner: Histogram<u64>,
    transport: Histogram<u64>,
    plan_wire: Histogram<u64>,
    deadline_misses: u64,
    late_received: u64,
    /// Steal ticks within the measured triggers' windows (None: not readable).
    host_steal_ticks: Option<u64>,
    /// Misses whose window saw some steal.
    misses_with_host_steal: u64,
    deadline_cuts: u64,
    iterations: u64,
    status: Option<PlannerStatus>,
    planner_stderr: String,
}

fn planner_run(opts: &IpcOptions, a: &BenchArgs) -> Result<PlannerRun, BenchError> {
    let world = load_world(&a.scenario).map_err(|e| BenchError::Usage(e.to_string()))?;
    let fingerprint = world.fingerprint();
    let inst = world.snapshot();
    let args = ServeArgs {
        ipc: IpcArgs::of(opts),
        scenario: a.scenario.clone(),
        service: a.service.clone(),
        lockstep: false,
        log: None,
    }
    .to_argv();
    let planner = Reaper(Some(spawn(&args)?));
    let ctx = IpcContext::<Shm>::new(opts, "bench")?;
    let stamp = Stamp::new(fingerprint);
    let mut snapshots = ctx.snapshot_outbox(stamp, inst.nodes.len())?;
    let mut states = ctx.outbox::<VehicleState>(stamp)?;
    let mut plans = ctx.inbox::<Plan>()?;
    let mut status_in = ctx.inbox::<PlannerStatus>()?;
    let mut waker = ctx.waker(Role::Vehicle)?;
    let mut res = Ok(());
    snapshots.publish(&mut |m| {
        res = write_snapshot(&inst, 0, m);
        m.next_update_s = 1e12;
    })?;
    res.map_err(|e| BenchError::Usage(e.to_string()))?;
    // Wait for the planner's heartbeat, handing it the snapshot once it subscribes.
    let t0 = Instant::now();
    let mut status: Option<PlannerStatus> = None;
    while status.is_none() {
        status_in.drain(&mut |s: &PlannerStatus| status = Some(*s))?;
        snapshots.refresh();
        if t0.elapsed() > ANSWER_TIMEOUT {
            return Err(BenchError::Timeout("planner serve", ANSWER_TIMEOUT.as_secs()));
        }
        wait(&mut waker, Duration::from_millis(20))?;
    }
    let deadline_ns = (a.service.deadline_ms * 1e6) as u64;
    let mut run = PlannerRun {
        end_to_end: histogram(),
        planner: histogram(),
        transport: histogram(),
        plan_wire: histogram(),
        deadline_misses: 0,
        late_received: 0,
        host_steal_ticks: host_steal_ticks().map(|_| 0),
        misses_with_host_steal: 0,
        deadline_cuts: 0,
        iterations: 0,
        status: None,
        planner_stderr: String::new(),
    };
    let start = inst.start as u16;
    let pause = Duration::from_secs_f64(a.pause_ms / 1e3);
    for k in 0..a.warmup + a.triggers {
        let steal_before = host_steal_ticks();
        let seq = states.publish(&mut |m: &mut VehicleState| {
            m.header.mission_time_s = 0.0;
            let p = inst.nodes[inst.start];
            m.position = [p.x, p.y, p.z];
            m.time_left_s = inst.time_available_s;
            m.mode = if k == 0 {
                VehicleMode::NoPlan
            } else {
                VehicleMode::Working
            } as u32;
            m.event = VehicleEvent::Arrival as u32;
            m.outcome = Outcome::Running as u32;
            m.from_node = start.into();
            m.to_node = start.into();
            // Each trigger is an arrival (the counter moves), planned from the start.
            m.arrivals = k;
            m.route_len = 1;
            m.route[0] = start;
        })?;
        let t0 = Instant::now();
        let mut got: Option<(Plan, u64)> = None;
        loop {
            plans.drain(&mut |p: &Plan| {
                if p.state_seq == seq {
                    // Stamp before copying the payload out, as the raw
                    // ping-pong does: reading it is the consumer's work.
                    let received = mono_now_ns();
                    got = Some((*p, received));
                }
            })?;
            if got.is_some() {
                break;
            }
            if t0.elapsed() > ANSWER_TIMEOUT {
                return Err(BenchError::Timeout("planner serve", ANSWER_TIMEOUT.as_secs()));
            }
            wait(&mut waker, Duration::from_millis(50))?;
        }
        let steal = host_steal_ticks()
            .zip(steal_before)
            .map(|(after, before)| after.saturating_sub(before));
        if pause > Duration::ZERO {
            std::thread::sleep(pause);
        }
        let Some((p, received)) = got else { continue };
        if k < a.warmup {
            continue;
        }
        let sent = p.trigger_sent_mono_ns;
        let total = received.saturating_sub(sent);
        let inside = p.header.sent_mono_ns.saturating_sub(p.trigger_received_mono_ns);
        record(&mut run.end_to_end, total);
        record(&mut run.planner, inside);
        record(&mut run.transport, total.saturating_sub(inside));
        record(&mut run.plan_wire, received.saturating_sub(p.header.sent_mono_ns));
        run.deadline_misses += u64::from(inside > deadline_ns);
        run.late_received += u64::from(total > deadline_ns);
        if let (Some(acc), Some(ticks)) = (&mut run.host_steal_ticks, steal) {
            *acc += ticks;
            run.misses_with_host_steal += u64::from(inside > deadline_ns && ticks > 0);
        }
        run.deadline_cuts += u64::from(p.deadline_cut);
        run.iterations += u64::from(p.iterations);
    }
    // End the service and keep its last status.
    states.publish(&mut |m: &mut VehicleState| {
        m.mode = VehicleMode::Finished as u32;
        m.event = VehicleEvent::Finished as u32;
        m.outcome = Outcome::GoalReached as u32;
        m.route_len = 1;
        m.route[0] = start;
    })?;
    let t0 = Instant::now();
    loop {
        status_in.drain(&mut |s: &PlannerStatus| status = Some(*s))?;
        if status.is_some_and(|s| s.phase == auv_messages::msg::PlannerPhase::Finished as u32)
            || t0.elapsed() > ANSWER_TIMEOUT
        {
            break;
        }
        wait(&mut waker, Duration::from_millis(20))?;
    }
    run.status = status;
    drop((snapshots, states, plans, status_in, waker, ctx));
    run.planner_stderr = planner.wait("planner serve")?;
    Ok(run)
}

fn bench(a: &BenchArgs) -> Result<serde_json::Value, BenchError> {
    if a.triggers == 0 {
        return Err(BenchError::Usage("--triggers must be at least 1".into()));
    }
    // The service's own checks, before anything starts.
    let world = load_world(&a.scenario).map_err(|e| BenchError::Usage(e.to_string()))?;
    a.service
        .config(&world, false)
        .map_err(|e| BenchError::Usage(e.to_string()))?;
    drop(world);
    if a.service.inject_plan.is_some() {
        // The bench takes the first plan for a trigger as its answer.
        return Err(BenchError::Usage(
            "--inject-plan: not with bench-latency (a bad plan would be timed as the answer)".into(),
        ));
    }
    if !(a.pause_ms.is_finite() && (0.0..=10_000.0).contains(&a.pause_ms)) {
        return Err(BenchError::Usage(format!(
            "--pause-ms {}: must be between 0 and 10000",
            a.pause_ms
        )));
    }
    let receiver_rt = request_fifo(
        "--receiver-rt-priority",
        a.receiver_rt_priority,
        Some(DEFAULT_RT_PRIORITY),
        "the bench receives on normal scheduling, so other work on its core shows in the wire tail",
    )
    .map_err(BenchError::Usage)?;
    signal::install();
    let prefix = unique_prefix("b");
    let mode = if a.spin { WaitMode::Spin } else { WaitMode::Event };
    let opts = IpcOptions::new(Some(&prefix), "bench", mode)?;
    let result = (|| {
        let raw = raw_pingpong(&opts, a.triggers, a.warmup)?;
        let run = planner_run(&opts, a)?;
        Ok::<_, BenchError>((raw, run))
    })();
    let retired = retire_domain(&prefix)?;
    let leftovers = auv_transport::ipc::leftover_files(&prefix);
    let (raw, run) = result?;
    let world_desc = load_world(&a.scenario).map(|w| w.describe()).unwrap_or_default();
    let alloc = run.status.map(|s| s.alloc).unwrap_or_default();
    let n = run.end_to_end.len().max(1);
    Ok(json!({
        "triggers": a.triggers,
        "warmup": a.warmup,
        "deadline_ms": a.service.deadline_ms,
        "spin": a.spin,
        "world": world_desc,
        "iterations_budget": a.service.iterations,
        "algorithm": a.service.algorithm.to_string(),
        "rt_priority": a.service.rt_priority,
        "receiver_rt_priority": receiver_rt,
        "pause_ms": a.pause_ms,
        "iterations_mean": run.iterations as f64 / n as f64,
        "payload_bytes": {
            "trigger": core::mem::size_of::<VehicleState>(),
            "plan": core::mem::size_of::<Plan>(),
        },
        "plan_us": summary_us(&run.end_to_end),
        "planner_us": summary_us(&run.planner),
        "transport_us": summary_us(&run.transport),
        "plan_wire_us": summary_us(&run.plan_wire),
        "raw_us": summary_us(&raw),
        "deadline_misses": run.deadline_misses,
        "late_received": run.late_received,
        "host_steal_ms": run.host_steal_ticks.map(|t| t as f64 * ms_per_tick()),
        "deadline_misses_with_host_steal": run.misses_with_host_steal,
        "deadline_cuts": run.deadline_cuts,
        "planner": {
            "steady_state_allocations": alloc.sys_allocs_steady,
            "steady_state_frees": alloc.sys_frees_steady,
            "pool_allocs_steady": alloc.pool_allocs_steady,
            "pool_high_water": alloc.pool_high_water,
            "pool_capacity": alloc.pool_capacity,
            "allocator_installed": alloc.pool_capacity > 0,
            "summary": run.planner_stderr.trim(),
        },
        "shm_leftovers": leftovers.len(),
        "domain_retired": retired,
    }))
}

fn print_table(v: &serde_json::Value) {
    let row = |name: &str, key: &str| {
        let s = &v[key];
        println!(
            "{name:<34} {:>9} {:>9} {:>9} {:>9} {:>9}",
            s["p50"], s["p99"], s["p999"], s["max"], s["mean"]
        );
    };
    println!(
        "{} triggers ({} warm-up), deadline {} ms, {} mode, {}; receiver {}",
        v["triggers"],
        v["warmup"],
        v["deadline_ms"],
        if v["spin"] == true { "spin" } else { "event" },
        v["world"],
        match v["receiver_rt_priority"].as_i64() {
            Some(p) => format!("SCHED_FIFO {p}"),
            None => "on normal scheduling".to_string(),
        }
    );
    println!(
        "{:<34} {:>9} {:>9} {:>9} {:>9} {:>9}",
        "µs", "p50", "p99", "p99.9", "max", "mean"
    );
    row("trigger → plan received", "plan_us");
    row("  planner (received → published)", "planner_us");
    row("  transport (the rest)", "transport_us");
    row("  plan wire (published → received)", "plan_wire_us");
    row("raw iceoryx2 ping-pong (same sizes)", "raw_us");
    println!(
        "deadline misses {}, received late {}, cut by the deadline {}, mean iterations {:.1}",
        v["deadline_misses"], v["late_received"], v["deadline_cuts"], v["iterations_mean"]
    );
    if let Some(ms) = v["host_steal_ms"].as_f64() {
        println!(
            "host steal during the measured triggers {ms:.0} ms; misses with steal in their window {}",
            v["deadline_misses_with_host_steal"]
        );
    }
    println!(
        "planner steady state: {} system allocations, {} pool blocks (high water {})",
        v["planner"]["steady_state_allocations"], v["planner"]["pool_allocs_steady"], v["planner"]["pool_high_water"]
    );
}

/// Runs `planner bench-latency`.
pub fn run_bench(a: &BenchArgs) -> ExitCode {
    match bench(a) {
        Ok(v) => {
            if a.json {
                println!("{v}");
            } else {
                print_table(&v);
            }
            ExitCode::SUCCESS
        }
        Err(e @ BenchError::Usage(_)) => {
            eprintln!("planner: error: {e}");
            ExitCode::from(2)
        }
        Err(BenchError::Interrupted) => ExitCode::from(130),
        Err(e) => {
            eprintln!("planner: error: bench-latency: {e}");
            ExitCode::from(1)
        }
    }
}

/// Runs `planner bench-echo`: answers every raw ping with a pong until told to stop.
pub fn run_echo(a: &EchoArgs) -> ExitCode {
    let run = || -> Result<(), BenchError> {
        signal::install();
        let opts = a.ipc.options()?;
        let ctx = IpcContext::<Shm>::new(&opts, "bench-echo")?;
        let mut pings = ctx.inbox::<RawPing>()?;
        let mut pongs = ctx.outbox::<RawPong>(Stamp::new(0))?;
        let mut waker = ctx.waker(Role::Planner)?;
        loop {
            let mut stop = false;
            let mut err = Ok(());
            pings.drain(&mut |p: &RawPing| {
                if p.body[0] == STOP {
                    stop = true;
                } else if err.is_ok() {
                    err = pongs
                        .publish(&mut |m: &mut RawPong| {
                            m.ping_seq = p.header.seq;
                            m.ping_sent_mono_ns = p.header.sent_mono_ns;
                        })
                        .map(|_| ());
                }
            })?;
            err?;
            if stop {
                return Ok(());
            }
            if waker.wait(Duration::from_millis(50))? == Wake::Shutdown {
                return Err(BenchError::Interrupted);
            }
        }
    };
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(BenchError::Interrupted) => ExitCode::from(130),
        Err(e) => {
            eprintln!("planner: error: bench-echo: {e}");
            ExitCode::from(1)
        }
    }
}
