//! Criterion benches for the planner's hot paths: decoding one
//! priority vector, decoding a swarm of 150 as one stream (per vector), and
//! a full paper budget of PSO (150 particles × 150
//! iterations) and BBO (50 habitats × 150 generations), at n = 40, 80, 128.
//!
//! Networks: the scenario generator's paper-model networks on the embedded
//! Benoit's Cove chart (`scenario::World::generate` with `nodes` = n and
//! every other setting at its default: 10 dynamic waypoints, tasks
//! ρ ~ U[1, 10], ξ ~ U[0.1, 1], δ ~ U[120, 900] s, v = 1.5 m/s, 31 000 s
//! budget), eight seeds per size. Each iteration takes the next network in
//! turn, so one odd network (some need the decoder's repair far more often)
//! does not decide the figure.
//!
//! The `cpu_class_*` groups time the capacity classes other than 128 (the
//! one every other group runs): n = 40 in the 64-node class that
//! `planner solve` picks for it, and the OPLib files kroA200-gen2-50 (201
//! nodes, 256 class) and rd400-gen2-50 (401 nodes, 512 class) from
//! `crates/core/tests/data/oplib/`: the stream decode per vector and the
//! paper's PSO budget.
//!
//! `cpu_risk_search/{40,64}` times `auto`'s depth-first search over the
//! low-risk edges (`paper_cost`) from its start until it has looked at
//! every candidate route (without an incumbent from elsewhere), on the
//! dense networks of that objective's training family.
//!
//! Run: `cargo bench --bench solvers -- --warm-up-time 1 --measurement-time 3`
//! (single-threaded; the medians are what the targets refer to).
//!
//! Every bench runs twice: by wall-clock time (`decode/40`, …, criterion's
//! default) and, on Linux, by the benchmark thread's CPU time
//! (`cpu_decode/40`, …). The machine is shared; when other processes keep
//! both cores busy, wall-clock medians include the time this thread waited
//! for a core, while CPU time counts only the time it ran (cache damage from
//! the other processes still shows).
use std::hint::black_box;

use auv_core::capacity::nodes_of;
use auv_core::decode::{Decoder, PRIORITY_MAX, PRIORITY_MIN};
use auv_core::problem::{MAX_NODES, Problem};
use auv_core::rng::PlannerRng;
use auv_core::route::Route;
use auv_core::solver::bbo::{Bbo, BboSettings};
use auv_core::solver::pso::{Pso, PsoSettings};
use auv_core::solver::{Budget, Solver, run};
use auv_world::scenario::{ScenarioConfig, World, load_map};
use criterion::measurement::{Measurement, ValueFormatter};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};

const SIZES: [usize; 3] = [40, 80, 128];
const NETWORKS: usize = 8;

/// The scenario generator's networks of `config`, one per seed 1000, 1001, …
fn networks<const W: usize>(config: &ScenarioConfig) -> Vec<Problem<W>> {
    let map = load_map(config, 1000).expect("the embedded chart loads");
    (0..NETWORKS)
        .map(|k| {
            let world = World::generate(config, 1000 + k as u64, &map).expect("the scenario generates");
            Problem::from_instance(&world.snapshot("bench")).expect("scenario networks join start and goal")
        })
        .collect()
}

/// The default scenario's networks of `n` waypoints.
fn problems(n: usize) -> Vec<Problem> {
    networks(&ScenarioConfig {
        nodes: n,
        ..ScenarioConfig::default()
    })
}

fn decode<M: Measurement>(c: &mut Criterion<M>, name: &str) {
    let mut g = c.benchmark_group(name);
    for n in SIZES {
        let ps = problems(n);
        // A pool of random vectors so the branch predictor cannot learn one.
        let mut rng = PlannerRng::new(7);
        let pool: Vec<[f64; MAX_NODES]> = (0..256)
            .map(|_| core::array::from_fn(|_| rng.uniform(PRIORITY_MIN, PRIORITY_MAX)))
            .collect();
        let mut d = Decoder::new();
        let mut r = Route::new();
        let mut k = 0usize;
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                k = k.wrapping_add(1);
                // Next network every 512 decodes: a solver decodes thousands
                // of vectors per network, with that network's tables in cache.
                black_box(d.decode(&ps[(k / 512) % NETWORKS], &pool[k & 255], &mut r))
            })
        });
    }
    g.finish();
}

