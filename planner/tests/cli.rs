//! End-to-end tests of the `planner` binary: `solve` output checked against
//! an independent recomputation from the instance, classic orienteering
//! instances converted and solved within their known optima, scenario
//! snapshots exported and re-solved, determinism, and one test per kind of
//! bad input (non-zero exit, one clear line, no panic).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use auv_core::fixtures::random_instance;
use auv_core::instance::{Instance, Objective};
use auv_core::oplib::BestKnown;
use auv_core::solution::Solution;
use serde_json::{Value, json};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../crates/core/tests/data");

fn planner(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_planner"))
        .args(args)
        .output()
        .expect("the planner binary runs")
}

/// A fresh, empty scratch folder for one test.
fn scratch(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("planner-cli").join(test);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn path_str(p: &Path) -> &str {
    p.to_str().expect("scratch paths are UTF-8")
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn assert_ok(out: &Output) {
    assert!(out.status.success(), "exit {:?}, stderr: {}", out.status, stderr(out));
}

/// Our own errors: exit 2, exactly one line `planner: error: …` naming
/// every `needle`, nothing on stdout, no panic.
fn assert_input_error(out: &Output, needles: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert!(!err.contains("panicked"), "panic: {err}");
    assert!(err.starts_with("planner: error: "), "{err}");
    assert_eq!(err.lines().count(), 1, "one line expected: {err}");
    for needle in needles {
        assert!(err.contains(needle), "{err:?} should mention {needle:?}");
    }
    assert!(out.stdout.is_empty(), "stdout: {}", stdout(out));
}

/// clap's usage errors: exit 2, no panic, the message names the problem.
fn assert_usage_error(out: &Output, needles: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert!(!err.contains("panicked"), "panic: {err}");
    for needle in needles {
        assert!(err.contains(needle), "{err:?} should mention {needle:?}");
    }
}

/// A paper-like network: 30 waypoints, tasks on edges, 31 000 s budget.
fn paper_like(seed: u64) -> Instance {
    random_instance(30, 0.35, 31_000.0, seed)
}

fn write_json(dir: &Path, name: &str, v: &Value) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, v.to_string()).unwrap();
    p
}

fn write_instance(dir: &Path, name: &str, inst: &Instance) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, inst.to_json()).unwrap();
    p
}

fn solve_json(instance: &Path, extra: &[&str]) -> (Value, String) {
    let mut args = vec!["solve", "--instance", path_str(instance), "--json"];
    args.extend_from_slice(extra);
    let out = planner(&args);
    assert_ok(&out);
    let text = stdout(&out);
    let v: Value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"));
    (v, text)
}

/// The format's derived figures, computed here from the instance document
/// alone, as an outside checker would (deliberately not the library's code).
struct Checked {
    weight: f64,
    time_s: f64,
    distance_m: f64,
    cost: f64,
    tasks: u64,
    feasible: bool,
}

