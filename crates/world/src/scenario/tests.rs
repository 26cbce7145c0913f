//! Tests of the world model on synthetic charts (the real embedded chart is
//! exercised once the chart layer lands).

use std::cell::Cell;

use super::synthetic::{GridMap, IslandMap, Rect};
use super::*;
use crate::truncnorm::TruncatedNormal;
use auv_core::instance::Objective;

/// 5 km × 10 km of water with three islands: enough land that many pairs
/// are blocked and many are not.
fn islands() -> IslandMap {
    let r = |x0, y0, x1, y1| Rect { x0, y0, x1, y1 };
    IslandMap::new(
        5000.0,
        10_000.0,
        vec![
            r(1000.0, 2000.0, 4000.0, 2600.0),
            r(500.0, 5000.0, 2000.0, 6500.0),
            r(3000.0, 7000.0, 4500.0, 7400.0),
        ],
    )
}

fn world(seed: u64) -> World {
    World::generate(&ScenarioConfig::default(), seed, &islands()).unwrap()
}

/// Dense sampling along the 2-D segment: an independent reference for edges.
fn sampled_segment(map: &impl WaterMap, p: Vec3, q: Vec3) -> bool {
    let samples = 20_000;
    (0..=samples).all(|k| {
        let t = k as f64 / samples as f64;
        map.is_water(p.x + t * (q.x - p.x), p.y + t * (q.y - p.y))
    })
}

/// Every invariant of the module contract that can be checked on one state.
fn assert_invariants(w: &World, map: &impl WaterMap) {
    let cfg = w.config();
    assert_eq!(w.n(), cfg.nodes);
    for (i, p) in w.positions().iter().enumerate() {
        assert!(map.is_water(p.x, p.y), "node {i} on land: {p:?}");
        assert!((0.0..=w.width_m()).contains(&p.x) && (0.0..=w.height_m()).contains(&p.y));
        assert!((0.0..=cfg.depth_max_m).contains(&p.z), "node {i} depth {}", p.z);
        let (nom, b) = (w.nominal_positions()[i], w.bounds()[i]);
        if w.is_dynamic(i) {
            for (v, nv, bv) in [(p.x, nom.x, b.x), (p.y, nom.y, b.y), (p.z, nom.z, b.z)] {
                assert!(
                    (v - nv).abs() <= bv * (1.0 + 1e-12) + 1e-9,
                    "node {i} outside its bound"
                );
            }
        } else {
            assert_eq!(*p, nom, "static node {i} moved");
            assert_eq!(b, Vec3::default());
        }
        assert_eq!(w.check_position(i, *p, map), Ok(()));
    }
    assert!(!w.is_dynamic(w.start()) && !w.is_dynamic(w.goal()));
    for a in 0..w.n() {
        for b in a + 1..w.n() {
            let (p, q) = (w.positions()[a], w.positions()[b]);
            let direct = map.segment_over_water((p.x, p.y), (q.x, q.y));
            assert_eq!(w.has_edge(a, b), direct, "edge cache wrong for {a}-{b}");
            assert_eq!(w.has_edge(b, a), direct);
        }
    }
}

#[test]
fn generated_world_satisfies_the_contract() {
    let map = islands();
    let w = world(42);
    assert_invariants(&w, &map);
    let expected: Vec<usize> = (1..=10).collect();
    assert_eq!(w.dynamic_nodes().iter().collect::<Vec<_>>(), expected);
    assert!(w.bounds()[1..=10].iter().all(|b| b.x > 0.0 && b.y > 0.0 && b.z > 0.0));
    let pairs = 40 * 39 / 2;
    let e = w.edge_count();
    assert!(
        e > pairs / 10 && e < pairs * 9 / 10,
        "{e} edges of {pairs}: the test map should block some"
    );
}

#[test]
fn edges_match_a_brute_force_segment_check_before_and_after_redraws() {
    let map = islands();
    let mut w = world(7);
    let check = |w: &World| {
        for a in 0..w.n() {
            for b in a + 1..w.n() {
                let (p, q) = (w.positions()[a], w.positions()[b]);
                assert_eq!(w.has_edge(a, b), sampled_segment(&map, p, q), "{a}-{b}");
            }
        }
    };
    check(&w);
    for k in 0..5 {
        let mut rng = w.redraw_rng(k);
        w.redraw_dynamic(&mut rng, &map);
        check(&w);
    }
}

