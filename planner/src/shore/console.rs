//! `planner shore`: the operator's console. It shows the vehicle live (a
//! compact terminal view), records what it receives (`DIR/shore.log`,
//! `DIR/shore.mcap` with the channels of `mission.mcap` it can fill,
//! `DIR/shore.json` at the end), exits when the mission it watches ends,
//! and sends one command with `--command` (then it waits for the ack and
//! exits: 0 applied, 1 refused or unanswered).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use serde_json::{Value, json};

use super::LinkOptions;
use crate::mission::mcap_log::{self, ChannelWriter, PlanFigures, Topic};
use auv_link::console::{Incoming, Received, ShoreLink};
use auv_link::encode::{Ack, Command, PlanMsg, REPLACE_MISSION, Snapshot, State, Status};
use auv_link::monitor::LinkChange;
use auv_link::replace::MAX_MISSION_BYTES;
use auv_messages::msg::CommandKind;
use auv_platform::clock::mono_now_ns;
use auv_platform::signal;
use auv_world::scenario::Vec3;

/// `planner shore` flags.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct ShoreArgs {
    /// The vehicle's link endpoint (what `planner mission --shore` listens on).
    #[arg(long, value_name = "tcp/HOST:PORT")]
    pub connect: String,
    /// Vehicle namespace (`auv/<vehicle>/…`).
    #[arg(long, default_value = "auv1")]
    pub vehicle: String,
    /// Record into this folder: shore.log, shore.mcap, shore.json.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// No live view (events still go to stderr).
    #[arg(long)]
    pub quiet: bool,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub link: LinkOptions,
    /// Send this command, wait for its ack, print it and exit.
    #[arg(
        long,
        value_name = "abort-to-goal|set-time-budget|add-task|remove-task|replace-mission"
    )]
    pub command: Option<String>,
    /// replace-mission: the new mission file (`auv-mission/1`); the vehicle
    /// takes it on where it is, within the time it has left.
    #[arg(long, value_name = "FILE")]
    pub mission: Option<PathBuf>,
    /// set-time-budget: the new mission time budget, s (mission time, like
    /// the mission's own budget).
    #[arg(long, value_name = "S")]
    pub budget_s: Option<f64>,
    /// add-task, remove-task: the waypoint, by its name in the mission file (or its id).
    #[arg(long, value_name = "NAME")]
    pub waypoint: Option<String>,
    /// The command's id (default: a fresh one); the same id sent again is
    /// answered again, never applied twice.
    #[arg(long, value_name = "N")]
    pub command_id: Option<u64>,
    /// Give up when no ack (with --command) or no vehicle (without) was
    /// heard within this long, real s.
    #[arg(long, value_name = "S")]
    pub give_up_s: Option<f64>,
}

fn unix_ms() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64() * 1000.0)
}

fn fresh_id() -> u64 {
    let mut s = mono_now_ns() ^ (u64::from(std::process::id()) << 32) ^ unix_ms() as u64;
    auv_core::rng::splitmix64(&mut s).max(1)
}

fn quantile(sorted: &[u64], q: f64) -> u64 {
    if sorted.is_empty() {
        return 0;
    }
    let k = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[k.min(sorted.len() - 1)]
}

/// What the console knows of the vehicle.
#[derive(Default)]
struct View {
    state: Option<State>,
    plan: Option<PlanMsg>,
    status: Option<Status>,
    snapshot: Option<Snapshot>,
    last_msg: Option<Instant>,
    /// Live plans by onboard session: the seqs seen.
    plan_seqs: BTreeMap<u64, Vec<u64>>,
    /// Shore-side latency of live plans (onboard send → shore receive), ns.
    latency_ns: Vec<u64>,
    plans_catch_up: u64,
    refused: u64,
    ended: Option<String>,
    prev_pos: Option<[f64; 3]>,
    yaw: f64,
    losses_detect_ms: Vec<f64>,
    restores: u64,
}

impl View {
    fn plans(&self) -> u64 {
        self.plan_seqs.values().map(|v| v.len() as u64).sum()
    }

    /// Plans of each onboard session up to the last one seen that the shore
    /// never received (a session numbers its plans from 1).
    fn gaps(&self) -> u64 {
        self.plan_seqs
            .values()
            .map(|v| {
                let mut v = v.clone();
                v.sort_unstable();
                v.dedup();
                v.last().map_or(0, |&last| last - v.len() as u64)
            })
            .sum()
    }
}

