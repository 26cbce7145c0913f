//! The waypoint snapshot as a routing network: conversions between the wire
//! form ([`WaypointSnapshot`]), the interchange form ([`Instance`]) and the
//! solvers' form ([`Problem`]).
//!
//! Contract: [`fill_problem`] refills a problem from a snapshot without
//! allocating (it is on the re-planning path) and computes every figure the
//! way `instance-format.md` defines it, through [`Problem`]'s own
//! `set_edge`/[`edge_time_s`]; [`write_snapshot`] and [`to_instance`] are
//! exact inverses for valid instances (tested).

use crate::msg::{MAX_WIRE_NODES, ObjectiveCode, SnapshotHead, WaypointSnapshot, WireEdge, WireNode};
use auv_core::instance::{Edge, Instance, Node, Objective};
use auv_core::problem::{NodeSet, Problem, ProblemError, edge_time_s};

/// Why an instance does not fit a snapshot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SnapshotError {
    /// More nodes than [`MAX_WIRE_NODES`].
    #[error("{0} waypoints exceed the message capacity of {MAX_WIRE_NODES}")]
    TooManyNodes(usize),
    /// More edges than the snapshot buffer holds.
    #[error("{0} edges exceed the snapshot's capacity of {1}")]
    TooManyEdges(usize, usize),
}

/// Edges a snapshot of an `n`-node network can carry at most (every pair):
/// what a publisher sizes its samples for.
pub fn max_edges_of(n: usize) -> usize {
    n * n.saturating_sub(1) / 2
}

/// Writes `inst` into `out` (header untouched; `epoch` set).
pub fn write_snapshot(inst: &Instance, epoch: u64, out: &mut WaypointSnapshot) -> Result<(), SnapshotError> {
    if inst.nodes.len() > MAX_WIRE_NODES {
        return Err(SnapshotError::TooManyNodes(inst.nodes.len()));
    }
    if inst.edges.len() > out.capacity() {
        return Err(SnapshotError::TooManyEdges(inst.edges.len(), out.capacity()));
    }
    out.epoch = epoch;
    out.speed_mps = inst.speed_mps;
    out.time_available_s = inst.time_available_s;
    match inst.objective {
        Objective::MaxWeight => {
            out.objective = ObjectiveCode::MaxWeight as u32;
            out.phi1 = 0.0;
            out.phi2 = 0.0;
        }
        Objective::PaperCost { phi1, phi2 } => {
            out.objective = ObjectiveCode::PaperCost as u32;
            out.phi1 = phi1;
            out.phi2 = phi2;
        }
    }
    out.node_count = inst.nodes.len() as u32;
    out.edge_count = inst.edges.len() as u32;
    out.start = inst.start as u32;
    out.goal = inst.goal as u32;
    for (w, n) in out.nodes.iter_mut().zip(&inst.nodes) {
        *w = WireNode {
            x: n.x,
            y: n.y,
            z: n.z,
            prize: n.prize,
        };
    }
    for (w, e) in out.edges.iter_mut().zip(&inst.edges) {
        *w = WireEdge {
            a: e.a as u32,
            b: e.b as u32,
            priority: e.priority,
            risk: e.risk,
            task_time_s: e.task_time_s,
        };
    }
    Ok(())
}

/// The objective a (validated) snapshot states.
pub fn objective(s: &SnapshotHead) -> Objective {
    if s.objective == ObjectiveCode::PaperCost as u32 {
        Objective::PaperCost {
            phi1: s.phi1,
            phi2: s.phi2,
        }
    } else {
        Objective::MaxWeight
    }
}

/// The snapshot as an instance (reports, plots, export; allocates).
pub fn to_instance(s: &WaypointSnapshot, name: &str) -> Instance {
    let n = (s.node_count as usize).min(MAX_WIRE_NODES);
    Instance {
        name: name.to_string(),
        speed_mps: s.speed_mps,
        time_available_s: s.time_available_s,
        start: s.start as usize,
        goal: s.goal as usize,
        nodes: s.nodes[..n]
            .iter()
            .map(|w| Node {
                x: w.x,
                y: w.y,
                z: w.z,
                prize: w.prize,
            })
            .collect(),
        edges: s
            .edges_in_use()
            .iter()
            .map(|e| Edge {
                a: e.a as usize,
                b: e.b as usize,
                priority: e.priority,
                risk: e.risk,
                task_time_s: e.task_time_s,
            })
            .collect(),
        objective: objective(s),
    }
}

/// 3-D distance between two waypoints of a snapshot, m.
#[inline]
pub fn distance_m(s: &SnapshotHead, a: usize, b: usize) -> f64 {
    let (p, q) = (&s.nodes[a], &s.nodes[b]);
    auv_core::instance::distance_3d_m([p.x, p.y, p.z], [q.x, q.y, q.z])
}

