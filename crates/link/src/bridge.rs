//! The onboard bridge (`planner link`): onboard topics → Zenoh, operator
//! commands → the planner, heartbeats both ways.
//!
//! Contract:
//! - One iceoryx2 subscriber per onboard topic (one of each topic's
//!   outside-client slots; a restarted bridge may briefly hold a second
//!   one), polled every [`POLL`]: the bridge takes no wake-listener slot
//!   and no publisher ever waits for it. Each message is validated
//!   ([`Guarded`]) and published as JSON ([`super::encode`]).
//! - A command is decoded, its waypoint resolved by name, and forwarded as
//!   an `auv.OperatorCommand.v1`; the planner's ack goes back on `…/ack`.
//!   The bridge remembers the ack of every id it forwarded: a command sent
//!   again (after a reconnect) is answered with the same ack and not
//!   forwarded again (the planner also answers a repeat without applying it).
//! - The shore's heartbeats drive a [`LinkMonitor`]; every change is a line
//!   in the link log (`link.log`, JSON) and a loss is never an error.
//! - A console that (re)connects asks for the latest state, plan, status
//!   and snapshot (`auv/<vehicle>/*`) and for the plans it missed
//!   (`auv/<vehicle>/history/plan`: the last [`PLAN_HISTORY`] plans).
//! - Once the vehicle reports the end of the mission, the bridge publishes
//!   `mission_end` for [`END_LINGER`] and exits.

use std::collections::HashMap;
use std::io::Write;
use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use serde_json::{Value, json};
use zenoh::Wait;
use zenoh::key_expr::KeyExpr;

use super::encode::{self, Ack, Command, Event, Heartbeat, PlanMsg, REPLACE_MISSION, Snapshot, State, Status};
use super::keys;
use super::monitor::{LinkChange, LinkMonitor, heartbeat_period};
use super::replace::{MAX_MISSION_BYTES, Requests};
use auv_messages::msg::{CommandAck, CommandKind, NO_NODE, OperatorCommand, Plan, PlannerStatus, VehicleState};
use auv_platform::signal;
use auv_transport::guard::Guarded;
use auv_transport::ipc::{IpcContext, Shm, Stamp};
use auv_transport::{Outbox, SetupError, TransportError};

/// How often the onboard topics are polled (our choice: 1 ms adds at most
/// that to a plan's way ashore, at a few percent of one core).
pub const POLL: Duration = Duration::from_millis(1);

/// Plans kept for a console that (re)connects (our choice: more than a
/// whole mission re-plans at the paper's scale, 300 KB of JSON at most).
pub const PLAN_HISTORY: usize = 2048;

/// How long the end of the mission is announced before the bridge exits.
pub const END_LINGER: Duration = Duration::from_millis(1000);

/// What the bridge needs besides its sessions.
#[derive(Clone, Debug)]
pub struct BridgeConfig {
    /// Vehicle namespace (`auv/<vehicle>/…`).
    pub vehicle: String,
    /// Silence of the shore after which the link counts as lost.
    pub link_timeout: Duration,
    /// Scenario fingerprint (commands are stamped with it).
    pub fingerprint: u64,
    /// Waypoint names by id (the mission file's names), for commands.
    pub names: Vec<String>,
    /// The link log, if any.
    pub log: Option<PathBuf>,
    /// The endpoint listened on (for the log).
    pub endpoint: String,
    /// Where the plans forwarded are kept (one payload per line), so a
    /// restarted bridge still answers the history with the plans its
    /// predecessor forwarded.
    pub plan_history: Option<PathBuf>,
    /// Where replace-mission requests go to the mission's supervisor
    /// (`None`: no supervisor, the command is refused as `unsupported`).
    pub requests: Option<Requests>,
    /// This bridge serves the mission that replace-mission command `id`
    /// brought: its ack goes out with the first plan of this mission.
    pub replaced_by: Option<u64>,
}

/// The plans forwarded so far, oldest first, the last [`PLAN_HISTORY`]:
/// in memory and, when given a file, appended to it as they come.
struct PlanHistory {
    plans: std::collections::VecDeque<Vec<u8>>,
    file: Option<std::fs::File>,
}

