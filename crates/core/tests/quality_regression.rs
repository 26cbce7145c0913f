//! Quality regression of the default planner `auto`, one test per
//! objective, on fixed instances with known optima. Solves run a fixed number
//! of steps (never a deadline: the machine is shared), so each result is a
//! function of the seed and the bounds hold with a margin over what the
//! planner reaches today (noted at each bound).

use auv_core::fixtures::random_instance;
use auv_core::instance::{Instance, Objective};
use auv_core::oplib::BestKnown;

use auv_core::rng::PlannerRng;
use auv_core::route::RouteStats;

use auv_core::solver::exact::solve_exact;
use auv_core::solver::{Budget, Solver, run};
use auv_core::tsplib::parse_oplib;

use auv_core::problem::Problem;
use auv_core::solver::auto::Auto;
type ExactSettings = auv_core::solver::exact::ExactSettings;

const OPLIB: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/oplib");

/// Steps of every solve: about 5-20 ms of `auto` on these sizes.
const STEPS: u32 = 40;

/// Solves `inst` with `auto` (seed 1, [`STEPS`] steps); returns the route's
/// recomputed figures.
fn solve(inst: &Instance) -> RouteStats {
    solve_in::<2>(inst, STEPS)
}

/// [`solve`] in the capacity class of `W` words, for `steps` steps.
fn solve_in<const W: usize>(inst: &Instance, steps: u32) -> RouteStats {
    let p = Problem::<W>::from_instance(inst).expect("a plannable instance");
    let mut s = Auto::<W>::default();
    run(&mut s, &p, &mut PlannerRng::new(1), None, Budget::iterations(steps));
    let (r, _) = s.best();
    RouteStats::from_instance(inst, &r.to_vec()).expect("a route of the instance")
}

#[test]
fn the_256_and_512_node_classes_stay_near_the_published_optima() {
    // (file, proved optimum from the shared best_known.csv, steps, bound on
    // the gap in %). Today: kroA200 14.43 % after 40 steps, rd400 22.26 %
    // after 10 (fewer steps at 401 nodes keep the test quick).
    for (name, optimum, steps, bound) in [
        ("kroA200-gen2-50", 6547.0, 40, 20.0),
        ("rd400-gen2-50", 13652.0, 10, 30.0),
    ] {
        let path = format!("{OPLIB}/gen2/{name}.oplib");
        let inst = parse_oplib(&std::fs::read_to_string(&path).unwrap())
            .unwrap()
            .to_instance(name);
        let stats = match auv_core::capacity::Class::for_nodes(inst.nodes.len()).unwrap() {
            auv_core::capacity::Class::N256 => solve_in::<4>(&inst, steps),
            auv_core::capacity::Class::N512 => solve_in::<8>(&inst, steps),
            other => panic!("{name}: {} nodes fall in {other:?}", inst.nodes.len()),
        };
        assert!(stats.feasible, "{name}");
        assert!(stats.weight <= optimum + 1e-9, "{name}: {} > {optimum}", stats.weight);
        let gap = 100.0 * (optimum - stats.weight) / optimum;
        eprintln!("{name}: {} of {optimum} (gap {gap:.2} %)", stats.weight);
        assert!(gap <= bound, "{name}: gap {gap:.2} % > {bound} %");
    }
}