/// The decode as the solvers run it: a swarm of 150 `f32` vectors decoded
/// as one stream (`Decoder::decode_stream`, eight walks in flight); the
/// figure is per vector (criterion's throughput, or the time / 150).
fn decode_stream<M: Measurement>(c: &mut Criterion<M>, name: &str) {
    const SWARM: usize = 150;
    let mut g = c.benchmark_group(name);
    g.throughput(Throughput::Elements(SWARM as u64));
    for n in SIZES {
        let ps = problems(n);
        let mut rng = PlannerRng::new(7);
        let pools: Vec<Vec<f32>> = (0..4)
            .map(|_| {
                (0..SWARM * MAX_NODES)
                    .map(|_| rng.uniform(PRIORITY_MIN, PRIORITY_MAX) as f32)
                    .collect()
            })
            .collect();
        let mut d = Decoder::new();
        let mut k = 0usize;
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                k = k.wrapping_add(1);
                let pool = &pools[k % 4];
                let mut weight = 0.0;
                d.decode_stream(
                    &ps[(k / 16) % NETWORKS],
                    SWARM,
                    &|i| &pool[i * MAX_NODES..(i + 1) * MAX_NODES],
                    &mut |_, w| weight += w.ranked().weight,
                );
                black_box(weight)
            })
        });
    }
    g.finish();
}

fn full_budget<S: Solver, M: Measurement>(c: &mut Criterion<M>, name: &str, iterations: u32, mut solver: S) {
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

fn pso<M: Measurement>(c: &mut Criterion<M>, name: &str) {
    let s = PsoSettings::paper();
    full_budget(c, name, s.iterations, Pso::new(s));
}

fn bbo<M: Measurement>(c: &mut Criterion<M>, name: &str) {
    let s = BboSettings::paper();
    full_budget(c, name, s.generations, Bbo::new(s));
}

fn wall(c: &mut Criterion) {
    decode(c, "decode");
    decode_stream(c, "decode_stream");
    pso(c, "pso_full_budget");
    bbo(c, "bbo_full_budget");
}

criterion_group!(by_wall_clock, wall);

/// CPU time of the calling thread (`CLOCK_THREAD_CPUTIME_ID`).
#[cfg(target_os = "linux")]
struct ThreadCpuTime;

#[cfg(target_os = "linux")]
mod cpu_clock {
    /// Nanoseconds of CPU time this thread has used.
    pub fn now_ns() -> u64 {
        (auv_platform::clock::thread_cpu_time_s() * 1e9) as u64
    }
}

#[cfg(target_os = "linux")]
struct NanosFormatter;

#[cfg(target_os = "linux")]
impl ValueFormatter for NanosFormatter {
    fn scale_values(&self, typical_ns: f64, values: &mut [f64]) -> &'static str {
        let (factor, unit) = match typical_ns {
            t if t < 1e3 => (1.0, "ns"),
            t if t < 1e6 => (1e-3, "µs"),
            t if t < 1e9 => (1e-6, "ms"),
            _ => (1e-9, "s"),
        };
        values.iter_mut().for_each(|v| *v *= factor);
        unit
    }

    fn scale_throughputs(&self, _typical: f64, throughput: &Throughput, values: &mut [f64]) -> &'static str {
        let per_iteration = match *throughput {
            Throughput::Elements(e) | Throughput::ElementsAndBytes { elements: e, .. } => e as f64,
            Throughput::Bytes(b) | Throughput::BytesDecimal(b) => b as f64,
            Throughput::Bits(b) => b as f64,
        };
        values.iter_mut().for_each(|v| *v = per_iteration * 1e9 / *v);
        "/s (CPU)"
    }

    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        "ns"
    }
}

#[cfg(target_os = "linux")]
impl Measurement for ThreadCpuTime {
    type Intermediate = u64;
    type Value = u64;

    fn start(&self) -> u64 {
        cpu_clock::now_ns()
    }
    fn end(&self, start: u64) -> u64 {
        cpu_clock::now_ns() - start
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, v: &u64) -> f64 {
        *v as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        &NanosFormatter
    }
}

