use super::hull::{Item, Seg, hull_segments, sort_items};
use super::*;
use crate::fixtures::random_instance;
use crate::instance::{Edge, Instance, Node};
use crate::route::RouteStats;

// The default capacity class unless a test names another.
type Problem = crate::problem::Problem;
type NodeSet = crate::problem::NodeSet;
type Route = crate::route::Route;
type ExactSettings = crate::solver::exact::ExactSettings;

/// Best route by plain enumeration of every simple start→goal path.
fn brute_force(p: &Problem) -> Option<(Route, RouteEval)> {
    fn walk(p: &Problem, route: &mut Route, used: NodeSet, best: &mut Option<(Route, RouteEval)>) {
        let u = route.last().unwrap_or(p.start());
        if u == p.goal() {
            let e = p.evaluate(route).expect("enumeration builds valid routes");
            if e.feasible && best.as_ref().is_none_or(|(_, b)| p.better(&e, b)) {
                *best = Some((*route, e));
            }
            return;
        }
        for v in p.neighbours(u).iter() {
            if !used.contains(v) {
                let mut used = used;
                used.insert(v);
                route.push(v);
                walk(p, route, used, best);
                route.truncate(route.len() - 1);
            }
        }
    }
    let mut route = Route::new();
    route.push(p.start());
    let mut used = NodeSet::EMPTY;
    used.insert(p.start());
    let mut best = None;
    walk(p, &mut route, used, &mut best);
    best
}

/// Objective value of an evaluated route: weight or cost.
fn value(p: &Problem, e: &RouteEval) -> f64 {
    match p.objective() {
        Objective::MaxWeight => e.weight,
        o => e.cost(o, p.budget_s()),
    }
}

/// Small random instances with binding budgets, some with node prizes, in
/// each objective.
fn small_instances() -> Vec<Instance> {
    let mut out = Vec::new();
    let objectives = [
        Objective::MaxWeight,
        Objective::PaperCost { phi1: 0.01, phi2: 1.0 },
        Objective::MaxWeight,
        Objective::PaperCost { phi1: 1.0, phi2: 0.0 },
        Objective::MaxWeight,
        Objective::PaperCost { phi1: 0.0, phi2: 1.0 },
    ];
    let mut seed = 0;
    for n in (2..=9).chain(7..=9) {
        for &density in &[0.4, 0.7, 1.0] {
            for &budget in &[9_000.0, 16_000.0, 30_000.0] {
                seed += 1;
                let mut inst = random_instance(n, density, budget, seed);
                if seed % 3 == 0 {
                    // Node prizes, integral and not, on some nodes.
                    for (i, node) in inst.nodes.iter_mut().enumerate() {
                        node.prize = if i % 2 == 0 {
                            (i * 7 % 11) as f64
                        } else {
                            0.5 * i as f64
                        };
                    }
                }
                inst.objective = objectives[seed as usize % objectives.len()];
                out.push(inst);
            }
        }
    }
    out
}

#[test]
fn matches_brute_force_on_small_random_graphs_in_both_objectives() {
    // [paper_cost, max_weight] instances compared, and how many optima
    // leave nodes out (the budget or the objective binds).
    let mut checked = [0usize; 2];
    let mut partial = 0;
    for inst in small_instances() {
        let Ok(p) = Problem::from_instance(&inst) else {
            continue; // goal not connected to the start in this draw
        };
        let brute = brute_force(&p);
        // Every combination of the optional parts must find the same optimum.
        for (tune_split, beam, break_ties) in [
            (true, true, true),
            (false, false, true),
            (true, false, true),
            (true, true, false),
        ] {
            let settings = ExactSettings {
                tune_split,
                beam,
                break_ties,
                ..ExactSettings::default()
            };
            let out = solve_exact(&p, &settings);
            match (brute, out) {
                (None, Err(ExactError::NoFeasibleRoute { .. })) => {}
                (Some((br, be)), Ok(o)) => {
                    assert!(o.proved_optimal, "{}: not proved", inst.name);
                    let (so, sb) = (p.score(&o.eval), p.score(&be));
                    assert!(
                        if break_ties {
                            !p.better(&be, &o.eval) && !p.better(&o.eval, &be)
                        } else {
                            (so - sb).abs() <= 1e-9 * (1.0 + sb.abs())
                        },
                        "{}: exact {:?} {:?} vs brute force {:?} {:?}",
                        inst.name,
                        o.route,
                        o.eval,
                        br,
                        be
                    );
                    assert_eq!(o.gap, 0.0);
                    assert_eq!(o.bound, value(&p, &o.eval));
                    // The reported figures are the checker's figures.
                    let stats = RouteStats::from_instance(&inst, &o.route.to_vec()).unwrap();
                    assert!(stats.feasible);
                    assert_eq!(stats.weight, o.eval.weight);
                    checked[matches!(p.objective(), Objective::MaxWeight) as usize] += 1;
                    partial += usize::from(br.len() < p.n());
                }
                (b, o) => panic!("{}: brute force {b:?}, exact {o:?}", inst.name),
            }
        }
    }
    // Both objectives were really exercised.
    assert!(
        checked[0] >= 90 && checked[1] >= 90 && partial >= 90,
        "{checked:?} {partial}"
    );
}

