//! Proof that the re-planning core allocates nothing once built, in every
//! capacity class the service runs (house style §4): this test binary
//! installs the counting allocator, builds a `PlannerCore<W>` with the
//! default solver and a network near the class's capacity, plays one
//! warm-up round of inputs, then counts the thread's allocations over
//! rounds of snapshots (a new epoch each), vehicle states (an arrival each)
//! and operator commands, with the re-plan, the plan and status messages
//! each one causes.

use auv_core::capacity::nodes_of;
use auv_core::fixtures::random_instance;
use auv_core::solver::Algorithm;
use auv_messages::msg::{
    CommandKind, Header, OperatorCommand, Plan, PlannerStatus, RejectCounters, VehicleEvent, VehicleMode, VehicleState,
    WaypointSnapshot, boxed_zeroed, route_ids,
};
use auv_messages::network::write_snapshot;
use auv_platform::alloc_counter::{self, CountingAllocator};
use auv_service::core::{PlannerCore, ServiceConfig, ServiceEvent};

#[global_allocator]
static ALLOC: CountingAllocator = CountingAllocator;

/// What a vehicle would report after following `plan` to its next node.
fn arrive(state: &mut VehicleState, plan: &Plan, seq: u64) -> bool {
    let ids = route_ids(&plan.route, plan.route_len);
    if ids.len() < 2 {
        return false;
    }
    let next = ids[1];
    let len = state.route_len as usize;
    state.route[len] = next;
    state.route_len += 1;
    state.header.seq = seq;
    state.header.mission_time_s += 60.0;
    state.time_left_s -= 60.0;
    state.from_node = u32::from(next);
    state.to_node = u32::from(next);
    state.arrivals += 1;
    state.tasks_completed += 1;
    state.mode = VehicleMode::Working as u32;
    state.event = VehicleEvent::Arrival as u32;
    true
}

/// Plays `rounds` rounds of inputs on `core`; returns the plans made.
#[allow(clippy::too_many_arguments)]
fn play<const W: usize>(
    core: &mut PlannerCore<W>,
    snaps: &mut [WaypointSnapshot; 2],
    state: &mut VehicleState,
    plan: &mut Plan,
    status: &mut PlannerStatus,
    command: &OperatorCommand,
    seq: &mut u64,
    rounds: u32,
) -> u64 {
    let mut sink = |_: &ServiceEvent| {};
    let rejected = RejectCounters::default();
    let mut plans = 0;
    for k in 0..rounds {
        *seq += 1;
        let snap = &mut snaps[(*seq % 2) as usize];
        snap.header.seq = *seq;
        snap.epoch = *seq;
        core.on_snapshot(snap, 0, &mut sink);
        *seq += 1;
        if k > 0 && !arrive(state, plan, *seq) {
            break;
        }
        state.header.seq = *seq;
        core.on_state(state, 0, &mut sink);
        if k % 2 == 1 {
            let mut c = *command;
            c.header = Header {
                seq: *seq,
                ..Header::default()
            };
            c.command_id = *seq;
            c.kind = CommandKind::SetTimeBudget as u32;
            c.value_s = state.header.mission_time_s + state.time_left_s - 1.0;
            let _ = core.on_command(&c, 0, &mut sink);
        }
        if let Some(Ok(r)) = core.replan() {
            core.fill_plan(&r, plan);
            core.published(&r, 0, &mut sink);
            core.take_acks(*seq, r.replan, &mut |_| {});
            plans += 1;
        }
        core.fill_status(&rejected, status);
    }
    plans
}

fn assert_no_allocations<const W: usize>() {
    assert!(alloc_counter::installed(), "the counting allocator must be installed");
    // Near the class's capacity (the 64 class: 60 nodes), a generous budget
    // so that plans run through many waypoints.
    let n = nodes_of(W) - 4;
    let inst = random_instance(n, 0.3, 1e6, W as u64);
    let mut snaps = [WaypointSnapshot::new(), WaypointSnapshot::new()];
    for s in &mut snaps {
        write_snapshot(&inst, 0, s).expect("the instance fits a snapshot");
        s.header.session = 1;
        s.next_update_s = 1e9;
    }
    let cfg = ServiceConfig {
        cut_at_deadline: false,
        iterations: 20,
        ..ServiceConfig::default()
    };
    let mut core = PlannerCore::<W>::new(cfg, Algorithm::Auto.build::<W>(20));
    let mut state = *boxed_zeroed::<VehicleState>();
    state.header.session = 2;
    state.time_left_s = 9e5;
    state.route_len = 1;
    state.mode = VehicleMode::NoPlan as u32;
    state.event = VehicleEvent::Start as u32;
    let mut plan = *boxed_zeroed::<Plan>();
    let mut status = *boxed_zeroed::<PlannerStatus>();
    let command = *boxed_zeroed::<OperatorCommand>();
    let mut seq = 0;
    // Warm-up: the first plan, first-use costs.
    assert_eq!(
        play(
            &mut core,
            &mut snaps,
            &mut state,
            &mut plan,
            &mut status,
            &command,
            &mut seq,
            1
        ),
        1
    );
    let (plans, counts) = alloc_counter::count(|| {
        play(
            &mut core,
            &mut snaps,
            &mut state,
            &mut plan,
            &mut status,
            &command,
            &mut seq,
            12,
        )
    });
    assert!(
        plans >= 6,
        "{W}: only {plans} plans: the rounds did not exercise re-planning"
    );
    assert!(state.route_len >= 6, "{W}: the vehicle did not move");
    assert_eq!(counts.allocations, 0, "class of {} nodes: {counts:?}", nodes_of(W));
    assert_eq!(counts.deallocations, 0, "class of {} nodes: {counts:?}", nodes_of(W));
}

#[test]
fn the_core_does_not_allocate_in_the_64_node_class() {
    assert_no_allocations::<1>();
}

#[test]
fn the_core_does_not_allocate_in_the_128_node_class() {
    assert_no_allocations::<2>();
}

#[test]
fn the_core_does_not_allocate_in_the_256_node_class() {
    assert_no_allocations::<4>();
}

#[test]
fn the_core_does_not_allocate_in_the_512_node_class() {
    assert_no_allocations::<8>();
}

#[test]
fn a_snapshot_copied_past_the_buffer_would_be_counted() {
    // The counter sees this thread's allocations: a fresh snapshot buffer is one.
    let (_, counts) = alloc_counter::count(|| std::hint::black_box(WaypointSnapshot::with_capacity(10)));
    assert!(counts.allocations >= 2, "{counts:?}");
}
