//! Proof that solving allocates nothing once a solver is built (house style
//! §4): this test binary installs the counting allocator, builds
//! problems and solvers, runs one warm-up solve, and then counts the solving
//! thread's allocations over many full-budget solves of PSO, BBO and auto — both
//! objectives, cold and warm-started, with and without a deadline. Counts are
//! per thread, so the harness's other test threads cannot disturb them.

use std::time::{Duration, Instant};

use auv_core::fixtures::random_instance;
use auv_core::instance::Objective;
use auv_core::problem::Problem;
use auv_core::rng::PlannerRng;
use auv_core::route::Route;
use auv_core::solver::auto::{Auto, AutoSettings};
use auv_core::solver::bbo::{Bbo, BboSettings};
use auv_core::solver::pso::{Pso, PsoSettings};
use auv_core::solver::{Budget, Solver, StopReason, run};
use auv_platform::alloc_counter::{self, CountingAllocator};

#[global_allocator]
static ALLOC: CountingAllocator = CountingAllocator;

/// Problems of several sizes under both objectives (built before counting).
fn problems() -> Vec<Problem> {
    let mut out = Vec::new();
    for (n, seed) in [(12, 1), (40, 2), (128, 3)] {
        for objective in [Objective::MaxWeight, Objective::PaperCost { phi1: 0.01, phi2: 1.0 }] {
            let mut inst = random_instance(n, 0.4, 31_000.0, seed);
            inst.objective = objective;
            out.push(Problem::from_instance(&inst).expect("connected at density 0.4"));
        }
    }
    out
}

/// Solves every problem cold, then warm from the cold result, then under a
/// deadline (one already past, one in the future), checking each stop reason.
fn solve_all<S: Solver>(solver: &mut S, problems: &[Problem], iterations: u32, seed: u64) -> u64 {
    let mut rng = PlannerRng::new(seed);
    let mut checksum = 0u64;
    for p in problems {
        let cold = run(solver, p, &mut rng, None, Budget::iterations(iterations));
        assert_eq!(cold.stop, StopReason::Budget);
        let warm: Route = *solver.best().0;
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

fn assert_no_allocations<S: Solver>(mut solver: S, iterations: u32) {
    assert!(alloc_counter::installed(), "the counting allocator must be installed");
    let problems = problems();
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
    assert_no_allocations(Pso::new(s), s.iterations);
}

#[test]
fn bbo_full_budget_solves_do_not_allocate() {
    let s = BboSettings::paper();
    assert_no_allocations(Bbo::new(s), s.generations);
}

#[test]
fn auto_solves_do_not_allocate() {
    // Fewer steps than PSO's budget: each step also polishes and kicks.
    assert_no_allocations(Auto::new(AutoSettings::default()), 40);
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
