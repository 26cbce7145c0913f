//! The mission's supervisor: runs the planner service (`planner serve`),
//! sensor-sim and vehicle-sim as child processes and keeps them running,
//! whoever caused a fault.
//!
//! Contract:
//! - A child that exits without being asked to (a signal, a non-zero exit,
//!   a panic) is restarted with the resume behaviour of each process: the
//!   vehicle from its journal, the sensor at the vehicle's mission time, the
//!   planner from the latest state and snapshot the topics keep. Exit code
//!   2 (bad arguments) is not restarted: it would fail the same way again.
//! - Each process has a restart budget ([`RestartBudget`]); when one is
//!   spent, the mission stops in a safe state: the vehicle is told to hold
//!   at its next waypoint (SIGUSR1) and ends with outcome `safe_hold`; when
//!   the vehicle itself is the process that keeps failing, the supervisor
//!   writes the hold into its journal (it holds where it last arrived).
//! - A child silent past its stall timeout is a stall (the passive
//!   [`Monitor`]); silent for `--stall-kill-ms` more, it is killed and
//!   restarted like a crashed one.
//! - Every restart and stall is counted by process and by cause: `injected`
//!   (the fault injector of `--faults` did it) or `external` (anything else).
//! - The children's pids are in `<out>/pids.json`, rewritten at every
//!   (re)start, so an operator or a test can signal one.
//! - SIGINT/SIGTERM to the supervisor is forwarded to the children, nothing
//!   is restarted any more, and the run ends with its report.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use super::child::Kid;
use super::replace::Replacement;
use super::restart::{
    DEFAULT_BACKOFF_MS, DEFAULT_MAX_RESTARTS, DEFAULT_WINDOW_S, RestartBudget, RestartPolicy, Verdict,
};
use super::run::{Launch, MissionArgs, MissionError, RunOut, io_err, sibling_binary};
use super::supervise::{FaultKind, FaultReport, LATEST_INJECTION, LivenessEvent, Monitor, Proc, plan_faults};
use crate::serve::ServeArgs;
use auv_messages::journal::{Journal, JournalEvent, JournalSummary};
use auv_messages::msg::Outcome;
use auv_platform::signal;
use auv_transport::{IpcArgs, IpcOptions};

/// Supervision flags of `planner mission`.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct SupervisorArgs {
    /// Most restarts of one process within --restart-window-s; one more
    /// failure stops the mission in a safe hold.
    #[arg(long, default_value_t = DEFAULT_MAX_RESTARTS)]
    pub max_restarts: u32,
    /// Window of the restart budget, real s.
    #[arg(long, default_value_t = DEFAULT_WINDOW_S)]
    pub restart_window_s: f64,
    /// Wait before restarting a process, real ms; doubles with each restart
    /// of it within the window (at most 5 s).
    #[arg(long, default_value_t = DEFAULT_BACKOFF_MS)]
    pub restart_backoff_ms: f64,
    /// A process stalled (silent past its stall timeout) this much longer is
    /// killed and restarted, real ms (0: never; scaled time only).
    #[arg(long, default_value_t = 5000.0)]
    pub stall_kill_ms: f64,
}

impl SupervisorArgs {
    /// The restart policy; `Err` names a flag out of range.
    pub fn policy(&self) -> Result<RestartPolicy, String> {
        if !(self.restart_window_s.is_finite() && self.restart_window_s > 0.0) {
            return Err(format!("--restart-window-s {}: must be > 0", self.restart_window_s));
        }
        if !(self.restart_backoff_ms.is_finite() && (0.0..=60_000.0).contains(&self.restart_backoff_ms)) {
            return Err(format!(
                "--restart-backoff-ms {}: must be between 0 and 60000",
                self.restart_backoff_ms
            ));
        }
        if !(self.stall_kill_ms.is_finite() && self.stall_kill_ms >= 0.0) {
            return Err(format!("--stall-kill-ms {}: must be >= 0", self.stall_kill_ms));
        }
        Ok(RestartPolicy {
            max_restarts: self.max_restarts,
            window: Duration::from_secs_f64(self.restart_window_s),
            backoff: Duration::from_secs_f64(self.restart_backoff_ms / 1000.0),
        })
    }
}

