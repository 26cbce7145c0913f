//! Routes and their figures.
//!
//! [`Route`] is a fixed-capacity node sequence (no heap). [`RouteEval`] holds
//! the figures a solver tracks while it builds a route on a [`Problem`];
//! [`RouteStats::from_instance`] recomputes every reported figure from an
//! [`Instance`] and a route alone, the way an outside checker does
//! (`instance-format.md`, "Derived quantities"). Tests hold the two equal.

use crate::capacity::{DEFAULT_WORDS, PerNode, nodes_of};
use crate::instance::{Instance, Objective};
use crate::problem::{FEASIBILITY_REL_TOL, NodeSet, Problem};

/// A node sequence of at most `64 · W` ids (the capacity class, see
/// [`crate::capacity`]). Equality compares the sequences only (entries past
/// `len` are scratch).
#[derive(Clone, Copy)]
pub struct Route<const W: usize = DEFAULT_WORDS> {
    nodes: PerNode<u16, W>,
    len: usize,
}

const _: () = assert!(crate::capacity::LARGEST_NODES <= 1 << 16, "node ids are stored as u16");

impl<const W: usize> Route<W> {
    /// Most nodes a route of this class holds.
    pub const CAPACITY: usize = nodes_of(W);

    /// The empty route.
    pub const fn new() -> Self {
        Self {
            nodes: PerNode::splat(0),
            len: 0,
        }
    }

    /// Builds a route from ids; `None` when there are more than the class
    /// holds or an id does not fit.
    pub fn from_slice(ids: &[usize]) -> Option<Self> {
        if ids.len() > Self::CAPACITY {
            return None;
        }
        let mut r = Self::new();
        for &id in ids {
            if id >= Self::CAPACITY {
                return None;
            }
            r.push(id);
        }
        Some(r)
    }

    /// The same route in the class of `V` words; `None` when it does not fit.
    pub fn to_class<const V: usize>(&self) -> Option<Route<V>> {
        if self.len > Route::<V>::CAPACITY || self.ids().iter().any(|&id| id as usize >= Route::<V>::CAPACITY) {
            return None;
        }
        let mut r = Route::<V>::new();
        r.nodes[..self.len].copy_from_slice(self.ids());
        r.len = self.len;
        Some(r)
    }

    /// Appends `id` (caller keeps len within the class, which a simple path does).
    #[inline]
    pub fn push(&mut self, id: usize) {
        self.nodes[self.len] = id as u16;
        self.len += 1;
    }

    /// Drops everything after the first `len` nodes.
    #[inline]
    pub fn truncate(&mut self, len: usize) {
        self.len = self.len.min(len);
    }

    /// Empties the route.
    #[inline]
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Number of nodes.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the route has no nodes.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Node at position `i`.
    #[inline]
    pub fn get(&self, i: usize) -> usize {
        self.nodes[i] as usize
    }

    /// Last node, if any.
    #[inline]
    pub fn last(&self) -> Option<usize> {
        self.len.checked_sub(1).map(|i| self.get(i))
    }