#[test]
fn an_early_stop_reports_a_valid_bound_on_small_graphs() {
    for inst in small_instances() {
        let Ok(p) = Problem::from_instance(&inst) else { continue };
        let Some((_, best)) = brute_force(&p) else { continue };
        let opt = value(&p, &best);
        for limit in 1..4 {
            let o = solve_exact(
                &p,
                &ExactSettings {
                    node_limit: Some(limit),
                    ..ExactSettings::default()
                },
            )
            .unwrap();
            let v = value(&p, &o.eval);
            assert!(o.eval.feasible);
            match p.objective() {
                Objective::MaxWeight => assert!(o.bound >= opt && opt >= v, "{}: {o:?} opt {opt}", inst.name),
                _ => assert!(
                    o.bound <= opt + 1e-9 && opt <= v + 1e-9,
                    "{}: {o:?} opt {opt}",
                    inst.name
                ),
            }
            assert!(o.gap >= 0.0);
        }
    }
}

#[test]
fn respects_excluded_nodes_and_a_moved_start() {
    // The re-planning case: start elsewhere, some nodes already visited.
    for seed in 1..=20 {
        let inst = random_instance(9, 0.6, 14_000.0, 100 + seed);
        let mut excluded = NodeSet::EMPTY;
        excluded.insert(1);
        excluded.insert(4);
        let mut p = Problem::new();
        if p.load_instance(&inst, 2, excluded, 12_000.0).is_err() {
            continue;
        }
        let brute = brute_force(&p);
        match (brute, solve_exact(&p, &ExactSettings::default())) {
            (None, Err(ExactError::NoFeasibleRoute { .. })) => {}
            (Some((_, be)), Ok(o)) => {
                assert!(o.route.iter().all(|v| !excluded.contains(v)));
                assert_eq!(o.route.get(0), 2);
                assert!(!p.better(&be, &o.eval) && !p.better(&o.eval, &be), "seed {seed}");
            }
            (b, o) => panic!("seed {seed}: brute force {b:?}, exact {o:?}"),
        }
    }
}

/// The classic OP file format (`shared/benchmarks/op/README.md`): `Tmax P`,
/// then `x y score` per node; node 0 the start, node 1 the end. Mapped onto
/// the interchange format as that document says.
fn read_op(path: &std::path::Path) -> Instance {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let tmax: f64 = lines
        .next()
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let nodes: Vec<Node> = lines
        .map(|l| {
            let f: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            Node {
                x: f[0],
                y: f[1],
                z: 0.0,
                prize: f[2],
            }
        })
        .collect();
    let n = nodes.len();
    let mut edges = Vec::new();
    for a in 0..n {
        for b in a + 1..n {
            edges.push(Edge {
                a,
                b,
                priority: 0.0,
                risk: 1.0,
                task_time_s: 0.0,
            });
        }
    }
    Instance {
        name: path.file_name().unwrap().to_string_lossy().into_owned(),
        speed_mps: 1.0,
        time_available_s: tmax,
        start: 0,
        goal: 1,
        nodes,
        edges,
        objective: Objective::MaxWeight,
    }
}