#[test]
fn redraws_keep_every_invariant_and_report_edge_changes() {
    let map = islands();
    let mut w = world(3);
    let mut rng = w.redraw_rng(0);
    let (mut added, mut removed) = (0, 0);
    for _ in 0..50 {
        let before = w.clone();
        let r = w.redraw_dynamic(&mut rng, &map);
        assert_invariants(&w, &map);
        assert!((r.moved - w.dynamic_nodes()).is_empty(), "only dynamic nodes move");
        assert_eq!(r.moved.len(), 10, "every dynamic node moves");
        assert_eq!(r.fallbacks, 0);
        let (mut plus, mut minus) = (0, 0);
        for a in 0..w.n() {
            for b in a + 1..w.n() {
                match (before.has_edge(a, b), w.has_edge(a, b)) {
                    (false, true) => plus += 1,
                    (true, false) => minus += 1,
                    _ => {}
                }
            }
        }
        assert_eq!((r.edges_added, r.edges_removed), (plus, minus));
        added += plus;
        removed += minus;
    }
    assert!(added > 0 && removed > 0, "redraws should change the network");
}

#[test]
fn same_seed_same_instance_and_different_seeds_differ() {
    let a = world(11).snapshot("s").to_json();
    let b = world(11).snapshot("s").to_json();
    let c = world(12).snapshot("s").to_json();
    assert_eq!(a, b);
    assert_ne!(a, c);
    // Redraw sequences are deterministic too.
    let map = islands();
    let run = || {
        let mut w = world(11);
        for k in 0..3 {
            w.redraw_dynamic(&mut w.redraw_rng(k), &map);
        }
        w.snapshot("s").to_json()
    };
    assert_eq!(run(), run());
    assert_ne!(run(), a);
}

#[test]
fn tasks_are_per_pair_and_survive_redraws() {
    let map = islands();
    let mut w = world(5);
    let original: Vec<Option<Task>> = (0..40)
        .flat_map(|a| (0..40).map(move |b| (a, b)))
        .map(|(a, b)| w.task(a, b))
        .collect();
    let mut gone: Vec<(usize, usize)> = Vec::new();
    let mut reappeared = 0;
    for k in 0..40 {
        let before = w.clone();
        w.redraw_dynamic(&mut w.redraw_rng(k), &map);
        for a in 0..40 {
            for b in a + 1..40 {
                if before.has_edge(a, b) && !w.has_edge(a, b) {
                    gone.push((a, b));
                }
                if !before.has_edge(a, b) && w.has_edge(a, b) && gone.contains(&(a, b)) {
                    reappeared += 1;
                }
            }
        }
        let now: Vec<Option<Task>> = (0..40)
            .flat_map(|a| (0..40).map(move |b| (a, b)))
            .map(|(a, b)| w.task(a, b))
            .collect();
        assert_eq!(now, original);
        for e in &w.snapshot("s").edges {
            let t = w.task(e.a, e.b).unwrap();
            assert_eq!((e.priority, e.risk, e.task_time_s), (t.priority, t.risk, t.task_time_s));
        }
    }
    assert!(
        reappeared > 0,
        "some edge should vanish and come back within 40 redraws"
    );
    // Tasks are symmetric, in range, and absent for a = b or out of range.
    assert_eq!(w.task(3, 9), w.task(9, 3));
    assert_eq!(w.task(4, 4), None);
    assert_eq!(w.task(0, 40), None);
    for a in 0..40 {
        for b in a + 1..40 {
            let t = w.task(a, b).unwrap();
            assert!((1.0..10.0).contains(&t.priority));
            assert!((0.1..1.0).contains(&t.risk));
            assert!((120.0..900.0).contains(&t.task_time_s));
        }
    }
}

#[test]
fn streams_are_independent_of_the_dynamic_count_and_prefix_stable_in_n() {
    let map = islands();
    let base = world(9);
    let fewer = World::generate(
        &ScenarioConfig {
            dynamic: 4,
            ..ScenarioConfig::default()
        },
        9,
        &map,
    )
    .unwrap();
    assert_eq!(base.nominal_positions(), fewer.nominal_positions());
    assert_eq!(&base.bounds()[..5], &fewer.bounds()[..5]);
    assert_eq!(&base.positions()[..5], &fewer.positions()[..5]);
    for a in 0..40 {
        for b in a + 1..40 {
            assert_eq!(base.task(a, b), fewer.task(a, b));
        }
    }
    let more = World::generate(
        &ScenarioConfig {
            nodes: 60,
            ..ScenarioConfig::default()
        },
        9,
        &map,
    )
    .unwrap();
    assert_eq!(&base.nominal_positions()[..39], &more.nominal_positions()[..39]);
    for a in 0..40 {
        for b in a + 1..40 {
            assert_eq!(base.task(a, b), more.task(a, b));
        }
    }
}

