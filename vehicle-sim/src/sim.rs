//! The vehicle's motion and task model, free of transport and clocks: an
//! event-driven simulation advanced to a given mission time.
//!
//! Model: the vehicle follows its plan edge by edge. On an edge it
//! travels at constant speed in 3-D straight towards the *latest reported*
//! position of the next waypoint (the target may move when a snapshot
//! arrives); on reaching it (an *arrival*) it spends the edge's task time
//! there; then it is free and takes the next edge of its plan. Arriving free
//! at the goal ends the mission in success; reaching the time budget before
//! that ends it in failure. With no plan, or a plan that ran out or lost its
//! next edge, it holds position.
//!
//! Contract: [`VehicleSim::step_until`] is exact (arrival and task-end times
//! are computed, not sampled) and deterministic: the same plans and snapshots
//! at the same mission times give bit-identical trajectories, whatever the
//! wall-clock pacing.

use auv_core::capacity::{LARGEST_WORDS, NodeSet as ClassNodeSet};
use auv_core::instance::distance_3d_m as dist;
use auv_core::route::Route as ClassRoute;
use auv_messages::journal::Resume;
use auv_messages::msg::{
    MAX_WIRE_NODES, Outcome, Plan, RejectKind, VehicleEvent, VehicleMode, VehicleState, WaypointSnapshot, WireId,
    route_ids,
};
use auv_messages::network::find_edge;

/// A route of the vehicle: any network the messages carry (the largest class).
pub type Route = ClassRoute<LARGEST_WORDS>;

/// A set of waypoints of any network the messages carry.
type NodeSet = ClassNodeSet<LARGEST_WORDS>;

/// What happened in a step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SimEvent {
    /// Reached waypoint `node`; its task starts.
    Arrival {
        /// The waypoint.
        node: usize,
    },
    /// Finished the task at `node`; free there.
    TaskDone {
        /// The waypoint.
        node: usize,
    },
    /// The mission ended.
    Finished(Outcome),
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// At `to`, free to leave.
    Free,
    /// Travelling from `from` to `to`.
    Travel,
    /// At `to`, working; seconds of task left.
    Task(f64),
}

/// What became of an offered plan that was not refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlanOffer {
    /// Followed from now on.
    Taken,
    /// Set aside: it answered a position the vehicle has left.
    Stale,
}

/// The simulated vehicle.
pub struct VehicleSim {
    net: WaypointSnapshot,
    have_net: bool,
    t: f64,
    pos: [f64; 3],
    from: usize,
    to: usize,
    phase: Phase,
    /// Weight of the current edge's task (ρ/ξ plus the far node's prize),
    /// fixed when the edge was taken.
    edge_weight: f64,
    /// Task time of the current edge, s, fixed when the edge was taken.
    edge_task_s: f64,
    plan: Route,
    /// `plan.get(cursor) == to` while a plan is held.
    cursor: usize,
    has_plan: bool,
    ever_planned: bool,
    plan_seq: u64,
    route: Route,
    visited: NodeSet,
    arrivals: u32,
    tasks: u32,
    weight: f64,
    distance_m: f64,
    outcome: Outcome,
    stale_plans: u32,
    /// A safe hold was asked for: no more plans; the mission ends at the
    /// next waypoint.
    holding: bool,
}

impl Default for VehicleSim {
    fn default() -> Self {
        Self::new()
    }
}

impl VehicleSim {
    /// A vehicle that knows no network yet.
    pub fn new() -> Self {
        Self {
            net: WaypointSnapshot::new(),
            have_net: false,
            t: 0.0,
            pos: [0.0; 3],
            from: 0,
            to: 0,
            phase: Phase::Free,
            edge_weight: 0.0,
            edge_task_s: 0.0,
            plan: Route::new(),
            cursor: 0,
            has_plan: false,
            ever_planned: false,
            plan_seq: 0,
            route: Route::new(),
            visited: NodeSet::EMPTY,
            arrivals: 0,
            tasks: 0,
            weight: 0.0,
            distance_m: 0.0,
            outcome: Outcome::Running,
            stale_plans: 0,
            holding: false,
        }
    }