/// Refills `p` from a validated snapshot, starting at `start` with
/// `budget_s` left and `excluded` nodes removed. Each edge's time is the
/// format's plus half the arrival allowance of each end (zeros give exactly
/// the format's figures). Does not allocate.
/// `arrival_allowance_s` has an entry per node (a missing entry counts 0).
pub fn fill_problem<const W: usize>(
    s: &WaypointSnapshot,
    p: &mut Problem<W>,
    start: usize,
    excluded: NodeSet<W>,
    budget_s: f64,
    arrival_allowance_s: &[f64],
) -> Result<(), ProblemError> {
    let n = (s.node_count as usize).min(MAX_WIRE_NODES);
    p.begin(n, start, s.goal as usize, budget_s, objective(s), excluded)?;
    for (i, w) in s.nodes[..n].iter().enumerate() {
        p.set_prize(i, w.prize);
    }
    let allowance_of = |i: usize| arrival_allowance_s.get(i).copied().unwrap_or(0.0);
    for e in s.edges_in_use() {
        let (a, b) = (e.a as usize, e.b as usize);
        let d = distance_m(s, a, b);
        let allowance = 0.5 * (allowance_of(a) + allowance_of(b));
        let time = edge_time_s(d, s.speed_mps, e.task_time_s) + allowance;
        p.set_edge(a, b, d, time, e.priority, e.risk);
    }
    p.finish()
}

/// The edge `a`–`b` of a snapshot, if it exists (linear scan: the vehicle's
/// per-arrival look-up, not a solver path).
pub fn find_edge(s: &WaypointSnapshot, a: usize, b: usize) -> Option<&WireEdge> {
    let (a, b) = (a as u32, b as u32);
    s.edges_in_use()
        .iter()
        .find(|e| (e.a == a && e.b == b) || (e.a == b && e.b == a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::Validate;
    use auv_core::fixtures::{line_instance, random_instance};
    use auv_core::route::{Route, RouteStats};

    #[test]
    fn instance_round_trips_through_a_snapshot() {
        let inst = random_instance(20, 0.3, 5000.0, 3);
        let mut s = WaypointSnapshot::new();
        write_snapshot(&inst, 4, &mut s).unwrap();
        s.header.seq = 1;
        assert_eq!(s.validate(), Ok(()));
        let back = to_instance(&s, &inst.name);
        assert_eq!(back, inst);
        assert_eq!(s.epoch, 4);
    }

    #[test]
    fn problem_from_snapshot_equals_problem_from_instance() {
        let inst = random_instance(30, 0.25, 8000.0, 11);
        let mut s = WaypointSnapshot::new();
        write_snapshot(&inst, 0, &mut s).unwrap();
        let mut from_msg: Problem = Problem::new();
        let mut ex = NodeSet::EMPTY;
        ex.insert(3);
        fill_problem(&s, &mut from_msg, 0, ex, 6000.0, &[]).unwrap();
        let mut from_inst = Problem::new();
        from_inst.load_instance(&inst, 0, ex, 6000.0).unwrap();
        for a in 0..30 {
            assert_eq!(from_msg.neighbours(a), from_inst.neighbours(a));
            for b in 0..30 {
                assert_eq!(from_msg.time_s(a, b).to_bits(), from_inst.time_s(a, b).to_bits());
                assert_eq!(from_msg.gain(a, b).to_bits(), from_inst.gain(a, b).to_bits());
            }
        }
    }

    #[test]
    fn route_figures_on_the_snapshot_problem_match_the_checker() {
        let inst = line_instance();
        let mut s = WaypointSnapshot::new();
        write_snapshot(&inst, 0, &mut s).unwrap();
        let mut p: Problem = Problem::new();
        fill_problem(&s, &mut p, 0, NodeSet::EMPTY, inst.time_available_s, &[]).unwrap();
        let r = Route::from_slice(&[0, 1, 2, 3]).unwrap();
        let e = p.evaluate(&r).unwrap();
        let c = RouteStats::from_instance(&inst, &[0, 1, 2, 3]).unwrap();
        assert_eq!(e.time_s, c.time_s);
        assert_eq!(e.weight, c.weight);
        assert!(find_edge(&s, 2, 1).is_some());
        assert!(find_edge(&s, 0, 2).is_none());
    }

    #[test]
    fn oversized_instances_are_refused() {
        let mut inst = line_instance();
        inst.nodes = vec![inst.nodes[0]; MAX_WIRE_NODES + 1];
        let mut s = WaypointSnapshot::new();
        assert_eq!(
            write_snapshot(&inst, 0, &mut s),
            Err(SnapshotError::TooManyNodes(MAX_WIRE_NODES + 1))
        );
        let inst = line_instance();
        let mut small = WaypointSnapshot::with_capacity(1);
        assert_eq!(
            write_snapshot(&inst, 0, &mut small),
            Err(SnapshotError::TooManyEdges(inst.edges.len(), 1))
        );
    }
}