#[test]
fn proves_the_known_optima_of_small_classic_instances() {
    // `shared/` sits beside the repository (CI) or further up (worktrees).
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .map(|a| a.join("shared/benchmarks/op"))
        .find(|d| d.is_dir())
        .expect("shared/benchmarks/op beside the repository");
    let table = std::fs::read_to_string(dir.join("best_known.csv")).expect("best_known.csv");
    let cases = [
        ("tsiligirides_set1", "tsiligirides_problem_1_budget_25.txt"),
        ("tsiligirides_set1", "tsiligirides_problem_1_budget_30.txt"),
        ("tsiligirides_set2", "tsiligirides_problem_2_budget_15.txt"),
        ("tsiligirides_set2", "tsiligirides_problem_2_budget_25.txt"),
        ("tsiligirides_set2", "tsiligirides_problem_2_budget_30.txt"),
        ("tsiligirides_set3", "tsiligirides_problem_3_budget_020.txt"),
        ("tsiligirides_set3", "tsiligirides_problem_3_budget_025.txt"),
        ("chao_set66_square", "set_66_1_015.txt"),
        // Every node fits: proving the value is immediate, the quickest such
        // route (the time tie-break) would be a travelling-salesman proof.
        ("tsiligirides_set3", "tsiligirides_problem_3_budget_110.txt"),
    ];
    for (set, file) in cases {
        let row = table
            .lines()
            .find(|l| l.starts_with(&format!("{set},{file},")))
            .unwrap_or_else(|| panic!("{file} not in best_known.csv"));
        let best: f64 = row.split(',').nth(4).unwrap().parse().unwrap();
        let inst = read_op(&dir.join(set).join(file));
        let p = Problem::from_instance(&inst).unwrap();
        let settings = ExactSettings {
            break_ties: !file.ends_with("_110.txt"),
            ..ExactSettings::default()
        };
        let o = solve_exact(&p, &settings).unwrap();
        assert!(o.proved_optimal, "{file}");
        assert_eq!(o.eval.weight, best, "{file}: route {:?}", o.route);
        let stats = RouteStats::from_instance(&inst, &o.route.to_vec()).unwrap();
        assert!(stats.feasible && stats.weight == best, "{file}");
    }
}

#[test]
fn a_stopped_40_node_search_reports_a_bound_above_the_optimum() {
    let inst = random_instance(40, 0.6, 31_000.0, 2);
    let p = Problem::from_instance(&inst).unwrap();
    let full = solve_exact(&p, &ExactSettings::default()).unwrap();
    assert!(full.proved_optimal && full.gap == 0.0);
    assert!(full.eval.tasks >= 5, "a paper-like route: {:?}", full.route);
    assert!(full.root_bound >= full.eval.weight);
    // The limits below must really cut the search short.
    assert!(full.nodes_explored > 600, "{}", full.nodes_explored);
    let limited = |node_limit, time_limit| ExactSettings {
        node_limit,
        time_limit,
        ..ExactSettings::default()
    };
    for settings in [
        limited(Some(1), None),
        limited(Some(40), None),
        limited(Some(500), None),
        limited(None, Some(Duration::ZERO)),
    ] {
        let o = solve_exact(&p, &settings).unwrap();
        assert!(!o.proved_optimal, "{settings:?}");
        assert!(o.eval.feasible && p.evaluate(&o.route) == Some(o.eval));
        assert!(o.bound >= full.eval.weight, "{o:?} vs optimum {}", full.eval.weight);
        assert!(full.eval.weight >= o.eval.weight);
        assert!((o.gap - (o.bound - o.eval.weight) / o.eval.weight).abs() < 1e-12);
    }
}

#[test]
fn same_input_same_result() {
    let inst = random_instance(30, 0.5, 31_000.0, 7);
    let p = Problem::from_instance(&inst).unwrap();
    let a = solve_exact(&p, &ExactSettings::default()).unwrap();
    let b = solve_exact(&p, &ExactSettings::default()).unwrap();
    assert_eq!(a.route, b.route);
    assert_eq!(a.nodes_explored, b.nodes_explored);
    assert_eq!(a.bound, b.bound);
}

#[test]
fn unsupported_cases_are_errors() {
    let inst = random_instance(8, 1.0, 31_000.0, 3);
    let p = Problem::from_instance(&inst).unwrap();
    let quick = p.to_goal_s(p.start());
    let mut tight = inst.clone();
    tight.time_available_s = 0.5 * quick;
    let p = Problem::from_instance(&tight).unwrap();
    assert!(matches!(
        solve_exact(&p, &ExactSettings::default()),
        Err(ExactError::NoFeasibleRoute { quickest_s, .. }) if quickest_s == quick
    ));
    let mut bad = inst.clone();
    bad.objective = Objective::PaperCost { phi1: -1.0, phi2: 1.0 };
    let p = Problem::from_instance(&bad).unwrap();
    let err = solve_exact(&p, &ExactSettings::default()).unwrap_err();
    assert!(err.to_string().contains("phi1 = -1"), "{err}");
}