    /// Applies a validated snapshot. The first one places the vehicle at the start.
    pub fn apply_snapshot(&mut self, s: &WaypointSnapshot) {
        if self.net.copy_snapshot(s).is_err() {
            // Cannot happen: both buffers hold the largest network.
            return;
        }
        if !self.have_net {
            self.have_net = true;
            let start = s.start as usize;
            self.from = start;
            self.to = start;
            self.pos = self.node_pos(start);
            self.route.clear();
            self.route.push(start);
            self.visited = NodeSet::EMPTY;
            self.visited.insert(start);
        }
    }

    /// Whether a snapshot has been applied.
    pub fn has_network(&self) -> bool {
        self.have_net
    }

    /// Epoch of the latest snapshot applied.
    pub fn epoch(&self) -> u64 {
        self.net.epoch
    }

    /// Mission time of the sensor's next update, as the latest snapshot announced it, s.
    pub fn epoch_next_update(&self) -> f64 {
        self.net.next_update_s
    }

    /// Mission time, s.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// How the mission stands.
    pub fn outcome(&self) -> Outcome {
        self.outcome
    }

    fn node_pos(&self, i: usize) -> [f64; 3] {
        let n = &self.net.nodes[i];
        [n.x, n.y, n.z]
    }

    fn goal(&self) -> usize {
        self.net.goal as usize
    }

    fn budget(&self) -> f64 {
        self.net.time_available_s
    }

    /// Offers a validated plan. It is taken when it starts where the vehicle
    /// will be free, ends at the goal, and uses only edges of the latest
    /// snapshot and waypoints not yet visited. It is set aside as stale,
    /// not refused, when it answers a position the vehicle has since left
    /// (it starts at a waypoint already visited: at speed, the vehicle can
    /// arrive and move on while the plan is on its way) or comes after the
    /// mission ended. Otherwise it is refused: `NodeOutOfRange`, `BadPlan`
    /// (no snapshot yet, wrong start, or not ending at the goal), `NonEdge`
    /// or `VisitedNode`.
    pub fn offer_plan(&mut self, p: &Plan) -> Result<PlanOffer, RejectKind> {
        let ids = route_ids(&p.route, p.route_len);
        let verdict = self.check_plan(ids);
        match verdict {
            Ok(PlanOffer::Taken) => {
                self.plan = Route::new();
                for &id in ids {
                    self.plan.push(id as usize);
                }
                self.cursor = 0;
                self.has_plan = true;
                self.ever_planned = true;
                self.plan_seq = p.header.seq;
            }
            Ok(PlanOffer::Stale) => self.stale_plans += 1,
            Err(_) => {}
        }
        verdict
    }

    fn check_plan(&self, ids: &[WireId]) -> Result<PlanOffer, RejectKind> {
        if !self.have_net {
            return Err(RejectKind::BadPlan);
        }
        let n = (self.net.node_count as usize).min(MAX_WIRE_NODES);
        if ids.iter().any(|&id| id as usize >= n) {
            return Err(RejectKind::NodeOutOfRange);
        }
        if self.outcome != Outcome::Running || self.holding {
            return Ok(PlanOffer::Stale);
        }
        let first = ids.first().map(|&id| id as usize);
        if first != Some(self.to) {
            return match first {
                Some(f) if self.visited.contains(f) => Ok(PlanOffer::Stale),
                _ => Err(RejectKind::BadPlan),
            };
        }
        if ids.last().map(|&id| id as usize) != Some(self.goal()) {
            return Err(RejectKind::BadPlan);
        }
        let mut seen: NodeSet = NodeSet::EMPTY;
        for (k, &id) in ids.iter().enumerate() {
            let id = id as usize;
            if seen.contains(id) || (k > 0 && self.visited.contains(id)) {
                return Err(RejectKind::VisitedNode);
            }
            seen.insert(id);
            if k > 0 && find_edge(&self.net, ids[k - 1] as usize, id).is_none() {
                return Err(RejectKind::NonEdge);
            }
        }
        Ok(PlanOffer::Taken)
    }