/// Who caused a restart or a stall.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cause {
    /// The fault injector (`--faults`).
    Injected = 0,
    /// Anything else: a crash, an operator's kill, the OOM killer, a hang.
    External = 1,
}

/// What the supervisor did, by process ([`Proc`] order) and [`Cause`].
#[derive(Clone, Debug, Default)]
pub struct SupervisionReport {
    /// Restarts.
    pub restarts: [[u64; 2]; 3],
    /// Stalls detected.
    pub stalls: [[u64; 2]; 3],
    /// Stalled processes killed to be restarted.
    pub stall_kills: [[u64; 2]; 3],
    /// Why the mission stopped in a safe hold, if it did.
    pub safe_hold: Option<String>,
    /// The restart policy in force.
    pub policy: RestartPolicy,
    /// `--stall-kill-ms`.
    pub stall_kill_ms: f64,
}

impl SupervisionReport {
    /// Restarts of `p` for every cause.
    pub fn restarts_of(&self, p: Proc) -> u64 {
        self.restarts[p as usize].iter().sum()
    }

    /// The report's `supervision` object.
    pub fn to_json(&self) -> Value {
        let by = |m: &[[u64; 2]; 3]| -> Value {
            let mut o = serde_json::Map::new();
            for p in Proc::ALL {
                let [inj, ext] = m[p as usize];
                o.insert(
                    p.name().into(),
                    json!({"injected": inj, "external": ext, "total": inj + ext}),
                );
            }
            Value::Object(o)
        };
        let total = |m: &[[u64; 2]; 3]| -> Value {
            json!({
                "injected": m.iter().map(|c| c[0]).sum::<u64>(),
                "external": m.iter().map(|c| c[1]).sum::<u64>(),
            })
        };
        json!({
            "restarts": by(&self.restarts),
            "restarts_total": total(&self.restarts),
            "stalls": by(&self.stalls),
            "stalls_total": total(&self.stalls),
            "stall_kills": by(&self.stall_kills),
            "safe_hold_reason": self.safe_hold,
            "restart_budget": {
                "max_restarts": self.policy.max_restarts,
                "window_s": self.policy.window.as_secs_f64(),
                "backoff_ms": self.policy.backoff.as_secs_f64() * 1000.0,
            },
            "stall_kill_ms": self.stall_kill_ms,
        })
    }
}