#[test]
fn max_weight_on_oplib_files_stays_near_the_published_optima() {
    let known = BestKnown::parse(&std::fs::read_to_string(format!("{OPLIB}/best_known.csv")).unwrap()).unwrap();
    let mut gaps = Vec::new();
    for (name, entry) in known.iter() {
        let path = format!("{OPLIB}/{}/{name}.oplib", entry.set);
        let op = parse_oplib(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let stats = solve(&op.to_instance(name));
        assert!(stats.feasible, "{name}");
        // A score above a proved optimum would mean a wrong encoding.
        assert!(
            stats.weight <= entry.score + 1e-9,
            "{name}: {} > {}",
            stats.weight,
            entry.score
        );
        let gap = 100.0 * (entry.score - stats.weight) / entry.score;
        eprintln!("{name}: {} of {} (gap {gap:.2} %)", stats.weight, entry.score);
        gaps.push(gap);
    }
    assert_eq!(gaps.len(), 6);
    let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
    let worst = gaps.iter().copied().fold(0.0, f64::max);
    // Today: mean 2.74 %, worst 11.45 % (gr96-gen2); the old weight-only
    // `auto` reached the same 6 at 2-3 times these steps' cost.
    assert!(mean <= MEAN_BOUND_MW, "mean gap {mean:.2} %");
    assert!(worst <= WORST_BOUND_MW, "worst gap {worst:.2} %");
}

#[test]
fn max_weight_on_a_sparse_chart_network_reaches_the_proved_optimum() {
    // A 60-node Bay of Islands snapshot with a loose budget (the generator's
    // `bi60-mw-loose` training family, seed 1; 653 of 1770 pairs are
    // edges). The optimum, proved by the exact solver in 0.4 s, runs
    // through a cluster the other way round from the route the iterated
    // local search settles on (828.79, 3.6 % below, from 20 ms to 1 s);
    // the beam search's route leads there. Today: the optimum after 80 steps.
    let gap = bay_fixture_gap("bi60-mw-loose-s1.json", 860.089289618572, 80);
    assert!(gap <= 1.0, "gap {gap:.2} %");
}

#[test]
fn max_weight_on_a_sparse_chart_network_leaves_the_local_search_basin() {
    // Seed 204 of the same generator family, never tuned on. Its optimum,
    // proved by the exact solver, runs through a region of about ten nodes
    // that the iterated local search's route never touches: without beams
    // it stayed 12.4 % below (685.03) from 100 steps to 1 s, and one beam
    // ranked by an optimistic bound did not lead there. Today: the optimum
    // after 60 steps, from the beams that price time.
    let gap = bay_fixture_gap("bi60-mw-loose-s204.json", 781.7595148767965, 100);
    assert!(gap <= 1.0, "gap {gap:.2} %");
}

/// Gap in % of `auto`'s weight after `steps` steps (128-node class) to the
/// proved `optimum` of a Bay of Islands fixture in `tests/data/bay`; the
/// route must be feasible and never beat the optimum.
fn bay_fixture_gap(file: &str, optimum: f64, steps: u32) -> f64 {
    let path = format!("{}/tests/data/bay/{file}", env!("CARGO_MANIFEST_DIR"));
    let inst = Instance::from_json(&std::fs::read_to_string(path).unwrap()).unwrap();
    let stats = solve_in::<2>(&inst, steps);
    assert!(stats.feasible, "{file}");
    assert!(
        stats.weight <= optimum + 1e-6,
        "{file}: {} beats the proved optimum",
        stats.weight
    );
    100.0 * (optimum - stats.weight) / optimum
}

/// Gaps in % of `auto`'s cost after [`STEPS`] steps to the exact solver's
/// proved optimum, on `paper_cost` versions of six small random networks of
/// `n` nodes and edge probability `density`.
fn paper_cost_gaps(n: usize, density: f64, budget_s: f64) -> Vec<f64> {
    let mut gaps = Vec::new();
    for seed in 0..6 {
        let mut inst = random_instance(n, density, budget_s, seed);
        inst.objective = Objective::PaperCost { phi1: 0.01, phi2: 1.0 };
        let p: Problem = Problem::from_instance(&inst).unwrap();
        let exact = solve_exact(&p, &ExactSettings::default()).unwrap();
        assert!(exact.proved_optimal, "seed {seed}");
        let optimum = exact.eval.cost(inst.objective, inst.time_available_s);
        let stats = solve(&inst);
        assert!(stats.feasible, "seed {seed}");
        assert!(
            stats.cost >= optimum - 1e-9,
            "seed {seed}: {} beats the optimum {optimum}",
            stats.cost
        );
        let gap = 100.0 * (stats.cost - optimum) / optimum;
        eprintln!("seed {seed}: cost {} against {optimum} (gap {gap:.2} %)", stats.cost);
        gaps.push(gap);
    }
    gaps
}

/// Mean and worst of `gaps` (at least 0).
fn mean_and_worst(gaps: &[f64]) -> (f64, f64) {
    let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
    (mean, gaps.iter().copied().fold(0.0, f64::max))
}

#[test]
fn paper_cost_stays_near_the_proved_optimum() {
    let (mean, worst) = mean_and_worst(&paper_cost_gaps(14, 0.6, 9_000.0));
    // Today: 6 of 6 at the optimum (before rerouting: 4 of 6, mean
    // 14.9 %, worst 82.4 %, seed 4 a two-edge route where the optimum takes
    // three). A planner that optimised weight instead of this cost fails it.
    assert!(mean <= MEAN_BOUND_PC, "mean gap {mean:.2} %");
    assert!(worst <= WORST_BOUND_PC, "worst gap {worst:.2} %");
}

#[test]
fn paper_cost_on_dense_networks_stays_near_the_proved_optimum() {
    // Edge probability 0.95: above auto's density threshold, so this runs
    // the dense networks' settings (no reroute polish, fewer reroute kicks,
    // no shortening in the recreate step).
    let (mean, worst) = mean_and_worst(&paper_cost_gaps(DENSE_N, 0.95, DENSE_BUDGET_S));
    // Today: 6 of 6 at the optimum (before the low-risk search: 4 of 6,
    // mean 12.4 %, worst 55.2 %); these routes must spend their budget to
    // the second at a low risk, which kicks alone rarely assemble on dense
    // networks (see docs/quality.md).
    assert!(mean <= MEAN_BOUND_PC_DENSE, "mean gap {mean:.2} %");
    assert!(worst <= WORST_BOUND_PC_DENSE, "worst gap {worst:.2} %");
}

/// Size and budget of the dense `paper_cost` networks.
const DENSE_N: usize = 16;
const DENSE_BUDGET_S: f64 = 9_000.0;

/// Bounds with a margin over today's figures (see each test).
const MEAN_BOUND_MW: f64 = 3.5;
const WORST_BOUND_MW: f64 = 12.0;
const MEAN_BOUND_PC: f64 = 5.0;
const WORST_BOUND_PC: f64 = 25.0;
const MEAN_BOUND_PC_DENSE: f64 = 2.0;
const WORST_BOUND_PC_DENSE: f64 = 10.0;