    /// The ids in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = usize> + '_ {
        self.nodes[..self.len].iter().map(|&b| b as usize)
    }

    /// The ids in order, as stored.
    #[inline]
    pub fn ids(&self) -> &[u16] {
        &self.nodes[..self.len]
    }

    /// Inserts `id` at position `i ≤ len`, shifting the rest back (caller
    /// keeps len below the class's capacity).
    #[inline]
    pub fn insert(&mut self, i: usize, id: usize) {
        self.nodes.copy_within(i..self.len, i + 1);
        self.nodes[i] = id as u16;
        self.len += 1;
    }

    /// Removes the node at position `i < len`.
    #[inline]
    pub fn remove(&mut self, i: usize) {
        self.nodes.copy_within(i + 1..self.len, i);
        self.len -= 1;
    }

    /// Reverses the positions `i..=j` (`i ≤ j < len`).
    #[inline]
    pub fn reverse(&mut self, i: usize, j: usize) {
        self.nodes[i..=j].reverse();
    }

    /// Moves the `l` nodes at positions `i..i + l` to stand right after the
    /// node now at position `k` (outside the segment), reversed when `rev`.
    pub fn relocate(&mut self, i: usize, l: usize, k: usize, rev: bool) {
        debug_assert!(l <= 3 && !(i..i + l).contains(&k) && k + 1 != i);
        let mut seg = [0u16; 3];
        seg[..l].copy_from_slice(&self.nodes[i..i + l]);
        if rev {
            seg[..l].reverse();
        }
        if k < i {
            // Shift k+1..i back by l, then place the segment after k.
            self.nodes.copy_within(k + 1..i, k + 1 + l);
            self.nodes[k + 1..k + 1 + l].copy_from_slice(&seg[..l]);
        } else {
            // Shift i+l..=k forward by l, then place the segment before k+1.
            self.nodes.copy_within(i + l..k + 1, i);
            self.nodes[k + 1 - l..k + 1].copy_from_slice(&seg[..l]);
        }
    }

    /// Copies the ids into a `Vec` (reporting, not hot paths).
    pub fn to_vec(&self) -> Vec<usize> {
        self.iter().collect()
    }
}

impl<const W: usize> Default for Route<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> PartialEq for Route<W> {
    fn eq(&self, other: &Self) -> bool {
        self.ids() == other.ids()
    }
}

impl<const W: usize> Eq for Route<W> {}

impl<const W: usize> core::fmt::Debug for Route<W> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

/// Figures of a route on a [`Problem`], accumulated edge by edge.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RouteEval {
    /// Route time T_R, s.
    pub time_s: f64,
    /// Route distance D_R, m.
    pub distance_m: f64,
    /// Route weight W_R = Σ ρ/ξ + Σ prize.
    pub weight: f64,
    /// Σ ξ/ρ over the edges (paper_cost's risk term).
    pub risk_ratio_sum: f64,
    /// Edges travelled (each carries one task).
    pub tasks: u32,
    /// T_R within the budget (with the format's tolerance).
    pub feasible: bool,
}

impl RouteEval {
    /// The paper's cost φ1·|T_R − T_available| + φ2·Σ ξ/ρ (0 for max_weight).
    pub fn cost(&self, objective: Objective, budget_s: f64) -> f64 {
        match objective {
            Objective::MaxWeight => 0.0,
            Objective::PaperCost { phi1, phi2 } => phi1 * (self.time_s - budget_s).abs() + phi2 * self.risk_ratio_sum,
        }
    }

    /// Time over the budget, s (0 when feasible by the plain comparison).
    pub fn violation_s(&self, budget_s: f64) -> f64 {
        (self.time_s - budget_s).max(0.0)
    }
}

impl<const W: usize> Problem<W> {
    /// The quickest start → goal path (by time), `None` when the goal cannot
    /// be reached. Dense Dijkstra from the start with parent links, so the
    /// path is simple even with zero-time edges; no allocation.
    pub fn quickest_route(&self) -> Option<Route<W>> {
        let n = self.n();
        let mut dist = PerNode::<f64, W>::splat(f64::INFINITY);
        let mut parent = PerNode::<usize, W>::splat(usize::MAX);
        let mut done = self.excluded();
        dist[self.start()] = 0.0;
        loop {
            let mut u = usize::MAX;
            let mut best = f64::INFINITY;
            for (v, &d) in dist.iter().enumerate().take(n) {
                if !done.contains(v) && d < best {
                    best = d;
                    u = v;
                }
            }
            if u == usize::MAX {
                return None;
            }
            if u == self.goal() {
                break;
            }
            done.insert(u);
            for v in self.neighbours(u).iter() {
                let c = best + self.time_s(u, v);
                if c < dist[v] {
                    dist[v] = c;
                    parent[v] = u;
                }
            }
        }
        let mut rev = PerNode::<usize, W>::splat(0);
        let mut len = 0;
        let mut u = self.goal();
        while u != usize::MAX {
            rev[len] = u;
            len += 1;
            u = parent[u];
        }
        let mut route = Route::new();
        for &v in rev[..len].iter().rev() {
            route.push(v);
        }
        Some(route)
    }