fn recompute(doc: &Value, route: &[usize]) -> Checked {
    let num = |v: &Value| v.as_f64().unwrap();
    let mut nodes = HashMap::new();
    for n in doc["nodes"].as_array().unwrap() {
        let id = n["id"].as_u64().unwrap() as usize;
        nodes.insert(id, [num(&n["x"]), num(&n["y"]), num(&n["z"]), num(&n["prize"])]);
    }
    let mut edges = HashMap::new();
    for e in doc["edges"].as_array().unwrap() {
        let (a, b) = (e["a"].as_u64().unwrap() as usize, e["b"].as_u64().unwrap() as usize);
        let task = [num(&e["priority"]), num(&e["risk"]), num(&e["task_time_s"])];
        edges.insert((a.min(b), a.max(b)), task);
    }
    let speed = num(&doc["speed_mps"]);
    let budget = num(&doc["time_available_s"]);
    assert_eq!(route.first().copied(), doc["start"].as_u64().map(|v| v as usize));
    assert_eq!(route.last().copied(), doc["goal"].as_u64().map(|v| v as usize));
    let mut distinct = route.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    assert_eq!(distinct.len(), route.len(), "route repeats a node: {route:?}");
    let mut c = Checked {
        weight: route.iter().map(|id| nodes[id][3]).sum(),
        time_s: 0.0,
        distance_m: 0.0,
        cost: 0.0,
        tasks: 0,
        feasible: false,
    };
    let mut ratio = 0.0;
    for w in route.windows(2) {
        let [p, r, t] = edges
            .get(&(w[0].min(w[1]), w[0].max(w[1])))
            .unwrap_or_else(|| panic!("{}-{} is not an edge", w[0], w[1]));
        let (u, v) = (nodes[&w[0]], nodes[&w[1]]);
        let d = ((u[0] - v[0]).powi(2) + (u[1] - v[1]).powi(2) + (u[2] - v[2]).powi(2)).sqrt();
        c.distance_m += d;
        c.time_s += d / speed + t;
        c.weight += p / r;
        if *p > 0.0 {
            ratio += r / p;
        }
        c.tasks += 1;
    }
    c.feasible = c.time_s <= budget * (1.0 + 1e-6);
    if doc["objective"]["kind"] == "paper_cost" {
        c.cost = num(&doc["objective"]["phi1"]) * (c.time_s - budget).abs() + num(&doc["objective"]["phi2"]) * ratio;
    }
    c
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

fn route_of(v: &Value) -> Vec<usize> {
    v["route"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap() as usize)
        .collect()
}

fn assert_figures_match(doc: &Value, sol: &Value) {
    let route = route_of(sol);
    let c = recompute(doc, &route);
    for (field, expected) in [
        ("weight", c.weight),
        ("time_s", c.time_s),
        ("distance_m", c.distance_m),
        ("cost", c.cost),
    ] {
        let got = sol[field].as_f64().unwrap();
        assert!(close(got, expected), "{field}: reported {got}, recomputed {expected}");
    }
    assert_eq!(sol["tasks"].as_u64(), Some(c.tasks));
    assert_eq!(sol["feasible"].as_bool(), Some(c.feasible));
}

#[test]
fn solve_json_figures_equal_the_recomputation_from_the_instance() {
    let dir = scratch("figures");
    for (k, objective) in [Objective::MaxWeight, Objective::PaperCost { phi1: 0.01, phi2: 2.0 }]
        .into_iter()
        .enumerate()
    {
        let mut inst = paper_like(11 + k as u64);
        inst.objective = objective;
        let path = write_instance(&dir, &format!("paper-{k}.json"), &inst);
        let doc: Value = serde_json::from_str(&inst.to_json()).unwrap();
        for algorithm in ["auto", "pso", "bbo"] {
            let (sol, text) = solve_json(&path, &["--algorithm", algorithm, "--iterations", "20"]);
            for key in [
                "route",
                "feasible",
                "weight",
                "time_s",
                "distance_m",
                "cost",
                "tasks",
                "solve_ms",
                "solve_thread_cpu_ms",
                "iterations",
                "algorithm",
                "seed",
                "stop",
                "objective",
            ] {
                assert!(sol.get(key).is_some(), "{key} missing: {text}");
            }
            assert_eq!(sol["algorithm"], algorithm);
            assert_eq!(sol["seed"], 1, "the documented default seed is reported");
            assert!(sol["iterations"].as_u64().unwrap() <= 20);
            assert!(["budget", "converged"].contains(&sol["stop"].as_str().unwrap()));
            assert_eq!(sol["objective"], if k == 0 { "max_weight" } else { "paper_cost" });
            assert!(sol["solve_ms"].as_f64().unwrap() >= 0.0);
            // Measured, not a placeholder: any solve costs its thread some CPU.
            assert!(sol["solve_thread_cpu_ms"].as_f64().unwrap() > 0.0, "{text}");
            assert_figures_match(&doc, &sol);
            // And bit-for-bit against the library's checker.
            Solution::from_json(&text).unwrap().verify(&inst).unwrap();
        }
    }
}

#[test]
fn instances_round_trip_through_json_bit_for_bit() {
    // What `solve` reads must be exactly what `export` wrote, or the
    // recomputed figures drift by an ulp from an outside checker's.
    for seed in 0..20 {
        let inst = paper_like(seed);
        assert_eq!(Instance::from_json(&inst.to_json()).unwrap(), inst, "seed {seed}");
    }
}

#[test]
fn solve_without_json_prints_a_readable_summary() {
    let dir = scratch("summary");
    let path = write_instance(&dir, "paper.json", &paper_like(5));
    let out = planner(&[
        "solve",
        "--instance",
        path_str(&path),
        "--iterations",
        "5",
        "--seed",
        "9",
    ]);
    assert_ok(&out);
    let text = stdout(&out);
    for needle in ["route      0 -> ", "feasible   ", "weight     ", "seed 9", "auto"] {
        assert!(text.contains(needle), "{needle:?} missing from:\n{text}");
    }
}

#[test]
fn same_seed_gives_identical_json_except_the_solve_times() {
    let dir = scratch("determinism");
    let path = write_instance(&dir, "paper.json", &paper_like(21));
    for algorithm in ["auto", "pso", "bbo"] {
        let args = ["--algorithm", algorithm, "--seed", "12345", "--iterations", "30"];
        let strip = |text: String| -> String {
            text.lines()
                .filter(|l| {
                    let l = l.trim_start();
                    !l.starts_with("\"solve_ms\"") && !l.starts_with("\"solve_thread_cpu_ms\"")
                })
                .collect::<Vec<_>>()
                .join("\n")
        };
        let (_, a) = solve_json(&path, &args);
        let (_, b) = solve_json(&path, &args);
        assert_eq!(strip(a.clone()), strip(b), "{algorithm}");
        assert!(a.contains("\"seed\": 12345"), "{a}");
    }
}

fn best_known() -> BestKnown {
    BestKnown::parse(&std::fs::read_to_string(format!("{DATA}/op/best_known.csv")).unwrap()).unwrap()
}

#[test]
fn classic_instances_convert_and_solve_within_the_known_optimum() {
    let dir = scratch("classic");
    let best = best_known();
    for tmax in ["05", "10"] {
        let name = format!("tsiligirides_problem_1_budget_{tmax}");
        let src = format!("{DATA}/op/tsiligirides_set1/{name}.txt");
        let json = dir.join(format!("{name}.json"));
        assert_ok(&planner(&["convert-op", &src, "--out", path_str(&json)]));
        let doc: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let optimum = best.get(&name).unwrap().score;
        for algorithm in ["auto", "pso", "bbo"] {
            let (sol, _) = solve_json(&json, &["--algorithm", algorithm]);
            assert_eq!(sol["feasible"], true, "{name} {algorithm}: {sol}");
            let weight = sol["weight"].as_f64().unwrap();
            assert!(
                weight <= optimum,
                "{name} {algorithm}: {weight} beats the proven optimum {optimum}"
            );
            assert!(sol["time_s"].as_f64().unwrap() <= doc["time_available_s"].as_f64().unwrap() * (1.0 + 1e-6));
            // Node prizes only: the weight is the score of the visited nodes.
            assert_figures_match(&doc, &sol);
        }
    }
}

#[test]
fn convert_op_maps_a_file_onto_the_format() {
    let dir = scratch("convert-file");
    let src = format!("{DATA}/op/tsiligirides_set1/tsiligirides_problem_1_budget_10.txt");
    // An existing folder as --out receives <name>.json.
    let out = planner(&["convert-op", &src, "--out", path_str(&dir)]);
    assert_ok(&out);
    let written = dir.join("tsiligirides_problem_1_budget_10.json");
    assert!(stdout(&out).contains("32 nodes, Tmax 10"), "{}", stdout(&out));
    let text = std::fs::read_to_string(&written).unwrap();
    let inst = Instance::from_json(&text).unwrap();
    assert_eq!(inst.name, "tsiligirides_problem_1_budget_10");
    assert_eq!((inst.start, inst.goal), (0, 1));
    assert_eq!((inst.speed_mps, inst.time_available_s), (1.0, 10.0));
    assert_eq!(inst.objective, Objective::MaxWeight);
    assert_eq!(inst.nodes.len(), 32);
    assert_eq!(inst.edges.len(), 32 * 31 / 2);
    assert!(
        inst.edges
            .iter()
            .all(|e| e.priority == 0.0 && e.risk == 1.0 && e.task_time_s == 0.0)
    );
    // The file's first and third node lines: "10.5 14.4 0" and "18 15.9 10".
    assert_eq!(
        (inst.nodes[0].x, inst.nodes[0].y, inst.nodes[0].prize),
        (10.5, 14.4, 0.0)
    );
    assert_eq!(
        (inst.nodes[2].x, inst.nodes[2].y, inst.nodes[2].prize),
        (18.0, 15.9, 10.0)
    );
    assert!(inst.nodes.iter().all(|n| n.z == 0.0));
    let total: f64 = inst.nodes.iter().map(|n| n.prize).sum();
    assert!(total > 0.0);
}

#[test]
fn convert_op_converts_a_folder_tree() {
    let dir = scratch("convert-tree");
    let out_dir = dir.join("out");
    let out = planner(&["convert-op", &format!("{DATA}/op"), "--out", path_str(&out_dir)]);
    assert_ok(&out);
    assert!(stdout(&out).contains("converted 3 files"), "{}", stdout(&out));
    for tmax in ["05", "10"] {
        let p = out_dir.join(format!("tsiligirides_set1/tsiligirides_problem_1_budget_{tmax}.json"));
        let inst = Instance::from_json(&std::fs::read_to_string(&p).unwrap()).unwrap();
        assert_eq!(inst.time_available_s, tmax.parse::<f64>().unwrap());
    }
    // README.md and best_known.csv are not benchmark files.
    assert!(!out_dir.join("README.json").exists());
    assert!(!out_dir.join("best_known.json").exists());
}

fn export(test: &str, extra: &[&str]) -> (PathBuf, Output) {
    let dir = scratch(test);
    let out_path = dir.join("snapshot.json");
    let mut args = vec!["export", "--out", path_str(&out_path)];
    args.extend_from_slice(extra);
    let out = planner(&args);
    (out_path, out)
}

#[test]
fn export_writes_the_default_scenario_snapshot_deterministically() {
    let (a, out) = export("export-a", &["--seed", "42"]);
    assert_ok(&out);
    assert!(stdout(&out).contains("benoits-cove-seed-42-t0"), "{}", stdout(&out));
    let text = std::fs::read_to_string(&a).unwrap();
    let inst = Instance::from_json(&text).unwrap();
    assert_eq!(inst.name, "benoits-cove-seed-42-t0");
    // The documented scenario defaults (auv_world::scenario module table).
    assert_eq!(inst.nodes.len(), 40);
    assert_eq!((inst.start, inst.goal), (0, 39));
    assert_eq!((inst.speed_mps, inst.time_available_s), (1.5, 31_000.0));
    assert_eq!(inst.objective, Objective::MaxWeight);
    assert!(!inst.edges.is_empty());
    for n in &inst.nodes {
        assert!((0.0..=5000.0).contains(&n.x) && (0.0..=10_000.0).contains(&n.y) && (0.0..=1000.0).contains(&n.z));
        assert_eq!(n.prize, 0.0);
    }
    for e in &inst.edges {
        assert!((1.0..=10.0).contains(&e.priority) && (0.1..=1.0).contains(&e.risk));
        assert!((120.0..=900.0).contains(&e.task_time_s));
    }
    let (b, out) = export("export-b", &["--seed", "42"]);
    assert_ok(&out);
    assert_eq!(std::fs::read(&b).unwrap(), text.as_bytes(), "same seed, same bytes");
    let (c, out) = export("export-c", &["--seed", "43"]);
    assert_ok(&out);
    assert_ne!(
        std::fs::read(&c).unwrap(),
        text.as_bytes(),
        "another seed, another network"
    );
}

#[test]
fn export_follows_a_scenario_file() {
    let dir = scratch("export-scenario");
    let scenario = write_json(
        &dir,
        "small.json",
        &json!({"format": "auv-scenario/1", "nodes": 12, "dynamic": 3, "time_available_s": 9000,
                "objective": {"kind": "paper_cost", "phi1": 0.01, "phi2": 1.0}}),
    );
    let (out_path, out) = export_scenario(&dir, &scenario, "7");
    assert_ok(&out);
    let inst = Instance::from_json(&std::fs::read_to_string(&out_path).unwrap()).unwrap();
    assert_eq!(inst.nodes.len(), 12);
    assert_eq!(inst.goal, 11);
    assert_eq!(inst.time_available_s, 9000.0);
    assert_eq!(inst.objective, Objective::PaperCost { phi1: 0.01, phi2: 1.0 });
}

#[test]
fn the_generator_exports_networks_beyond_the_service_class_and_they_solve() {
    let dir = scratch("export-large");
    let scenario = write_json(&dir, "n200.json", &json!({"format": "auv-scenario/1", "nodes": 200}));
    let (out_path, out) = export_scenario(&dir, &scenario, "3");
    assert_ok(&out);
    let inst = Instance::from_json(&std::fs::read_to_string(&out_path).unwrap()).unwrap();
    assert_eq!((inst.nodes.len(), inst.goal), (200, 199));
    assert!(inst.edges.len() > 1000, "{} edges", inst.edges.len());
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&out_path).unwrap()).unwrap();
    let (sol, _) = solve_json(&out_path, &["--algorithm", "pso", "--iterations", "10"]);
    assert_eq!(sol["feasible"], true, "{sol}");
    assert_figures_match(&doc, &sol);
    // The Monte Carlo study keeps the paper's 128-waypoint networks: a clear
    // one-line refusal, exit 2 like any other bad input.
    let out = planner(&[
        "montecarlo",
        "--scenario",
        path_str(&scenario),
        "--runs",
        "1",
        "--out",
        path_str(&dir.join("mc")),
    ]);
    assert_input_error(&out, &["`nodes` = 200", "up to 128 waypoints"]);
}