impl PlanHistory {
    /// The history kept in `path` (read back if it exists), or in memory only.
    fn open(path: Option<&PathBuf>) -> Result<Self, BridgeError> {
        let mut h = Self {
            plans: std::collections::VecDeque::new(),
            file: None,
        };
        let Some(path) = path else { return Ok(h) };
        let io = |e: std::io::Error| BridgeError::Log {
            path: path.display().to_string(),
            detail: e.to_string(),
        };
        let mut torn = false;
        match std::fs::read(path) {
            // A torn last line (the predecessor killed mid-write) is dropped:
            // only complete payloads are answered.
            Ok(bytes) => {
                for line in bytes.split(|&b| b == b'\n') {
                    if serde_json::from_slice::<serde_json::Value>(line).is_ok() {
                        h.remember(line.to_vec());
                    }
                }
                torn = bytes.last().is_some_and(|&b| b != b'\n');
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(io(e)),
        }
        let mut file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(io)?;
        if torn {
            // End the torn line so the next plan starts a line of its own.
            std::io::Write::write_all(&mut file, b"\n").map_err(io)?;
        }
        h.file = Some(file);
        Ok(h)
    }

    fn remember(&mut self, bytes: Vec<u8>) {
        if self.plans.len() == PLAN_HISTORY {
            self.plans.pop_front();
        }
        self.plans.push_back(bytes);
    }

    /// Adds a plan; a failed write costs only the history of a restart.
    fn push(&mut self, bytes: &[u8]) {
        if let Some(f) = &mut self.file {
            use std::io::Write as _;
            let mut line = Vec::with_capacity(bytes.len() + 1);
            line.extend_from_slice(bytes);
            line.push(b'\n');
            let _ = f.write_all(&line);
        }
        self.remember(bytes.to_vec());
    }
}

/// Why the bridge stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// iceoryx2 set-up failed.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The onboard transport failed.
    #[error("transport: {0}")]
    Transport(#[from] TransportError),
    /// Zenoh refused a declaration.
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// The link log or the plan history could not be opened.
    #[error("{path}: {detail}")]
    Log {
        /// The file.
        path: String,
        /// What went wrong.
        detail: String,
    },
}

fn zerr(e: impl std::fmt::Display) -> BridgeError {
    BridgeError::Zenoh(e.to_string())
}

/// What the bridge saw, for its caller.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BridgeSummary {
    /// Messages forwarded ashore.
    pub forwarded: u64,
    /// Link losses declared.
    pub losses: u64,
    /// Restorations.
    pub restores: u64,
    /// Largest silence at a loss's declaration, ms.
    pub detect_ms_max: f64,
    /// Commands applied / refused (by the planner or, for an unknown
    /// waypoint or a bad payload, by the bridge).
    pub commands_applied: u64,
    /// See `commands_applied`.
    pub commands_refused: u64,
    /// The mission ended while the bridge ran.
    pub mission_ended: bool,
}

fn unix_ms() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64() * 1000.0)
}

/// The link log: one JSON object per line, with the wall clock (`unix_ms`)
/// and the latest mission time (`t`).
struct LinkLog {
    file: Option<(std::fs::File, PathBuf)>,
}

impl LinkLog {
    fn open(path: Option<&PathBuf>) -> Result<Self, BridgeError> {
        let file = match path {
            Some(p) => Some((
                std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(p)
                    .map_err(|e| BridgeError::Log {
                        path: p.display().to_string(),
                        detail: e.to_string(),
                    })?,
                p.clone(),
            )),
            None => None,
        };
        Ok(Self { file })
    }

    fn line(&mut self, t: f64, mut v: Value) {
        v["t"] = json!(t);
        v["unix_ms"] = json!(unix_ms());
        eprintln!("planner link: {v}");
        if let Some((f, p)) = &mut self.file
            && writeln!(f, "{v}").is_err()
        {
            eprintln!("planner link: warning: cannot append to {}", p.display());
        }
    }
}

/// A command as the planner takes it, or the reason the bridge refuses it.
fn resolve(c: &Command, names: &[String]) -> Result<(CommandKind, f64, u32), &'static str> {
    let kind = CommandKind::from_name(&c.command).ok_or("unknown_command")?;
    match kind {
        CommandKind::AbortToGoal => Ok((kind, 0.0, NO_NODE)),
        CommandKind::SetTimeBudget => match c.budget_s {
            Some(b) if b.is_finite() && b > 0.0 => Ok((kind, b, NO_NODE)),
            _ => Err("budget_out_of_range"),
        },
        CommandKind::AddTask | CommandKind::RemoveTask => {
            let w = c.waypoint.as_deref().ok_or("unknown_waypoint")?;
            let id = names
                .iter()
                .position(|n| n == w)
                .or_else(|| w.parse::<usize>().ok().filter(|&i| i < names.len()))
                .ok_or("unknown_waypoint")?;
            Ok((kind, 0.0, id as u32))
        }
    }
}