/// The fault being injected now.
#[derive(Clone, Copy, Debug)]
enum Active {
    /// A killed process is restarted: cleared when it is heard from again.
    Restarting { p: Proc, key_idx: usize, since: Instant },
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

/// How often the supervisor looks for replace-mission requests.
#[cfg(feature = "shore")]
const REQUEST_POLL: Duration = Duration::from_millis(100);

/// Longest wait for the vehicle to reach its hold, real s.
const HOLD_LIMIT: Duration = Duration::from_secs(30);

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

/// One supervised process and what the supervisor knows of it.
struct Slot {
    kid: Kid,
    budget: RestartBudget,
    /// When to start it again (it exited unasked).
    restart_at: Option<Instant>,
    /// Who caused the exit expected next (the supervisor sent a kill).
    kill_cause: Option<Cause>,
}

/// The shore link's process (`planner link`, with `--shore`): restarted
/// whenever it fails, with a growing back-off and no budget, and never a
/// reason to stop the mission: the vehicle does not depend on it.
struct LinkSlot {
    kid: Kid,
    restart_at: Option<Instant>,
    started_at: Instant,
    backoff: Duration,
    restarts: u64,
}

/// First wait before restarting the link, doubled per quick failure up to
/// [`LINK_BACKOFF_MAX`] (our choice: the shore notices a loss within its
/// timeout, 1 s by default; a restart well inside it keeps the gap short).
const LINK_BACKOFF: Duration = Duration::from_millis(200);
/// Longest the mission waits at start for the link's ports, before it
/// starts the others anyway.
const LINK_READY_WAIT: Duration = Duration::from_secs(3);

/// `link_start` lines the link has written to its events file (one per start,
/// once its onboard ports are open).
fn count_link_starts(events: &Path) -> usize {
    std::fs::read_to_string(events).map_or(0, |t| t.lines().filter(|l| l.contains("\"link_start\"")).count())
}

/// Longest wait before restarting the link.
const LINK_BACKOFF_MAX: Duration = Duration::from_secs(5);

/// Writes `<out>/pids.json`: this process and each child's pid (null while
/// it is down), replaced atomically.
fn write_pids(out: &Path, slots: &[Slot; 3], link: Option<&LinkSlot>) {
    let mut v = json!({"supervisor": std::process::id()});
    for p in Proc::ALL {
        v[p.name()] = json!(slots[p as usize].kid.pid());
    }
    if let Some(l) = link {
        v["link"] = json!(l.kid.pid());
    }
    let tmp = out.join("pids.json.tmp");
    if std::fs::write(&tmp, format!("{v}\n")).is_ok() {
        let _ = std::fs::rename(&tmp, out.join("pids.json"));
    }
}

/// Ends the journal in a safe hold on the vehicle's behalf (its process
/// keeps failing, so it cannot say so itself): it holds where it last arrived.
fn journal_hold(path: &Path) -> Result<(), MissionError> {
    let j = JournalSummary::read(path).map_err(|e| MissionError::Child(e.to_string()))?;
    if j.outcome().is_some() {
        return Ok(());
    }
    let t = j.time_s();
    let node = j.route().last().copied().unwrap_or(0);
    let mut w = Journal::open(path).map_err(|e| MissionError::Child(e.to_string()))?;
    w.append(&JournalEvent::Hold { t, node })
        .and_then(|()| {
            w.append(&JournalEvent::End {
                t,
                outcome: Outcome::SafeHold,
            })
        })
        .map_err(|e| MissionError::Child(e.to_string()))
}

/// Runs the mission's three processes under supervision, injecting the
/// faults `--faults` asks for.
pub(super) fn supervise(
    a: &MissionArgs,
    opts: &IpcOptions,
    l: &Launch,
    sensor_period_s: f64,
    fingerprint: u64,
) -> Result<RunOut, MissionError> {
    let (out, budget) = (l.out, l.budget);
    let policy = a.supervisor.policy().map_err(MissionError::Usage)?;
    let stall_kill =
        (a.supervisor.stall_kill_ms > 0.0).then(|| Duration::from_secs_f64(a.supervisor.stall_kill_ms / 1000.0));
    let stall = Duration::from_secs_f64(a.stall_timeout_ms / 1000.0);
    let sensor_stall = if a.lockstep {
        stall
    } else {
        stall.max(Duration::from_secs_f64(3.0 * sensor_period_s / a.time_scale))
    };
    let timeouts = [stall, sensor_stall, stall];
    // The monitor subscribes before anyone publishes: it sees every status.
    let mut monitor = Monitor::new(opts, timeouts, fingerprint)?;
    let log_path = out.join("mission.log");
    File::create(&log_path).map_err(|e| io_err(&log_path, e))?;
    let planner_args = ServeArgs {
        ipc: IpcArgs::of(opts),
        scenario: l.scenario.clone(),
        service: a.service.clone(),
        lockstep: a.lockstep && !a.enforce_deadline,
        log: Some(log_path),
    }
    .to_argv();
    let me = std::env::current_exe().map_err(|e| MissionError::Child(format!("cannot locate planner: {e}")))?;
    let child = |e: super::child::ChildError| MissionError::Child(e.to_string());
    let kids = [
        Kid::new("planner", me, &planner_args, out).map_err(child)?,
        if a.external.external_sensor {
            Kid::outside("sensor-sim", out).map_err(child)?
        } else {
            Kid::new("sensor-sim", sibling_binary("sensor-sim")?, l.sensor_args, out).map_err(child)?
        },
        if a.external.external_vehicle {
            Kid::outside("vehicle-sim", out).map_err(child)?
        } else {
            Kid::new("vehicle-sim", sibling_binary("vehicle-sim")?, l.vehicle_args, out).map_err(child)?
        },
    ];
    let mut slots = kids.map(|kid| Slot {
        kid,
        budget: RestartBudget::new(policy),
        restart_at: None,
        kill_cause: None,
    });
    let mut link = match &a.shore {
        Some(endpoint) => {
            let mut args = vec!["link".to_string()];
            args.extend(l.common.iter().cloned());
            args.extend(["--listen".into(), endpoint.clone()]);
            args.extend(a.link.to_flags());
            args.extend(["--log".into(), out.join("link.jsonl").display().to_string()]);
            args.extend([
                "--plan-history".into(),
                out.join("link-plans.jsonl").display().to_string(),
            ]);
            if let Some(r) = l.requests {
                args.extend(["--requests".into(), r.display().to_string()]);
            }
            if let Some(id) = l.replaced_by {
                args.extend(["--replaced-by".into(), id.to_string()]);
            }
            let me = std::env::current_exe().map_err(|e| MissionError::Child(format!("cannot locate planner: {e}")))?;
            let mut kid = Kid::new("link", me, &args, out).map_err(child)?;
            let journal = out.join("link.jsonl");
            let starts = count_link_starts(&journal);
            kid.start(&[]).map_err(child)?;
            // The link first, so that its subscribers exist before the
            // planner's first plan (plans are not replayed); but only for a
            // moment: the mission never waits on the link.
            let t0 = Instant::now();
            while count_link_starts(&journal) == starts && t0.elapsed() < LINK_READY_WAIT {
                std::thread::sleep(Duration::from_millis(10));
            }
            Some(LinkSlot {
                kid,
                restart_at: None,
                started_at: Instant::now(),
                backoff: LINK_BACKOFF,
                restarts: 0,
            })
        }
        None => None,
    };
    for s in &mut slots {
        s.kid.start(&[]).map_err(child)?;
    }
    write_pids(out, &slots, link.as_ref());
    let fault_seed = a.fault_seed.unwrap_or(l.seed);
    let faults = plan_faults(fault_seed, a.faults, budget, &Proc::ALL);
    let mut report = FaultReport {
        planned: faults.clone(),
        timeouts_ms: timeouts.map(|t| t.as_secs_f64() * 1000.0),
        ..FaultReport::default()
    };
    let mut sup = SupervisionReport {
        policy,
        stall_kill_ms: a.supervisor.stall_kill_ms,
        ..SupervisionReport::default()
    };
    let keys: Vec<String> = faults.iter().map(|f| f.key()).collect();
    let faults_path = out.join("faults.log");
    let mut flog = BufWriter::new(File::create(&faults_path).map_err(|e| io_err(&faults_path, e))?);
    let wall0 = Instant::now();
    let note = |flog: &mut BufWriter<File>, t: f64, v: Value| {
        let mut v = v;
        v["t"] = json!(t);
        v["wall_s"] = json!(wall0.elapsed().as_secs_f64());
        let _ = writeln!(flog, "{v}");
        let _ = flog.flush();
    };
    let bar = progress_bar(a.quiet, budget);
    let mut next = 0;
    let mut active: Option<Active> = None;
    let mut events = Vec::new();
    // Set once the run is being wound down: shutdown, or a safe hold.
    let mut stopping = false;
    let mut forwarded = false;
    let mut hold_since: Option<Instant> = None;
    let mut child_error = None;
    let mut rss_kb = [0u64; 3];
    let mut rss_at = Instant::now();
    let journal_path = out.join("journal.jsonl");
    let mut replaced: Option<Replacement> = None;
    let mut requests_at = Instant::now();
    loop {
        let now = Instant::now();
        if rss_at.elapsed() >= Duration::from_millis(100) {
            rss_at = now;
            for (peak, s) in rss_kb.iter_mut().zip(&slots) {
                *peak = (*peak).max(s.kid.rss_kb().unwrap_or(0));
            }
        }
        let final_state_seen = monitor
            .last_state()
            .is_some_and(|s| s.outcome != Outcome::Running as u32);
        // The mission is over when the vehicle exits having ended it (its
        // journal says how; a vehicle stopped by SIGTERM ends it aborted).
        // An outside vehicle is not ours to see exit: its final state ends it.
        if a.external.external_vehicle && final_state_seen {
            break;
        }
        let vehicle = &mut slots[Proc::Vehicle as usize].kid;
        if vehicle.poll()
            && (vehicle.exit_status().is_some_and(|s| s.success())
                || JournalSummary::read(&journal_path).is_ok_and(|j| j.outcome().is_some()))
        {
            break;
        }
        let mission_over = final_state_seen || stopping;
        let mut watch = [false; 3];
        for p in Proc::ALL {
            let s = &mut slots[p as usize];
            watch[p as usize] = !a.lockstep && !mission_over && s.restart_at.is_none() && s.kid.running();
        }
        // The sensor keeps the vehicle's clock: while the vehicle is down it
        // is silent by design, not stalled.
        let v = &mut slots[Proc::Vehicle as usize];
        if v.restart_at.is_some() || !v.kid.running() {
            watch[Proc::Sensor as usize] = false;
            monitor.forget(Proc::Sensor);
        }
        events.clear();
        monitor.poll(watch, &mut events);
        let t = monitor.last_state().map_or(0.0, |s| s.header.mission_time_s);
        bar.set_position(t.clamp(0.0, budget) as u64);
        for e in &events {
            match *e {
                LivenessEvent::Stalled { proc, silent } => {
                    let mut cause = Cause::External;
                    if let Some(Active::Paused { p, since, detected, .. }) = &mut active
                        && *p == proc
                    {
                        cause = Cause::Injected;
                        if !*detected {
                            *detected = true;
                            report.detect_ms_max = report.detect_ms_max.max(since.elapsed().as_secs_f64() * 1000.0);
                        }
                    }
                    sup.stalls[proc as usize][cause as usize] += 1;
                    eprintln!("planner: {} silent for {} ms: stalled", proc.name(), silent.as_millis());
                    note(
                        &mut flog,
                        t,
                        json!({"event": "stall_detected", "process": proc.name(), "silent_ms": silent.as_millis() as u64, "cause": cause_name(cause)}),
                    );
                }
                LivenessEvent::Recovered { proc, silent } => note(
                    &mut flog,
                    t,
                    json!({"event": "recovered", "process": proc.name(), "silent_ms": silent.as_millis() as u64}),
                ),
            }
        }
        // A process stalled too long is killed, to be restarted below.
        if let Some(limit) = stall_kill
            && !mission_over
        {
            for p in Proc::ALL {
                let injected = matches!(active, Some(Active::Paused { p: q, .. }) if q == p);
                let s = &mut slots[p as usize];
                if s.kill_cause.is_none() && monitor.stalled_for(p).is_some_and(|d| d >= limit) {
                    let cause = if injected { Cause::Injected } else { Cause::External };
                    sup.stall_kills[p as usize][cause as usize] += 1;
                    note(
                        &mut flog,
                        t,
                        json!({"event": "stall_kill", "process": p.name(), "cause": cause_name(cause)}),
                    );
                    s.kill_cause = Some(cause);
                    s.kid.signal(libc::SIGKILL);
                    s.kid.signal(libc::SIGCONT);
                }
            }
        }
        // Exits nobody asked for: restart, within the budget.
        for p in Proc::ALL {
            let s = &mut slots[p as usize];
            if s.restart_at.is_some() || !s.kid.poll() {
                continue;
            }
            let Some(status) = s.kid.exit_status() else { continue };
            let cause = s.kill_cause.take().unwrap_or(Cause::External);
            // Done (its mission ended) or told to stop (a Ctrl-C reaches the
            // children as it reaches us): not a fault.
            if status.success() || mission_over || signal::shutdown_requested() {
                continue;
            }
            if status.code() == Some(2) {
                child_error = Some(format!("{} exited with {status}: {}", p.name(), s.kid.log_tail()));
                stopping = true;
                for q in &slots {
                    q.kid.signal(libc::SIGCONT);
                    q.kid.signal(libc::SIGTERM);
                }
                break;
            }
            s.kid.clear_exit();
            monitor.forget(p);
            note(
                &mut flog,
                t,
                json!({"event": "exited", "process": p.name(), "status": status.to_string(), "cause": cause_name(cause)}),
            );
            match s.budget.on_exit(now) {
                Verdict::RestartAt(at) => {
                    sup.restarts[p as usize][cause as usize] += 1;
                    s.restart_at = Some(at);
                }
                Verdict::Exhausted { restarts } => {
                    let why = format!(
                        "{} failed again after {restarts} restarts within {} s ({status})",
                        p.name(),
                        policy.window.as_secs_f64()
                    );
                    eprintln!("planner: {why}: stopping the mission in a safe hold");
                    note(&mut flog, t, json!({"event": "safe_hold", "reason": why}));
                    sup.safe_hold = Some(why);
                    stopping = true;
                    hold_since = Some(now);
                    if p == Proc::Vehicle {
                        journal_hold(&journal_path)?;
                        for q in [Proc::Planner, Proc::Sensor] {
                            slots[q as usize].kid.signal(libc::SIGCONT);
                            slots[q as usize].kid.signal(libc::SIGTERM);
                        }
                    } else {
                        let v = &slots[Proc::Vehicle as usize].kid;
                        v.signal(libc::SIGCONT);
                        v.signal(libc::SIGUSR1);
                    }
                    break;
                }
            }
        }
        let mut started = false;
        for p in Proc::ALL {
            let s = &mut slots[p as usize];
            match s.restart_at {
                Some(_) if stopping || final_state_seen => s.restart_at = None,
                Some(at) if now >= at => {
                    s.restart_at = None;
                    s.kid.start(&restart_flags(p)).map_err(child)?;
                    note(&mut flog, t, json!({"event": "restarted", "process": p.name()}));
                    started = true;
                }
                _ => {}
            }
        }
        if let Some(lk) = &mut link {
            let over = mission_over || stopping || signal::shutdown_requested();
            if lk.restart_at.is_none() && lk.kid.poll() {
                let status = lk.kid.exit_status();
                lk.kid.clear_exit();
                if !over && !status.is_some_and(|s| s.success()) {
                    let st = status.map_or("unknown".to_string(), |s| s.to_string());
                    if lk.started_at.elapsed() > Duration::from_secs(10) {
                        lk.backoff = LINK_BACKOFF;
                    }
                    lk.restarts += 1;
                    lk.restart_at = Some(now + lk.backoff);
                    lk.backoff = (lk.backoff * 2).min(LINK_BACKOFF_MAX);
                    eprintln!("planner: shore link exited ({st}); restarting it, the mission goes on");
                    note(
                        &mut flog,
                        t,
                        json!({"event": "exited", "process": "link", "status": st}),
                    );
                }
            }
            match lk.restart_at {
                Some(_) if over => lk.restart_at = None,
                Some(at) if now >= at => {
                    lk.restart_at = None;
                    lk.kid.start(&[]).map_err(child)?;
                    lk.started_at = Instant::now();
                    note(&mut flog, t, json!({"event": "restarted", "process": "link"}));
                    started = true;
                }
                _ => {}
            }
        }
        if started {
            write_pids(out, &slots, link.as_ref());
        }
        let vehicle_gone =
            !slots[Proc::Vehicle as usize].kid.running() && slots[Proc::Vehicle as usize].restart_at.is_none();
        if stopping && vehicle_gone {
            break;
        }
        if hold_since.is_some_and(|h| h.elapsed() > HOLD_LIMIT) {
            eprintln!("planner: the vehicle did not reach its hold in time; stopping");
            break;
        }
        // The fault in hand, then the next one.
        let vehicle_done = final_state_seen || stopping;
        match active {
            Some(Active::Restarting { p, key_idx, since }) => {
                let s = &slots[p as usize];
                if s.restart_at.is_none() && s.kill_cause.is_none() && monitor.heard(p) {
                    *report.cleared.entry(keys[key_idx].clone()).or_default() += 1;
                    note(&mut flog, t, json!({"event": "cleared", "fault": keys[key_idx]}));
                    active = None;
                } else if since.elapsed() > CLEAR_LIMIT || vehicle_done {
                    active = None;
                }
            }
            Some(Active::Paused {
                p,
                key_idx,
                until,
                detected,
                ..
            }) => {
                if now >= until || vehicle_done && p != Proc::Vehicle {
                    slots[p as usize].kid.signal(libc::SIGCONT);
                    note(&mut flog, t, json!({"event": "continued", "process": p.name()}));
                    active = Some(Active::Continued { p, key_idx, detected });
                }
            }
            Some(Active::Continued { p, key_idx, detected }) => {
                if !monitor.stalled(p) || vehicle_done {
                    if detected {
                        *report.cleared.entry(keys[key_idx].clone()).or_default() += 1;
                        note(&mut flog, t, json!({"event": "cleared", "fault": keys[key_idx]}));
                    }
                    active = None;
                }
            }
            None => {
                if next < faults.len() && t >= faults[next].at_s && t > LATEST_INJECTION * budget {
                    report.skipped_late += 1;
                    note(&mut flog, t, json!({"event": "skipped_late", "fault": keys[next]}));
                    next += 1;
                } else if next < faults.len() && !vehicle_done && t >= faults[next].at_s {
                    let f = faults[next];
                    let p = f.target;
                    let s = &mut slots[p as usize];
                    // A pause of a process already silent could not be told
                    // from that silence: wait until it is heard again.
                    if s.kid.running() && !monitor.stalled(p) {
                        *report.injected.entry(keys[next].clone()).or_default() += 1;
                        note(
                            &mut flog,
                            t,
                            json!({"event": "inject", "fault": keys[next], "planned_t": f.at_s}),
                        );
                        match f.kind {
                            FaultKind::Kill => {
                                s.kill_cause = Some(Cause::Injected);
                                s.kid.signal(libc::SIGKILL);
                                active = Some(Active::Restarting {
                                    p,
                                    key_idx: next,
                                    since: now,
                                });
                            }
                            FaultKind::Pause => {
                                s.kid.signal(libc::SIGSTOP);
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
        }
        // A new mission from shore (the link files it): checked against
        // where the vehicle is; taken on, it ends this leg.
        #[cfg(feature = "shore")]
        if let Some(dir) = l.requests
            && requests_at.elapsed() >= REQUEST_POLL
        {
            requests_at = now;
            let requests = auv_link::replace::Requests::new(dir);
            for id in requests.pending() {
                let over = final_state_seen || stopping || signal::shutdown_requested();
                let vehicle = &mut slots[Proc::Vehicle as usize].kid;
                let verdict = super::replace::take_on(id, &requests, l, a.external.any(), over, vehicle, &mut monitor);
                let answer = match &verdict {
                    Ok(r) => super::replace::applied(r.t),
                    Err(refusal) => refusal.answer(monitor.last_state().map_or(0.0, |s| s.header.mission_time_s)),
                };
                note(
                    &mut flog,
                    t,
                    json!({"event": "replace_mission", "id": id, "applied": answer.applied, "reason": answer.reason, "detail": answer.detail}),
                );
                if let Err(e) = requests.answer(id, &answer) {
                    eprintln!("planner: cannot answer replace-mission {id}: {e}");
                }
                if let Ok(r) = verdict {
                    eprintln!(
                        "planner: taking on the mission of replace-mission {id} at t {:.0} s, from ({:.0}, {:.0}) m",
                        r.t, r.start_at[0], r.start_at[1]
                    );
                    replaced = Some(r);
                    break;
                }
            }
            if replaced.is_some() {
                // Killed, not stopped: a stopped vehicle would end the
                // mission, and the link would announce that end ashore.
                for s in &slots {
                    s.kid.signal(libc::SIGKILL);
                    s.kid.signal(libc::SIGCONT);
                }
                if let Some(lk) = &link {
                    lk.kid.signal(libc::SIGKILL);
                }
                break;
            }
        }
        #[cfg(not(feature = "shore"))]
        let _ = (&mut requests_at, &mut replaced);
        if signal::shutdown_requested() && !forwarded {
            forwarded = true;
            stopping = true;
            for s in &slots {
                s.kid.signal(libc::SIGCONT);
                s.kid.signal(signal::received_signal());
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    bar.finish_and_clear();
    for s in &slots {
        s.kid.signal(libc::SIGCONT);
    }
    // The planner and the sensor end when they see the vehicle's last state.
    for s in &mut slots {
        s.kid.finish(Duration::from_secs(10));
    }
    // The link announces the end for a moment, then exits by itself.
    if let Some(lk) = &mut link {
        lk.kid.finish(Duration::from_secs(5));
    }
    write_pids(out, &slots, link.as_ref());
    events.clear();
    monitor.poll([false; 3], &mut events);
    let _ = flog.flush();
    if let Some(e) = child_error {
        return Err(MissionError::Child(e));
    }
    let totals = monitor.planner_totals();
    let last_state = monitor.last_state().copied();
    let last_epoch = monitor.last_epoch();
    let announced = monitor.announced().clone();
    drop(monitor);
    let journal = JournalSummary::read(&journal_path).map_err(|e| MissionError::Child(e.to_string()))?;
    Ok(RunOut {
        totals,
        allocator_installed: true,
        finished: journal.outcome().is_some_and(|o| o != Outcome::Aborted),
        last_state,
        journal,
        last_epoch,
        faults: Some(report),
        supervision: sup,
        announced,
        rss_kb,
        link_restarts: link.map(|l| l.restarts),
        replaced,
    })
}

fn cause_name(c: Cause) -> &'static str {
    match c {
        Cause::Injected => "injected",
        Cause::External => "external",
    }
}

fn progress_bar(quiet: bool, budget: f64) -> indicatif::ProgressBar {
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::new(budget as u64);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} s mission time")
    {
        b.set_style(style.progress_chars("=> "));
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_supervision_report_counts_by_process_and_cause() {
        let mut r = SupervisionReport::default();
        r.restarts[Proc::Sensor as usize][Cause::External as usize] = 2;
        r.restarts[Proc::Sensor as usize][Cause::Injected as usize] = 1;
        r.stalls[Proc::Planner as usize][Cause::Injected as usize] = 1;
        let j = r.to_json();
        assert_eq!(j["restarts"]["sensor-sim"]["external"], 2);
        assert_eq!(j["restarts"]["sensor-sim"]["total"], 3);
        assert_eq!(j["restarts_total"]["injected"], 1);
        assert_eq!(j["stalls"]["planner"]["injected"], 1);
        assert_eq!(j["safe_hold_reason"], Value::Null);
        assert_eq!(r.restarts_of(Proc::Sensor), 3);
    }

    #[test]
    fn supervision_flags_out_of_range_are_named() {
        let ok = SupervisorArgs {
            max_restarts: 3,
            restart_window_s: 10.0,
            restart_backoff_ms: 50.0,
            stall_kill_ms: 0.0,
        };
        assert!(ok.policy().is_ok());
        let bad = SupervisorArgs {
            restart_window_s: 0.0,
            ..ok.clone()
        };
        assert!(bad.policy().unwrap_err().contains("--restart-window-s"));
        let bad = SupervisorArgs {
            restart_backoff_ms: f64::NAN,
            ..ok.clone()
        };
        assert!(bad.policy().unwrap_err().contains("--restart-backoff-ms"));
        let bad = SupervisorArgs {
            stall_kill_ms: -1.0,
            ..ok
        };
        assert!(bad.policy().unwrap_err().contains("--stall-kill-ms"));
    }
}