#[test]
fn an_exported_snapshot_solves_with_checkable_figures() {
    let (path, out) = export("export-solve", &["--seed", "5"]);
    assert_ok(&out);
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    for algorithm in ["auto", "pso", "bbo"] {
        let (sol, _) = solve_json(&path, &["--algorithm", algorithm, "--iterations", "30"]);
        assert_eq!(sol["feasible"], true, "{algorithm}: {sol}");
        assert!(sol["weight"].as_f64().unwrap() > 0.0);
        assert_figures_match(&doc, &sol);
    }
}

// ---- bad input: one test each -------------------------------------------

/// A small valid instance document to break in one place per test.
fn base_doc() -> Value {
    serde_json::from_str(&paper_like(3).to_json()).unwrap()
}

fn solve_doc(test: &str, doc: &Value) -> Output {
    let dir = scratch(test);
    let path = write_json(&dir, "bad.json", doc);
    planner(&["solve", "--instance", path_str(&path)])
}

fn solve_text(test: &str, text: &str) -> Output {
    let dir = scratch(test);
    let path = dir.join("bad.json");
    std::fs::write(&path, text).unwrap();
    planner(&["solve", "--instance", path_str(&path)])
}

#[test]
fn bad_input_missing_file() {
    let out = planner(&["solve", "--instance", "/nonexistent/instance.json"]);
    assert_input_error(&out, &["cannot read /nonexistent/instance.json", "No such file"]);
}

#[test]
fn bad_input_not_json() {
    let out = solve_text("not-json", "this is not json\n");
    assert_input_error(&out, &["bad.json", "not valid JSON", "line 1"]);
    let out = solve_text("truncated-json", &base_doc().to_string()[..200]);
    assert_input_error(&out, &["not valid JSON", "EOF"]);
}

#[test]
fn bad_input_wrong_format_tag() {
    let mut doc = base_doc();
    doc["format"] = json!("auv-route-instance/2");
    assert_input_error(
        &solve_doc("format-tag", &doc),
        &["unsupported format", "auv-route-instance/2", "auv-route-instance/1"],
    );
}

#[test]
fn bad_input_missing_field() {
    let mut doc = base_doc();
    doc.as_object_mut().unwrap().remove("time_available_s");
    assert_input_error(&solve_doc("missing-field", &doc), &["missing field `time_available_s`"]);
    let mut doc = base_doc();
    doc["edges"][2].as_object_mut().unwrap().remove("risk");
    assert_input_error(&solve_doc("missing-edge-field", &doc), &["missing field `risk`"]);
}

#[test]
fn bad_input_nan_number() {
    let text = base_doc()
        .to_string()
        .replacen("\"speed_mps\":1.5", "\"speed_mps\":NaN", 1);
    assert!(text.contains("NaN"), "the fixture's speed is 1.5");
    assert_input_error(
        &solve_text("nan", &text),
        &["NaN is not a JSON number", "line 1, column"],
    );
}

#[test]
fn bad_input_negative_numbers() {
    let cases = [
        ("speed_mps", json!(-1.5), "speed_mps = -1.5 is invalid: must be > 0"),
        ("time_available_s", json!(-10.0), "time_available_s = -10 is invalid"),
    ];
    for (field, value, needle) in cases {
        let mut doc = base_doc();
        doc[field] = value;
        assert_input_error(&solve_doc("negative", &doc), &[needle]);
    }
    let mut doc = base_doc();
    doc["edges"][4]["task_time_s"] = json!(-1.0);
    assert_input_error(
        &solve_doc("negative-task", &doc),
        &["edges[4].task_time_s = -1 is invalid"],
    );
    let mut doc = base_doc();
    doc["nodes"][2]["prize"] = json!(-5.0);
    assert_input_error(&solve_doc("negative-prize", &doc), &["nodes[2].prize = -5 is invalid"]);
}

#[test]
fn bad_input_unknown_node_id() {
    let mut doc = base_doc();
    doc["edges"][0]["b"] = json!(99);
    assert_input_error(
        &solve_doc("unknown-node", &doc),
        &["edges[0].b refers to unknown node id 99"],
    );
    let mut doc = base_doc();
    doc["goal"] = json!(30);
    assert_input_error(&solve_doc("unknown-goal", &doc), &["goal refers to unknown node id 30"]);
}

