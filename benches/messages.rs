//! Criterion benches of what a waypoint snapshot costs a receiver: taking a
//! sample in (`WaypointSnapshot::receive`, what a subscriber does with each
//! sample: the head's scalars and used waypoints, and the edge slice, into
//! a buffer that holds every pair of 512 waypoints) and the planner's copy
//! of an accepted snapshot into its own (`copy_snapshot`), on the scenario
//! generator's networks of 40, 128, 256 and 401 waypoints (Benoit's Cove
//! defaults, seed 1000: 88–93 % of pairs are edges). Throughput is in
//! bytes of the message (head and edges).
//!
//! Run: `cargo bench --bench messages -- --warm-up-time 1 --measurement-time 3`
use std::hint::black_box;

use auv_messages::msg::{SnapshotHead, WaypointSnapshot};
use auv_messages::network::write_snapshot;
use auv_world::scenario::{ScenarioConfig, World, load_map};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};

const SIZES: [usize; 4] = [40, 128, 256, 401];

fn snapshot(n: usize) -> WaypointSnapshot {
    let config = ScenarioConfig {
        nodes: n,
        ..ScenarioConfig::default()
    };
    let map = load_map(&config, 1000).expect("the embedded chart loads");
    let world = World::generate(&config, 1000, &map).expect("the default scenario generates");
    let mut s = WaypointSnapshot::new();
    write_snapshot(&world.snapshot("bench"), 0, &mut s).expect("the network fits a snapshot");
    s
}

fn receive(c: &mut Criterion) {
    let mut g = c.benchmark_group("snapshot_receive");
    for n in SIZES {
        let src = snapshot(n);
        let (head, edges) = (*src.head(), src.edges_in_use().to_vec());
        let bytes = core::mem::size_of::<SnapshotHead>() + core::mem::size_of_val(edges.as_slice());
        g.throughput(Throughput::Bytes(bytes as u64));
        let mut dst = WaypointSnapshot::new();
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                dst.receive(black_box(&head), black_box(&edges));
                black_box(dst.edge_count)
            })
        });
    }
    g.finish();
}

fn copy(c: &mut Criterion) {
    let mut g = c.benchmark_group("snapshot_copy");
    for n in SIZES {
        let src = snapshot(n);
        let bytes = core::mem::size_of::<SnapshotHead>() + core::mem::size_of_val(src.edges_in_use());
        g.throughput(Throughput::Bytes(bytes as u64));
        let mut dst = WaypointSnapshot::new();
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                dst.copy_snapshot(black_box(&src)).expect("the buffer holds it");
                black_box(dst.edge_count)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, receive, copy);
criterion_main!(benches);
