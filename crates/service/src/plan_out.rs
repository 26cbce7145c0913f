//! Where the service hands over a plan: the [`PlanOutbox`] seam, and
//! [`FaultyPlans`], its decorator that sends bad plans for tests.
//!
//! A plan's bad twin cannot be made from the plan alone: a route through a
//! non-neighbour needs the network the plan was computed on, one through a
//! visited waypoint needs the vehicle's route so far. The service therefore
//! publishes a plan together with a [`PlanContext`] (two borrows of what
//! the core already holds, no copy); a plain outbox ignores it.
//!
//! [`FaultyPlans`]' contract, for each plan with a fault due (the
//! [`FaultCycle`]'s kinds in turn): the bad plan goes just before the good
//! one, the same plan but for its route ([`bad_route`]); a fault that
//! cannot be built now (nothing visited yet, no snapshot) is used up and
//! nothing extra is sent. The good plan always goes out. With an empty
//! cycle the decorator is a pass-through, so the service loop has no
//! injection branch.

use auv_messages::msg::{MAX_WIRE_NODES, Plan, WaypointSnapshot, WireId, boxed_zeroed, route_ids};
use auv_messages::wire::{FaultCycle, bad_route};
use auv_transport::{Outbox, TransportError};

/// What a plan was computed from, as far as a decorator needs it.
#[derive(Clone, Copy, Debug, Default)]
pub struct PlanContext<'a> {
    /// The waypoint snapshot in force (`None` before the first).
    pub snapshot: Option<&'a WaypointSnapshot>,
    /// The vehicle's route so far, node ids (empty before its first state).
    pub visited: &'a [WireId],
}

/// Where the service publishes its plans.
pub trait PlanOutbox {
    /// Publishes the plan `fill` writes, computed in `ctx`; returns the
    /// good plan's sequence number.
    fn publish_plan(&mut self, ctx: PlanContext<'_>, fill: &mut dyn FnMut(&mut Plan)) -> Result<u64, TransportError>;

    /// As [`Outbox::refresh`].
    fn refresh(&mut self);
}

impl<O: Outbox<Plan>> PlanOutbox for O {
    fn publish_plan(&mut self, _: PlanContext<'_>, fill: &mut dyn FnMut(&mut Plan)) -> Result<u64, TransportError> {
        self.publish(fill)
    }

    fn refresh(&mut self) {
        Outbox::refresh(self);
    }
}

/// A plan outbox that sends a bad plan before good ones (see the module
/// doc); a pass-through when its cycle is empty.
pub struct FaultyPlans<O> {
    inner: O,
    faults: FaultCycle,
    /// The good plan, filled once more to read its route, and the bad
    /// plan's route (allocated here, not per plan: the service's steady
    /// state allocates nothing).
    scratch: Box<Plan>,
    bad: Box<[WireId; MAX_WIRE_NODES]>,
}

impl<O> FaultyPlans<O> {
    /// Decorates `inner` with the plan faults of `faults`
    /// ([`FaultCycle::NONE`]: none).
    pub fn new(inner: O, faults: FaultCycle) -> Self {
        Self {
            inner,
            faults,
            scratch: boxed_zeroed::<Plan>(),
            bad: Box::new([0; MAX_WIRE_NODES]),
        }
    }

    /// The decorated outbox.
    pub fn inner_mut(&mut self) -> &mut O {
        &mut self.inner
    }
}

impl<O: Outbox<Plan>> PlanOutbox for FaultyPlans<O> {
    fn publish_plan(&mut self, ctx: PlanContext<'_>, fill: &mut dyn FnMut(&mut Plan)) -> Result<u64, TransportError> {
        if let (Some(fault), Some(snap)) = (self.faults.advance(), ctx.snapshot) {
            fill(&mut self.scratch);
            let good = route_ids(&self.scratch.route, self.scratch.route_len);
            if let Some(len) = bad_route(fault, good, snap, ctx.visited, &mut self.bad) {
                let bad = &self.bad[..len];
                self.inner.publish(&mut |m: &mut Plan| {
                    fill(m);
                    m.route[..len].copy_from_slice(bad);
                    m.route_len = len as u32;
                })?;
            }
        }
        self.inner.publish(fill)
    }