#[test]
fn dynamic_offsets_follow_the_truncated_normal_of_their_bound() {
    // Open water, so no land rejection distorts the law: the x offsets of
    // node 1 over many redraws must be N(0, σ²) truncated to its bound
    // (and to the chart), checked by KS against the closed-form CDF.
    let map = IslandMap::new(50_000.0, 50_000.0, vec![]);
    let mut w = World::generate(&ScenarioConfig::default(), 1, &map).unwrap();
    let nom = w.nominal_positions()[1];
    let b = w.bounds()[1];
    let (lo, hi) = bound_interval(nom.x, b.x, w.width_m());
    let law = TruncatedNormal::new(nom.x, 150.0, lo, hi).unwrap();
    let mut rng = w.redraw_rng(0);
    let runs = 20_000;
    let mut xs: Vec<f64> = (0..runs)
        .map(|_| {
            w.redraw_dynamic(&mut rng, &map);
            w.positions()[1].x
        })
        .collect();
    xs.sort_by(f64::total_cmp);
    let d = xs
        .iter()
        .enumerate()
        .map(|(i, &x)| {
            let f = law.cdf(x);
            (f - i as f64 / runs as f64)
                .abs()
                .max(((i + 1) as f64 / runs as f64 - f).abs())
        })
        .fold(0.0, f64::max);
    assert!(d < 2.0 / (runs as f64).sqrt(), "KS {d}");
    // A wrong σ (the bound's 300 m instead of 150 m) would be caught.
    let wrong = TruncatedNormal::new(nom.x, 300.0, lo, hi).unwrap();
    let d_wrong = xs
        .iter()
        .enumerate()
        .map(|(i, &x)| (wrong.cdf(x) - i as f64 / runs as f64).abs())
        .fold(0.0, f64::max);
    assert!(b.x > 100.0, "premise: a bound wide enough for σ to matter ({})", b.x);
    assert!(d_wrong > 2.0 / (runs as f64).sqrt(), "KS of the wrong law {d_wrong}");
}

/// Water everywhere while `open` is set, otherwise only at the listed points:
/// makes every redraw miss so the fallback path runs.
struct PinholeMap {
    open: Cell<bool>,
    holes: Vec<(f64, f64)>,
}

impl WaterMap for PinholeMap {
    fn width_m(&self) -> f64 {
        5000.0
    }
    fn height_m(&self) -> f64 {
        5000.0
    }
    fn is_water(&self, x: f64, y: f64) -> bool {
        let inside = (0.0..5000.0).contains(&x) && (0.0..5000.0).contains(&y);
        inside && (self.open.get() || self.holes.contains(&(x, y)))
    }
    fn segment_over_water(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        self.is_water(a.0, a.1) && self.is_water(b.0, b.1)
    }
}

#[test]
fn a_dynamic_waypoint_with_no_water_in_reach_falls_back_to_its_nominal_position() {
    let mut map = PinholeMap {
        open: Cell::new(true),
        holes: vec![],
    };
    let cfg = ScenarioConfig {
        redraw_attempts: 20,
        ..ScenarioConfig::default()
    };
    let mut w = World::generate(&cfg, 2, &map).unwrap();
    map.holes = w.nominal_positions().iter().map(|p| (p.x, p.y)).collect();
    map.open.set(false);
    let r = w.redraw_dynamic(&mut w.redraw_rng(0), &map);
    assert_eq!(r.fallbacks, 10);
    for i in 1..=10 {
        let (p, nom) = (w.positions()[i], w.nominal_positions()[i]);
        assert_eq!((p.x, p.y), (nom.x, nom.y));
    }
    assert_invariants(&w, &map);
}

