//! The world's per-update calls make no heap allocation: `redraw_dynamic`,
//! `apply_positions` and `fill_problem` run many times under a counting
//! global allocator after the world and the problem are built.
//!
//! A test binary of its own, so that its global allocator counts only this.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use auv_core::problem::{NodeSet, Problem};
use auv_world::scenario::synthetic::GridMap;
use auv_world::scenario::{ScenarioConfig, World};

/// Counts allocations made by the current thread (other threads of the
/// test harness cannot disturb the count).
struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: defers every call to the system allocator; only adds a counter.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as ours.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as ours.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as ours.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations() -> u64 {
    ALLOCATIONS.with(Cell::get)
}

#[test]
fn per_update_calls_do_not_allocate() {
    let map = GridMap::cove();
    let cfg = ScenarioConfig::default();
    let mut sensor = World::generate(&cfg, 4, &map).unwrap();
    let mut planner = sensor.clone();
    let mut problem: Problem = Problem::new();
    let mut positions = sensor.positions().to_vec();
    let mut rng = sensor.redraw_rng(0);
    let before = allocations();
    let (mut filled, mut applied) = (0, 0);
    for _ in 0..200 {
        sensor.redraw_dynamic(&mut rng, &map);
        positions.copy_from_slice(sensor.positions());
        applied += u32::from(planner.apply_positions(&positions, &map).is_ok());
        filled += u32::from(planner.fill_problem(&mut problem, 0, NodeSet::EMPTY, 31_000.0).is_ok());
    }
    let made = allocations() - before;
    assert_eq!(made, 0, "{made} allocations in 200 updates");
    // The loop did real work: every report applied, most problems built.
    assert_eq!(applied, 200);
    assert!(filled > 100, "{filled}");
    // And the counter does count: building a snapshot allocates.
    let before = allocations();
    std::hint::black_box(planner.snapshot("s"));
    assert!(allocations() > before);
}