#[test]
fn hull_keeps_only_the_rising_concave_chain() {
    let it = |t: f64, v: f64, a: u16| Item { t, v, a, b: a };
    // (1,1) and (2,3) and (4,4): (2,3) is on the hull, (1,1) is under the
    // chord origin→(2,3); (3,2) gives no more value than (2,3); (5,4) neither.
    let mut items = vec![
        it(1.0, 1.0, 1),
        it(2.0, 3.0, 2),
        it(4.0, 4.0, 3),
        it(3.0, 2.0, 4),
        it(5.0, 4.0, 5),
    ];
    sort_items(&mut items);
    let (mut stack, mut out) = (Vec::new(), Vec::<Seg>::new());
    let named = hull_segments::<2>(&items, it(0.0, 0.0, 0), 9, &mut stack, &mut out);
    let pts: Vec<(f64, f64)> = out.iter().map(|s| (s.dt, s.dv)).collect();
    assert_eq!(pts, vec![(2.0, 3.0), (2.0, 1.0)]);
    assert!(out.iter().all(|s| s.class == 9));
    assert_eq!(named.iter().collect::<Vec<_>>(), vec![0, 2, 3]);
    // A zero-time item with value is an infinitely steep first segment.
    let mut items = vec![it(0.0, 2.0, 1), it(1.0, 3.0, 2)];
    sort_items(&mut items);
    out.clear();
    hull_segments::<2>(&items, it(0.0, 0.0, 0), 0, &mut stack, &mut out);
    assert_eq!(out[0].dt, 0.0);
    assert_eq!(out[0].slope, f64::INFINITY);
    assert_eq!(out.len(), 2);
}

/// Every route one polish move away from `r`, built position by position
/// (the reference the polish's edge deltas must agree with).
fn one_move_away(p: &Problem, r: &Route) -> Vec<Route> {
    let c: Vec<usize> = r.iter().collect();
    let len = c.len();
    let free: Vec<usize> = p.free_nodes(r).iter().collect();
    let mut out: Vec<Vec<usize>> = Vec::new();
    for i in 0..len - 1 {
        for &v in &free {
            let mut x = c.clone();
            x.insert(i + 1, v);
            out.push(x);
        }
    }
    for i in 1..len - 1 {
        for &v in &free {
            let mut x = c.clone();
            x[i] = v;
            out.push(x);
        }
        let mut x = c.clone();
        x.remove(i);
        out.push(x);
        for j in i + 1..len - 1 {
            let mut x = c.clone();
            x[i..=j].reverse();
            out.push(x);
            let mut x = c.clone();
            x.swap(i, j);
            out.push(x);
        }
        for j in 1..len - 1 {
            if j != i {
                let mut x = c.clone();
                let v = x.remove(i);
                x.insert(j, v);
                out.push(x);
            }
        }
    }
    out.iter().filter_map(|x| Route::from_slice(x)).collect()
}

#[test]
fn polish_ends_where_no_single_move_improves_the_route() {
    let mut polished = 0;
    for (k, n) in (4..=24).enumerate() {
        for (density, budget) in [(0.5, 20_000.0), (1.0, 14_000.0), (0.8, 40_000.0)] {
            let seed = 500 + 3 * k as u64;
            let mut inst = random_instance(n, density, budget, seed);
            if k % 2 == 1 {
                for (i, node) in inst.nodes.iter_mut().enumerate() {
                    node.prize = (i * 5 % 7) as f64;
                }
            }
            for objective in [Objective::MaxWeight, Objective::PaperCost { phi1: 0.01, phi2: 1.0 }] {
                inst.objective = objective;
                let Ok(p) = Problem::from_instance(&inst) else { continue };
                let Some(start) = p.quickest_route() else { continue };
                let Some(e0) = p.evaluate(&start).filter(|e| e.feasible) else {
                    continue;
                };
                let (r, e) = polish::polish(&p, start, e0, || false);
                assert_eq!(p.evaluate(&r), Some(e), "figures of the polished route");
                assert!(
                    e.feasible && !p.better(&e0, &e),
                    "{} n={n}: worse than its start",
                    inst.name
                );
                for x in one_move_away(&p, &r) {
                    if let Some(ex) = p.evaluate(&x).filter(|ex| ex.feasible) {
                        let margin = 1e-7 * p.score(&e).abs().max(1.0);
                        assert!(
                            p.score(&ex) <= p.score(&e) + margin,
                            "n={n} {objective:?}: {:?} (score {}) improves on the polished {:?} (score {})",
                            x.to_vec(),
                            p.score(&ex),
                            r.to_vec(),
                            p.score(&e)
                        );
                    }
                }
                polished += usize::from(r != start);
            }
        }
    }
    assert!(
        polished > 40,
        "only {polished} routes changed: the test would not see a wrong delta"
    );
}