    /// Mission time of the next event if nothing changes, s (∞ while holding
    /// with time to spare: only the budget ends a hold).
    pub fn next_event_time(&self) -> f64 {
        if self.outcome != Outcome::Running || !self.have_net {
            return f64::INFINITY;
        }
        let t = match self.phase {
            Phase::Free => {
                if self.to == self.goal() || self.holding || self.next_edge().is_some() {
                    self.t
                } else {
                    f64::INFINITY
                }
            }
            Phase::Travel => self.t + dist(self.pos, self.node_pos(self.to)) / self.net.speed_mps,
            Phase::Task(_) if self.holding => self.t,
            Phase::Task(rem) => self.t + rem,
        };
        t.min(self.budget())
    }

    fn next_edge(&self) -> Option<(usize, f64, f64)> {
        if !self.has_plan || self.cursor + 1 >= self.plan.len() {
            return None;
        }
        let w = self.plan.get(self.cursor + 1);
        let e = find_edge(&self.net, self.to, w)?;
        let prize = self.net.nodes[w].prize;
        Some((w, e.task_time_s, e.priority / e.risk + prize))
    }

    /// Advances to `t_target` or to the next event, whichever comes first.
    /// Returns the event, or `None` when `t_target` was reached quietly.
    pub fn step_until(&mut self, t_target: f64) -> Option<SimEvent> {
        if self.outcome != Outcome::Running || !self.have_net {
            return None;
        }
        let end = t_target.min(self.budget());
        loop {
            match self.phase {
                Phase::Free => {
                    if self.to == self.goal() {
                        self.outcome = Outcome::GoalReached;
                        return Some(SimEvent::Finished(Outcome::GoalReached));
                    }
                    if self.holding {
                        return Some(self.end_in_hold());
                    }
                    if let Some((w, task_s, weight)) = self.next_edge() {
                        self.from = self.to;
                        self.to = w;
                        self.cursor += 1;
                        self.edge_weight = weight;
                        self.edge_task_s = task_s;
                        self.phase = Phase::Travel;
                        continue;
                    }
                    if self.has_plan {
                        // Plan ran out, or its next edge vanished: hold.
                        self.has_plan = false;
                    }
                    return self.wait_until(end);
                }
                Phase::Travel => {
                    let target = self.node_pos(self.to);
                    let d = dist(self.pos, target);
                    let t_arrive = self.t + d / self.net.speed_mps;
                    if t_arrive <= end {
                        self.t = t_arrive;
                        self.pos = target;
                        self.distance_m += d;
                        self.arrivals += 1;
                        self.route.push(self.to);
                        self.visited.insert(self.to);
                        self.phase = Phase::Task(self.edge_task_s);
                        return Some(SimEvent::Arrival { node: self.to });
                    }
                    let frac = (end - self.t) * self.net.speed_mps / d;
                    for (p, q) in self.pos.iter_mut().zip(target) {
                        *p += (q - *p) * frac;
                    }
                    self.distance_m += (end - self.t) * self.net.speed_mps;
                    return self.wait_until(end);
                }
                Phase::Task(_) if self.holding => {
                    // Holding: the task there is left undone.
                    self.phase = Phase::Free;
                    return Some(self.end_in_hold());
                }
                Phase::Task(rem) => {
                    if self.t + rem <= end {
                        self.t += rem;
                        self.tasks += 1;
                        self.weight += self.edge_weight;
                        self.phase = Phase::Free;
                        return Some(SimEvent::TaskDone { node: self.to });
                    }
                    self.phase = Phase::Task(rem - (end - self.t));
                    return self.wait_until(end);
                }
            }
        }
    }