#[test]
fn bad_input_duplicate_edge() {
    let mut doc = base_doc();
    let mut twin = doc["edges"][0].clone();
    let (a, b) = (twin["a"].clone(), twin["b"].clone());
    twin["a"] = b;
    twin["b"] = a;
    doc["edges"].as_array_mut().unwrap().push(twin);
    assert_input_error(&solve_doc("duplicate-edge", &doc), &["duplicates edges[0]"]);
}

#[test]
fn bad_input_start_equals_goal() {
    let mut doc = base_doc();
    doc["goal"] = doc["start"].clone();
    assert_input_error(&solve_doc("start-goal", &doc), &["start and goal are both node 0"]);
}

#[test]
fn bad_input_more_nodes_than_capacity() {
    // Beyond the largest capacity class (512 nodes).
    let inst = random_instance(513, 0.01, 31_000.0, 4);
    let doc: Value = serde_json::from_str(&inst.to_json()).unwrap();
    assert_input_error(&solve_doc("capacity", &doc), &["513 nodes", "capacity of 512"]);
}

#[test]
fn instances_beyond_128_nodes_solve_in_a_larger_class() {
    let dir = scratch("large-class");
    for (n, algorithm) in [(200, "pso"), (450, "bbo"), (300, "auto")] {
        let inst = random_instance(n, 0.05, 31_000.0, 4);
        let path = write_instance(&dir, &format!("n{n}.json"), &inst);
        let (v, _) = solve_json(&path, &["--algorithm", algorithm, "--iterations", "3"]);
        let route = route_of(&v);
        assert_eq!(
            (route.first(), route.last()),
            (Some(&inst.start), Some(&inst.goal)),
            "{n}"
        );
        assert!(
            route.iter().any(|&id| id >= 128),
            "{n}: no id beyond the 128 class in {route:?}"
        );
        let doc: Value = serde_json::from_str(&inst.to_json()).unwrap();
        assert_figures_match(&doc, &v);
    }
}

#[test]
fn bad_input_goal_unreachable() {
    let mut doc = base_doc();
    let goal = doc["goal"].as_u64().unwrap();
    doc["edges"]
        .as_array_mut()
        .unwrap()
        .retain(|e| e["a"].as_u64() != Some(goal) && e["b"].as_u64() != Some(goal));
    assert_input_error(&solve_doc("unreachable", &doc), &["no path joins start 0 and goal 29"]);
}

#[test]
fn bad_input_unknown_algorithm() {
    let dir = scratch("algorithm");
    let path = write_instance(&dir, "ok.json", &paper_like(3));
    let out = planner(&["solve", "--instance", path_str(&path), "--algorithm", "ga"]);
    assert_usage_error(&out, &["invalid value 'ga'", "--algorithm", "pso", "bbo"]);
}

#[test]
fn bad_input_iterations_zero_or_negative() {
    let dir = scratch("iterations");
    let path = write_instance(&dir, "ok.json", &paper_like(3));
    for bad in ["0", "-3"] {
        let out = planner(&["solve", "--instance", path_str(&path), "--iterations", bad]);
        assert_usage_error(&out, &[&format!("invalid value '{bad}'"), "--iterations"]);
    }
    let out = planner(&["solve", "--instance", path_str(&path), "--iterations", "many"]);
    assert_usage_error(&out, &["invalid value 'many'", "--iterations"]);
    let out = planner(&["solve", "--instance", path_str(&path), "--seed", "-1"]);
    assert_usage_error(&out, &["invalid value '-1'", "--seed"]);
}

#[test]
fn bad_input_malformed_op_file() {
    let dir = scratch("bad-op");
    let cases = [
        (
            "fields.txt",
            "5 1\n0 0 0\n1 1\n",
            "line 3: expected 3 fields (x y score), found 2",
        ),
        (
            "word.txt",
            "5 1\n0 0 0\n1 x 0\n",
            "line 3, column 3: y \"x\" is not a number",
        ),
        ("paths.txt", "5 2\n0 0 0\n1 1 0\n", "P = 2"),
        (
            "negative.txt",
            "5 1\n0 0 0\n1 1 -4\n",
            "line 3, column 5: score = -4 is invalid",
        ),
        (
            "nan.txt",
            "NaN 1\n0 0 0\n1 1 0\n",
            "line 1, column 1: Tmax = NaN is invalid",
        ),
        ("short.txt", "5 1\n0 0 0\n", "1 node line(s)"),
        ("empty.txt", "", "empty file"),
    ];
    for (name, text, needle) in cases {
        let src = dir.join(name);
        std::fs::write(&src, text).unwrap();
        let out = planner(&["convert-op", path_str(&src), "--out", path_str(&dir.join("x.json"))]);
        assert_input_error(&out, &[name, needle]);
        assert!(!dir.join("x.json").exists(), "nothing is written for {name}");
    }
    // In a folder, the bad file is named even when good ones come first.
    let tree = dir.join("tree");
    std::fs::create_dir_all(tree.join("sub")).unwrap();
    std::fs::write(tree.join("a.txt"), "5 1\n0 0 0\n1 1 0\n").unwrap();
    std::fs::write(tree.join("sub/b.txt"), "5 1\n0 0 0\n1 1 zero\n").unwrap();
    let out = planner(&["convert-op", path_str(&tree), "--out", path_str(&dir.join("out"))]);
    assert_input_error(&out, &["sub/b.txt", "line 3, column 5: score \"zero\" is not a number"]);
}

#[test]
fn bad_input_convert_op_missing_input_or_empty_folder() {
    let dir = scratch("op-missing");
    let out = planner(&["convert-op", "/nonexistent/op", "--out", path_str(&dir)]);
    assert_input_error(&out, &["cannot read /nonexistent/op"]);
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let out = planner(&["convert-op", path_str(&empty), "--out", path_str(&dir.join("o"))]);
    assert_input_error(&out, &["no .txt or .oplib benchmark files"]);
}

#[test]
fn convert_op_reads_oplib_files_in_their_documented_encoding() {
    let dir = scratch("convert-oplib");
    let src = format!("{DATA}/oplib/gen2/gr48-gen2-50.oplib");
    let out = planner(&["convert-op", &src, "--out", path_str(&dir)]);
    assert_ok(&out);
    assert!(stdout(&out).contains("49 nodes, budget 2523.5"), "{}", stdout(&out));
    let text = std::fs::read_to_string(dir.join("gr48-gen2-50.json")).unwrap();
    let inst = Instance::from_json(&text).unwrap();
    // The depot (city 1) is the start; its copy, node 48, the goal.
    assert_eq!((inst.start, inst.goal), (0, 48));
    assert_eq!(inst.nodes[48].prize, 0.0);
    assert_eq!(inst.edges.len(), 49 * 48 / 2);
    // gr48's matrix starts 0 / 593 0 / 409 258 0 (LOWER_DIAG_ROW).
    assert_eq!(inst.edge_between(0, 1).unwrap().task_time_s, 593.0);
    assert_eq!(inst.edge_between(1, 2).unwrap().task_time_s, 258.0);
    assert_eq!(inst.edge_between(2, 48).unwrap().task_time_s, 409.0);
    // A whole folder converts, and `quality` reads the files directly.
    let out = planner(&[
        "convert-op",
        &format!("{DATA}/oplib"),
        "--out",
        path_str(&dir.join("all")),
    ]);
    assert_ok(&out);
    assert!(dir.join("all/gen1/att48-gen1-50.json").is_file());
    let csv = dir.join("q.csv");
    let out = planner(&[
        "quality",
        "--instances",
        &format!("{DATA}/oplib"),
        "--algorithms",
        "auto",
        "--deadline-ms",
        "2",
        "--out",
        path_str(&csv),
        "--plot",
        path_str(&dir.join("q.svg")),
    ]);
    assert_ok(&out);
    // A process of its own: the figure's text needs the embedded font registered here too.
    let svg = std::fs::read_to_string(dir.join("q.svg")).unwrap();
    assert!(
        svg.contains("<svg") && svg.contains("gen1"),
        "{}",
        &svg[..svg.len().min(300)]
    );
    let table = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(
        table.lines().filter(|l| l.contains(",best_known,")).count(),
        6,
        "{table}"
    );
}