/// An OPLib file of the core's test data as a problem of class `W`.
fn oplib_problem<const W: usize>(name: &str) -> Problem<W> {
    let path = format!(
        "{}/crates/core/tests/data/oplib/gen2/{name}.oplib",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(&path).expect("the core's test data");
    let inst = auv_core::tsplib::parse_oplib(&text)
        .expect("a valid OPLib file")
        .to_instance(name);
    Problem::from_instance(&inst).expect("OPLib graphs are complete")
}

/// The stream decode (per vector) and the paper's PSO budget on `ps`, all
/// of class `W`, under the id `label`.
fn class_benches<const W: usize, M: Measurement>(c: &mut Criterion<M>, prefix: &str, label: &str, ps: Vec<Problem<W>>) {
    const SWARM: usize = 150;
    let cap = nodes_of(W);
    let mut rng = PlannerRng::new(7);
    let pool: Vec<f32> = (0..SWARM * cap)
        .map(|_| rng.uniform(PRIORITY_MIN, PRIORITY_MAX) as f32)
        .collect();
    let mut d = Decoder::<W>::new();
    let mut g = c.benchmark_group(format!("{prefix}class_decode_stream"));
    g.throughput(Throughput::Elements(SWARM as u64));
    let mut k = 0usize;
    g.bench_function(label, |b| {
        b.iter(|| {
            k = k.wrapping_add(1);
            let mut weight = 0.0;
            d.decode_stream(
                &ps[k % ps.len()],
                SWARM,
                &|i| &pool[i * cap..(i + 1) * cap],
                &mut |_, w| weight += w.ranked().weight,
            );
            black_box(weight)
        })
    });
    g.finish();
    let s = PsoSettings::paper();
    let mut solver = Pso::<W>::new(s);
    let mut g = c.benchmark_group(format!("{prefix}class_pso_full_budget"));
    let mut k = 0u64;
    g.bench_function(label, |b| {
        b.iter(|| {
            k += 1;
            let mut rng = PlannerRng::new(k);
            run(
                &mut solver,
                &ps[k as usize % ps.len()],
                &mut rng,
                None,
                Budget::iterations(s.iterations),
            );
            black_box(solver.best().1.weight)
        })
    });
    g.finish();
}

/// The classes other than 128 (see the module notes).
fn classes<M: Measurement>(c: &mut Criterion<M>, prefix: &str) {
    let small: Vec<Problem<1>> = networks(&ScenarioConfig {
        nodes: 40,
        ..ScenarioConfig::default()
    });
    class_benches(c, prefix, "c64-n40", small);
    class_benches(c, prefix, "c256-n201", vec![oplib_problem::<4>("kroA200-gen2-50")]);
    class_benches(c, prefix, "c512-n401", vec![oplib_problem::<8>("rd400-gen2-50")]);
}

/// `auto`'s depth-first search over the low-risk edges (`paper_cost`), run
/// until it has looked at every candidate route, per network in turn, on
/// the dense networks of 40 and 64 nodes of that objective's training
/// family (Benoit's Cove, φ1 = 0.01, φ2 = 1).
fn risk_search<M: Measurement>(c: &mut Criterion<M>, name: &str) {
    use auv_core::instance::Objective;
    use auv_core::solver::risk_search::{CANDIDATES, RiskSearch};
    let mut g = c.benchmark_group(name);
    g.sample_size(16);
    for n in [40, 64] {
        let ps: Vec<Problem<1>> = networks(&ScenarioConfig {
            nodes: n,
            objective: Objective::PaperCost { phi1: 0.01, phi2: 1.0 },
            ..ScenarioConfig::default()
        });
        let mut search = RiskSearch::<1>::new();
        let mut k = 0usize;
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                k = k.wrapping_add(1);
                let p = &ps[k % NETWORKS];
                search.start(p, CANDIDATES);
                while !search.is_done() {
                    black_box(search.run(p, f64::INFINITY, 1 << 20).is_some());
                }
            })
        });
    }
    g.finish();
}

#[cfg(target_os = "linux")]
fn cpu(c: &mut Criterion<ThreadCpuTime>) {
    risk_search(c, "cpu_risk_search");
    decode(c, "cpu_decode");
    decode_stream(c, "cpu_decode_stream");
    pso(c, "cpu_pso_full_budget");
    bbo(c, "cpu_bbo_full_budget");
    classes(c, "cpu_");
}

#[cfg(target_os = "linux")]
criterion_group! {
    name = by_thread_cpu_time;
    config = Criterion::default().with_measurement(ThreadCpuTime);
    targets = cpu
}

#[cfg(target_os = "linux")]
criterion_main!(by_wall_clock, by_thread_cpu_time);
#[cfg(not(target_os = "linux"))]
criterion_main!(by_wall_clock);