/// The recording in `--out`.
struct Recorder {
    log: BufWriter<File>,
    lines: usize,
    mcap: Option<ChannelWriter<BufWriter<File>>>,
    dir: PathBuf,
}

impl Recorder {
    fn open(dir: &PathBuf, vehicle: &str) -> Result<Self, String> {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let open = |name: &str| {
            let p = dir.join(name);
            File::create(&p)
                .map(BufWriter::new)
                .map_err(|e| format!("{}: {e}", p.display()))
        };
        let log = open("shore.log")?;
        let mcap = ChannelWriter::new(open("shore.mcap")?, vehicle, &[])
            .map_err(|e| format!("{}: {e}", dir.join("shore.mcap").display()))?;
        Ok(Self {
            log,
            lines: 0,
            mcap: Some(mcap),
            dir: dir.clone(),
        })
    }

    fn line(&mut self, t: f64, mut v: Value) {
        v["t"] = json!(t);
        v["unix_ms"] = json!(unix_ms());
        let text = v.to_string();
        let _ = writeln!(self.log, "{text}");
        let _ = self.log.flush();
        self.lines += 1;
        let level = if v["event"] == "link_lost" || v["status"] == "refused" {
            3
        } else {
            2
        };
        let t_ns = mcap_log::log_time_ns(t);
        self.mcap_write(
            Topic::Events,
            t_ns,
            &mcap_log::log_message(t_ns, level, &text, "shore", "shore.log", self.lines),
        );
    }

    fn mcap_write(&mut self, topic: Topic, t_ns: u64, data: &Value) {
        if let Some(w) = &mut self.mcap
            && let Err(e) = w.write(topic, t_ns, data)
        {
            eprintln!("planner shore: warning: shore.mcap: {e}; recording stopped");
            self.mcap = None;
        }
    }

    fn finish(&mut self, summary: &Value) -> Result<(), String> {
        if let Some(w) = self.mcap.take() {
            w.finish()
                .and_then(|mut b| b.flush().map_err(Into::into))
                .map_err(|e| format!("{}: {e}", self.dir.join("shore.mcap").display()))?;
        }
        let p = self.dir.join("shore.json");
        let text = serde_json::to_string_pretty(summary).unwrap_or_default();
        std::fs::write(&p, text + "\n").map_err(|e| format!("{}: {e}", p.display()))
    }
}

