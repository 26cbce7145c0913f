//! `planner soak`: N missions back to back, with random faults when asked,
//! and one summary (`DIR/soak.json`, printed too) of what they came to.
//!
//! Contract:
//! - Mission k (0-based) runs scenario seed `seed + k`, planner seed
//!   `seed`, fault seed `derive_seed(seed, k)`, in its own iceoryx2 domain
//!   `<base>k_` and folder `DIR/mission-k`; the same seed gives the same
//!   missions and the same fault plans.
//! - Scaled time by default; `--lockstep` without faults gives
//!   reproducible missions.
//! - External kills (`--external-kills N`): N SIGKILLs per mission sent by
//!   a thread of this process that is not the mission's supervisor, to the
//!   pids the supervisor publishes, at wall times drawn from
//!   `derive_seed(seed, k)` ([`plan_external_kills`]); the supervisor must
//!   notice and restart on its own. `soak.json` sets the kills sent next to
//!   the restarts the missions' reports count by cause.
//! - Leaks: after each mission its domain is retired and the files it left
//!   are counted; at the end the whole soak's prefix family is scanned again
//!   (`shm_files_leaked`). Memory: the peak resident set of each child per
//!   mission and of this process before and after, so growth from mission
//!   to mission shows.
//! - Bad messages (`--bad-messages`): every kind, from all three senders,
//!   through `planner mission --inject-*` ([`bad_message_flags`]).

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use serde_json::{Value, json};

use super::child::rss_kb_of;
use super::external_kills::{KillTally, plan_external_kills, run_kills};
use super::run::{MissionArgs, mission};
use super::supervise::Proc;
use auv_core::rng::derive_seed;
use auv_messages::msg::{Outcome, REJECT_KINDS, RejectKind};
use auv_platform::host::{host_steal_ticks, ms_per_tick};
use auv_platform::signal;
use auv_transport::ipc::leftover_files;
use auv_transport::unique_prefix;

/// `planner soak` flags.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct SoakArgs {
    /// Missions to run back to back.
    #[arg(long)]
    pub missions: u32,
    /// Inject faults at random (kills and restarts, pauses).
    #[arg(long)]
    pub faults: bool,
    /// Faults per mission with --faults.
    #[arg(long, default_value_t = 3)]
    pub faults_per_mission: usize,
    /// Base seed (mission k: scenario seed + k).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output folder (soak.json and one folder per mission).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Waypoints per scenario (the paper's generator; not with --mission).
    #[arg(long, default_value_t = 12)]
    pub nodes: usize,
    /// Run this mission file (`auv-mission/1`) every time, mission k with
    /// seed `seed + k` in place of the file's (its drift, generated
    /// waypoints and drawn tasks change; the written waypoints do not).
    #[arg(long, value_name = "FILE")]
    pub mission: Option<PathBuf>,
    /// Mission seconds per real second.
    #[arg(long, default_value_t = 3000.0)]
    pub time_scale: f64,
    /// Deterministic lockstep missions (no faults).
    #[arg(long, conflicts_with_all = ["faults", "external_kills"])]
    pub lockstep: bool,
    /// SIGKILLs per mission sent from outside the supervisor to random
    /// children at random times (seeded), as an operator would.
    #[arg(long, default_value_t = 0)]
    pub external_kills: usize,
    /// Stall timeout, real ms.
    #[arg(long, default_value_t = 1000.0)]
    pub stall_timeout_ms: f64,
    /// Also inject bad messages of every kind from all three processes.
    #[arg(long)]
    pub bad_messages: bool,
    /// No per-mission lines.
    #[arg(long)]
    pub quiet: bool,
}

/// Flags that make mission `k`'s processes send bad messages: every kind
/// the wire layer can inject, from the sensor (snapshots), the vehicle
/// (states) and the planner (plans), each next to the good message it
/// spoils (`planner mission --inject-*`). The same for
/// every mission: each kind is then rejected in every mission.
pub fn bad_message_flags() -> Vec<String> {
    [
        "--inject-sensor",
        "all",
        "--inject-vehicle",
        "all",
        "--inject-plan",
        "all",
    ]
    .map(String::from)
    .to_vec()
}

#[derive(Parser)]
struct MissionOnly {
    #[command(flatten)]
    m: MissionArgs,
}

