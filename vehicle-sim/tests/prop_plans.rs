//! Property test of the vehicle's plan check: any plan at any moment of a
//! mission is either taken, and then fits (starts where the vehicle will be
//! free, ends at the goal, uses only edges of the latest snapshot and no
//! waypoint already visited), or refused with a plan kind; the vehicle
//! never panics and its travelled route stays a valid one.

use auv_core::fixtures::random_instance;
use auv_messages::msg::plan_through;
use auv_messages::msg::{Outcome, RejectKind, VehicleEvent, VehicleState, WaypointSnapshot, boxed_zeroed, route_ids};
use auv_messages::network::{find_edge, write_snapshot};
use proptest::prelude::*;
use vehicle_sim::sim::{PlanOffer, SimEvent, VehicleSim};

fn state(v: &VehicleSim) -> VehicleState {
    let mut m = *boxed_zeroed::<VehicleState>();
    v.fill_state(VehicleEvent::Periodic, 0.0, false, &mut m);
    m
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn any_plan_is_taken_only_when_it_fits_and_the_vehicle_never_panics(
        seed in 0u64..1000,
        n in 3usize..20,
        density in 0.2f64..1.0,
        offers in proptest::collection::vec(
            (proptest::collection::vec(0u16..24, 0..10), any::<bool>(), 0.0f64..3000.0),
            1..10,
        ),
    ) {
        let inst = random_instance(n, density, 20_000.0, seed);
        let mut s = WaypointSnapshot::new();
        write_snapshot(&inst, 0, &mut s).unwrap();
        let goal = s.goal as u16;
        let mut v = VehicleSim::new();
        v.apply_snapshot(&s);
        let mut t = 0.0;
        for (k, (ids, anchored, dt)) in offers.into_iter().enumerate() {
            let before = state(&v);
            let visited = route_ids(&before.route, before.route_len).to_vec();
            // Anchored offers start at the vehicle's next node and end at the
            // goal, so some of them fit; the rest are anything at all.
            let mut route = ids;
            if anchored {
                route.insert(0, before.to_node as u16);
                route.push(goal);
            }
            match v.offer_plan(&plan_through(&route, k as u64 + 1)) {
                Ok(PlanOffer::Stale) => {
                    // Only after the mission, or a plan from a waypoint the vehicle has left.
                    let left_behind = route
                        .first()
                        .is_some_and(|&f| u32::from(f) != before.to_node && visited.contains(&f));
                    prop_assert!(
                        before.outcome != Outcome::Running as u32 || left_behind,
                        "{:?} stale", route
                    );
                }
                Ok(PlanOffer::Taken) => {
                    prop_assert_eq!(route.first().copied(), Some(before.to_node as u16));
                    prop_assert_eq!(route.last().copied(), Some(goal));
                    for w in route.windows(2) {
                        prop_assert!(find_edge(&s, w[0] as usize, w[1] as usize).is_some(), "non-edge {:?} taken", w);
                    }
                    for (i, id) in route.iter().enumerate() {
                        prop_assert!(!route[..i].contains(id), "{} twice", id);
                        prop_assert!(i == 0 || !visited.contains(id), "visited {} taken", id);
                    }
                }
                Err(kind) => prop_assert!(
                    matches!(kind, RejectKind::BadPlan | RejectKind::NonEdge | RejectKind::VisitedNode | RejectKind::NodeOutOfRange),
                    "{:?}", kind
                ),
            }
            t += dt;
            while let Some(ev) = v.step_until(t) {
                if matches!(ev, SimEvent::Finished(_)) {
                    break;
                }
            }
        }
        // What the vehicle travelled is a valid walk: edges only, no repeats.
        let end = state(&v);
        let travelled = route_ids(&end.route, end.route_len);
        for w in travelled.windows(2) {
            prop_assert!(find_edge(&s, w[0] as usize, w[1] as usize).is_some());
        }
        for (i, id) in travelled.iter().enumerate() {
            prop_assert!(!travelled[..i].contains(id));
        }
    }
}