#[test]
fn bad_input_oplib_names_the_line() {
    let dir = scratch("oplib-bad");
    let text = std::fs::read_to_string(format!("{DATA}/oplib/gen1/eil51-gen1-50.oplib")).unwrap();
    let broken = dir.join("broken.oplib");
    std::fs::write(&broken, text.replacen("\n3 ", "\n3 x", 1)).unwrap();
    let out = planner(&["convert-op", path_str(&broken), "--out", path_str(&dir.join("o.json"))]);
    assert_input_error(&out, &["broken.oplib", "line", "is invalid"]);
}

/// `planner export --seed SEED --scenario SCENARIO` into `DIR/snap.json`.
fn export_scenario(dir: &Path, scenario: &Path, seed: &str) -> (PathBuf, Output) {
    let out_path = dir.join("snap.json");
    let out = planner(&[
        "export",
        "--seed",
        seed,
        "--scenario",
        path_str(scenario),
        "--out",
        path_str(&out_path),
    ]);
    (out_path, out)
}

fn export_with_scenario(test: &str, scenario: &Value) -> Output {
    let dir = scratch(test);
    let path = write_json(&dir, "scenario.json", scenario);
    let (out_path, out) = export_scenario(&dir, &path, "1");
    assert!(!out_path.exists(), "nothing is written on error");
    out
}

#[test]
fn bad_input_malformed_scenario_file() {
    let cases = [
        (json!({"nodez": 40}), "unknown field `nodez`"),
        (json!({"format": "auv-scenario/9"}), "`format`"),
        (
            json!({"nodes": 513}),
            "`nodes` = 513 exceeds the planner's largest capacity class of 512",
        ),
        (json!({"nodes": 10, "dynamic": 9}), "`dynamic` = 9"),
        (json!({"sigma_m": -150}), "`sigma_m` = -150"),
        (json!({"risk": [0, 1]}), "`risk[0]`"),
        (json!({"chart": "atlantis"}), "unknown embedded chart `atlantis`"),
        (json!([1, 2]), "JSON object"),
    ];
    for (doc, needle) in cases {
        assert_input_error(&export_with_scenario("bad-scenario", &doc), &["scenario.json", needle]);
    }
    let dir = scratch("bad-scenario-text");
    let nan = dir.join("nan.json");
    std::fs::write(&nan, "{\"sigma_m\": NaN}").unwrap();
    let out = planner(&[
        "export",
        "--seed",
        "1",
        "--scenario",
        path_str(&nan),
        "--out",
        path_str(&dir.join("o.json")),
    ]);
    assert_input_error(&out, &["nan.json", "NaN is not a JSON number"]);
    let out = planner(&[
        "export",
        "--seed",
        "1",
        "--scenario",
        path_str(&dir.join("missing.json")),
        "--out",
        path_str(&dir.join("o.json")),
    ]);
    assert_input_error(&out, &["cannot read", "missing.json"]);
    let out = planner(&["export", "--seed", "-4", "--out", path_str(&dir.join("o.json"))]);
    assert_usage_error(&out, &["invalid value '-4'", "--seed"]);
}

/// A PNG of one colour (RGB, 8 bit).
fn write_png(path: &Path, width: u32, height: u32, rgb: [u8; 3]) {
    let file = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().unwrap();
    let data: Vec<u8> = (0..width * height).flat_map(|_| rgb).collect();
    writer.write_image_data(&data).unwrap();
}

#[test]
fn bad_input_chart_with_no_water() {
    let dir = scratch("no-water");
    // Sand colour everywhere: no cluster is water. The chart path is
    // relative to the scenario file.
    write_png(&dir.join("desert.png"), 40, 30, [220, 203, 156]);
    let scenario = write_json(
        &dir,
        "scenario.json",
        &json!({"chart": {"png": "desert.png", "metres_per_pixel": 10}}),
    );
    let out = planner(&[
        "export",
        "--seed",
        "1",
        "--scenario",
        path_str(&scenario),
        "--out",
        path_str(&dir.join("out.json")),
    ]);
    assert_input_error(&out, &["scenario.json", "desert.png", "no navigable water"]);
    assert!(!dir.join("out.json").exists());
    // And a chart that is not a PNG at all.
    std::fs::write(dir.join("desert.png"), "not a png").unwrap();
    let out = planner(&[
        "export",
        "--seed",
        "1",
        "--scenario",
        path_str(&scenario),
        "--out",
        path_str(&dir.join("out.json")),
    ]);
    assert_input_error(&out, &["desert.png"]);
}

#[test]
fn montecarlo_writes_the_table_csv_and_figures_deterministically() {
    let dir = scratch("montecarlo");
    let run = |out: &Path| {
        planner(&[
            "montecarlo",
            "--runs",
            "3",
            "--nodes",
            "12",
            "--seed",
            "5",
            "--threads",
            "2",
            "--out",
            path_str(out),
        ])
    };
    let (a, b) = (dir.join("a"), dir.join("b"));
    let out = run(&a);
    assert_ok(&out);
    let table = stdout(&out);
    for needle in [
        "cost",
        "cpu_time (ms)",
        "route_time (s)",
        "distance (m)",
        "tasks",
        "weight",
        "violation (s)",
        "feasible (rate)",
        "pso",
        "bbo",
    ] {
        assert!(table.contains(needle), "{needle} missing from\n{table}");
    }
    for f in [
        "runs.csv",
        "summary.txt",
        "fig4-cost-cpu.svg",
        "fig5-time-distance.svg",
        "fig6-tasks-weight.svg",
        "fig7-violation.svg",
        "fig8-replan.svg",
    ] {
        assert!(a.join(f).is_file(), "{f} not written");
    }
    for needle in [
        "edges_changed (re-plan)",
        "edges_changed (cold re-plan)",
        "warm_start (rate)",
    ] {
        assert!(table.contains(needle), "{needle} missing from\n{table}");
    }
    let fig8 = std::fs::read_to_string(a.join("fig8-replan.svg")).unwrap();
    for needle in ["pso: ", "bbo: ", "edges changed by the re-plan", "before the change"] {
        assert!(fig8.contains(needle), "{needle} missing from fig8-replan.svg");
    }
    let csv = std::fs::read_to_string(a.join("runs.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some(
            "run,algorithm,seed,cost,cpu_ms,route_time_s,distance_m,tasks,weight,violation_s,feasible,\
             edges_changed,edges_changed_cold,replan_weight,replan_weight_cold,replan_feasible,warm_start"
        )
    );
    assert_eq!(lines.count(), 6, "3 runs x 2 algorithms");
    // Same seed, same rows (the CPU time column aside).
    assert_ok(&run(&b));
    let strip = |p: &Path| -> Vec<String> {
        std::fs::read_to_string(p.join("runs.csv"))
            .unwrap()
            .lines()
            .map(|l| {
                let mut cols: Vec<&str> = l.split(',').collect();
                cols.remove(4);
                cols.join(",")
            })
            .collect()
    };
    assert_eq!(strip(&a), strip(&b));
}