fn mission_args(a: &SoakArgs, k: u32, prefix: &str) -> Result<MissionArgs, String> {
    let mut argv: Vec<String> = vec!["mission".into(), "--quiet".into()];
    let out = a.out.join(format!("mission-{k}"));
    argv.extend([
        "--seed".into(),
        (a.seed + u64::from(k)).to_string(),
        "--planner-seed".into(),
        a.seed.to_string(),
        "--out".into(),
        out.display().to_string(),
        "--ipc-prefix".into(),
        prefix.into(),
        "--stall-timeout-ms".into(),
        a.stall_timeout_ms.to_string(),
    ]);
    match &a.mission {
        Some(file) => argv.extend(["--mission".into(), file.display().to_string()]),
        None => argv.extend(["--nodes".into(), a.nodes.to_string()]),
    }
    if a.lockstep {
        argv.push("--lockstep".into());
    } else {
        argv.extend(["--time-scale".into(), a.time_scale.to_string()]);
    }
    if a.faults {
        argv.extend([
            "--faults".into(),
            a.faults_per_mission.to_string(),
            "--fault-seed".into(),
            derive_seed(a.seed, u64::from(k)).to_string(),
        ]);
    }
    if a.bad_messages {
        argv.extend(bad_message_flags());
    }
    MissionOnly::try_parse_from(argv)
        .map(|w| w.m)
        .map_err(|e| e.to_string().lines().next().unwrap_or("bad mission flags").to_string())
}

fn add(map: &mut BTreeMap<String, u64>, v: &Value) {
    if let Some(o) = v.as_object() {
        for (k, n) in o {
            *map.entry(k.clone()).or_default() += n.as_u64().unwrap_or(0);
        }
    }
}

/// `{process: n}` of a by-process, by-cause table, causes summed.
fn by_process(m: &[[u64; 2]; 3]) -> Value {
    let mut o = serde_json::Map::new();
    for p in Proc::ALL {
        o.insert(p.name().into(), json!(m[p as usize].iter().sum::<u64>()));
    }
    Value::Object(o)
}

/// `{process: {injected, external}}` of a by-process, by-cause table.
fn by_cause(m: &[[u64; 2]; 3]) -> Value {
    let mut o = serde_json::Map::new();
    for p in Proc::ALL {
        let [inj, ext] = m[p as usize];
        o.insert(p.name().into(), json!({"injected": inj, "external": ext}));
    }
    Value::Object(o)
}