    fn refresh(&mut self) {
        self.inner.refresh();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_core::fixtures::random_instance;
    use auv_messages::network::{find_edge, write_snapshot};
    use auv_messages::wire::PLAN_FAULTS;

    /// Records the routes that would have been sent.
    #[derive(Default)]
    struct Recorder {
        sent: Vec<Vec<WireId>>,
    }

    impl Outbox<Plan> for Recorder {
        fn publish(&mut self, fill: &mut dyn FnMut(&mut Plan)) -> Result<u64, TransportError> {
            let mut m = boxed_zeroed::<Plan>();
            fill(&mut m);
            self.sent.push(m.route[..m.route_len as usize].to_vec());
            Ok(self.sent.len() as u64)
        }
        fn refresh(&mut self) {}
    }

    /// A good route 0 → goal, as the service would fill it.
    fn good(goal: WireId) -> impl FnMut(&mut Plan) {
        move |m: &mut Plan| {
            m.route[0] = 0;
            m.route[1] = goal;
            m.route_len = 2;
        }
    }

    #[test]
    fn a_plain_outbox_and_an_empty_cycle_send_the_plan_alone() {
        let mut plain = Recorder::default();
        plain.publish_plan(PlanContext::default(), &mut good(5)).unwrap();
        let mut quiet = FaultyPlans::new(Recorder::default(), FaultCycle::NONE);
        for _ in 0..3 {
            quiet.publish_plan(PlanContext::default(), &mut good(5)).unwrap();
        }
        assert_eq!(plain.sent, vec![vec![0, 5]]);
        assert_eq!(quiet.inner_mut().sent, vec![vec![0, 5]; 3]);
    }

    #[test]
    fn each_bad_plan_goes_before_its_good_one_and_breaks_the_rule_it_names() {
        let inst = random_instance(15, 0.4, 20_000.0, 3);
        let mut snap = WaypointSnapshot::new();
        write_snapshot(&inst, 0, &mut snap).unwrap();
        let goal = inst.goal as WireId;
        let faults = FaultCycle::parse("--inject-plan", "all", &PLAN_FAULTS).unwrap();
        let mut out = FaultyPlans::new(Recorder::default(), faults);
        // Nothing visited at first: the visited-node fault cannot be built
        // then and is used up without a twin.
        let mut ctx = PlanContext {
            snapshot: Some(&snap),
            visited: &[],
        };
        let visited: [WireId; 3] = [0, 7, 3];
        let mut seqs = Vec::new();
        for k in 0..4 {
            if k == 2 {
                ctx.visited = &visited;
            }
            seqs.push(out.publish_plan(ctx, &mut good(goal)).unwrap());
        }
        let sent = &out.inner_mut().sent;
        // non_edge, visited_node (skipped), bad_plan, then non_edge again.
        assert_eq!(sent.len(), 7, "{sent:?}");
        assert_eq!(seqs, vec![2, 3, 5, 7]);
        let (non_edge, bad_plan, non_edge_again) = (&sent[0], &sent[3], &sent[5]);
        assert_eq!((non_edge[0], *non_edge.last().unwrap()), (0, goal));
        assert!(find_edge(&snap, 0, non_edge[1] as usize).is_none());
        assert_eq!(bad_plan, &vec![goal]);
        assert!(find_edge(&snap, 0, non_edge_again[1] as usize).is_none());
        assert!(!visited.contains(&non_edge_again[1]), "{sent:?}");
        // The good plans, unchanged, each right after its twin (if any).
        for i in [1, 2, 4, 6] {
            assert_eq!(sent[i], vec![0, goal]);
        }
        // Without a snapshot no fault can be built; it is used up all the same.
        let mut out = FaultyPlans::new(Recorder::default(), faults);
        out.publish_plan(PlanContext::default(), &mut good(goal)).unwrap();
        out.publish_plan(ctx, &mut good(goal)).unwrap();
        assert_eq!(
            out.inner_mut().sent,
            vec![vec![0, goal], vec![0, 7, goal], vec![0, goal]]
        );
    }
}
