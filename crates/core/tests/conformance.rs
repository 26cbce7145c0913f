//! One generic conformance suite for every anytime solver (house style §10),
//! instantiated below for each algorithm, plus pinned regressions that keep
//! the paper-faithful PSO and BBO reproducible.
//!
//! Each property is a generic function over `S: Solver` taking a factory;
//! `conformance!` turns them into one `#[test]` each per solver, so a new
//! solver (the `auto` planner, say) joins with one line.

use std::collections::HashSet;
use std::time::Instant;

use auv_core::fixtures::random_instance;
use auv_core::instance::{Edge, Instance, Objective};

use auv_core::rng::PlannerRng;
use auv_core::route::{RouteEval, RouteStats};
use auv_core::solver::auto::AutoSettings;
use auv_core::solver::bbo::BboSettings;
use auv_core::solver::pso::PsoSettings;
use auv_core::solver::{Algorithm, Budget, Solver, StopReason, run};

// The default capacity class unless a test names another.
type Problem = auv_core::problem::Problem;
type Route = auv_core::route::Route;
type Pso = auv_core::solver::pso::Pso;
type Bbo = auv_core::solver::bbo::Bbo;
type Auto = auv_core::solver::auto::Auto;

/// The paper's model on a random network, with a chain added so every
/// instance is connected (tiny or sparse ones may not be otherwise).
fn instance(n: usize, density: f64, budget_s: f64, seed: u64, objective: Objective) -> Instance {
    let mut inst = random_instance(n, density, budget_s, seed);
    for a in 0..n - 1 {
        if inst.edge_between(a, a + 1).is_none() {
            inst.edges.push(Edge {
                a,
                b: a + 1,
                priority: 5.0,
                risk: 0.5,
                task_time_s: 300.0,
            });
        }
    }
    inst.objective = objective;
    inst
}

const PAPER_COST: Objective = Objective::PaperCost {
    phi1: 0.001,
    phi2: 10.0,
};

fn problem(inst: &Instance) -> Problem {
    Problem::from_instance(inst).expect("fixture instances are valid and connected")
}

/// The solver's best, checked against the instance by the independent
/// checker (`RouteStats`) and against the problem's own evaluation.
fn checked_best<S: Solver>(s: &S, inst: &Instance, p: &Problem) -> (Route, RouteEval) {
    let (route, e) = s.best();
    let stats = RouteStats::from_instance(inst, &route.to_vec()).expect("the best route is a route of the instance");
    assert_eq!(p.evaluate(route), Some(*e), "reported figures are the route's");
    assert_eq!(stats.time_s, e.time_s);
    assert_eq!(stats.weight, e.weight);
    assert_eq!(stats.feasible, e.feasible);
    assert_eq!(stats.cost, e.cost(inst.objective, inst.time_available_s));
    (*route, *e)
}

fn valid_routes_on_random_instances<S: Solver>(make: impl Fn() -> S) {
    let mut s = make();
    let mut rng = PlannerRng::new(11);
    for (n, density) in [
        (2, 1.0),
        (3, 0.5),
        (10, 0.5),
        (40, 0.3),
        (40, 0.5),
        (80, 0.4),
        (128, 0.3),
    ] {
        for (seed, budget) in [(1, 31_000.0), (2, 9_000.0)] {
            for objective in [Objective::MaxWeight, PAPER_COST] {
                let inst = instance(n, density, budget, seed, objective);
                let p = problem(&inst);
                run(&mut s, &p, &mut rng, None, Budget::iterations(5));
                let (_, e) = checked_best(&s, &inst, &p);
                let quickest_fits = p.to_goal_s(p.start()) <= p.budget_limit_s();
                assert_eq!(e.feasible, quickest_fits, "n={n} seed={seed} budget={budget}");
            }
        }
    }
}