fn pos3(p: [f64; 3]) -> Vec3 {
    Vec3 {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

/// Applies one message to the view and the recording.
fn take(view: &mut View, rec: &mut Option<Recorder>, r: Received) {
    view.last_msg = Some(Instant::now());
    match r.msg {
        Incoming::State(s) => {
            let t_ns = mcap_log::log_time_ns(s.origin.t);
            if let Some(prev) = view.prev_pos
                && (s.position[0] - prev[0]).hypot(s.position[1] - prev[1]) > 1e-6
            {
                view.yaw = (s.position[1] - prev[1]).atan2(s.position[0] - prev[0]);
            }
            view.prev_pos = Some(s.position);
            if let Some(rec) = rec {
                rec.mcap_write(
                    Topic::Pose,
                    t_ns,
                    &mcap_log::pose_message(t_ns, pos3(s.position), view.yaw),
                );
                if s.event == "arrival" && !r.catch_up {
                    let node = u64::from(s.to_node);
                    let msg = mcap_log::progress_message(
                        s.origin.t,
                        node,
                        u64::from(s.tasks_completed),
                        s.weight,
                        s.time_left_s,
                    );
                    rec.mcap_write(Topic::Progress, t_ns, &msg);
                }
            }
            if s.finished() && view.ended.is_none() {
                view.ended = Some(s.outcome.clone());
            }
            view.state = Some(s);
        }
        Incoming::Plan(p) => {
            let live = !r.catch_up;
            let seen = view
                .plan_seqs
                .get(&p.origin.session)
                .is_some_and(|v| v.contains(&p.origin.seq));
            if !seen {
                view.plan_seqs.entry(p.origin.session).or_default().push(p.origin.seq);
                if live {
                    view.latency_ns
                        .push(r.recv_mono_ns.saturating_sub(p.origin.sent_mono_ns));
                } else {
                    // A plan missed while the link was down, from the bridge's history.
                    view.plans_catch_up += 1;
                }
            }
            if let Some(rec) = rec
                && !seen
            {
                let t_ns = mcap_log::log_time_ns(p.origin.t);
                let route: Vec<usize> = p.route.iter().map(|&n| usize::from(n)).collect();
                if let Some(snap) = &view.snapshot
                    && route.iter().all(|&n| n < snap.nodes.len())
                {
                    let pts: Vec<Vec3> = route
                        .iter()
                        .map(|&n| Vec3 {
                            x: snap.nodes[n][0],
                            y: snap.nodes[n][1],
                            z: 0.0,
                        })
                        .collect();
                    let first = view.plans() <= 1;
                    rec.mcap_write(
                        Topic::Plan,
                        t_ns,
                        &mcap_log::plan_message(t_ns, u64::from(p.replan), &route, &pts, first),
                    );
                }
                let figures = PlanFigures {
                    t: p.origin.t,
                    replan: u64::from(p.replan),
                    trigger: p.trigger.clone(),
                    budget_s: p.budget_s,
                    route_len: p.route.len(),
                    time_s: p.time_s,
                    weight: p.weight,
                    distance_m: p.distance_m,
                    feasible: p.feasible,
                    iterations: u64::from(p.iterations),
                    deadline_cut: p.deadline_cut,
                    epoch: p.snapshot_epoch,
                };
                rec.mcap_write(Topic::Status, t_ns, &figures.message());
                let latency_ms = r.recv_mono_ns.saturating_sub(p.origin.sent_mono_ns) as f64 / 1e6;
                rec.line(
                    p.origin.t,
                    json!({"event": "plan", "seq": p.origin.seq, "replan": p.replan, "trigger": p.trigger, "route": p.route, "catch_up": r.catch_up, "latency_ms": latency_ms}),
                );
            }
            // History plans come oldest first: keep the newest in view.
            if view.plan.as_ref().is_none_or(|c| p.origin.t >= c.origin.t) {
                view.plan = Some(p);
            }
        }
        Incoming::Status(s) => view.status = Some(s),
        Incoming::Snapshot(s) => view.snapshot = Some(s),
        Incoming::Ack(a) => {
            if let Some(rec) = rec {
                rec.line(a.t, json!({"event": "ack", "id": a.id, "command": a.command, "status": a.status, "reason": a.reason, "plan_seq": a.plan_seq}));
            }
        }
        Incoming::Event(e) => {
            if e.event == "mission_end" && view.ended.is_none() {
                view.ended = Some(e.outcome.clone().unwrap_or_else(|| "ended".into()));
            }
        }
        Incoming::Heartbeat(_) => {}
    }
}

fn render(view: &View, link: &ShoreLink, a: &ShoreArgs) -> String {
    let mut o = String::new();
    let age = view.last_msg.map_or("never".to_string(), |t| {
        format!("{:.1} s ago", t.elapsed().as_secs_f64())
    });
    let m = link.monitor();
    o += &format!(
        "{} at {}: link {} (last message {age}; lost {} times, restored {})\n",
        a.vehicle,
        a.connect,
        m.state().as_str(),
        m.losses,
        m.restores
    );
    match &view.state {
        Some(s) => {
            o += &format!(
                "  t {:.0} s, time left {:.0} s, at ({:.0}, {:.0}) m, {} -> waypoint {}, tasks {}, weight {:.1}, outcome {}\n",
                s.origin.t,
                s.time_left_s,
                s.position[0],
                s.position[1],
                s.mode,
                s.to_node,
                s.tasks_completed,
                s.weight,
                s.outcome
            );
        }
        None => o += "  no vehicle state yet\n",
    }
    if let Some(p) = &view.plan {
        let route: Vec<String> = p.route.iter().map(u16::to_string).collect();
        o += &format!(
            "  plan {} ({}): {} | {:.0} s of {:.0} s, weight {:.1}{}\n",
            p.replan,
            p.trigger,
            route.join(" "),
            p.time_s,
            p.budget_s,
            p.weight,
            if p.feasible { "" } else { ", infeasible: quickest path" }
        );
    }
    let mut lat = view.latency_ns.clone();
    lat.sort_unstable();
    if let Some(s) = &view.status {
        o += &format!(
            "  planner: {} plans, onboard latency p50 {:.2} ms p99 {:.2} ms; ashore p50 {:.2} ms p99 {:.2} ms ({} plans seen)\n",
            s.plans,
            s.latency_p50_ns as f64 / 1e6,
            s.latency_p99_ns as f64 / 1e6,
            quantile(&lat, 0.5) as f64 / 1e6,
            quantile(&lat, 0.99) as f64 / 1e6,
            view.plans()
        );
    }
    o
}

fn summary(view: &View, link: &ShoreLink, a: &ShoreArgs) -> Value {
    let mut lat = view.latency_ns.clone();
    lat.sort_unstable();
    let ms = |ns: u64| ns as f64 / 1e6;
    let m = link.monitor();
    json!({
        "format": "auv-shore-summary/1",
        "vehicle": a.vehicle,
        "endpoint": a.connect,
        "outcome": view.ended,
        "plans": view.plans(),
        "plan_seq_gaps": view.gaps(),
        "plans_catch_up": view.plans_catch_up,
        "plans_live": view.latency_ns.len(),
        "onboard_plans": view.status.as_ref().map(|s| s.plans),
        "latency_ms": {
            "p50": ms(quantile(&lat, 0.5)), "p99": ms(quantile(&lat, 0.99)),
            "max": ms(lat.last().copied().unwrap_or(0)), "samples": lat.len(),
            "what": "onboard plan sent -> shore received, one host's CLOCK_MONOTONIC",
        },
        "onboard_latency_ms": view.status.as_ref().map(|s| json!({
            "p50": ms(s.latency_p50_ns), "p99": ms(s.latency_p99_ns),
            "what": "trigger arrival -> plan published, the planner's own histogram",
        })),
        "link": {
            "timeout_ms": a.link.link_timeout_ms,
            "losses": m.losses,
            "restores": m.restores,
            "detect_ms": view.losses_detect_ms,
            "detect_ms_max": m.detect_max.as_secs_f64() * 1000.0,
        },
        "refused_payloads": view.refused,
        "final_state": view.state.as_ref().map(|s| json!({
            "t": s.origin.t, "position": s.position, "tasks": s.tasks_completed, "weight": s.weight,
            "route": s.route,
        })),
    })
}

fn command_of(a: &ShoreArgs) -> Result<Option<Command>, String> {
    let Some(name) = &a.command else {
        return Ok(None);
    };
    if a.command_id == Some(0) {
        return Err("--command-id 0: must be > 0".into());
    }
    if name == REPLACE_MISSION {
        let path = a
            .mission
            .as_deref()
            .ok_or("--command replace-mission needs --mission FILE")?;
        let text = replacement_mission(path)?;
        return Ok(Some(Command::replace_mission(
            a.command_id.unwrap_or_else(fresh_id),
            text,
        )));
    }
    if a.mission.is_some() {
        return Err(format!("--mission: only with --command replace-mission, not {name}"));
    }
    let kind = CommandKind::from_name(name).ok_or_else(|| {
        format!("--command {name}: expected abort-to-goal, set-time-budget, add-task, remove-task or replace-mission")
    })?;
    match kind {
        CommandKind::SetTimeBudget => match a.budget_s {
            Some(b) if b.is_finite() && b > 0.0 => {}
            _ => return Err("--command set-time-budget needs --budget-s S (> 0)".into()),
        },
        CommandKind::AddTask | CommandKind::RemoveTask if a.waypoint.is_none() => {
            return Err(format!("--command {name} needs --waypoint NAME"));
        }
        _ => {}
    }
    Ok(Some(Command::new(
        a.command_id.unwrap_or_else(fresh_id),
        kind,
        a.budget_s.filter(|_| kind == CommandKind::SetTimeBudget),
        a.waypoint
            .clone()
            .filter(|_| matches!(kind, CommandKind::AddTask | CommandKind::RemoveTask)),
    )))
}

/// The text of a mission file to send, checked here first as the vehicle
/// will check it (all but where the vehicle is and the time it has left),
/// so that a mistake is caught before it travels.
fn replacement_mission(path: &std::path::Path) -> Result<String, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("--mission {}: {e}", path.display()))?;
    if text.len() > MAX_MISSION_BYTES {
        return Err(format!(
            "--mission {}: {} bytes; at most {MAX_MISSION_BYTES} are sent",
            path.display(),
            text.len()
        ));
    }
    auv_world::mission_file::load(path, auv_world::mission_file::Overrides::default())
        .map_err(|e| format!("--mission: {e}"))?;
    // Onboard the file is kept apart from the mission folder: a chart file
    // relative to it would not be found there.
    if let Some(chart) = auv_world::mission_file::chart_file(&text)
        && chart.is_relative()
    {
        return Err(format!(
            "--mission {}: chart file {} is relative to the file; the vehicle looks for it elsewhere: name it by its absolute path on the vehicle, or use an embedded chart",
            path.display(),
            chart.display()
        ));
    }
    Ok(text)
}

