//! Fuzz-style tests of every parser of outside input: the instance format,
//! the scenario configuration, solutions, the orienteering benchmark files
//! and their known-optimum table, and chart PNGs. Each gets random bytes
//! and random mutations of a valid document (truncated, characters flipped,
//! fields deleted or retyped, numbers made huge, tiny, negative or
//! non-finite, junk spliced in) and must answer `Ok` or `Err`, never panic;
//! whatever it accepts must satisfy the format's own rules. Case counts keep
//! each test to a few seconds.

use auv_core::fixtures::{line_instance, random_instance};
use auv_core::instance::Instance;
use auv_core::oplib::{BestKnown, parse_op};
use auv_core::route::RouteStats;
use auv_core::solution::Solution;
use auv_world::chart::Chart;
use auv_world::chart::mask::WaterMask;
use auv_world::scenario::ScenarioConfig;
use proptest::prelude::*;
use serde_json::Value;

/// Characters that matter to JSON and number parsers.
const SPICY: &[char] = &[
    '{', '}', '[', ']', '"', ',', ':', '0', '1', '9', '-', '+', '.', 'e', 'E', 'n', 't', 'f', '\\', ' ', '\n', 'é',
    '\u{0}',
];

/// Replacement values for a JSON node: extremes, wrong types, non-finite spellings.
fn replacement(k: usize) -> Value {
    let texts = [
        "1e308",
        "-1e308",
        "1e-320",
        "0",
        "-0.0",
        "-1",
        "18446744073709551616",
        "-9223372036854775809",
        "4294967296",
        "300",
        "1.5",
        "null",
        "true",
        "\"NaN\"",
        "\"inf\"",
        "\"\"",
        "[]",
        "{}",
        "[1,2]",
        "{\"kind\":\"paper_cost\"}",
    ];
    serde_json::from_str(texts[k % texts.len()]).unwrap_or(Value::Null)
}

/// Number of nodes of a JSON tree (pre-order).
fn size(v: &Value) -> usize {
    1 + match v {
        Value::Array(a) => a.iter().map(size).sum(),
        Value::Object(o) => o.values().map(size).sum(),
        _ => 0,
    }
}

/// Applies `op` to the `at`-th node (pre-order) of `v`: 0 replaces it, 1
/// deletes it from its parent, 2 duplicates it in its parent.
fn mutate(v: &mut Value, at: &mut usize, op: u8, k: usize) -> bool {
    if *at == 0 {
        *v = replacement(k);
        return true;
    }
    *at -= 1;
    match v {
        Value::Array(a) => {
            for i in 0..a.len() {
                if *at == 0 && op > 0 {
                    if op == 1 {
                        a.remove(i);
                    } else {
                        let dup = a[i].clone();
                        a.insert(i, dup);
                    }
                    return true;
                }
                if mutate(&mut a[i], at, op, k) {
                    return true;
                }
            }
        }
        Value::Object(o) => {
            let keys: Vec<String> = o.keys().cloned().collect();
            for key in keys {
                if *at == 0 && op == 1 {
                    o.remove(&key);
                    return true;
                }
                if let Some(child) = o.get_mut(&key)
                    && mutate(child, at, op, k)
                {
                    return true;
                }
            }
        }
        _ => {}
    }
    false
}

/// One mutation of `valid`, chosen by the numbers.
fn mutated(valid: &str, kind: u8, pos: usize, k: usize, junk: &str) -> String {
    let chars: Vec<char> = valid.chars().collect();
    let p = pos % (chars.len() + 1);
    match kind % 6 {
        0 => chars[..p].iter().collect(),
        1 => {
            let mut c = chars.clone();
            if p < c.len() {
                c[p] = SPICY[k % SPICY.len()];
            }
            c.into_iter().collect()
        }
        2 => {
            let mut c = chars.clone();
            c.splice(p..p, junk.chars());
            c.into_iter().collect()
        }
        3 => {
            let mut c = chars.clone();
            let end = (p + 1 + k % 16).min(c.len());
            c.drain(p.min(end)..end);
            c.into_iter().collect()
        }
        op => match serde_json::from_str::<Value>(valid) {
            Ok(mut v) => {
                let mut at = pos % size(&v);
                mutate(&mut v, &mut at, op - 4 + (k % 2) as u8, k);
                v.to_string()
            }
            Err(_) => valid.to_string(),
        },
    }
}