/// Files a replace-mission command for the supervisor; the path of its
/// mission file, or the reason (and its words) it is refused here.
fn file_replacement(c: &Command, requests: Option<&Requests>) -> Result<PathBuf, (&'static str, String)> {
    let req = requests.ok_or(("unsupported", "this link runs without a mission supervisor".to_string()))?;
    let text = c.mission.as_deref().unwrap_or("");
    if text.trim().is_empty() {
        return Err(("bad_mission", "the command carries no mission file".into()));
    }
    if text.len() > MAX_MISSION_BYTES {
        return Err((
            "bad_mission",
            format!(
                "the mission file has {} bytes; at most {MAX_MISSION_BYTES} are accepted",
                text.len()
            ),
        ));
    }
    if req.submitted(c.id) {
        return Ok(req.mission_path(c.id));
    }
    req.submit(c.id, text).map_err(|e| {
        (
            "unsupported",
            format!("cannot file the request in {}: {e}", req.dir().display()),
        )
    })
}

/// Runs the bridge until the mission ends (then it lingers [`END_LINGER`])
/// or a signal arrives.
pub fn run_bridge(
    ctx: &IpcContext<Shm>,
    session: &zenoh::Session,
    cfg: &BridgeConfig,
) -> Result<BridgeSummary, BridgeError> {
    let fp = cfg.fingerprint;
    let mut states = Guarded::new(ctx.inbox::<VehicleState>()?, fp, "link");
    let mut plans = Guarded::new(ctx.inbox::<Plan>()?, fp, "link");
    let mut statuses = Guarded::new(ctx.inbox::<PlannerStatus>()?, fp, "link");
    let mut snapshots = Guarded::new(ctx.snapshot_inbox()?, fp, "link");
    let mut acks_in = Guarded::new(ctx.inbox::<CommandAck>()?, fp, "link");
    let mut commands_out = ctx.outbox::<OperatorCommand>(Stamp::new(fp))?;

    let v = &cfg.vehicle;
    let publisher = |leaf: &str| session.declare_publisher(keys::key(v, leaf)).wait().map_err(zerr);
    let pub_state = publisher(keys::STATE)?;
    let pub_plan = publisher(keys::PLAN)?;
    let pub_status = publisher(keys::STATUS)?;
    let pub_snapshot = publisher(keys::SNAPSHOT)?;
    let pub_event = publisher(keys::EVENT)?;
    let pub_ack = publisher(keys::ACK)?;
    let pub_heartbeat = publisher(keys::HEARTBEAT_ONBOARD)?;
    let sub_heartbeat = session
        .declare_subscriber(keys::key(v, keys::HEARTBEAT_SHORE))
        .wait()
        .map_err(zerr)?;
    let sub_command = session
        .declare_subscriber(keys::key(v, keys::COMMAND))
        .wait()
        .map_err(zerr)?;
    let queryable = session.declare_queryable(keys::latest(v)).wait().map_err(zerr)?;
    let history_key = keys::key(v, keys::PLAN_HISTORY);
    let history_queryable = session.declare_queryable(history_key.clone()).wait().map_err(zerr)?;
    let mut history = PlanHistory::open(cfg.plan_history.as_ref())?;

    let mut log = LinkLog::open(cfg.log.as_ref())?;
    let mut monitor = LinkMonitor::new(cfg.link_timeout);
    let period = heartbeat_period(cfg.link_timeout);
    let session_id = Stamp::new(fp).session;
    let mut summary = BridgeSummary::default();
    // Latest payload per catch-up leaf.
    let mut latest: HashMap<&'static str, Vec<u8>> = HashMap::new();
    // Ack per forwarded command id (None: forwarded, not answered yet).
    let mut answered: HashMap<u64, Option<Vec<u8>>> = HashMap::new();
    // Replace-mission requests waiting for the supervisor's answer.
    let mut replacing: Vec<u64> = Vec::new();
    if let Some(id) = cfg.replaced_by {
        answered.insert(id, None);
    }
    let mut replace_ack_due = cfg.replaced_by;
    let mut t = 0.0f64;
    let mut hb_seq = 0u64;
    let mut last_hb: Option<Instant> = None;
    let mut ended: Option<(Instant, String)> = None;
    let mut last_end_note = Instant::now();
    log.line(
        t,
        json!({"event": "link_start", "endpoint": cfg.endpoint, "timeout_ms": cfg.link_timeout.as_millis() as u64}),
    );
    loop {
        if signal::shutdown_requested() {
            break;
        }
        let now = Instant::now();
        // Onboard → shore.
        let mut out: Vec<(&'static str, Vec<u8>)> = Vec::new();
        let mut acks: Vec<Ack> = Vec::new();
        states.drain(&mut |s| {
            let m = State::of(s);
            t = t.max(m.origin.t);
            if m.finished() && ended.is_none() {
                ended = Some((Instant::now(), m.outcome.clone()));
            }
            out.push((keys::STATE, encode::encode(&m)));
        })?;
        let mut first_plan = None;
        plans.drain(&mut |p| {
            first_plan = first_plan.or(Some((p.header.seq, p.replan)));
            out.push((keys::PLAN, encode::encode(&PlanMsg::of(p))));
        })?;
        // The replacement this mission is took effect with its first plan.
        if let (Some(id), Some(plan)) = (replace_ack_due, first_plan) {
            replace_ack_due = None;
            acks.push(Ack::new(id, REPLACE_MISSION, true, "none", plan, t));
        }
        statuses.drain(&mut |s| out.push((keys::STATUS, encode::encode(&Status::of(s)))))?;
        snapshots.drain(&mut |s| out.push((keys::SNAPSHOT, encode::encode(&Snapshot::of(s)))))?;
        acks_in.drain(&mut |a| acks.push(Ack::of(a)))?;
        // The supervisor's refusals (an applied replacement is answered by
        // the next mission's bridge, with that mission's first plan).
        if let Some(req) = &cfg.requests {
            replacing.retain(|&id| match req.answer_of(id) {
                Some(ans) if !ans.applied => {
                    let mut a = Ack::new(id, REPLACE_MISSION, false, &ans.reason, (0, 0), ans.t);
                    a.detail = Some(ans.detail);
                    acks.push(a);
                    false
                }
                Some(_) => false,
                None => true,
            });
        }
        for (leaf, bytes) in out {
            let p = match leaf {
                keys::STATE => &pub_state,
                keys::PLAN => &pub_plan,
                keys::STATUS => &pub_status,
                _ => &pub_snapshot,
            };
            // A put fails only when the session is closing: the vehicle
            // does not care, the next message tries again.
            let _ = p.put(bytes.clone()).wait();
            summary.forwarded += 1;
            if leaf == keys::PLAN {
                history.push(&bytes);
            }
            latest.insert(leaf, bytes);
        }
        for a in acks {
            let bytes = encode::encode(&a);
            let _ = pub_ack.put(bytes.clone()).wait();
            answered.insert(a.id, Some(bytes));
            if a.applied() {
                summary.commands_applied += 1;
            } else {
                summary.commands_refused += 1;
            }
            log.line(t, json!({"event": "command_ack", "id": a.id, "command": a.command, "status": a.status, "reason": a.reason, "detail": a.detail, "plan_seq": a.plan_seq, "replan": a.replan}));
        }
        // Shore → onboard.
        while let Ok(Some(_)) = sub_heartbeat.try_recv() {
            let change = monitor.heard(Instant::now());
            // The shore that sent this mission may still be reconnecting to
            // this new bridge: its ack, once sent, goes again to every shore
            // heard anew.
            if change.is_some()
                && let Some(Some(bytes)) = cfg.replaced_by.and_then(|id| answered.get(&id))
            {
                let _ = pub_ack.put(bytes.clone()).wait();
            }
            match change {
                Some(LinkChange::Connected) => log.line(t, json!({"event": "link_connected"})),
                Some(LinkChange::Restored { down }) => {
                    let down_ms = down.as_secs_f64() * 1000.0;
                    log.line(t, json!({"event": "link_restored", "down_ms": down_ms}));
                    let mut e = Event::new("link_restored", t);
                    e.down_ms = Some(down_ms);
                    let _ = pub_event.put(encode::encode(&e)).wait();
                }
                _ => {}
            }
        }
        while let Ok(Some(sample)) = sub_command.try_recv() {
            let bytes = sample.payload().to_bytes();
            let c: Command = match encode::decode(&bytes, encode::COMMAND_TYPE) {
                Ok(c) => c,
                Err(e) => {
                    log.line(t, json!({"event": "command_refused", "detail": e.to_string()}));
                    continue;
                }
            };
            match answered.get(&c.id) {
                Some(Some(ack)) => {
                    let _ = pub_ack.put(ack.clone()).wait();
                    continue;
                }
                Some(None) => continue,
                None => {}
            }
            if c.command == REPLACE_MISSION && c.id != 0 {
                match file_replacement(&c, cfg.requests.as_ref()) {
                    Ok(path) => {
                        answered.insert(c.id, None);
                        replacing.push(c.id);
                        log.line(t, json!({"event": "command", "id": c.id, "command": c.command, "mission": path.display().to_string()}));
                    }
                    Err((reason, detail)) => {
                        let mut a = Ack::new(c.id, &c.command, false, reason, (0, 0), t);
                        a.detail = Some(detail);
                        let bytes = encode::encode(&a);
                        let _ = pub_ack.put(bytes.clone()).wait();
                        answered.insert(c.id, Some(bytes));
                        summary.commands_refused += 1;
                        log.line(t, json!({"event": "command_ack", "id": c.id, "command": c.command, "status": "refused", "reason": reason, "detail": a.detail, "plan_seq": 0, "replan": 0}));
                    }
                }
                continue;
            }
            match resolve(&c, &cfg.names) {
                Ok(_) if c.id == 0 => {
                    log.line(t, json!({"event": "command_refused", "detail": "command id 0"}));
                }
                Ok((kind, value_s, node)) => {
                    commands_out.publish(&mut |m: &mut OperatorCommand| {
                        m.header.mission_time_s = t.max(0.0);
                        m.command_id = c.id;
                        m.kind = kind as u32;
                        m.value_s = value_s;
                        m.node = node;
                    })?;
                    answered.insert(c.id, None);
                    log.line(t, json!({"event": "command", "id": c.id, "command": c.command, "budget_s": c.budget_s, "waypoint": c.waypoint, "node": node}));
                }
                Err(reason) => {
                    let a = Ack::new(c.id, &c.command, false, reason, (0, 0), t);
                    let bytes = encode::encode(&a);
                    let _ = pub_ack.put(bytes.clone()).wait();
                    answered.insert(c.id, Some(bytes));
                    summary.commands_refused += 1;
                    log.line(t, json!({"event": "command_ack", "id": c.id, "command": c.command, "status": "refused", "reason": reason, "plan_seq": 0, "replan": 0}));
                }
            }
        }
        while let Ok(Some(q)) = queryable.try_recv() {
            for leaf in keys::LATEST {
                let key = keys::key(v, leaf);
                let Some(bytes) = latest.get(leaf) else { continue };
                let Ok(k) = KeyExpr::try_from(key.as_str()) else {
                    continue;
                };
                if q.key_expr().intersects(&k) {
                    let _ = q.reply(k, bytes.clone()).wait();
                }
            }
        }
        while let Ok(Some(q)) = history_queryable.try_recv() {
            for bytes in &history.plans {
                let _ = q.reply(history_key.as_str(), bytes.clone()).wait();
            }
        }
        // Heartbeat and loss detection.
        if last_hb.is_none_or(|h| now.duration_since(h) >= period) {
            last_hb = Some(now);
            hb_seq += 1;
            let hb = Heartbeat::new("onboard", hb_seq, session_id, t, monitor.state().as_str());
            let _ = pub_heartbeat.put(encode::encode(&hb)).wait();
        }
        if let Some(LinkChange::Lost { silent }) = monitor.poll(Instant::now()) {
            log.line(
                t,
                json!({"event": "link_lost", "silent_ms": silent.as_secs_f64() * 1000.0}),
            );
        }
        if let Some((since, outcome)) = &ended {
            if last_end_note.elapsed() >= Duration::from_millis(200) || !summary.mission_ended {
                if !summary.mission_ended {
                    log.line(t, json!({"event": "mission_end", "outcome": outcome}));
                }
                summary.mission_ended = true;
                last_end_note = Instant::now();
                let mut e = Event::new("mission_end", t);
                e.outcome = Some(outcome.clone());
                let _ = pub_event.put(encode::encode(&e)).wait();
            }
            if since.elapsed() >= END_LINGER {
                break;
            }
        }
        std::thread::sleep(POLL);
    }
    summary.losses = monitor.losses;
    summary.restores = monitor.restores;
    summary.detect_ms_max = monitor.detect_max.as_secs_f64() * 1000.0;
    log.line(t, json!({"event": "link_stop", "forwarded": summary.forwarded, "losses": summary.losses, "restores": summary.restores}));
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plan_history_survives_a_restart_and_drops_a_torn_line() {
        let dir = std::env::temp_dir().join(format!("auv-link-history-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("plans.jsonl");
        let _ = std::fs::remove_file(&f);
        let mut h = PlanHistory::open(Some(&f)).unwrap();
        h.push(br#"{"seq":1}"#);
        h.push(br#"{"seq":2}"#);
        drop(h);
        // The predecessor died in the middle of its third line.
        std::fs::OpenOptions::new()
            .append(true)
            .open(&f)
            .and_then(|mut w| std::io::Write::write_all(&mut w, br#"{"seq":"#))
            .unwrap();
        let mut h = PlanHistory::open(Some(&f)).unwrap();
        assert_eq!(h.plans.len(), 2);
        h.push(br#"{"seq":3}"#);
        let again = PlanHistory::open(Some(&f)).unwrap();
        let seqs: Vec<_> = again
            .plans
            .iter()
            .map(|b| String::from_utf8_lossy(b).into_owned())
            .collect();
        assert_eq!(seqs.last().map(String::as_str), Some(r#"{"seq":3}"#), "{seqs:?}");
        let mut mem = PlanHistory::open(None).unwrap();
        for k in 0..PLAN_HISTORY + 5 {
            mem.push(format!("{{\"seq\":{k}}}").as_bytes());
        }
        assert_eq!(mem.plans.len(), PLAN_HISTORY);
        assert_eq!(mem.plans.front().map(Vec::as_slice), Some(&b"{\"seq\":5}"[..]));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_new_mission_is_filed_once_for_the_supervisor_or_refused_with_its_reason() {
        let dir = std::env::temp_dir().join(format!("auv-link-replace-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let req = Requests::new(&dir);
        let text = "format = \"auv-mission/1\"\n".to_string();
        let c = Command::replace_mission(8, text.clone());
        assert_eq!(file_replacement(&c, None).unwrap_err().0, "unsupported");
        let path = file_replacement(&c, Some(&req)).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), text);
        assert_eq!(req.pending(), vec![8]);
        // Sent again: the same request, not a second one.
        assert_eq!(file_replacement(&c, Some(&req)).unwrap(), path);
        assert_eq!(req.pending(), vec![8]);
        let empty = Command::replace_mission(9, "  \n".into());
        assert_eq!(file_replacement(&empty, Some(&req)).unwrap_err().0, "bad_mission");
        let mut none = Command::replace_mission(10, String::new());
        none.mission = None;
        assert_eq!(file_replacement(&none, Some(&req)).unwrap_err().0, "bad_mission");
        let huge = Command::replace_mission(11, "#".repeat(MAX_MISSION_BYTES + 1));
        let (reason, detail) = file_replacement(&huge, Some(&req)).unwrap_err();
        assert_eq!(reason, "bad_mission");
        assert!(detail.contains("bytes"), "{detail}");
        assert_eq!(req.pending(), vec![8]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn commands_resolve_waypoints_by_name_or_id_and_refuse_the_rest() {
        let names: Vec<String> = ["start", "buoy-a", "goal"].iter().map(|s| s.to_string()).collect();
        let c = |kind, budget, w: Option<&str>| Command::new(1, kind, budget, w.map(str::to_string));
        assert_eq!(
            resolve(&c(CommandKind::RemoveTask, None, Some("buoy-a")), &names),
            Ok((CommandKind::RemoveTask, 0.0, 1))
        );
        assert_eq!(
            resolve(&c(CommandKind::AddTask, None, Some("2")), &names),
            Ok((CommandKind::AddTask, 0.0, 2))
        );
        assert_eq!(
            resolve(&c(CommandKind::AddTask, None, Some("nowhere")), &names),
            Err("unknown_waypoint")
        );
        assert_eq!(
            resolve(&c(CommandKind::AddTask, None, Some("3")), &names),
            Err("unknown_waypoint")
        );
        assert_eq!(
            resolve(&c(CommandKind::AddTask, None, None), &names),
            Err("unknown_waypoint")
        );
        assert_eq!(
            resolve(&c(CommandKind::SetTimeBudget, Some(f64::NAN), None), &names),
            Err("budget_out_of_range")
        );
        assert_eq!(
            resolve(&c(CommandKind::SetTimeBudget, Some(9000.0), None), &names),
            Ok((CommandKind::SetTimeBudget, 9000.0, NO_NODE))
        );
        let mut bad = c(CommandKind::AbortToGoal, None, None);
        bad.command = "self-destruct".into();
        assert_eq!(resolve(&bad, &names), Err("unknown_command"));
    }
}