#[test]
fn montecarlo_rejects_bad_arguments() {
    let dir = scratch("montecarlo-bad");
    let out_dir = dir.join("out");
    let o = path_str(&out_dir);
    assert_usage_error(&planner(&["montecarlo", "--runs", "0", "--out", o]), &["--runs"]);
    assert_usage_error(&planner(&["montecarlo", "--algorithms", "pso,ga", "--out", o]), &["ga"]);
    assert_input_error(
        &planner(&["montecarlo", "--nodes", "129", "--out", o]),
        &["--nodes 129", "128"],
    );
    assert_input_error(&planner(&["montecarlo", "--nodes", "1", "--out", o]), &["--nodes 1"]);
    assert!(!out_dir.exists(), "nothing is written for rejected arguments");
}

const QUALITY_HEADER: &str = "instance,deadline_ms,algorithm,score,optimum,gap,gap_bound,solve_ms,feasible,optimum_source,family,time_to_best_ms";

/// Runs `planner quality --instances DIR FLAGS… --out CSV`, which must
/// succeed and write the documented header; returns its stdout and the
/// CSV's rows, split into fields.
fn run_quality(instances: &str, flags: &[&str], csv: &Path) -> (String, Vec<Vec<String>>) {
    let mut args = vec!["quality", "--instances", instances];
    args.extend_from_slice(flags);
    args.extend(["--out", path_str(csv)]);
    let out = planner(&args);
    assert_ok(&out);
    let body = std::fs::read_to_string(csv).unwrap();
    let mut lines = body.lines();
    assert_eq!(lines.next(), Some(QUALITY_HEADER));
    let rows = lines.map(|l| l.split(',').map(str::to_string).collect()).collect();
    (stdout(&out), rows)
}

#[test]
fn quality_reports_gaps_on_classic_instances() {
    let dir = scratch("quality");
    let csv = dir.join("quality.csv");
    let (text, rows) = run_quality(
        &format!("{DATA}/op"),
        &["--deadline-ms", "20,5", "--algorithms", "auto,pso"],
        &csv,
    );
    for needle in [
        "3 instances",
        "deadline 20 ms",
        "deadline 5 ms",
        "mean gap%",
        "p99 ms",
        "auto",
        "pso",
        "per family, auto",
        "tsiligirides_set1",
        "to best (median)",
    ] {
        assert!(text.contains(needle), "{needle:?} missing from:\n{text}");
    }
    let best = best_known();
    assert_eq!(rows.len(), 12, "3 instances x 2 deadlines x 2 algorithms");
    for r in &rows {
        assert!(r[1] == "20" || r[1] == "5", "{r:?}");
        let optimum = best.get(r[0].as_str()).unwrap().score;
        assert_eq!(r[4].parse::<f64>().unwrap(), optimum);
        let score: f64 = r[3].parse().unwrap();
        assert!(score <= optimum, "{r:?}");
        let gap: f64 = r[5].parse().unwrap();
        assert!((gap - 100.0 * (optimum - score) / optimum).abs() < 1e-3, "{r:?}");
        assert_eq!(r[6], r[5], "a known optimum certifies the gap itself");
        assert_eq!(r[8], "true");
        assert_eq!(r[9], "best_known");
        // The time to the best-known score is within the solve, when reached.
        if gap <= 1e-6 {
            let at: f64 = r[11].parse().unwrap();
            assert!(at <= r[7].parse::<f64>().unwrap() + 1e-3, "{r:?}");
        } else {
            assert_eq!(r[11], "", "{r:?}");
        }
    }
}

#[test]
fn quality_computes_the_optimum_with_the_exact_solver() {
    let dir = scratch("quality-exact");
    let instances = dir.join("instances");
    std::fs::create_dir_all(&instances).unwrap();
    for seed in [4, 5] {
        write_instance(
            &instances,
            &format!("r{seed}.json"),
            &random_instance(18, 0.5, 31_000.0, seed),
        );
    }
    let csv = dir.join("q.csv");
    let (text, rows) = run_quality(
        path_str(&instances),
        &["--deadline-ms", "5", "--algorithms", "pso,auto", "--clock", "cpu"],
        &csv,
    );
    assert!(text.contains("exact solver on 2 instances: 2 proved"), "{text}");
    assert_eq!(rows.len(), 4);
    for r in &rows {
        // An independent check of the optimum: no algorithm may beat it.
        let (score, optimum): (f64, f64) = (r[3].parse().unwrap(), r[4].parse().unwrap());
        assert!(score <= optimum + 1e-9, "{r:?}");
        assert_eq!(r[9], "exact", "{r:?}");
        assert_eq!(r[5], r[6], "a proved optimum certifies the gap itself");
    }
    // Both instances' optima equal what `solve --algorithm exact` proves.
    for seed in [4, 5] {
        let (sol, _) = solve_json(&instances.join(format!("r{seed}.json")), &["--algorithm", "exact"]);
        let optimum: f64 = rows.iter().find(|r| r[0] == format!("r{seed}")).unwrap()[4]
            .parse()
            .unwrap();
        assert_eq!(sol["weight"].as_f64().unwrap(), optimum);
    }
}

#[test]
fn quality_rejects_bad_inputs() {
    let dir = scratch("quality-bad");
    let csv = dir.join("q.csv");
    let o = path_str(&csv);
    let missing = dir.join("missing");
    assert_input_error(
        &planner(&["quality", "--instances", path_str(&missing), "--out", o]),
        &["--instances", "not a folder"],
    );
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    assert_input_error(
        &planner(&["quality", "--instances", path_str(&empty), "--out", o]),
        &["no instance files"],
    );
    let bad_op = dir.join("bad-op");
    std::fs::create_dir_all(&bad_op).unwrap();
    std::fs::write(bad_op.join("broken.txt"), "5 x\n1 2\n").unwrap();
    assert_input_error(
        &planner(&["quality", "--instances", path_str(&bad_op), "--out", o]),
        &["broken.txt"],
    );
    let bad_json = dir.join("bad-json");
    std::fs::create_dir_all(&bad_json).unwrap();
    std::fs::write(bad_json.join("broken.json"), "{").unwrap();
    assert_input_error(
        &planner(&["quality", "--instances", path_str(&bad_json), "--out", o]),
        &["broken.json"],
    );
    assert_usage_error(
        &planner(&[
            "quality",
            "--instances",
            path_str(&bad_json),
            "--algorithms",
            "ga",
            "--out",
            o,
        ]),
        &["ga"],
    );
    assert_usage_error(
        &planner(&[
            "quality",
            "--instances",
            path_str(&bad_json),
            "--deadline-ms",
            "0",
            "--out",
            o,
        ]),
        &["--deadline-ms"],
    );
    for bad in ["0", "-1", "soon", "NaN", "1e9"] {
        assert_input_error(
            &planner(&[
                "quality",
                "--instances",
                path_str(&bad_json),
                "--exact-time-limit",
                bad,
                "--out",
                o,
            ]),
            &["--exact-time-limit", bad],
        );
    }
    assert!(!csv.exists(), "no CSV after a failure");
}