fn small_instance_json(seed: u64) -> String {
    random_instance(3 + (seed % 6) as usize, 0.5, 5_000.0, seed).to_json()
}

/// What every accepted instance must satisfy (the format's rules).
fn check_instance(inst: &Instance) {
    let n = inst.nodes.len();
    assert!(n >= 1 && inst.start < n && inst.goal < n);
    assert!(inst.speed_mps.is_finite() && inst.speed_mps > 0.0);
    assert!(inst.time_available_s.is_finite() && inst.time_available_s > 0.0);
    for e in &inst.edges {
        assert!(e.a < n && e.b < n && e.a != e.b);
        assert!(e.risk > 0.0 && e.priority >= 0.0 && e.task_time_s >= 0.0);
    }
    // Accepted instances can be written and read back as they were.
    let back = Instance::from_json(&inst.to_json()).expect("an accepted instance round-trips");
    assert_eq!(&back, inst);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn instance_parser_survives_random_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        if let Ok(inst) = Instance::from_json(&String::from_utf8_lossy(&bytes)) {
            check_instance(&inst);
        }
    }

    #[test]
    fn instance_parser_survives_mutated_documents(
        seed in 0u64..50, kind in 0u8..6, pos in 0usize..100_000, k in 0usize..1000, junk in "[ -~]{0,12}",
    ) {
        let text = mutated(&small_instance_json(seed), kind, pos, k, &junk);
        if let Ok(inst) = Instance::from_json(&text) {
            check_instance(&inst);
        }
    }

    #[test]
    fn scenario_config_parser_survives_random_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        if let Ok(cfg) = ScenarioConfig::from_json(&String::from_utf8_lossy(&bytes)) {
            prop_assert!(cfg.validate().is_ok());
        }
    }

    #[test]
    fn scenario_config_parser_survives_mutated_documents(
        kind in 0u8..6, pos in 0usize..100_000, k in 0usize..1000, junk in "[ -~]{0,12}",
    ) {
        let text = mutated(&ScenarioConfig::default().to_json(), kind, pos, k, &junk);
        if let Ok(cfg) = ScenarioConfig::from_json(&text) {
            // Accepted means valid, and it survives a round trip.
            prop_assert!(cfg.validate().is_ok());
            let back = ScenarioConfig::from_json(&cfg.to_json());
            prop_assert_eq!(back.ok(), Some(cfg));
        }
    }

    #[test]
    fn solution_reader_and_verifier_survive_mutations(
        kind in 0u8..6, pos in 0usize..100_000, k in 0usize..1000, junk in "[ -~]{0,12}",
    ) {
        let inst = line_instance();
        let route = vec![0, 1, 2, 3];
        let s = RouteStats::from_instance(&inst, &route).unwrap();
        let good = Solution {
            route, feasible: s.feasible, weight: s.weight, time_s: s.time_s, distance_m: s.distance_m,
            cost: s.cost, tasks: s.tasks, solve_ms: 1.0, solve_thread_cpu_ms: 0.5, iterations: 3, algorithm: "pso".into(), seed: 1,
            stop: "budget".into(), objective: "max_weight".into(), instance: inst.name.clone(),
        };
        prop_assert!(good.verify(&inst).is_ok());
        let text = mutated(&good.to_json(), kind, pos, k, &junk);
        if let Ok(sol) = Solution::from_json(&text) {
            // Any route ids at all: verification answers, never panics.
            let _ = sol.verify(&inst);
        }
    }

    #[test]
    fn benchmark_file_parser_survives_mutations(
        kind in 0u8..4, pos in 0usize..10_000, k in 0usize..1000, junk in "[ -~\n]{0,12}",
        bytes in proptest::collection::vec(any::<u8>(), 0..128),
    ) {
        let valid = "5 1\n0 0 0\n1 1 0\n18 15.9 10\n3.5 -4 10\n";
        for text in [mutated(valid, kind, pos, k, &junk), String::from_utf8_lossy(&bytes).into_owned()] {
            if let Ok(op) = parse_op(&text) {
                prop_assert!(op.tmax.is_finite() && op.tmax > 0.0);
                prop_assert!(op.nodes.len() >= 2);
                prop_assert!(op.nodes.iter().all(|n| n.x.is_finite() && n.y.is_finite() && n.score.is_finite()));
                let inst = op.to_instance("fuzz");
                prop_assert_eq!(inst.nodes.len(), op.nodes.len());
            }
        }
    }

    #[test]
    fn known_optimum_table_parser_survives_mutations(
        kind in 0u8..4, pos in 0usize..10_000, k in 0usize..1000, junk in "[ -~\n]{0,12}",
        bytes in proptest::collection::vec(any::<u8>(), 0..128),
    ) {
        let valid = "set,instance,n_nodes,tmax,best_known_score,proved_optimal,source\n\
                     tsiligirides_1,tsiligirides_1_tmax_5,32,5,10,yes,Chao 1996\n\
                     chao_64,set_64_1_15,64,15,96,no,somebody, with a comma\n";
        prop_assert!(BestKnown::parse(valid).is_ok());
        for text in [mutated(valid, kind, pos, k, &junk), String::from_utf8_lossy(&bytes).into_owned()] {
            let _ = BestKnown::parse(&text);
        }
    }
}