fn deterministic_per_seed<S: Solver>(make: impl Fn() -> S) {
    let inst = instance(40, 0.4, 31_000.0, 3, Objective::MaxWeight);
    let p = problem(&inst);
    let solve = |s: &mut S, seed: u64| {
        run(s, &p, &mut PlannerRng::new(seed), None, Budget::iterations(8));
        let (r, e) = s.best();
        (r.to_vec(), *e)
    };
    // Fresh solvers agree; a reused solver forgets its previous problem.
    let (mut a, mut b) = (make(), make());
    let first = solve(&mut a, 7);
    solve(&mut b, 99);
    assert_eq!(solve(&mut b, 7), first);
    assert_eq!(solve(&mut a, 7), first);
    // Different seeds usually lead elsewhere.
    let routes: HashSet<Vec<usize>> = (0..6).map(|seed| solve(&mut a, seed).0).collect();
    assert!(routes.len() >= 2, "six seeds gave one route");
}

fn best_so_far_only_improves<S: Solver>(make: impl Fn() -> S) {
    let mut s = make();
    for objective in [Objective::MaxWeight, PAPER_COST] {
        let inst = instance(40, 0.4, 31_000.0, 4, objective);
        let p = problem(&inst);
        let mut rng = PlannerRng::new(5);
        s.start(&p, &mut rng, None);
        let (mut route, mut e) = checked_best(&s, &inst, &p);
        let mut changes = 0;
        for _ in 0..25 {
            s.step(&p, &mut rng);
            let (r, f) = checked_best(&s, &inst, &p);
            if r.ids() != route.ids() || f != e {
                assert!(p.better(&f, &e), "the best changed without improving");
                changes += 1;
            }
            (route, e) = (r, f);
        }
        assert!(changes > 0, "25 generations never improved on the start");
    }
}

fn deadline_in_the_past_stops_at_once<S: Solver>(make: impl Fn() -> S) {
    let mut s = make();
    let inst = instance(40, 0.4, 31_000.0, 6, Objective::MaxWeight);
    let p = problem(&inst);
    let budget = Budget {
        iterations: 150,
        deadline: Some(Instant::now()),
    };
    let out = run(&mut s, &p, &mut PlannerRng::new(1), None, budget);
    assert_eq!(out.stop, StopReason::Deadline);
    assert_eq!(out.iterations, 0);
    checked_best(&s, &inst, &p);
}

fn each_objective_is_the_one_optimised<S: Solver>(make: impl Fn() -> S) {
    let mut s = make();
    let (mut weight_gain, mut cost_gain) = (0.0, 0.0);
    for seed in 0..4 {
        let mut results = Vec::new();
        for objective in [Objective::MaxWeight, PAPER_COST] {
            let inst = instance(40, 0.4, 31_000.0, 20 + seed, objective);
            let p = problem(&inst);
            run(&mut s, &p, &mut PlannerRng::new(seed), None, Budget::iterations(10));
            results.push(checked_best(&s, &inst, &p).1);
        }
        let (w, c) = (results[0], results[1]);
        weight_gain += w.weight - c.weight;
        cost_gain += w.cost(PAPER_COST, 31_000.0) - c.cost(PAPER_COST, 31_000.0);
    }
    // Over four networks, solving for weight finds more weight and solving
    // for the paper's cost finds a lower cost.
    assert!(weight_gain > 0.0, "max_weight did not find more weight ({weight_gain})");
    assert!(cost_gain > 0.0, "paper_cost did not find a lower cost ({cost_gain})");
}