/// How often an unanswered command is sent again (our choice: often
/// enough to ride out a short loss, rare enough to be no load).
const RESEND: Duration = Duration::from_millis(500);

/// Sends `c` until its ack arrives; returns the ack and the time from the
/// first send to the ack (the operator's round trip, retries included).
fn send_command(link: &mut ShoreLink, c: &Command, give_up: Duration) -> Result<(Ack, Duration), String> {
    let t0 = Instant::now();
    let mut first_sent: Option<Instant> = None;
    let mut sent: Option<Instant> = None;
    loop {
        if signal::shutdown_requested() {
            return Err("interrupted".into());
        }
        let mut ack = None;
        let changes = link.poll(Duration::from_millis(50), &mut |r| {
            if let Ok(Received {
                msg: Incoming::Ack(a), ..
            }) = r
                && a.id == c.id
            {
                ack = Some(a);
            }
        });
        for ch in changes {
            eprintln!("planner shore: link {}", change_name(&ch));
            // An ack published while the link was down is lost: ask again at
            // once rather than at the next resend (a new mission restarts the
            // bridge, and its ack comes with the new bridge's first plan).
            if matches!(ch, LinkChange::Restored { .. }) {
                sent = None;
            }
        }
        if let Some(a) = ack {
            return Ok((a, first_sent.map_or(Duration::ZERO, |f| f.elapsed())));
        }
        let up = link.state() == auv_link::monitor::LinkState::Up;
        if up && sent.is_none_or(|s| s.elapsed() >= RESEND) {
            link.send(c).map_err(|e| e.to_string())?;
            sent = Some(Instant::now());
            first_sent.get_or_insert(Instant::now());
        }
        if t0.elapsed() >= give_up {
            return Err(format!(
                "{} (id {}): no acknowledgement within {:.1} s (link {})",
                c.command,
                c.id,
                give_up.as_secs_f64(),
                link.state().as_str()
            ));
        }
    }
}