/// A small valid PNG: a 24 × 16 water/land pattern, grey or RGB.
fn small_png(colour: bool) -> Vec<u8> {
    let (w, h) = (24u32, 16u32);
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(if colour {
            png::ColorType::Rgb
        } else {
            png::ColorType::Grayscale
        });
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().unwrap();
        let px = |x: u32, y: u32| if (x / 6 + y / 4).is_multiple_of(3) { 20u8 } else { 230u8 };
        let data: Vec<u8> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .flat_map(|(x, y)| {
                let v = px(x, y);
                if colour { vec![v / 4, v / 2, v] } else { vec![v] }
            })
            .collect();
        writer.write_image_data(&data).unwrap();
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn chart_and_mask_readers_survive_corrupt_pngs(
        colour in any::<bool>(), flips in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..6),
        cut in any::<usize>(), truncate in any::<bool>(), mpp in prop_oneof![Just(1.0), Just(0.0), Just(-3.0), Just(f64::NAN), 0.01f64..100.0],
    ) {
        let mut bytes = small_png(colour);
        for (at, v) in flips {
            let i = at % bytes.len();
            bytes[i] ^= v;
        }
        if truncate {
            bytes.truncate(cut % (bytes.len() + 1));
        }
        let _ = Chart::from_png_bytes(&bytes, mpp);
        let _ = WaterMask::from_mask_png(&bytes, mpp, "fuzz");
    }
}

#[test]
fn the_seed_documents_are_valid() {
    // The mutations start from valid documents (else they test nothing).
    for seed in 0..10 {
        check_instance(&Instance::from_json(&small_instance_json(seed)).unwrap());
    }
    ScenarioConfig::from_json(&ScenarioConfig::default().to_json()).unwrap();
    parse_op("5 1\n0 0 0\n1 1 0\n18 15.9 10\n3.5 -4 10\n").unwrap();
    assert!(Chart::from_png_bytes(&small_png(true), 1.0).is_ok());
    assert!(WaterMask::from_mask_png(&small_png(false), 1.0, "seed").is_ok());
}

#[test]
fn the_mutations_reach_both_acceptance_and_every_kind_of_rejection_path() {
    // A fuzzer whose inputs all fail at the first byte tests little: the
    // mutations must leave some documents valid and break others.
    let valid = small_instance_json(7);
    let (mut ok, mut err) = (0, 0);
    for kind in 0..6u8 {
        for pos in (0..valid.len()).step_by(37) {
            match Instance::from_json(&mutated(&valid, kind, pos, pos / 7, "0")) {
                Ok(_) => ok += 1,
                Err(_) => err += 1,
            }
        }
    }
    assert!(ok > 10 && err > 10, "{ok} accepted, {err} rejected");
}