fn warm_start_is_never_worse<S: Solver>(make: impl Fn() -> S) {
    let mut s = make();
    for objective in [Objective::MaxWeight, PAPER_COST] {
        for seed in 0..3 {
            let inst = instance(40, 0.4, 31_000.0, 30 + seed, objective);
            let p = problem(&inst);
            run(&mut s, &p, &mut PlannerRng::new(1), None, Budget::iterations(10));
            let (warm, warm_e) = checked_best(&s, &inst, &p);
            // Another seed, one generation, or no generation at all.
            for budget in [
                Budget::iterations(1),
                Budget {
                    iterations: 10,
                    deadline: Some(Instant::now()),
                },
            ] {
                run(&mut s, &p, &mut PlannerRng::new(2 + seed), Some(&warm), budget);
                let (_, e) = checked_best(&s, &inst, &p);
                assert!(!p.better(&warm_e, &e), "warm start returned worse than its warm route");
            }
        }
    }
    // A stale warm route (from another network) is only a hint: still a
    // valid route comes back.
    let other = instance(40, 0.4, 31_000.0, 40, Objective::MaxWeight);
    run(
        &mut s,
        &problem(&other),
        &mut PlannerRng::new(1),
        None,
        Budget::iterations(2),
    );
    let stale = *s.best().0;
    let inst = instance(40, 0.2, 31_000.0, 41, Objective::MaxWeight);
    let p = problem(&inst);
    run(&mut s, &p, &mut PlannerRng::new(1), Some(&stale), Budget::iterations(2));
    checked_best(&s, &inst, &p);
}

/// Plain Dijkstra on the instance: the quickest start → goal path.
fn quickest_path(inst: &Instance) -> Vec<usize> {
    let n = inst.nodes.len();
    let time = |a: usize, b: usize| {
        inst.edge_between(a, b)
            .map(|e| inst.distance(a, b) / inst.speed_mps + e.task_time_s)
    };
    let mut dist = vec![f64::INFINITY; n];
    let mut prev = vec![usize::MAX; n];
    let mut done = vec![false; n];
    dist[inst.start] = 0.0;
    while let Some(u) = (0..n)
        .filter(|&v| !done[v] && dist[v].is_finite())
        .min_by(|&a, &b| dist[a].total_cmp(&dist[b]))
    {
        done[u] = true;
        for v in 0..n {
            if let Some(t) = time(u, v)
                && !done[v]
                && dist[u] + t < dist[v]
            {
                dist[v] = dist[u] + t;
                prev[v] = u;
            }
        }
    }
    let mut path = vec![inst.goal];
    while *path.last().unwrap() != inst.start {
        path.push(prev[*path.last().unwrap()]);
    }
    path.reverse();
    path
}

fn infeasible_instance_yields_the_quickest_path<S: Solver>(make: impl Fn() -> S) {
    let mut s = make();
    for seed in 0..3 {
        let mut inst = instance(40, 0.4, 31_000.0, 50 + seed, Objective::MaxWeight);
        let quick = problem(&inst).to_goal_s(inst.start);
        inst.time_available_s = 0.5 * quick;
        let p = problem(&inst);
        run(&mut s, &p, &mut PlannerRng::new(seed), None, Budget::iterations(5));
        let (route, e) = checked_best(&s, &inst, &p);
        assert!(!e.feasible);
        assert_eq!(route.to_vec(), quickest_path(&inst));
    }
}

macro_rules! conformance {
    ($name:ident, $make:expr) => {
        mod $name {
            use super::*;

            #[test]
            fn valid_routes_on_random_instances() {
                super::valid_routes_on_random_instances($make);
            }
            #[test]
            fn deterministic_per_seed() {
                super::deterministic_per_seed($make);
            }
            #[test]
            fn best_so_far_only_improves() {
                super::best_so_far_only_improves($make);
            }
            #[test]
            fn deadline_in_the_past_stops_at_once() {
                super::deadline_in_the_past_stops_at_once($make);
            }
            #[test]
            fn each_objective_is_the_one_optimised() {
                super::each_objective_is_the_one_optimised($make);
            }
            #[test]
            fn warm_start_is_never_worse() {
                super::warm_start_is_never_worse($make);
            }
            #[test]
            fn infeasible_instance_yields_the_quickest_path() {
                super::infeasible_instance_yields_the_quickest_path($make);
            }
        }
    };
}