    /// Moves the clock to `end` (motion already applied); reports a time-out
    /// when `end` is the budget.
    fn wait_until(&mut self, end: f64) -> Option<SimEvent> {
        self.t = self.t.max(end);
        if self.t >= self.budget() {
            self.outcome = Outcome::TimedOut;
            return Some(SimEvent::Finished(Outcome::TimedOut));
        }
        None
    }

    /// Picks up where an earlier vehicle process left off (after the first
    /// snapshot): at the last waypoint it arrived at, at the mission time of
    /// its last journal event, with its totals, visited waypoints, the task
    /// it had started there (redone in full) and its last plan, when that
    /// plan still passes through here.
    pub fn resume(&mut self, r: &Resume) {
        let Some(&here) = r.route.last() else { return };
        let n = (self.net.node_count as usize).min(MAX_WIRE_NODES);
        if !self.have_net || here >= n || r.route.iter().any(|&i| i >= n) {
            return;
        }
        self.t = r.t;
        self.from = here;
        self.to = here;
        self.pos = self.node_pos(here);
        self.route.clear();
        self.visited = NodeSet::EMPTY;
        for &i in &r.route {
            self.route.push(i);
            self.visited.insert(i);
        }
        self.arrivals = r.route.len().saturating_sub(1) as u32;
        self.tasks = r.tasks;
        self.weight = r.weight;
        self.distance_m = r.distance_m;
        self.phase = match r.pending_task {
            Some((task_s, weight)) => {
                self.edge_task_s = task_s;
                self.edge_weight = weight;
                Phase::Task(task_s)
            }
            None => Phase::Free,
        };
        self.has_plan = false;
        if let Some((seq, plan)) = &r.plan {
            self.ever_planned = true;
            if let Some(k) = plan.iter().position(|&i| i == here)
                && plan.iter().all(|&i| i < n)
            {
                self.plan = Route::new();
                for &i in plan {
                    self.plan.push(i);
                }
                self.cursor = k;
                self.has_plan = true;
                self.plan_seq = *seq;
            }
        }
    }

    /// The task of the current edge: (duration s, weight).
    pub fn current_task(&self) -> (f64, f64) {
        (self.edge_task_s, self.edge_weight)
    }

    /// Position (x east, y north, z depth down), m.
    pub fn position(&self) -> [f64; 3] {
        self.pos
    }

    /// The plan held (empty when none).
    pub fn plan(&self) -> &[u16] {
        if self.has_plan { self.plan.ids() } else { &[] }
    }

    /// Asks for a safe hold: the vehicle takes no more plans, goes on to the
    /// waypoint it is heading for, and ends the mission there
    /// ([`Outcome::SafeHold`]).
    pub fn hold(&mut self) {
        if self.outcome == Outcome::Running {
            self.holding = true;
            self.has_plan = false;
        }
    }

    fn end_in_hold(&mut self) -> SimEvent {
        self.outcome = Outcome::SafeHold;
        SimEvent::Finished(Outcome::SafeHold)
    }

    /// The waypoint the vehicle is at or heading for.
    pub fn next_waypoint(&self) -> usize {
        self.to
    }

    /// Ends the mission from outside (Ctrl-C).
    pub fn abort(&mut self) {
        if self.outcome == Outcome::Running {
            self.outcome = Outcome::Aborted;
        }
    }