/// Runs the soak; the summary as JSON.
pub fn soak(a: &SoakArgs) -> Result<Value, String> {
    if a.missions == 0 {
        return Err("--missions 0: must be at least 1".into());
    }
    if !(a.time_scale.is_finite() && a.time_scale > 0.0) {
        return Err(format!("--time-scale {}: must be > 0", a.time_scale));
    }
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    signal::install();
    let base = unique_prefix("k");
    let me = std::process::id();
    let rss_self_start = rss_kb_of(me).unwrap_or(0);
    let mut per_mission = Vec::new();
    let (mut completed, mut reached_goal, mut deadline_misses, mut steady_allocs, mut leaked) =
        (0, 0, 0u64, 0u64, 0u64);
    let mut injected = BTreeMap::new();
    let mut survived = BTreeMap::new();
    let mut cleared = BTreeMap::new();
    let (mut cut_short, mut skipped_late, mut stale_plans) = (0u64, 0u64, 0u64);
    let mut stalls = BTreeMap::new();
    let mut rejected = [0u64; REJECT_KINDS];
    let mut rss_children: Vec<[u64; 3]> = Vec::new();
    let mut rss_self = Vec::new();
    let mut steal_total_ms = host_steal_ticks().map(|_| 0.0);
    let mut kills = KillTally::default();
    let mut restarts = [[0u64; 2]; 3];
    let mut stalls_by_cause = [[0u64; 2]; 3];
    let (mut safe_holds, mut lost_journal_events) = (0u64, 0u64);
    for k in 0..a.missions {
        if signal::shutdown_requested() {
            break;
        }
        let prefix = format!("{base}{k}_");
        let m = mission_args(a, k, &prefix)?;
        let t0 = std::time::Instant::now();
        let steal_before = host_steal_ticks();
        let budget_s = m.scenario.config().map_err(|e| e.to_string())?.time_available_s;
        let plan = plan_external_kills(
            derive_seed(a.seed, u64::from(k)),
            a.external_kills,
            std::time::Duration::from_secs_f64(budget_s / a.time_scale),
        );
        let out_k = m.out.clone().unwrap_or_default();
        let stop = std::sync::atomic::AtomicBool::new(false);
        let (result, tally) = std::thread::scope(|scope| {
            let killer = scope.spawn(|| run_kills(&out_k, &plan, &stop));
            let r = mission(&m);
            stop.store(true, std::sync::atomic::Ordering::Relaxed);
            (r, killer.join().unwrap_or_default())
        });
        for i in 0..3 {
            kills.sent[i] += tally.sent[i];
            kills.missed[i] += tally.missed[i];
        }
        let line = match result {
            Ok((r, _)) => {
                safe_holds += u64::from(r.outcome == Outcome::SafeHold);
                lost_journal_events += r.lost_journal_events;
                for (acc, n) in restarts
                    .iter_mut()
                    .flatten()
                    .zip(r.supervision.restarts.iter().flatten())
                {
                    *acc += n;
                }
                for (acc, n) in stalls_by_cause
                    .iter_mut()
                    .flatten()
                    .zip(r.supervision.stalls.iter().flatten())
                {
                    *acc += n;
                }
                let ok = matches!(r.outcome, Outcome::GoalReached | Outcome::TimedOut);
                completed += u64::from(ok);
                reached_goal += u64::from(r.goal_reached());
                deadline_misses += r.deadline_misses;
                stale_plans += u64::from(r.stale_plans);
                steady_allocs += r.alloc.sys_allocs_steady;
                leaked += r.shm_files_left as u64;
                // Refusals by both receivers: the planner and the vehicle.
                for (acc, n) in rejected.iter_mut().zip(r.rejected.0) {
                    *acc += n;
                }
                for (acc, n) in rejected.iter_mut().zip(r.rejected_vehicle.0) {
                    *acc += n;
                }
                rss_children.push(r.rss_kb);
                let j = r.to_json();
                let f = &j["faults"];
                add(&mut injected, &f["injected_by_kind"]);
                add(&mut survived, &f["survived_by_kind"]);
                add(&mut cleared, &f["cleared_by_kind"]);
                cut_short += f["cut_short_by_end"].as_u64().unwrap_or(0);
                skipped_late += f["skipped_late"].as_u64().unwrap_or(0);
                add(&mut stalls, &by_process(&r.supervision.stalls));
                json!({
                    "mission": k,
                    "seed": m.scenario.seed.unwrap_or(1),
                    "outcome": j["outcome"],
                    "tasks": r.tasks_completed,
                    "weight": r.weight,
                    "faults_injected": f["injected"],
                    "faults": f["injected_by_kind"],
                    "survived": f["survived_by_kind"],
                    "cleared": f["cleared_by_kind"],
                    "stalls_detected": j["supervision"]["stalls"],
                    "restarts": j["supervision"]["restarts"],
                    "external_kills_sent": by_process(&tally.sent.map(|n| [0, n])),
                    "lost_journal_events": r.lost_journal_events,
                    "reason": j["reason"],
                    "rejected_messages": r.rejected.total() + r.rejected_vehicle.total(),
                    "stale_plans": r.stale_plans,
                    "deadline_misses": r.deadline_misses,
                    "steady_state_allocations": r.alloc.sys_allocs_steady,
                    "rss_kb_peak": j["rss_kb_peak"],
                    "shm_files_left": r.shm_files_left,
                    "wall_s": t0.elapsed().as_secs_f64(),
                })
            }
            Err(e) => json!({"mission": k, "seed": m.scenario.seed.unwrap_or(1), "error": e.to_string()}),
        };
        let rss_now = rss_kb_of(me).unwrap_or(0);
        rss_self.push(rss_now);
        let mut line = line;
        line["supervisor_rss_kb"] = rss_now.into();
        // The host's steal time over the mission (both CPUs): set next to
        // its deadline misses, it tells a host stall from one of ours.
        let steal_ms = host_steal_ticks()
            .zip(steal_before)
            .map(|(after, before)| after.saturating_sub(before) as f64 * ms_per_tick());
        line["host_steal_ms"] = steal_ms.into();
        steal_total_ms = steal_total_ms.zip(steal_ms).map(|(t, m)| t + m);
        if !a.quiet {
            println!("{line}");
        }
        per_mission.push(line);
    }
    // Whatever any mission of this soak left behind, counted again at the end.
    let left_at_end = leftover_files(&base).len() as u64;
    let rss = |i: usize| {
        json!({
            "start": rss_children.first().map_or(0, |r| r[i]),
            "end": rss_children.last().map_or(0, |r| r[i]),
            "max": rss_children.iter().map(|r| r[i]).max().unwrap_or(0),
        })
    };
    let by_kind: serde_json::Map<String, Value> = (0..REJECT_KINDS)
        .map(|k| (RejectKind::ALL[k].as_str().to_string(), json!(rejected[k])))
        .collect();
    Ok(json!({
        "missions": per_mission.len(),
        "completed": completed,
        "reached_goal": reached_goal,
        "faults_injected": injected.values().sum::<u64>(),
        "faults_injected_by_kind": injected,
        "faults_survived": survived.values().sum::<u64>(),
        "faults_survived_by_kind": survived,
        "faults_cleared": cleared.values().sum::<u64>(),
        "faults_cleared_by_kind": cleared,
        "faults_cut_short_by_mission_end": cut_short,
        "faults_skipped_late": skipped_late,
        "stalls_detected": stalls,
        "stalls_by_cause": by_cause(&stalls_by_cause),
        "safe_hold": safe_holds,
        "goal_or_safe_hold": reached_goal + safe_holds,
        "restarts_by_cause": by_cause(&restarts),
        "external_kills": {
            "per_mission": a.external_kills,
            "planned": u64::from(a.missions) * a.external_kills as u64,
            "sent": kills.sent.iter().sum::<u64>(),
            "sent_by_process": by_process(&kills.sent.map(|n| [0, n])),
            "missed_by_process": by_process(&kills.missed.map(|n| [0, n])),
        },
        "lost_journal_events": lost_journal_events,
        "rejected_messages": rejected.iter().sum::<u64>(),
        "rejected_messages_by_kind": by_kind,
        "bad_messages": a.bad_messages,
        "stale_plans": stale_plans,
        "host_steal_ms": steal_total_ms,
        "deadline_misses": deadline_misses,
        "steady_state_allocations": steady_allocs,
        "rss_kb": {
            "supervisor": {
                "start": rss_self_start,
                "after_first": rss_self.first().copied().unwrap_or(0),
                "end": rss_self.last().copied().unwrap_or(0),
            },
            "planner": rss(0),
            "sensor-sim": rss(1),
            "vehicle-sim": rss(2),
        },
        "shm_files_leaked": leaked + left_at_end,
        "settings": {
            "seed": a.seed,
            "faults": a.faults,
            "faults_per_mission": if a.faults { a.faults_per_mission } else { 0 },
            "nodes": a.nodes,
            "lockstep": a.lockstep,
            "external_kills": a.external_kills,
            "time_scale": if a.lockstep { Value::Null } else { json!(a.time_scale) },
        },
        "per_mission": per_mission,
    }))
}