#[test]
fn solve_takes_a_deadline() {
    let dir = scratch("deadline");
    let path = write_instance(&dir, "paper.json", &paper_like(8));
    let (sol, _) = solve_json(&path, &["--deadline-ms", "5"]);
    assert_eq!(sol["algorithm"], "auto");
    assert_eq!(sol["feasible"], true, "{sol}");
    assert_usage_error(
        &planner(&["solve", "--instance", path_str(&path), "--deadline-ms", "0"]),
        &["--deadline-ms"],
    );
}

#[test]
fn mission_and_serve_refuse_bad_service_flags_before_starting_anything() {
    for cmd in ["mission", "serve"] {
        for (flag, value, needle) in [
            ("--rt-priority", "100", "--rt-priority 100"),
            ("--rt-priority", "-1", "--rt-priority -1"),
            ("--drift-allowance", "-0.5", "--drift-allowance -0.5"),
            ("--drift-allowance", "NaN", "--drift-allowance NaN"),
            ("--reserve-s", "-1", "--reserve-s -1"),
        ] {
            let out = planner(&[cmd, "--nodes", "6", &format!("{flag}={value}")]);
            assert_input_error(&out, &[needle]);
        }
    }
}

#[test]
fn solve_exact_proves_an_optimum_no_heuristic_beats() {
    let dir = scratch("exact");
    let inst = paper_like(11);
    let path = write_instance(&dir, "paper.json", &inst);
    let doc: Value = serde_json::from_str(&inst.to_json()).unwrap();
    let (sol, text) = solve_json(&path, &["--algorithm", "exact"]);
    assert_figures_match(&doc, &sol);
    assert_eq!(sol["algorithm"], "exact");
    assert_eq!(sol["proved_optimal"], true, "{text}");
    assert_eq!(sol["stop"], "converged");
    assert_eq!(sol["gap"].as_f64(), Some(0.0));
    assert_eq!(sol["bound"], sol["weight"]);
    // The format's fields come first and parse as a solution object.
    Solution::from_json(&text).unwrap();
    for algorithm in ["auto", "pso", "bbo"] {
        let (h, _) = solve_json(&path, &["--algorithm", algorithm, "--iterations", "30"]);
        assert!(
            h["weight"].as_f64().unwrap() <= sol["weight"].as_f64().unwrap(),
            "{algorithm} beats the proved optimum: {h} vs {sol}"
        );
    }
    let out = planner(&["solve", "--instance", path_str(&path), "--algorithm", "exact"]);
    assert_ok(&out);
    let human = stdout(&out);
    assert!(human.contains("optimum    proved"), "{human}");
    assert!(human.contains("gap 0.0000 %"), "{human}");
}

#[test]
fn solve_exact_stopped_early_reports_its_bound_and_gap() {
    let dir = scratch("exact-limit");
    // 40 waypoints: far more than a microsecond of search.
    let path = write_instance(&dir, "big.json", &random_instance(40, 0.45, 31_000.0, 2));
    let (sol, text) = solve_json(&path, &["--algorithm", "exact", "--time-limit", "0.000001"]);
    assert_eq!(sol["proved_optimal"], false, "{text}");
    assert_eq!(sol["stop"], "deadline");
    assert_eq!(sol["feasible"], true);
    let (w, b, g) = (
        sol["weight"].as_f64().unwrap(),
        sol["bound"].as_f64().unwrap(),
        sol["gap"].as_f64().unwrap(),
    );
    assert!(b >= w, "{text}");
    assert!((g - (b - w) / w).abs() < 1e-12, "{text}");
    let out = planner(&[
        "solve",
        "--instance",
        path_str(&path),
        "--algorithm",
        "exact",
        "--time-limit",
        "0.000001",
    ]);
    assert_ok(&out);
    assert!(stdout(&out).contains("NOT proved"), "{}", stdout(&out));
}

#[test]
fn bad_input_time_limit() {
    let dir = scratch("time-limit");
    let path = write_instance(&dir, "ok.json", &paper_like(3));
    let p = path_str(&path);
    for bad in ["0", "-2", "abc", "NaN", "inf", "1e30", ""] {
        let out = planner(&["solve", "--instance", p, "--algorithm", "exact", "--time-limit", bad]);
        assert_input_error(&out, &["--time-limit", "seconds > 0"]);
    }
    for algorithm in ["auto", "pso", "bbo"] {
        let out = planner(&["solve", "--instance", p, "--algorithm", algorithm, "--time-limit", "1"]);
        assert_input_error(&out, &["--time-limit 1", "only --algorithm exact"]);
    }
    let out = planner(&["solve", "--instance", p, "--algorithm", "exact", "--deadline-ms", "5"]);
    assert_input_error(&out, &["--deadline-ms 5", "--time-limit"]);
    let out = planner(&["solve", "--instance", p, "--algorithm", "exact", "--iterations", "5"]);
    assert_input_error(&out, &["--iterations 5", "--time-limit"]);
}

#[test]
fn fault_and_soak_options_out_of_range_are_one_line_errors() {
    let dir = scratch("soak-args");
    let out = path_str(&dir).to_string();
    assert_input_error(&planner(&["soak", "--missions", "0", "--out", &out]), &["--missions 0"]);
    assert_input_error(
        &planner(&["soak", "--missions", "1", "--time-scale", "0", "--out", &out]),
        &["--time-scale 0"],
    );
    assert_input_error(
        &planner(&["mission", "--stall-timeout-ms", "1", "--out", &out]),
        &["--stall-timeout-ms 1"],
    );
    assert_usage_error(
        &planner(&["mission", "--faults", "2", "--lockstep"]),
        &["--faults", "--lockstep"],
    );
    assert_usage_error(
        &planner(&["soak", "--missions", "1", "--faults", "--lockstep", "--out", &out]),
        &["--lockstep"],
    );
    assert_usage_error(&planner(&["mission", "--faults", "many"]), &["--faults"]);
}

#[test]
fn montecarlo_includes_auto_next_to_pso_and_bbo() {
    let dir = scratch("montecarlo-auto");
    let out_dir = dir.join("out");
    let out = planner(&[
        "montecarlo",
        "--runs",
        "2",
        "--nodes",
        "12",
        "--algorithms",
        "pso,bbo,auto",
        "--threads",
        "1",
        "--out",
        path_str(&out_dir),
    ]);
    assert_ok(&out);
    assert!(stdout(&out).contains("auto"), "{}", stdout(&out));
    let csv = std::fs::read_to_string(out_dir.join("runs.csv")).unwrap();
    let algorithms: Vec<&str> = csv.lines().skip(1).map(|l| l.split(',').nth(1).unwrap()).collect();
    assert_eq!(algorithms, ["pso", "bbo", "auto", "pso", "bbo", "auto"]);
    for row in csv.lines().skip(1) {
        let cols: Vec<&str> = row.split(',').collect();
        assert_eq!(cols[10], "true", "infeasible plan: {row}");
        assert_eq!(cols[15], "true", "infeasible re-plan: {row}");
    }
}