    /// Writes the state message for `event` (header's mission time included).
    pub fn fill_state(&self, event: VehicleEvent, time_scale: f64, needs_answer: bool, m: &mut VehicleState) {
        m.header.mission_time_s = self.t;
        m.position = self.pos;
        m.time_left_s = (self.budget() - self.t).max(0.0);
        m.eta_free_s = match self.phase {
            Phase::Free => 0.0,
            Phase::Travel => dist(self.pos, self.node_pos(self.to)) / self.net.speed_mps + self.edge_task_s,
            Phase::Task(rem) => rem,
        };
        m.weight = self.weight;
        m.distance_m = self.distance_m;
        m.time_scale = time_scale;
        m.plan_seq = if self.has_plan { self.plan_seq } else { 0 };
        m.snapshot_epoch = self.net.epoch;
        m.mode = self.mode() as u32;
        m.event = event as u32;
        m.outcome = self.outcome as u32;
        m.from_node = self.from as u32;
        m.to_node = self.to as u32;
        m.arrivals = self.arrivals;
        m.tasks_completed = self.tasks;
        m.needs_answer = u32::from(needs_answer);
        m.stale_plans = self.stale_plans;
        m.route_len = self.route.len() as u32;
        let ids = self.route.ids();
        m.route[..ids.len()].copy_from_slice(ids);
    }

    /// What the vehicle is doing.
    pub fn mode(&self) -> VehicleMode {
        if self.outcome != Outcome::Running {
            return VehicleMode::Finished;
        }
        match self.phase {
            Phase::Travel => VehicleMode::Travelling,
            Phase::Task(_) => VehicleMode::Working,
            Phase::Free if !self.ever_planned => VehicleMode::NoPlan,
            Phase::Free => VehicleMode::Holding,
        }
    }

    /// Waypoints visited, in order.
    pub fn route(&self) -> &Route {
        &self.route
    }