/// Runs `planner soak`: 0 when every mission completed and nothing leaked,
/// 1 otherwise, 2 on bad arguments.
pub fn run_soak(a: &SoakArgs) -> ExitCode {
    match soak(a) {
        Ok(v) => {
            let path = a.out.join("soak.json");
            let text = serde_json::to_string_pretty(&v).unwrap_or_default() + "\n";
            if let Err(e) = std::fs::write(&path, &text) {
                eprintln!("planner: error: {}: {e}", path.display());
                return ExitCode::from(1);
            }
            let mut summary = v.clone();
            if let Some(o) = summary.as_object_mut() {
                o.remove("per_mission");
            }
            println!("{}", serde_json::to_string_pretty(&summary).unwrap_or_default());
            println!("wrote {}", path.display());
            // A safe hold is a safe end too: the supervisor stopped a
            // crash loop as designed.
            let ok = v["completed"].as_u64().unwrap_or(0) + v["safe_hold"].as_u64().unwrap_or(0)
                == v["missions"].as_u64().unwrap_or(u64::MAX)
                && v["shm_files_leaked"] == 0
                && v["lost_journal_events"] == 0;
            if ok { ExitCode::SUCCESS } else { ExitCode::from(1) }
        }
        Err(e) => {
            eprintln!("planner: error: {e}");
            ExitCode::from(2)
        }
    }
}