    /// The nodes a route could still take: neither on `route` nor excluded.
    pub fn free_nodes(&self, route: &Route<W>) -> NodeSet<W> {
        let mut on_route = NodeSet::EMPTY;
        for u in route.iter() {
            on_route.insert(u);
        }
        NodeSet::first(self.n()) - on_route - self.excluded()
    }

    /// Evaluates `route` on this problem; `None` when it is not a valid
    /// route (wrong ends, a repeated or excluded node, a non-edge).
    pub fn evaluate(&self, route: &Route<W>) -> Option<RouteEval> {
        if route.len() < 2 || route.get(0) != self.start() || route.last() != Some(self.goal()) {
            return None;
        }
        let mut seen = NodeSet::<W>::EMPTY;
        let mut e = RouteEval {
            weight: self.prize(self.start()),
            ..RouteEval::default()
        };
        for (i, u) in route.iter().enumerate() {
            if u >= self.n() || seen.contains(u) || self.excluded().contains(u) {
                return None;
            }
            seen.insert(u);
            if i + 1 < route.len() {
                let v = route.get(i + 1);
                if v >= self.n() || !self.has_edge(u, v) {
                    return None;
                }
                e.time_s += self.time_s(u, v);
                e.distance_m += self.distance_m(u, v);
                e.weight += self.gain(u, v);
                e.risk_ratio_sum += self.risk_ratio(u, v);
                e.tasks += 1;
            }
        }
        e.feasible = e.time_s <= self.budget_limit_s();
        Some(e)
    }

    /// Objective score of an evaluated route, higher is better: feasible
    /// routes always beat infeasible ones, which rank by smaller violation.
    #[inline]
    pub fn score(&self, e: &RouteEval) -> f64 {
        if !e.feasible {
            // Below every feasible score: feasible scores are ≥ −(cost) ≥ −1e300.
            return -1e300 - e.violation_s(self.budget_s());
        }
        match self.objective() {
            Objective::MaxWeight => e.weight,
            o @ Objective::PaperCost { .. } => -e.cost(o, self.budget_s()),
        }
    }

    /// Whether `a` is strictly better than `b` under this problem's
    /// objective (ties on score go to the shorter route time).
    #[inline]
    pub fn better(&self, a: &RouteEval, b: &RouteEval) -> bool {
        let (sa, sb) = (self.score(a), self.score(b));
        sa > sb || (sa == sb && a.time_s < b.time_s)
    }
}

/// Every figure the solution output reports, recomputed from the instance.
#[derive(Clone, Debug, PartialEq)]
pub struct RouteStats {
    /// T_R, s.
    pub time_s: f64,
    /// D_R, m.
    pub distance_m: f64,
    /// W_R.
    pub weight: f64,
    /// Objective cost (paper_cost; 0 for max_weight).
    pub cost: f64,
    /// Tasks completed (edges travelled).
    pub tasks: u32,
    /// T_R ≤ T_available within 1e-6 relative.
    pub feasible: bool,
}

/// Why a route is not a route of an instance.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RouteError {
    /// Fewer than two nodes.
    #[error("a route needs at least two nodes")]
    TooShort,
    /// Does not begin at the start.
    #[error("route begins at {found}, not at the start {start}")]
    WrongStart {
        /// First node.
        found: usize,
        /// The start.
        start: usize,
    },
    /// Does not end at the goal.
    #[error("route ends at {found}, not at the goal {goal}")]
    WrongGoal {
        /// Last node.
        found: usize,
        /// The goal.
        goal: usize,
    },
    /// Unknown id.
    #[error("route position {pos} names unknown node {node}")]
    UnknownNode {
        /// Position.
        pos: usize,
        /// Id.
        node: usize,
    },
    /// A node visited twice.
    #[error("route visits node {0} twice")]
    Repeated(usize),
    /// Consecutive nodes without an edge.
    #[error("route steps {a} -> {b}, which is not an edge")]
    NotAnEdge {
        /// From.
        a: usize,
        /// To.
        b: usize,
    },
}