    /// (tasks completed, weight, distance m).
    pub fn totals(&self) -> (u32, f64, f64) {
        (self.tasks, self.weight, self.distance_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_core::fixtures::line_instance;
    use auv_messages::msg::{boxed_zeroed, plan_through};
    use auv_messages::network::write_snapshot;

    fn net() -> WaypointSnapshot {
        // 0 - 1 - 2 - 3 on a line 100 m apart (+ shortcut 0 - 3), 1 m/s,
        // tasks 10 s, budget 1000 s.
        let mut s = WaypointSnapshot::new();
        write_snapshot(&line_instance(), 0, &mut s).unwrap();
        s
    }

    fn run_to_end(v: &mut VehicleSim) -> Vec<(f64, SimEvent)> {
        let mut out = Vec::new();
        while let Some(e) = v.step_until(f64::INFINITY) {
            out.push((v.time(), e));
            if matches!(e, SimEvent::Finished(_)) {
                break;
            }
        }
        out
    }

    #[test]
    fn follows_the_plan_with_exact_arrival_and_task_times() {
        let mut v = VehicleSim::new();
        v.apply_snapshot(&net());
        v.offer_plan(&plan_through(&[0, 1, 2, 3], 1)).unwrap();
        let ev = run_to_end(&mut v);
        assert_eq!(
            ev,
            vec![
                (100.0, SimEvent::Arrival { node: 1 }),
                (110.0, SimEvent::TaskDone { node: 1 }),
                (210.0, SimEvent::Arrival { node: 2 }),
                (220.0, SimEvent::TaskDone { node: 2 }),
                (320.0, SimEvent::Arrival { node: 3 }),
                (330.0, SimEvent::TaskDone { node: 3 }),
                (330.0, SimEvent::Finished(Outcome::GoalReached)),
            ]
        );
        let (tasks, weight, d) = v.totals();
        assert_eq!((tasks, d), (3, 300.0));
        assert_eq!(weight, 2.0 / 0.5 + 3.0 / 0.5 + 4.0 / 0.5);
        assert_eq!(v.route().to_vec(), vec![0, 1, 2, 3]);
    }

    #[test]
    fn a_safe_hold_ends_the_mission_at_the_next_waypoint_and_refuses_new_plans() {
        let mut v = VehicleSim::new();
        v.apply_snapshot(&net());
        v.offer_plan(&plan_through(&[0, 1, 2, 3], 1)).unwrap();
        assert_eq!(v.step_until(50.0), None);
        v.hold();
        assert_eq!(v.next_waypoint(), 1);
        assert_eq!(v.offer_plan(&plan_through(&[1, 2, 3], 2)), Ok(PlanOffer::Stale));
        let ev = run_to_end(&mut v);
        assert_eq!(
            ev,
            vec![
                (100.0, SimEvent::Arrival { node: 1 }),
                (100.0, SimEvent::Finished(Outcome::SafeHold)),
            ]
        );
        assert_eq!(v.outcome(), Outcome::SafeHold);
        assert_eq!(v.totals().0, 0, "the task at the hold is left undone");
        assert_eq!(v.route().to_vec(), vec![0, 1]);
    }

    #[test]
    fn holds_without_a_plan_and_times_out() {
        let mut v = VehicleSim::new();
        v.apply_snapshot(&net());
        assert_eq!(v.mode(), VehicleMode::NoPlan);
        assert_eq!(v.step_until(500.0), None);
        assert_eq!(v.time(), 500.0);
        assert_eq!(v.step_until(5000.0), Some(SimEvent::Finished(Outcome::TimedOut)));
        assert_eq!(v.time(), 1000.0);
        let mut m = *boxed_zeroed::<VehicleState>();
        v.fill_state(VehicleEvent::Finished, 0.0, false, &mut m);
        assert_eq!(m.mode, VehicleMode::Finished as u32);
        assert_eq!(m.outcome, Outcome::TimedOut as u32);
        assert_eq!(m.time_left_s, 0.0);
    }

    #[test]
    fn rejects_plans_that_do_not_fit() {
        let mut v = VehicleSim::new();
        v.apply_snapshot(&net());
        assert_eq!(
            v.offer_plan(&plan_through(&[1, 2, 3], 1)),
            Err(RejectKind::BadPlan),
            "wrong start"
        );
        assert_eq!(
            v.offer_plan(&plan_through(&[0, 2, 3], 2)),
            Err(RejectKind::NonEdge),
            "0-2 is no edge"
        );
        assert_eq!(
            v.offer_plan(&plan_through(&[0, 1, 2], 3)),
            Err(RejectKind::BadPlan),
            "not at the goal"
        );
        assert_eq!(
            v.offer_plan(&plan_through(&[0, 9, 3], 4)),
            Err(RejectKind::NodeOutOfRange)
        );
        v.offer_plan(&plan_through(&[0, 1, 2, 3], 5)).unwrap();
        assert_eq!(v.step_until(105.0), Some(SimEvent::Arrival { node: 1 }));
        assert_eq!(v.step_until(105.0), None); // working at 1 until 110
        assert_eq!(
            v.offer_plan(&plan_through(&[1, 0, 3], 6)),
            Err(RejectKind::VisitedNode),
            "0 visited"
        );
        // Planned from 0, which the vehicle has left: stale, not refused.
        assert_eq!(v.offer_plan(&plan_through(&[0, 2, 3], 8)), Ok(PlanOffer::Stale));
        assert_eq!(v.offer_plan(&plan_through(&[1, 2, 3], 7)), Ok(PlanOffer::Taken));
        let mut m = *boxed_zeroed::<VehicleState>();
        v.fill_state(VehicleEvent::Periodic, 1000.0, false, &mut m);
        assert_eq!(m.stale_plans, 1);
        assert_eq!(m.plan_seq, 7);
        assert_eq!(m.eta_free_s, 5.0);
        assert_eq!(m.mode, VehicleMode::Working as u32);
    }

    #[test]
    fn a_moving_target_is_tracked_and_a_lost_edge_makes_it_hold() {
        let mut v = VehicleSim::new();
        v.apply_snapshot(&net());
        v.offer_plan(&plan_through(&[0, 1, 2, 3], 1)).unwrap();
        assert_eq!(v.step_until(50.0), None);
        // Node 1 moves 100 m further: the vehicle turns towards it.
        let mut moved = net();
        moved.nodes[1].x = 200.0;
        moved.epoch = 1;
        v.apply_snapshot(&moved);
        assert_eq!(v.step_until(1e9), Some(SimEvent::Arrival { node: 1 }));
        assert_eq!(v.time(), 200.0);
        // Edge 1-2 disappears: after the task the vehicle holds.
        let mut cut = moved.clone();
        cut.edges[1] = cut.edges[3];
        cut.edge_count = 3;
        v.apply_snapshot(&cut);
        assert_eq!(v.step_until(1e9), Some(SimEvent::TaskDone { node: 1 }));
        assert_eq!(v.step_until(300.0), None);
        assert_eq!(v.mode(), VehicleMode::Holding);
    }

    #[test]
    fn a_resumed_vehicle_continues_from_its_last_arrival_with_its_plan() {
        // The original run, stopped while travelling 1 → 2.
        let mut a = VehicleSim::new();
        a.apply_snapshot(&net());
        a.offer_plan(&plan_through(&[0, 1, 2, 3], 1)).unwrap();
        assert_eq!(a.step_until(1e9), Some(SimEvent::Arrival { node: 1 }));
        let (task_s, task_w) = a.current_task();
        assert_eq!(a.step_until(1e9), Some(SimEvent::TaskDone { node: 1 }));
        assert_eq!(a.step_until(150.0), None);
        // What the journal would say: arrived at 1 at 100 s, task done at 110 s.
        let r = Resume {
            t: 110.0,
            route: vec![0, 1],
            tasks: 1,
            weight: task_w,
            distance_m: 100.0,
            pending_task: None,
            plan: Some((1, vec![0, 1, 2, 3])),
        };
        let mut b = VehicleSim::new();
        b.apply_snapshot(&net());
        b.resume(&r);
        assert_eq!(b.time(), 110.0);
        assert_eq!(b.position(), [100.0, 0.0, 0.0]);
        assert_eq!(b.plan(), &[0, 1, 2, 3]);
        let ev = run_to_end(&mut b);
        assert_eq!(ev.last(), Some(&(330.0, SimEvent::Finished(Outcome::GoalReached))));
        assert_eq!(b.route().to_vec(), vec![0, 1, 2, 3]);
        assert_eq!(b.totals().0, 3);
        // Stopped during the task at 1: the task is redone, then the plan goes on.
        let mut c = VehicleSim::new();
        c.apply_snapshot(&net());
        c.resume(&Resume {
            t: 100.0,
            tasks: 0,
            weight: 0.0,
            pending_task: Some((task_s, task_w)),
            ..r
        });
        assert_eq!(c.mode(), VehicleMode::Working);
        assert_eq!(c.step_until(1e9), Some(SimEvent::TaskDone { node: 1 }));
        assert_eq!(c.time(), 100.0 + task_s);
        assert_eq!(c.totals().1, task_w);
        assert_eq!(c.step_until(1e9), Some(SimEvent::Arrival { node: 2 }));
        // Without a plan through here it holds (and may take a new one).
        let mut d = VehicleSim::new();
        d.apply_snapshot(&net());
        d.resume(&Resume {
            t: 110.0,
            route: vec![0, 1],
            tasks: 1,
            weight: task_w,
            distance_m: 100.0,
            pending_task: None,
            plan: Some((1, vec![0, 3])),
        });
        assert_eq!(d.step_until(200.0), None);
        assert_eq!(d.mode(), VehicleMode::Holding);
        d.offer_plan(&plan_through(&[1, 2, 3], 2)).unwrap();
        assert_eq!(
            d.offer_plan(&plan_through(&[1, 0, 3], 3)),
            Err(RejectKind::VisitedNode),
            "0 visited"
        );
    }
}