#[test]
fn apply_positions_mirrors_another_process_and_refuses_bad_reports() {
    let map = islands();
    // The sensor's world moves; the planner's copy applies the report.
    let mut sensor = world(21);
    let mut planner = world(21);
    for k in 0..5 {
        sensor.redraw_dynamic(&mut sensor.redraw_rng(k), &map);
        let report = planner.apply_positions(sensor.positions(), &map).unwrap();
        assert_eq!(planner.snapshot("s"), sensor.snapshot("s"));
        assert!(report.moved.len() <= 10);
    }
    let good: Vec<Vec3> = planner.positions().to_vec();
    let before = planner.snapshot("s");
    let nom = planner.nominal_positions()[2];
    let b = planner.bounds()[2];
    type Edit = Box<dyn Fn(&mut Vec<Vec3>)>;
    let edits: Vec<(Edit, PositionError)> = vec![
        (
            Box::new(|p| {
                p.pop();
            }),
            PositionError::WrongCount { expected: 40, got: 39 },
        ),
        (Box::new(|p| p[3].y = f64::NAN), PositionError::NonFinite { node: 3 }),
        (Box::new(|p| p[0].x += 1.0), PositionError::StaticMoved { node: 0 }),
        (Box::new(|p| p[39].z += 1e-6), PositionError::StaticMoved { node: 39 }),
        (
            Box::new(move |p| p[2].x = nom.x + b.x + 1.0),
            PositionError::OutsideBound { node: 2, axis: 'x' },
        ),
        (
            Box::new(move |p| p[2].z = nom.z - b.z - 1.0),
            PositionError::OutsideBound { node: 2, axis: 'z' },
        ),
    ];
    for (edit, expected) in edits {
        let mut bad = good.clone();
        edit(&mut bad);
        let err = planner.apply_positions(&bad, &map).unwrap_err();
        assert_eq!(err, expected);
        assert_eq!(planner.snapshot("s"), before, "a refused report changes nothing");
    }
    // On land: pretend the whole chart is an island.
    let land = IslandMap::new(
        5000.0,
        10_000.0,
        vec![Rect {
            x0: 0.0,
            y0: 0.0,
            x1: 5000.0,
            y1: 10_000.0,
        }],
    );
    let mut moved = good.clone();
    moved[1] = sensor.nominal_positions()[1];
    assert_eq!(
        planner.apply_positions(&moved, &land),
        Err(PositionError::OnLand { node: 1 })
    );
}

#[test]
fn snapshot_is_a_valid_instance_and_round_trips() {
    let w = world(42);
    let inst = w.snapshot("benoits-cove-seed-42-t0");
    let back = Instance::from_json(&inst.to_json()).unwrap();
    assert_eq!(back, inst);
    assert_eq!((inst.start, inst.goal), (0, 39));
    assert_eq!(inst.speed_mps, 1.5);
    assert_eq!(inst.time_available_s, 31_000.0);
    assert_eq!(inst.objective, Objective::MaxWeight);
    assert_eq!(inst.edges.len(), w.edge_count());
    assert!(inst.nodes.iter().all(|n| n.prize == 0.0));
    let paper = World::generate(
        &ScenarioConfig {
            objective: Objective::PaperCost { phi1: 0.5, phi2: 2.0 },
            ..ScenarioConfig::default()
        },
        42,
        &islands(),
    )
    .unwrap();
    let inst = paper.snapshot("p");
    assert_eq!(Instance::from_json(&inst.to_json()).unwrap(), inst);
}

/// Every table of two problems, bit for bit.
fn assert_same_problem<const W: usize>(p: &Problem<W>, q: &Problem<W>) {
    assert_eq!((p.n(), p.start(), p.goal()), (q.n(), q.start(), q.goal()));
    assert_eq!(p.budget_s().to_bits(), q.budget_s().to_bits());
    assert_eq!(p.excluded(), q.excluded());
    for a in 0..p.n() {
        assert_eq!(p.neighbours(a), q.neighbours(a));
        assert_eq!(p.to_goal_s(a).to_bits(), q.to_goal_s(a).to_bits());
        for b in 0..p.n() {
            assert_eq!(p.time_s(a, b).to_bits(), q.time_s(a, b).to_bits());
            assert_eq!(p.distance_m(a, b).to_bits(), q.distance_m(a, b).to_bits());
            assert_eq!(p.gain(a, b).to_bits(), q.gain(a, b).to_bits());
            assert_eq!(p.risk_ratio(a, b).to_bits(), q.risk_ratio(a, b).to_bits());
        }
    }
}

