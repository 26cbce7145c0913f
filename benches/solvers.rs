//! Criterion benches for the planner's hot paths (issue 2 §7): decoding one
//! priority vector, and a full paper budget of PSO (150 particles × 150
//! iterations) and BBO (50 habitats × 150 generations), at n = 40, 80, 128.
//!
//! Networks: `fixtures::random_instance`, eight per size with edge density
//! cycling through 0.3, 0.4, 0.5, tasks and speed as in the paper's model
//! (ρ ~ U[1, 10], ξ ~ U[0.1, 1], δ ~ U[120, 900] s, v = 1.5 m/s) and the
//! paper's 31 000 s budget. Each iteration takes the next network in turn,
//! so one odd network (some need the decoder's repair far more often) does
//! not decide the figure. They stand in for the scenario generator's
//! chart-based networks; the benches will switch to those when that
//! generator lands.
//!
//! Run: `cargo bench --bench solvers -- --warm-up-time 1 --measurement-time 3`
//! (single-threaded; the medians are what the targets refer to).
use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use planner::decode::{Decoder, PRIORITY_MAX, PRIORITY_MIN};
use planner::fixtures::random_instance;
use planner::problem::{MAX_NODES, Problem};
use planner::rng::PlannerRng;
use planner::route::Route;
use planner::solver::bbo::{Bbo, BboSettings};
use planner::solver::pso::{Pso, PsoSettings};
use planner::solver::{Budget, Solver, run};

const SIZES: [usize; 3] = [40, 80, 128];
const DENSITIES: [f64; 3] = [0.3, 0.4, 0.5];
const NETWORKS: usize = 8;
const BUDGET_S: f64 = 31_000.0;

fn problems(n: usize) -> Vec<Problem> {
    (0..NETWORKS)
        .map(|k| {
            let inst = random_instance(n, DENSITIES[k % DENSITIES.len()], BUDGET_S, 1000 + k as u64);
            Problem::from_instance(&inst).expect("bench networks at density >= 0.3 are connected")
        })
        .collect()
}

fn decode(c: &mut Criterion) {
    let mut g = c.benchmark_group("decode");
    for n in SIZES {
        let ps = problems(n);
        // A pool of random vectors so the branch predictor cannot learn one.
        let mut rng = PlannerRng::new(7);
        let pool: Vec<[f64; MAX_NODES]> = (0..256)
            .map(|_| core::array::from_fn(|_| rng.uniform(PRIORITY_MIN, PRIORITY_MAX)))
            .collect();
        let mut d = Decoder::new();
        let mut r = Route::new();
        let mut k = 0;
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                k = (k + 1) & 255;
                black_box(d.decode(&ps[k % NETWORKS], &pool[k], &mut r))
            })
        });
    }
    g.finish();
}

fn full_budget<S: Solver>(c: &mut Criterion, name: &str, iterations: u32, mut solver: S) {
    let mut g = c.benchmark_group(name);
    for n in SIZES {
        let ps = problems(n);
        let mut k = 0u64;
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                k += 1;
                let mut rng = PlannerRng::new(k);
                run(
                    &mut solver,
                    &ps[k as usize % NETWORKS],
                    &mut rng,
                    None,
                    Budget::iterations(iterations),
                );
                black_box(solver.best().1.weight)
            })
        });
    }
    g.finish();
}

fn pso(c: &mut Criterion) {
    let s = PsoSettings::paper();
    full_budget(c, "pso_full_budget", s.iterations, Pso::new(s));
}

fn bbo(c: &mut Criterion) {
    let s = BboSettings::paper();
    full_budget(c, "bbo_full_budget", s.generations, Bbo::new(s));
}

criterion_group!(benches, decode, pso, bbo);
criterion_main!(benches);