#[test]
fn montecarlo_knobs_change_one_thing_each_and_bad_values_are_refused() {
    let dir = scratch("montecarlo-knobs");
    let run = |name: &str, extra: &[&str]| {
        let out_dir = dir.join(name);
        let mut args = vec![
            "montecarlo",
            "--runs",
            "2",
            "--nodes",
            "12",
            "--threads",
            "1",
            "--iterations",
            "5",
        ];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--out", path_str(&out_dir)]);
        let out = planner(&args);
        (out, out_dir)
    };
    let rows = |d: &Path| -> Vec<String> {
        std::fs::read_to_string(d.join("runs.csv"))
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| {
                let mut cols: Vec<&str> = l.split(',').collect();
                cols.remove(4);
                cols.join(",")
            })
            .collect()
    };
    let (base, base_dir) = run("base", &[]);
    assert_ok(&base);
    let (free, free_dir) = run(
        "free",
        &[
            "--pso-walls",
            "free",
            "--pso-velocity-clamp",
            "none",
            "--pso-particles",
            "30",
        ],
    );
    assert_ok(&free);
    let text = stdout(&free);
    assert!(
        text.contains("pso 30 particles x 5 iterations, velocity clamp inf, walls Free"),
        "{text}"
    );
    let (b, f) = (rows(&base_dir), rows(&free_dir));
    // Only PSO's rows move; BBO's are the same solves.
    assert_ne!(b[0], f[0]);
    assert_eq!(b[1], f[1]);
    let (thin, _) = run(
        "thin",
        &[
            "--edge-density",
            "0.6",
            "--objective",
            "paper-cost",
            "--phi1",
            "0.0001",
            "--bbo-generations",
            "3",
            "--budget-s",
            "20000",
        ],
    );
    assert_ok(&thin);
    let text = stdout(&thin);
    for needle in [
        "paper_cost (phi1 0.0001, phi2 1)",
        "budget 20000 s",
        "edge density 0.6",
        "x 3 generations",
    ] {
        assert!(text.contains(needle), "{needle} missing from\n{text}");
    }
    let bad = dir.join("bad");
    let o = path_str(&bad);
    assert_usage_error(
        &planner(&["montecarlo", "--edge-density", "0", "--out", o]),
        &["--edge-density"],
    );
    assert_usage_error(
        &planner(&["montecarlo", "--pso-velocity-clamp", "0", "--out", o]),
        &["--pso-velocity-clamp"],
    );
    assert_usage_error(
        &planner(&["montecarlo", "--pso-walls", "bounce", "--out", o]),
        &["bounce"],
    );
    assert_usage_error(
        &planner(&["montecarlo", "--bbo-mutation", "2", "--out", o]),
        &["--bbo-mutation"],
    );
    assert_usage_error(
        &planner(&["montecarlo", "--bbo-elites", "50", "--out", o]),
        &["--bbo-elites 50"],
    );
}

#[test]
fn quality_certifies_a_gap_bound_when_the_exact_search_is_cut() {
    let dir = scratch("quality-unproved");
    let instances = dir.join("instances");
    std::fs::create_dir_all(&instances).unwrap();
    write_instance(&instances, "big.json", &random_instance(40, 0.45, 31_000.0, 2));
    let csv = dir.join("q.csv");
    let (text, rows) = run_quality(
        path_str(&instances),
        &[
            "--deadline-ms",
            "2",
            "--algorithms",
            "bbo",
            "--exact-time-limit",
            "0.000001",
        ],
        &csv,
    );
    assert!(text.contains("0 proved, 1 not proved"), "{text}");
    let row = &rows[0];
    assert_eq!(row[9], "exact_unproved");
    let (gap, bound): (f64, f64) = (row[5].parse().unwrap(), row[6].parse().unwrap());
    assert!(
        gap >= 0.0 && bound > gap,
        "the bound's gap must exceed the best route's: {row:?}"
    );
}

#[test]
fn bench_latency_refuses_a_bad_pause_before_starting_anything() {
    for value in ["-1", "NaN", "20000"] {
        let out = planner(&["bench-latency", "--triggers", "1", &format!("--pause-ms={value}")]);
        assert_input_error(&out, &[&format!("--pause-ms {value}")]);
    }
}

#[test]
fn bench_latency_refuses_a_bad_receiver_priority_before_starting_anything() {
    for value in ["-1", "100"] {
        let out = planner(&[
            "bench-latency",
            "--triggers",
            "1",
            &format!("--receiver-rt-priority={value}"),
        ]);
        assert_input_error(&out, &[&format!("--receiver-rt-priority {value}"), "between 0 and 99"]);
    }
}

#[test]
fn scaling_reports_every_column_per_instance_and_draws_them() {
    let dir = scratch("scaling");
    let csv = dir.join("s.csv");
    let svg = dir.join("s.svg");
    let files = format!("{DATA}/oplib/gen1/eil51-gen1-50.oplib,{DATA}/oplib/gen2/kroA200-gen2-50.oplib");
    let out = planner(&[
        "scaling",
        "--instances",
        &files,
        "--exact-time-limit",
        "0.5",
        "--repeats",
        "2",
        "--deadline-ms",
        "5,10",
        "--out",
        path_str(&csv),
        "--plot",
        path_str(&svg),
    ]);
    assert_ok(&out);
    let table = std::fs::read_to_string(&csv).unwrap();
    let mut lines = table.lines();
    assert_eq!(
        lines.next(),
        Some(
            "instance,nodes,class_nodes,edges,decode_ns,pso_ms,auto_5ms_score,auto_5ms_gap,auto_10ms_score,\
             auto_10ms_gap,reference,reference_source,exact_proved,exact_s,exact_gap,snapshot_bytes"
        )
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2, "{table}");
    // Sorted by size; each in the smallest class that holds it.
    assert_eq!(&rows[0][..4], &["eil51-gen1-50", "52", "64", "1326"]);
    assert_eq!(&rows[1][..3], &["kroA200-gen2-50", "201", "256"]);
    let oplib_best =
        BestKnown::parse(&std::fs::read_to_string(format!("{DATA}/oplib/best_known.csv")).unwrap()).unwrap();
    for r in &rows {
        let reference: f64 = r[10].parse().unwrap();
        // kroA200 has no entry in the test data: its reference is the best route these runs found.
        match oplib_best.get(r[0]) {
            Some(entry) => assert_eq!((reference, r[11]), (entry.score, "best_known"), "{r:?}"),
            None => assert!(r[11] == "best_found" || r[11] == "exact", "{r:?}"),
        }
        for k in [6, 8] {
            let score: f64 = r[k].parse().unwrap();
            let gap: f64 = r[k + 1].parse().unwrap();
            assert!(score <= reference, "{r:?}");
            assert!((gap - 100.0 * (reference - score) / reference).abs() < 1e-3, "{r:?}");
        }
        assert!(
            r[4].parse::<f64>().unwrap() > 0.0 && r[5].parse::<f64>().unwrap() > 0.0,
            "{r:?}"
        );
    }
    // The snapshot message: its head (512 waypoint slots of 32 B and 112 B
    // of scalars) and 32 B per edge, so it grows with the network.
    for r in &rows {
        let edges: usize = r[3].parse().unwrap();
        assert_eq!(r[15].parse::<usize>().unwrap(), 112 + 32 * 512 + 32 * edges, "{r:?}");
    }
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(
        text.contains("<svg") && text.contains("auto at 10 ms"),
        "{}",
        &text[..text.len().min(300)]
    );
}

#[test]
fn bad_input_scaling_names_the_missing_instance() {
    let dir = scratch("scaling-bad");
    let missing = dir.join("nothing-here.json");
    assert_input_error(
        &planner(&[
            "scaling",
            "--instances",
            path_str(&missing),
            "--out",
            path_str(&dir.join("s.csv")),
        ]),
        &["--instances", "nothing-here.json", "no such file"],
    );
}