fn change_name(c: &LinkChange) -> String {
    match c {
        LinkChange::Connected => "connected".into(),
        LinkChange::Lost { silent } => format!("lost (silent {} ms)", silent.as_millis()),
        LinkChange::Restored { down } => format!("restored (down {} ms)", down.as_millis()),
    }
}

fn shore(a: &ShoreArgs) -> Result<u8, (u8, String)> {
    let usage = |e: String| (2, e);
    let timeout = a.link.timeout().map_err(usage)?;
    auv_link::session::check_endpoint(&a.connect).map_err(|e| usage(format!("--connect: {e}")))?;
    auv_transport::IpcOptions::new(Some("x"), &a.vehicle, auv_transport::WaitMode::Event)
        .map_err(|e| usage(e.to_string()))?;
    if let Some(g) = a.give_up_s
        && !(g.is_finite() && g > 0.0)
    {
        return Err(usage(format!("--give-up-s {g}: must be > 0")));
    }
    let command = command_of(a).map_err(usage)?;
    signal::install();
    let mut link = ShoreLink::open(&a.connect, &a.vehicle, a.link.zenoh_config.as_deref(), timeout)
        .map_err(|e| (1, e.to_string()))?;
    if let Some(c) = command {
        let give_up = Duration::from_secs_f64(a.give_up_s.unwrap_or(15.0));
        let (ack, round_trip) = send_command(&mut link, &c, give_up).map_err(|e| (1, e))?;
        let ms = round_trip.as_secs_f64() * 1e3;
        if ack.applied() {
            println!(
                "{} (id {}): applied at t {:.0} s, plan seq {} (re-plan {}), acknowledged {ms:.1} ms after sending",
                ack.command, ack.id, ack.t, ack.plan_seq, ack.replan
            );
            return Ok(0);
        }
        let detail = ack.detail.as_deref().map(|d| format!(" ({d})")).unwrap_or_default();
        return Err((
            1,
            format!(
                "{} (id {}) refused: {}{detail}, acknowledged {ms:.1} ms after sending",
                ack.command, ack.id, ack.reason
            ),
        ));
    }
    let mut rec = match &a.out {
        Some(d) => Some(Recorder::open(d, &a.vehicle).map_err(|e| (1, e))?),
        None => None,
    };
    let mut view = View::default();
    let tty = std::io::stdout().is_terminal();
    let t0 = Instant::now();
    let mut drawn = Instant::now() - Duration::from_secs(1);
    let mut ended_at: Option<Instant> = None;
    let code = loop {
        if signal::shutdown_requested() {
            break 130;
        }
        let mut got = Vec::new();
        let changes = link.poll(Duration::from_millis(20), &mut |r| got.push(r));
        for r in got {
            match r {
                Ok(r) => take(&mut view, &mut rec, r),
                Err(e) => {
                    view.refused += 1;
                    eprintln!("planner shore: refused a payload on {}: {}", e.key, e.error);
                }
            }
        }
        let t = view.state.as_ref().map_or(0.0, |s| s.origin.t);
        for ch in &changes {
            eprintln!("planner shore: link {} at t {t:.0} s", change_name(ch));
            let v = match ch {
                LinkChange::Connected => json!({"event": "link_connected"}),
                LinkChange::Lost { silent } => {
                    let ms = silent.as_secs_f64() * 1000.0;
                    view.losses_detect_ms.push(ms);
                    json!({"event": "link_lost", "silent_ms": ms})
                }
                LinkChange::Restored { down } => {
                    view.restores += 1;
                    json!({"event": "link_restored", "down_ms": down.as_secs_f64() * 1000.0})
                }
            };
            if let Some(rec) = &mut rec {
                rec.line(t, v);
            }
        }
        if !a.quiet && drawn.elapsed() >= Duration::from_millis(500) {
            drawn = Instant::now();
            let text = render(&view, &link, a);
            if tty {
                print!("\x1b[H\x1b[2J{text}");
            } else {
                print!("{text}");
            }
            let _ = std::io::stdout().flush();
        }
        // Once the end is known, a moment more for the last messages.
        if view.ended.is_some() && ended_at.is_none() {
            ended_at = Some(Instant::now());
        }
        if ended_at.is_some_and(|e| e.elapsed() >= Duration::from_millis(300)) {
            break 0;
        }
        if let Some(g) = a.give_up_s
            && view.last_msg.is_none()
            && t0.elapsed().as_secs_f64() >= g
        {
            if let Some(rec) = &mut rec {
                let _ = rec.finish(&summary(&view, &link, a));
            }
            return Err((
                1,
                format!("no message from {} at {} within {g} s", a.vehicle, a.connect),
            ));
        }
    };
    let s = summary(&view, &link, a);
    if let Some(rec) = &mut rec {
        rec.line(
            view.state.as_ref().map_or(0.0, |s| s.origin.t),
            json!({"event": "finished", "outcome": view.ended}),
        );
        rec.finish(&s).map_err(|e| (1, e))?;
    }
    if !a.quiet {
        println!("{}", render(&view, &link, a));
        println!(
            "mission ended: {}; {} plans seen live ({} missing), link lost {} times",
            view.ended.as_deref().unwrap_or("unknown (interrupted)"),
            view.plans(),
            view.gaps(),
            link.monitor().losses
        );
    }
    Ok(code)
}

/// Runs `planner shore`: 0 when the watched mission ended (or the command
/// was applied), 1 on a failure (a refused or unanswered command), 2 on bad
/// arguments, 130 when interrupted.
pub fn run_shore(a: &ShoreArgs) -> ExitCode {
    match shore(a) {
        Ok(code) => ExitCode::from(code),
        Err((code, e)) => {
            eprintln!("planner: error: shore: {e}");
            ExitCode::from(code)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_count_plans_never_seen_live() {
        let mut v = View::default();
        v.plan_seqs.insert(1, vec![1, 2, 4, 5]);
        v.plan_seqs.insert(2, vec![7]);
        assert_eq!((v.plans(), v.gaps()), (5, 1 + 6));
        assert_eq!(quantile(&[1, 2, 3, 4], 0.5), 3);
        assert_eq!(quantile(&[], 0.99), 0);
    }
}
