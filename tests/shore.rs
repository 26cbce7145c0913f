//! The shore link end to end: real `planner mission --shore` missions in
//! scaled time and real `planner shore` consoles, on loopback
//! (`tcp/127.0.0.1:<free port>`, multicast scouting and gossip off in every
//! session). Two iceoryx2 domains stand for the two hosts: the mission's
//! (its own prefix) and none at all ashore (the console speaks only Zenoh).

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use auv_system::{binary, leftovers, prefix, read_json, temp_dir, wait_with_watchdog};

/// Watchdog of one mission or console (not a timing assertion).
const LIMIT: Duration = Duration::from_secs(240);

/// One mission at a time (several scaled-time missions at once on a small
/// machine would starve each other).
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn alone() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// A loopback endpoint on a port free right now.
fn endpoint() -> String {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("bind a free port");
    format!("tcp/127.0.0.1:{}", l.local_addr().expect("local address").port())
}

/// A scaled-time mission that listens for the shore on `ep`.
fn start_mission(out: &Path, p: &str, ep: &str, scale: &str, extra: &[&str]) -> Child {
    auv_system::start_scaled_mission(out, p, scale, &[&["--shore", ep][..], extra].concat())
}

fn start_shore(ep: &str, out: Option<&Path>, extra: &[&str]) -> Child {
    let mut c = Command::new(binary("planner"));
    c.args(["shore", "--quiet", "--connect", ep]).args(extra);
    if let Some(o) = out {
        c.arg("--out").arg(o);
    }
    c.stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start the shore console")
}