#[test]
fn fill_problem_equals_loading_the_snapshot() {
    let map = islands();
    let mut w = world(13);
    let (mut direct, mut via): (Problem, Problem) = (Problem::new(), Problem::new());
    let mut cases = 0;
    for k in 0..4 {
        w.redraw_dynamic(&mut w.redraw_rng(k), &map);
        let inst = w.snapshot("s");
        let mut excluded = NodeSet::EMPTY;
        excluded.insert(5);
        excluded.insert(17);
        for (start, ex, budget) in [(0, NodeSet::EMPTY, 31_000.0), (3, excluded, 12_000.0)] {
            let a = w.fill_problem(&mut direct, start, ex, budget);
            let b = via.load_instance(&inst, start, ex, budget);
            assert_eq!(a, b);
            if a.is_ok() {
                assert_same_problem(&direct, &via);
                cases += 1;
            }
        }
    }
    assert!(cases >= 4, "most of these networks should join start and goal");
    // Errors pass through: an excluded endpoint.
    let mut ex = NodeSet::EMPTY;
    ex.insert(39);
    assert_eq!(
        w.fill_problem(&mut direct, 0, ex, 100.0),
        Err(ProblemError::EndpointExcluded(39))
    );
}

#[test]
fn a_world_beyond_the_service_class_fills_the_classes_that_hold_it() {
    let map = islands();
    let cfg = ScenarioConfig {
        nodes: 300,
        dynamic: 60,
        ..ScenarioConfig::default()
    };
    let mut w = World::generate(&cfg, 5, &map).unwrap();
    w.redraw_dynamic(&mut w.redraw_rng(1), &map);
    assert_eq!(w.n(), 300);
    assert_eq!(w.dynamic_nodes().len(), 60);
    assert!(w.dynamic_nodes().contains(60) && !w.dynamic_nodes().contains(61));
    let inst = w.snapshot("big");
    assert_eq!(inst.edges.len(), w.edge_count());
    // Ids above 256 have edges too (the rows of the largest class are used).
    assert!(inst.edges.iter().any(|e| e.a > 256 || e.b > 256));
    let mut excluded = NodeSet::<8>::EMPTY;
    excluded.insert(270);
    let (mut direct, mut via) = (Problem::<8>::new(), Problem::<8>::new());
    w.fill_problem(&mut direct, 0, excluded, 31_000.0).unwrap();
    via.load_instance(&inst, 0, excluded, 31_000.0).unwrap();
    assert_same_problem(&direct, &via);
    // A class too small for the world is the problem's own error.
    let mut small: Problem = Problem::new();
    assert_eq!(
        w.fill_problem(&mut small, 0, NodeSet::EMPTY, 31_000.0),
        Err(ProblemError::TooManyNodes { n: 300, capacity: 128 })
    );
}

#[test]
fn generation_errors_are_clear() {
    let map = islands();
    let cfg = |edit: fn(&mut ScenarioConfig)| {
        let mut c = ScenarioConfig::default();
        edit(&mut c);
        c
    };
    let err = World::generate(&cfg(|c| c.nodes = 513), 1, &map).unwrap_err();
    assert_eq!(err, ScenarioError::Config(ConfigError::TooManyNodes(513)));
    assert!(err.to_string().contains("largest capacity class of 512"), "{err}");
    World::generate(&cfg(|c| c.nodes = 512), 1, &map).unwrap();
    World::generate(
        &cfg(|c| {
            c.nodes = 2;
            c.dynamic = 0
        }),
        1,
        &map,
    )
    .unwrap();
    assert!(matches!(
        World::generate(&cfg(|c| c.dynamic = 39), 1, &map),
        Err(ScenarioError::Config(ConfigError::TooManyDynamic {
            dynamic: 39,
            max: 38
        }))
    ));
    let dry = IslandMap::new(
        1000.0,
        1000.0,
        vec![Rect {
            x0: 0.0,
            y0: 0.0,
            x1: 1000.0,
            y1: 1000.0,
        }],
    );
    let err = World::generate(&cfg(|c| c.position_attempts = 1000), 1, &dry).unwrap_err();
    assert_eq!(
        err,
        ScenarioError::NotEnoughWater {
            node: 0,
            attempts: 1000
        }
    );
    assert!(err.to_string().contains("too little water"), "{err}");
    let flat = IslandMap::new(0.0, 1000.0, vec![]);
    assert!(matches!(
        World::generate(&ScenarioConfig::default(), 1, &flat),
        Err(ScenarioError::BadChartExtent { .. })
    ));
}

