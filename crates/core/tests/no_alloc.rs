//! Proof that solving allocates nothing once a solver is built (house style
//! §4): this test binary installs the counting allocator, builds
//! problems and solvers, runs one warm-up solve, and then counts the solving
//! thread's allocations over many full-budget solves of PSO, BBO and auto — both
//! objectives, cold and warm-started, with and without a deadline — in the
//! 128-node capacity class and the 512-node one (PSO in all four). Counts
//! are per thread, so the harness's other test threads cannot disturb them.

use std::time::{Duration, Instant};

use auv_core::fixtures::random_instance;
use auv_core::instance::Objective;

use auv_core::rng::PlannerRng;

use auv_core::capacity::nodes_of;
use auv_core::problem::Problem;
use auv_core::route::Route;
use auv_core::solver::auto::Auto;
use auv_core::solver::auto::AutoSettings;
use auv_core::solver::bbo::Bbo;
use auv_core::solver::bbo::BboSettings;
use auv_core::solver::pso::Pso;
use auv_core::solver::pso::PsoSettings;
use auv_core::solver::{Budget, Solver, StopReason, run};
use auv_platform::alloc_counter::{self, CountingAllocator};

#[global_allocator]
static ALLOC: CountingAllocator = CountingAllocator;

/// Problems of several sizes up to the class's capacity, under both
/// objectives, on sparse and dense networks (`auto` picks its moves by
/// density), built before counting.
fn problems<const W: usize>() -> Vec<Problem<W>> {
    let mut out = Vec::new();
    let top = nodes_of(W);
    for (n, seed) in [(12, 1), (40.min(top), 2), (top, 3)] {
        // Sparser at 512 nodes, so the tables are not mostly edges.
        let densities: &[f64] = if n > 128 { &[0.1] } else { &[0.4, 0.9] };
        for &density in densities {
            for objective in [Objective::MaxWeight, Objective::PaperCost { phi1: 0.01, phi2: 1.0 }] {
                let mut inst = random_instance(n, density, 31_000.0, seed);
                inst.objective = objective;
                out.push(Problem::from_instance(&inst).expect("connected at these densities"));
            }
        }
    }
    out
}

/// Solves every problem cold, then warm from the cold result, then under a
/// deadline (one already past, one in the future), checking each stop reason.
fn solve_all<const W: usize, S: Solver<W>>(solver: &mut S, problems: &[Problem<W>], iterations: u32, seed: u64) -> u64 {
    let mut rng = PlannerRng::new(seed);
    let mut checksum = 0u64;
    for p in problems {
        let cold = run(solver, p, &mut rng, None, Budget::iterations(iterations));
        assert_eq!(cold.stop, StopReason::Budget);
        let warm: Route<W> = *solver.best().0;
        run(solver, p, &mut rng, Some(&warm), Budget::iterations(iterations));
        let past = Budget {
            iterations,
            deadline: Some(Instant::now()),
        };
        assert_eq!(run(solver, p, &mut rng, Some(&warm), past).stop, StopReason::Deadline);
        let future = Budget {
            iterations: 3,
            deadline: Some(Instant::now() + Duration::from_secs(3600)),
        };
        run(solver, p, &mut rng, None, future);
        checksum = checksum.wrapping_add(solver.best().0.len() as u64);
    }
    checksum
}

fn assert_no_allocations<const W: usize, S: Solver<W>>(mut solver: S, iterations: u32) {
    assert!(alloc_counter::installed(), "the counting allocator must be installed");
    let problems = problems::<W>();
    // Warm-up: first-use costs (CPU feature detection, lazy statics) happen here.
    solve_all(&mut solver, &problems, 2, 0);
    let (_, counts) = alloc_counter::count(|| {
        let mut sum = 0;
        for seed in 1..=3 {
            sum += solve_all(&mut solver, &problems, iterations, seed);
        }
        std::hint::black_box(sum)
    });
    assert_eq!(counts.allocations, 0, "{counts:?}");
    assert_eq!(counts.deallocations, 0, "{counts:?}");
}

#[test]
fn pso_full_budget_solves_do_not_allocate() {
    let s = PsoSettings::paper();
    assert_no_allocations(Pso::<2>::new(s), s.iterations);
}

#[test]
fn bbo_full_budget_solves_do_not_allocate() {
    let s = BboSettings::paper();
    assert_no_allocations(Bbo::<2>::new(s), s.generations);
}

#[test]
fn auto_solves_do_not_allocate() {
    // Fewer steps than PSO's budget: each step also polishes and kicks.
    assert_no_allocations(Auto::<2>::new(AutoSettings::default()), 40);
}

#[test]
fn pso_does_not_allocate_in_the_other_classes() {
    // A shorter budget: the point is every class's code path, not the count.
    let s = PsoSettings {
        iterations: 20,
        ..PsoSettings::paper()
    };
    assert_no_allocations(Pso::<1>::new(s), s.iterations);
    assert_no_allocations(Pso::<4>::new(s), s.iterations);
    assert_no_allocations(Pso::<8>::new(s), s.iterations);
}

#[test]
fn bbo_and_auto_do_not_allocate_at_512_nodes() {
    let s = BboSettings {
        generations: 20,
        ..BboSettings::paper()
    };
    assert_no_allocations(Bbo::<8>::new(s), s.generations);
    assert_no_allocations(Auto::<8>::new(AutoSettings::default()), 10);
}

#[test]
fn a_deliberate_allocation_is_counted() {
    // The check above can fail: an allocation on this thread shows up.
    let (v, counts) = alloc_counter::count(|| std::hint::black_box(vec![7u8; 64]));
    assert_eq!(v.len(), 64);
    assert_eq!(counts.allocations, 1);
    assert!(counts.bytes >= 64);
    drop(v);
    // And the process-wide total moves with it.
    let before = alloc_counter::total_allocations();
    std::hint::black_box(Box::new([0u8; 32]));
    assert!(alloc_counter::total_allocations() > before);
}