/// A one-shot `planner shore … --command …` (giving up after 30 s unless
/// `args` says otherwise).
fn shore_command(ep: &str, args: &[&str]) -> Output {
    let give_up: &[&str] = if args.contains(&"--give-up-s") {
        &[]
    } else {
        &["--give-up-s", "30"]
    };
    let child = start_shore(ep, None, &[give_up, args].concat());
    wait_with_watchdog(child, LIMIT)
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Waits until `file` in `dir` has a line containing `needle`.
fn wait_for_line(dir: &Path, file: &str, needle: &str) -> String {
    let t0 = Instant::now();
    loop {
        let t = std::fs::read_to_string(dir.join(file)).unwrap_or_default();
        if let Some(l) = t.lines().find(|l| l.contains(needle)) {
            return l.to_string();
        }
        assert!(
            t0.elapsed() < LIMIT,
            "no line with {needle} in {file} within {LIMIT:?}:\n{t}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn count_lines(dir: &Path, file: &str, needle: &str) -> usize {
    let t = std::fs::read_to_string(dir.join(file)).unwrap_or_default();
    t.lines().filter(|l| l.contains(needle)).count()
}

fn pid_of(out: &Path, name: &str) -> Option<u64> {
    std::fs::read_to_string(out.join("pids.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| v[name].as_u64())
}

fn sigkill(pid: u64) {
    // SAFETY: a signal to a pid the mission's supervisor (or this test) started.
    unsafe { libc::kill(pid as libc::pid_t, libc::SIGKILL) };
}

/// The mission went as missions go without a link: the goal, no restart or
/// stall of the three processes, nothing rejected, nothing leaked.
fn assert_undisturbed(r: &serde_json::Value, p: &str) {
    assert_eq!(r["outcome"], "goal_reached", "{r:#}");
    let s = &r["supervision"];
    for k in ["restarts_total", "stalls_total"] {
        assert_eq!(s[k]["external"], 0, "{s:#}");
        assert_eq!(s[k]["injected"], 0, "{s:#}");
    }
    assert_eq!(r["allocations"]["system_allocs_steady"], 0, "{r:#}");
    assert_eq!(r["shm_files_left"], 0, "{r:#}");
    assert!(leftovers(p).is_empty(), "{:?}", leftovers(p));
}

fn finish(child: Child, what: &str) -> Output {
    let o = wait_with_watchdog(child, LIMIT);
    assert!(o.status.success(), "{what}: {}\n{}", o.status, text(&o.stderr));
    o
}

#[test]
fn the_shore_sees_every_plan_published_onboard_and_the_end_of_the_mission() {
    let _alone = alone();
    let (out, shore_out, p, ep) = (temp_dir("sm"), temp_dir("ss"), prefix("sh"), endpoint());
    let shore = start_shore(&ep, Some(&shore_out), &["--give-up-s", "60"]);
    let mission = start_mission(&out, &p, &ep, "1500", &[]);
    finish(mission, "mission");
    finish(shore, "shore");
    let r = read_json(&out.join("report.json"));
    let s = read_json(&shore_out.join("shore.json"));
    assert_undisturbed(&r, &p);
    assert_eq!(s["outcome"], r["outcome"], "{s:#}");
    assert_eq!(s["plans"], r["plans"], "shore {s:#}\nonboard {r:#}");
    assert_eq!(s["plan_seq_gaps"], 0, "{s:#}");
    assert!(s["plans_live"].as_u64().unwrap() >= 1, "{s:#}");
    assert_eq!(s["final_state"]["route"], r["route"], "{s:#}");
    assert!(
        r["shore_link"]["connected"].as_u64().unwrap() >= 1,
        "{:#}",
        r["shore_link"]
    );
    // The recording opens as an MCAP file with the mission's plan and pose channels.
    let o = auv_system::run(
        &binary("planner"),
        &["replay", shore_out.join("shore.mcap").to_str().unwrap()],
        LIMIT,
    );
    let listing = text(&o.stdout) + &text(&o.stderr);
    assert!(
        listing.contains("/auv1/planner/plan") && listing.contains("/auv1/vehicle/pose"),
        "{listing}"
    );
}

/// A waypoint the vehicle will not reach soon, from the mission's log: one
/// neither visited nor planned if there is one, else the plan's last before
/// the goal (a small network may have every waypoint on the plan).
fn unvisited_waypoint(out: &Path) -> u64 {
    let log = std::fs::read_to_string(out.join("mission.log")).unwrap_or_default();
    let mut visited = vec![0u64, 11];
    let mut route = Vec::new();
    for l in log.lines() {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        match v["event"].as_str() {
            Some("arrival") => visited.push(v["node"].as_u64().unwrap()),
            Some("plan") => {
                route = v["route"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .filter_map(|n| n.as_u64())
                    .collect()
            }
            _ => {}
        }
    }
    (1..11u64)
        .rev()
        .find(|n| !visited.contains(n) && !route.contains(n))
        .or_else(|| route.iter().rev().copied().find(|n| !visited.contains(n)))
        .expect("a waypoint not visited yet")
}

#[test]
fn each_command_kind_is_validated_applied_once_and_acknowledged_with_its_plan() {
    let _alone = alone();
    let (out, p, ep) = (temp_dir("cm"), prefix("sc"), endpoint());
    let mission = start_mission(&out, &p, &ep, "300", &[]);
    wait_for_line(&out, "mission.log", "\"plan\"");
    // Refused by the planner: a budget beyond the vehicle's own.
    let o = shore_command(&ep, &["--command", "set-time-budget", "--budget-s", "1e9"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("refused: budget_out_of_range"),
        "{}",
        text(&o.stderr)
    );
    // Refused by the link: no such waypoint.
    let o = shore_command(&ep, &["--command", "remove-task", "--waypoint", "nowhere"]);
    assert!(
        text(&o.stderr).contains("refused: unknown_waypoint"),
        "{}",
        text(&o.stderr)
    );
    // Applied, and a plan made for it.
    let w = unvisited_waypoint(&out).to_string();
    let args = ["--command", "remove-task", "--waypoint", &w, "--command-id", "4242"];
    let o = shore_command(&ep, &args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let first = text(&o.stdout);
    assert!(first.contains("applied") && !first.contains("plan seq 0 "), "{first}");
    // The same command again: the same answer, not applied again.
    let o = shore_command(&ep, &args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let again = text(&o.stdout);
    let seq = |s: &str| {
        s.split("plan seq ")
            .nth(1)
            .map(|r| r.split(' ').next().unwrap_or("").to_string())
    };
    assert_eq!(seq(&again), seq(&first), "{first} / {again}");
    for cmd in [
        &["--command", "add-task", "--waypoint", &w][..],
        &["--command", "set-time-budget", "--budget-s", "30000"],
        &["--command", "abort-to-goal"],
    ] {
        let o = shore_command(&ep, cmd);
        assert!(o.status.success(), "{cmd:?}: {}", text(&o.stderr));
        assert!(text(&o.stdout).contains("applied"), "{}", text(&o.stdout));
    }
    let o = shore_command(&ep, &["--command", "abort-to-goal"]);
    assert!(text(&o.stderr).contains("refused: no_change"), "{}", text(&o.stderr));
    finish(mission, "mission");
    let r = read_json(&out.join("report.json"));
    assert_undisturbed(&r, &p);
    let c = &r["shore_link"]["commands"];
    assert_eq!(c["applied"], 4, "{c:#}");
    assert_eq!(c["refused"], 3, "{c:#}");
    assert_eq!(c["refused_by_link"], 1, "{c:#}");
    assert_eq!(count_lines(&out, "mission.log", "\"id\":4242"), 1);
    assert!(count_lines(&out, "mission.log", "\"kind\":\"operator\"") >= 4);
}

#[test]
fn a_link_cut_changes_nothing_onboard_is_reported_on_both_sides_and_the_shore_catches_up() {
    let _alone = alone();
    let (out, first_out, second_out) = (temp_dir("lm"), temp_dir("l1"), temp_dir("l2"));
    let (p, ep) = (prefix("sl"), endpoint());
    let timeout = ["--link-timeout-ms", "300"];
    let mission = start_mission(&out, &p, &ep, "600", &timeout);
    let first = start_shore(&ep, Some(&first_out), &[&timeout[..], &["--give-up-s", "60"]].concat());
    wait_for_line(&first_out, "shore.log", "\"plan\"");
    // The console can hold a plan (its catch-up asks the bridge for one)
    // before the bridge has heard the console's first heartbeat: wait for
    // that too, or the count of connections below would start at zero.
    wait_for_line(&out, "link.jsonl", "link_connected");
    // Cut 1: the bridge killed; the supervisor restarts it, the shore reconnects.
    let link = pid_of(&out, "link").expect("the link's pid");
    sigkill(link);
    wait_for_line(&first_out, "shore.log", "link_lost");
    wait_for_line(&first_out, "shore.log", "link_restored");
    // The new bridge must have heard this console before it goes, or it
    // has no link to lose.
    let t0 = Instant::now();
    while count_lines(&out, "link.jsonl", "link_connected") < 2 {
        assert!(t0.elapsed() < LIMIT, "the restarted bridge never heard the console");
        std::thread::sleep(Duration::from_millis(20));
    }
    // Cut 2: the console killed; the bridge notices, a new console catches up.
    let mut first = first;
    let _ = first.kill();
    let _ = first.wait();
    wait_for_line(&out, "link.jsonl", "link_lost");
    let second = start_shore(&ep, Some(&second_out), &[&timeout[..], &["--give-up-s", "60"]].concat());
    finish(mission, "mission");
    finish(second, "second shore");
    let r = read_json(&out.join("report.json"));
    assert_undisturbed(&r, &p);
    let l = &r["shore_link"];
    assert!(l["link_restarts"].as_u64().unwrap() >= 1, "{l:#}");
    assert!(l["losses"].as_u64().unwrap() >= 1, "{l:#}");
    assert!(l["restores"].as_u64().unwrap() >= 1, "{l:#}");
    // Detected after the timeout, not before.
    assert!(l["detect_ms_max"].as_f64().unwrap() >= 300.0, "{l:#}");
    let s = read_json(&second_out.join("shore.json"));
    assert_eq!(s["outcome"], r["outcome"], "{s:#}");
    // Every plan from the first on: seen live, caught up from the bridge's
    // history (kept across its restart), or published while no bridge ran
    // and counted as a gap.
    let (seen, gaps) = (s["plans"].as_u64().unwrap(), s["plan_seq_gaps"].as_u64().unwrap());
    assert_eq!(seen + gaps, r["plans"].as_u64().unwrap(), "{s:#}\n{r:#}");
    assert!(s["plans_catch_up"].as_u64().unwrap() >= 1, "{s:#}");
}

fn write(dir: &Path, name: &str, body: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, body).expect("write a config file");
    p
}

#[test]
fn peers_without_credentials_can_neither_read_nor_command_and_a_viewer_cannot_command() {
    let _alone = alone();
    let (out, cfg, watch_out) = (temp_dir("am"), temp_dir("ac"), temp_dir("aw"));
    let (p, ep) = (prefix("sa"), endpoint());
    let users = write(&cfg, "users.txt", "operator:op-secret\nviewer:view-secret\n");
    let onboard = std::fs::read_to_string(auv_system::workspace_root().join("config/zenoh/onboard-auth.json5"))
        .expect("the shipped onboard configuration")
        .replace("/etc/auv/shore-users.txt", users.to_str().unwrap());
    let onboard = write(&cfg, "onboard.json5", &onboard);
    let cred = |file: &str, user: &str, pw: &str| {
        let body = format!("{{ transport: {{ auth: {{ usrpwd: {{ user: \"{user}\", password: \"{pw}\" }} }} }} }}");
        write(&cfg, file, &body)
    };
    let operator = cred("operator.json5", "operator", "op-secret");
    let viewer = cred("viewer.json5", "viewer", "view-secret");
    let intruder = cred("intruder.json5", "operator", "guess");
    let op = ["--zenoh-config", operator.to_str().unwrap()];
    let mission = start_mission(&out, &p, &ep, "600", &["--zenoh-config", onboard.to_str().unwrap()]);
    let watcher = start_shore(&ep, Some(&watch_out), &[&op[..], &["--give-up-s", "60"]].concat());
    wait_for_line(&watch_out, "shore.log", "\"plan\"");
    for (who, extra) in [
        ("no credentials", vec![]),
        ("a wrong password", vec!["--zenoh-config", intruder.to_str().unwrap()]),
    ] {
        let o = wait_with_watchdog(
            start_shore(&ep, None, &[&extra[..], &["--give-up-s", "4"]].concat()),
            LIMIT,
        );
        assert_eq!(o.status.code(), Some(1), "{who}: {}", text(&o.stderr));
        assert!(text(&o.stderr).contains("no message"), "{who}: {}", text(&o.stderr));
        let o = shore_command(
            &ep,
            &[&extra[..], &["--command", "abort-to-goal", "--give-up-s", "4"]].concat(),
        );
        assert!(
            text(&o.stderr).contains("no acknowledgement"),
            "{who}: {}",
            text(&o.stderr)
        );
        assert!(
            text(&o.stderr).contains("(link waiting)"),
            "{who} heard the vehicle: {}",
            text(&o.stderr)
        );
    }
    // The viewer hears the vehicle (its link is up) but its commands never arrive.
    let o = shore_command(
        &ep,
        &[
            "--zenoh-config",
            viewer.to_str().unwrap(),
            "--command",
            "abort-to-goal",
            "--give-up-s",
            "4",
        ],
    );
    assert!(text(&o.stderr).contains("no acknowledgement"), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("(link up)"), "{}", text(&o.stderr));
    // The operator's do.
    let o = shore_command(
        &ep,
        &[&op[..], &["--command", "set-time-budget", "--budget-s", "30500"]].concat(),
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    finish(mission, "mission");
    finish(watcher, "operator's console");
    let r = read_json(&out.join("report.json"));
    assert_undisturbed(&r, &p);
    assert_eq!(r["shore_link"]["commands"]["applied"], 1, "{:#}", r["shore_link"]);
    let s = read_json(&watch_out.join("shore.json"));
    assert_eq!(s["plans"], r["plans"], "{s:#}");
}

/// The default mission file with another time budget, written into `dir`.
/// A console's ack line without its round-trip time (which differs between
/// two sends of the same command).
fn the_ack(line: &str) -> String {
    let (ack, took) = line
        .split_once(", acknowledged ")
        .unwrap_or_else(|| panic!("no round-trip time in {line:?}"));
    let ms = took.trim_end().strip_suffix(" ms after sending");
    assert!(ms.is_some_and(|m| m.parse::<f64>().is_ok_and(|v| v >= 0.0)), "{line:?}");
    ack.to_string()
}

fn mission_with_budget(dir: &Path, name: &str, budget: &str) -> PathBuf {
    let text = std::fs::read_to_string(auv_system::workspace_root().join("missions/benoits-cove.toml"))
        .expect("the shipped default mission");
    assert!(
        text.contains("time_available_s = 31000"),
        "the default mission's budget moved"
    );
    write(
        dir,
        name,
        &text.replacen("time_available_s = 31000", &format!("time_available_s = {budget}"), 1),
    )
}

#[test]
fn a_mission_from_shore_is_checked_then_taken_on_where_the_vehicle_is() {
    let _alone = alone();
    let (out, cfg, watch_out) = (temp_dir("rm"), temp_dir("rc"), temp_dir("rw"));
    let (p, ep) = (prefix("sr"), endpoint());
    let watcher = start_shore(&ep, Some(&watch_out), &["--give-up-s", "60"]);
    let mission = start_mission(&out, &p, &ep, "300", &[]);
    wait_for_line(&out, "mission.log", "\"plan\"");
    // Caught ashore, never sent: not a mission file.
    let junk = write(&cfg, "junk.toml", "format = \"auv-mission/1\"\nname = 3\n");
    let o = shore_command(
        &ep,
        &["--command", "replace-mission", "--mission", junk.to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("--mission") && text(&o.stderr).contains("name"),
        "{}",
        text(&o.stderr)
    );
    // Refused onboard: more time than the vehicle has left.
    let long = mission_with_budget(&cfg, "long.toml", "1000000");
    let o = shore_command(
        &ep,
        &["--command", "replace-mission", "--mission", long.to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    let e = text(&o.stderr);
    assert!(
        e.contains("refused: budget_out_of_range") && e.contains("has left"),
        "{e}"
    );
    // Taken on: the ack carries the first plan of the new mission.
    let short = mission_with_budget(&cfg, "short.toml", "9000");
    let args = [
        "--command",
        "replace-mission",
        "--mission",
        short.to_str().unwrap(),
        "--command-id",
        "777",
    ];
    let o = shore_command(&ep, &args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let first = text(&o.stdout);
    assert!(
        first.contains("replace-mission (id 777): applied") && first.contains("plan seq "),
        "{first}"
    );
    // Sent again (the console's resend, or by hand): answered again, taken on once.
    let o = shore_command(&ep, &args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(the_ack(&text(&o.stdout)), the_ack(&first));
    finish(mission, "mission");
    let watched = finish(watcher, "shore");
    // The first leg ends where the shore replaced it; the second is the new
    // mission, from the vehicle's position, to its goal.
    let r1 = read_json(&out.join("report.json"));
    assert_eq!(r1["outcome"], "replaced", "{r1:#}");
    let rep = &r1["replaced"];
    assert_eq!(rep["command_id"], 777, "{rep:#}");
    assert_eq!(rep["continued_in"], "leg-2", "{rep:#}");
    let r2 = read_json(&out.join("leg-2/report.json"));
    assert_eq!(r2["outcome"], "goal_reached", "{r2:#}");
    assert_eq!(r2["time_available_s"], 9000.0, "{r2:#}");
    for r in [&r1, &r2] {
        assert_eq!(r["supervision"]["restarts_total"]["external"], 0, "{r:#}");
        assert_eq!(r["shm_files_left"], 0, "{r:#}");
    }
    assert!(leftovers(&p).is_empty(), "{:?}", leftovers(&p));
    // Where the second leg started is where the first left the vehicle.
    let journal = std::fs::read_to_string(out.join("journal.jsonl")).unwrap_or_default();
    assert!(
        !journal.contains("\"end\""),
        "the first leg was replaced, not ended:\n{journal}"
    );
    let start = rep["start_at"].as_array().expect("start_at");
    assert_eq!(start.len(), 3, "{rep:#}");
    // The console watched both legs through and ended with the second.
    let s = read_json(&watch_out.join("shore.json"));
    assert_eq!(s["outcome"], "goal_reached", "{s:#}\n{}", text(&watched.stderr));
    let log = std::fs::read_to_string(out.join("faults.log")).unwrap_or_default();
    assert_eq!(log.matches("\"replace_mission\"").count(), 2, "{log}");
}