#[test]
fn fingerprint_tells_scenarios_apart() {
    let map = islands();
    let base = world(1).fingerprint();
    assert_eq!(base, world(1).fingerprint());
    assert_ne!(base, world(2).fingerprint());
    let edits: Vec<fn(&mut ScenarioConfig)> = vec![
        |c| c.nodes = 41,
        |c| c.dynamic = 9,
        |c| c.sigma_m = 151.0,
        |c| c.bound_sigma_m = 301.0,
        |c| c.depth_max_m = 999.0,
        |c| c.speed_mps = 1.6,
        |c| c.time_available_s = 30_000.0,
        |c| c.priority.hi = 11.0,
        |c| c.risk.lo = 0.2,
        |c| c.task_time_s.hi = 901.0,
        |c| c.objective = Objective::PaperCost { phi1: 1.0, phi2: 1.0 },
        |c| c.chart = ChartSource::Embedded("bay-of-islands".into()),
        |c| {
            c.chart = ChartSource::Png {
                path: "x.png".into(),
                metres_per_pixel: 10.0,
            }
        },
        |c| c.k = 4,
        |c| c.sensor_period_s = 30.0,
        |c| c.position_attempts = 99,
        |c| c.redraw_attempts = 99,
    ];
    let mut seen = std::collections::HashSet::new();
    seen.insert(base);
    for edit in edits {
        let mut c = ScenarioConfig::default();
        edit(&mut c);
        let f = World::generate(&c, 1, &map).unwrap().fingerprint();
        assert!(seen.insert(f), "{c:?} collides");
    }
    // Same config and seed on another chart.
    let other = IslandMap::new(5000.0, 10_000.0, vec![]);
    assert_ne!(base, scenario_fingerprint(&ScenarioConfig::default(), 1, &other));
    // Redraws do not change the scenario's identity.
    let mut w = world(1);
    w.redraw_dynamic(&mut w.redraw_rng(0), &map);
    assert_eq!(w.fingerprint(), base);
}

#[test]
fn works_on_a_raster_chart_with_a_coastline() {
    let map = GridMap::cove();
    let mut w = World::generate(&ScenarioConfig::default(), 8, &map).unwrap();
    assert_invariants(&w, &map);
    for k in 0..10 {
        w.redraw_dynamic(&mut w.redraw_rng(k), &map);
        assert_invariants(&w, &map);
    }
    let mut p: Problem = Problem::new();
    w.fill_problem(&mut p, 0, NodeSet::EMPTY, 31_000.0).unwrap();
}

/// Not a test of speed (no timing assertions): prints generation and redraw
/// times for the report. `cargo test --release -p planner --lib
/// scenario::tests::measure -- --ignored --nocapture`.
#[test]
#[ignore]
fn measure_generation_and_redraw_times() {
    use std::time::Instant;
    let map = GridMap::cove();
    for nodes in [40, 128] {
        let cfg = ScenarioConfig {
            nodes,
            dynamic: 10,
            ..ScenarioConfig::default()
        };
        let reps = 50;
        let t = Instant::now();
        for s in 0..reps {
            std::hint::black_box(World::generate(&cfg, s, &map).unwrap());
        }
        let gen_us = t.elapsed().as_secs_f64() * 1e6 / reps as f64;
        let mut w = World::generate(&cfg, 1, &map).unwrap();
        let mut rng = w.redraw_rng(0);
        let reps = 2000;
        let t = Instant::now();
        for _ in 0..reps {
            std::hint::black_box(w.redraw_dynamic(&mut rng, &map));
        }
        let redraw_us = t.elapsed().as_secs_f64() * 1e6 / reps as f64;
        let mut p: Problem = Problem::new();
        let t = Instant::now();
        for _ in 0..reps {
            // The goal may be cut off in some redraw; the time counts anyway.
            let _ = std::hint::black_box(w.fill_problem(&mut p, 0, NodeSet::EMPTY, 31_000.0));
        }
        let fill_us = t.elapsed().as_secs_f64() * 1e6 / reps as f64;
        let t = Instant::now();
        for _ in 0..reps {
            std::hint::black_box(scenario_fingerprint(&cfg, 1, &map));
        }
        let fp_us = t.elapsed().as_secs_f64() * 1e6 / reps as f64;
        println!(
            "n = {nodes}: generate {gen_us:.0} µs, redraw (10 dynamic) {redraw_us:.1} µs, \
             fill_problem {fill_us:.1} µs, fingerprint {fp_us:.0} µs, {} edges",
            w.edge_count()
        );
    }
}