impl RouteStats {
    /// Recomputes the figures of `route` from `inst` alone (the checker's
    /// computation; not for hot paths).
    pub fn from_instance(inst: &Instance, route: &[usize]) -> Result<Self, RouteError> {
        if route.len() < 2 {
            return Err(RouteError::TooShort);
        }
        if route[0] != inst.start {
            return Err(RouteError::WrongStart {
                found: route[0],
                start: inst.start,
            });
        }
        let last = route[route.len() - 1];
        if last != inst.goal {
            return Err(RouteError::WrongGoal {
                found: last,
                goal: inst.goal,
            });
        }
        let mut seen = vec![false; inst.nodes.len()];
        let (mut time_s, mut distance_m, mut ratio) = (0.0, 0.0, 0.0);
        for (pos, &u) in route.iter().enumerate() {
            if u >= inst.nodes.len() {
                return Err(RouteError::UnknownNode { pos, node: u });
            }
            if seen[u] {
                return Err(RouteError::Repeated(u));
            }
            seen[u] = true;
        }
        // Sum edge by edge in route order, the same order as the solvers, so
        // the floating-point sums agree to the last bit.
        let mut total_weight = inst.nodes[route[0]].prize;
        for w in route.windows(2) {
            let (a, b) = (w[0], w[1]);
            let e = inst.edge_between(a, b).ok_or(RouteError::NotAnEdge { a, b })?;
            let d = inst.distance(a, b);
            distance_m += d;
            time_s += crate::problem::edge_time_s(d, inst.speed_mps, e.task_time_s);
            total_weight += e.priority / e.risk + inst.nodes[b].prize;
            if e.priority > 0.0 {
                ratio += e.risk / e.priority;
            }
        }
        let eval = RouteEval {
            time_s,
            distance_m,
            weight: total_weight,
            risk_ratio_sum: ratio,
            tasks: (route.len() - 1) as u32,
            feasible: time_s <= inst.time_available_s * (1.0 + FEASIBILITY_REL_TOL),
        };
        Ok(Self {
            time_s,
            distance_m,
            weight: total_weight,
            cost: eval.cost(inst.objective, inst.time_available_s),
            tasks: eval.tasks,
            feasible: eval.feasible,
        })
    }
}

#[cfg(test)]
mod equality_tests {

    // The default capacity class unless a test names another.
    type Route = crate::route::Route;

    #[test]
    fn equal_sequences_are_equal_whatever_the_scratch_bytes() {
        let mut a = Route::from_slice(&[0, 5, 9, 3]).unwrap();
        a.truncate(2);
        let b = Route::from_slice(&[0, 5]).unwrap();
        assert_eq!(a, b);
        assert_ne!(a, Route::from_slice(&[0, 5, 9]).unwrap());
    }

    #[test]
    fn in_place_edits_match_their_definitions() {
        let base = [0, 1, 2, 3, 4, 5, 6, 7];
        let r = Route::from_slice(&base).unwrap();
        let mut x = r;
        x.insert(3, 9);
        assert_eq!(x.to_vec(), vec![0, 1, 2, 9, 3, 4, 5, 6, 7]);
        x.remove(3);
        assert_eq!(x, r);
        x.reverse(2, 5);
        assert_eq!(x.to_vec(), vec![0, 1, 5, 4, 3, 2, 6, 7]);
        for l in 1..=3 {
            for i in 1..base.len() - l {
                for k in 0..base.len() - 1 {
                    if (i - 1..i + l).contains(&k) {
                        continue;
                    }
                    for rev in [false, true] {
                        let mut seg: Vec<usize> = base[i..i + l].to_vec();
                        if rev {
                            seg.reverse();
                        }
                        let mut want = Vec::new();
                        for (x, &v) in base.iter().enumerate() {
                            if (i..i + l).contains(&x) {
                                continue;
                            }
                            want.push(v);
                            if x == k {
                                want.extend(&seg);
                            }
                        }
                        let mut got = r;
                        got.relocate(i, l, k, rev);
                        assert_eq!(got.to_vec(), want, "i {i} l {l} k {k} rev {rev}");
                    }
                }
            }
        }
    }
}