// The command line's constructors, with the paper's settings.
conformance!(pso, || Algorithm::Pso.build(150));
conformance!(bbo, || Algorithm::Bbo.build(150));
conformance!(auto, || Algorithm::Auto.build(150));
// A one-particle swarm with many kicks: the ILS path carries the search.
conformance!(auto_tiny_swarm, || Auto::new(AutoSettings {
    particles: 1,
    kicks: 9,
    ..AutoSettings::default()
}));
// An odd, tiny swarm: exercises the unpaired decode and small populations.
conformance!(pso_odd_swarm, || Pso::new(PsoSettings {
    particles: 7,
    ..PsoSettings::paper()
}));
conformance!(bbo_small, || Bbo::new(BboSettings {
    habitats: 5,
    elites: 1,
    ..BboSettings::paper()
}));

/// The fixture of the pinned regressions: a 40-node network of the paper's
/// model (density 0.4, 31 000 s), solved with seed 42 at the paper's full
/// budget.
fn pinned(algorithm: Algorithm) -> (Vec<usize>, RouteEval, Instance) {
    let inst = random_instance(40, 0.4, 31_000.0, 2016);
    let p = problem(&inst);
    let mut s = algorithm.build(algorithm.paper_iterations());
    let out = run(
        &mut s,
        &p,
        &mut PlannerRng::new(42),
        None,
        Budget::iterations(algorithm.paper_iterations()),
    );
    assert_eq!((out.stop, out.iterations), (StopReason::Budget, 150));
    let (route, e) = checked_best(&s, &inst, &p);
    (route.to_vec(), e, inst)
}

/// The paper-faithful PSO must stay reproducible per seed: if this
/// fails, a change altered what `--algorithm pso --seed 42` returns. Only
/// update the pin for a deliberate change to the paper-faithful PSO, and say
/// so in the commit.
#[test]
fn pso_paper_settings_pinned_route() {
    let (route, e, _) = pinned(Algorithm::Pso);
    assert_eq!(route, [0, 6, 13, 17, 35, 15, 37, 1, 9, 38, 26, 34, 23, 39]);
    assert!(e.feasible);
    assert_eq!(e.weight.to_bits(), 415.34113623957495f64.to_bits());
}

/// As above, for the paper-faithful BBO.
#[test]
fn bbo_paper_settings_pinned_route() {
    let (route, e, _) = pinned(Algorithm::Bbo);
    assert_eq!(route, [0, 11, 1, 34, 6, 37, 15, 35, 17, 13, 23, 39]);
    assert!(e.feasible);
    assert_eq!(e.weight.to_bits(), 391.3262799143507f64.to_bits());
}

/// The default planner at 100 steps against the paper-faithful PSO at its
/// full 150 iterations, on twelve fixed networks and seeds (quality only; no
/// timing): at least as good on average, and on at least three in four
/// (PSO wins a few: over 40 networks it won 9 before the decoder's f32
/// arithmetic and 4 after, so a claim on every network would hold only for
/// lucky seeds).
#[test]
fn auto_is_at_least_as_good_as_paper_pso() {
    let (mut lost, mut pso_sum, mut auto_sum) = (0, 0.0, 0.0);
    for seed in 0..12 {
        let inst = random_instance(40, 0.4, 31_000.0, 500 + seed);
        let p = problem(&inst);
        let mut pso = Algorithm::Pso.build(150);
        run(&mut pso, &p, &mut PlannerRng::new(seed), None, Budget::iterations(150));
        let (_, pe) = checked_best(&pso, &inst, &p);
        let mut auto = Algorithm::Auto.build(100);
        run(&mut auto, &p, &mut PlannerRng::new(seed), None, Budget::iterations(100));
        let (_, ae) = checked_best(&auto, &inst, &p);
        assert!(pe.feasible && ae.feasible, "seed {seed}");
        if p.better(&pe, &ae) {
            lost += 1;
        }
        pso_sum += pe.weight;
        auto_sum += ae.weight;
    }
    assert!(lost <= 3, "pso beat auto on {lost} of 12 networks");
    assert!(
        auto_sum >= pso_sum,
        "mean weight: auto {} < pso {}",
        auto_sum / 12.0,
        pso_sum / 12.0
    );
}
