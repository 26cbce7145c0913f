//! The compiled routing problem the solvers work on: fixed capacity, dense
//! tables, built once per network change and then only read.
//!
//! Contract: a [`Problem`] is a snapshot of one [`Instance`] (or of the live
//! world) with an optional start override, excluded nodes and a budget. All
//! buffers are allocated by [`Problem::new`]; [`Problem::load_instance`] and
//! the `begin`/`set_edge`/`finish` sequence refill them without allocating, so
//! the re-planning service can rebuild in place. Nothing here knows about PSO,
//! BBO or transport (house style §2).
//!
//! The figures it derives (edge time, weight, feasibility) follow
//! `instance-format.md` exactly; [`crate::route::RouteStats::from_instance`]
//! recomputes them independently and the tests hold the two equal.

pub use crate::capacity::NodeSet;
use crate::capacity::{DEFAULT_WORDS, PerNode, nodes_of};
use crate::decode::{SCAN_BLOCK, padded_len};
use crate::instance::{Instance, Objective};
use crate::route::RouteEval;

/// Default planning reserve held back from every plan's budget, s (our
/// choice, measured: lockstep missions on
/// the default scenario, seeds 1–26, reached the goal 25 times with 300 s
/// against 23 with none, at about the same weight; 900 s was no safer).
pub const DEFAULT_RESERVE_S: f64 = 300.0;

/// Nodes of the default capacity class (the default of every generic type,
/// and the Monte Carlo study's limit). 128 covers the paper's 40-node
/// networks, the largest classic orienteering set (66 nodes) and the
/// design's "at least 128" requirement. The service and the offline
/// commands pick a class per network ([`crate::capacity::Class`]), up to
/// [`crate::capacity::LARGEST_NODES`].
pub const MAX_NODES: usize = nodes_of(DEFAULT_WORDS);

/// Relative tolerance of the feasibility test `T_R ≤ T_available`
/// (instance format: "within 1e-6 relative").
pub const FEASIBILITY_REL_TOL: f64 = 1e-6;

/// Why a problem could not be built.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum ProblemError {
    /// More nodes than the problem's capacity class holds.
    #[error("{n} nodes exceed the capacity of {capacity} nodes")]
    TooManyNodes {
        /// Node count.
        n: usize,
        /// Nodes the class holds.
        capacity: usize,
    },
    /// Fewer than two nodes.
    #[error("a route needs at least 2 nodes, got {0}")]
    TooFewNodes(usize),
    /// A node id outside 0..n.
    #[error("node {node} is out of range for {n} nodes")]
    NodeOutOfRange {
        /// The id.
        node: usize,
        /// Node count.
        n: usize,
    },
    /// Start equals goal.
    #[error("start and goal are both node {0}")]
    StartIsGoal(usize),
    /// The start or goal is excluded.
    #[error("node {0} is both excluded and an endpoint of the route")]
    EndpointExcluded(usize),
    /// A budget that is not a positive finite number.
    #[error("time budget {0} s must be finite and > 0")]
    BadBudget(f64),
    /// Speed not positive and finite.
    #[error("speed {0} m/s must be finite and > 0")]
    BadSpeed(f64),
    /// No path at all joins start and goal.
    #[error("no path joins start {start} and goal {goal}")]
    GoalUnreachable {
        /// Start id.
        start: usize,
        /// Goal id.
        goal: usize,
    },
}

/// What the decoder needs about one directed step `a → b`, packed into one
/// 32-byte record so a step touches one cache line instead of four tables.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub(crate) struct EdgeData {
    /// Edge time T_ab = d_ab / v + δ_ab, s; +∞ where there is no edge.
    pub time_s: f64,
    /// 3-D length d_ab, m.
    pub distance_m: f64,
    /// Edge weight ρ/ξ plus the prize of the far node `b`.
    pub gain: f64,
    /// ξ/ρ of the edge's task (0 when ρ = 0), for `paper_cost`.
    pub risk_ratio: f64,
}

impl EdgeData {
    /// No edge.
    const NONE: Self = Self {
        time_s: f64::INFINITY,
        distance_m: 0.0,
        gain: 0.0,
        risk_ratio: 0.0,
    };
}

/// A dense per-pair table for a class of `W` words: `64 · W` rows of
/// `64 · W` entries, nested so its size follows from `W`; used flat
/// ([`flat`]).
type Table<T, const W: usize> = [[[[T; 64]; W]; 64]; W];

/// The entries of a table, row-major.
#[inline(always)]
fn flat<T, const W: usize>(t: &Table<T, W>) -> &[T] {
    t.as_flattened().as_flattened().as_flattened()
}

/// [`flat`], mutable.
#[inline(always)]
fn flat_mut<T, const W: usize>(t: &mut Table<T, W>) -> &mut [T] {
    t.as_flattened_mut().as_flattened_mut().as_flattened_mut()
}

/// Dense per-pair tables, boxed because they are large (832 KiB at 128
/// nodes). Each is row-major with a row stride of `padded_len(n)` (n
/// rounded up to the decoder's scan block), not the capacity, so a small
/// problem's rows sit together (13 KiB of look-ahead at n = 40 instead of
/// 40 rows spread 1 KiB apart). Entry (a, b) is at `a * stride + b`.
struct Tables<const W: usize> {
    /// Look-ahead: T_ab + shortest time from b to the goal, rounded *up* to
    /// `f32` ([`f32_up`]); +∞ where there is no edge or b is excluded (and in
    /// every padding column n..stride, which the decoder's padded scan
    /// relies on). A decoder may step to b only if this fits in the time
    /// left rounded *down* ([`f32_down`]), so an `f32` pass is never a step
    /// the exact `f64` test would refuse. `f32` puts sixteen candidates in
    /// one AVX-512 compare. Scanned whole rows at a time, so kept apart.
    reach_s: Table<f32, W>,
    /// Edge time T_ab, s; +∞ where there is no edge. Duplicates
    /// `edge[..].time_s` so [`Problem::time_row`] can hand out a row, and so
    /// the decoder's step → time → next step chain loads from this small
    /// table rather than the 4× larger `edge`.
    time_s: Table<f64, W>,
    /// What a step a → b adds to the figure the objective ranks by (the
    /// gain for `max_weight`, ξ/ρ for `paper_cost`; 0 where there is no
    /// edge): a decoder's walk sums it beside the time, from a table as
    /// small as the time's, so a finished walk is ranked without a second
    /// pass over its route.
    merit: Table<f64, W>,
    /// Everything a step a → b adds to a route's figures.
    edge: Table<EdgeData, W>,
}

impl<const W: usize> Tables<W> {
    /// Entries of each table.
    const CELLS: usize = nodes_of(W) * nodes_of(W);

    /// Every table "no edge", built directly on the heap (the value is too
    /// large for small thread stacks on its way into a Box).
    fn new_boxed() -> Box<Self> {
        let mut b = Box::<Self>::new_uninit();
        let p = b.as_mut_ptr();
        // SAFETY: each table is a plain nested array of Copy values with no
        // padding between entries, so `CELLS` consecutive writes through a
        // pointer to its first entry initialise it whole.
        unsafe {
            let reach = core::ptr::addr_of_mut!((*p).reach_s).cast::<f32>();
            let time = core::ptr::addr_of_mut!((*p).time_s).cast::<f64>();
            let merit = core::ptr::addr_of_mut!((*p).merit).cast::<f64>();
            let edge = core::ptr::addr_of_mut!((*p).edge).cast::<EdgeData>();
            for cell in 0..Self::CELLS {
                reach.add(cell).write(f32::INFINITY);
                time.add(cell).write(f64::INFINITY);
                merit.add(cell).write(0.0);
                edge.add(cell).write(EdgeData::NONE);
            }
            b.assume_init()
        }
    }
}

/// One routing problem, ready for the solvers, for up to `64 · W` nodes
/// (see [`crate::capacity`]).
pub struct Problem<const W: usize = DEFAULT_WORDS> {
    n: usize,
    /// Row stride of the tables: `padded_len(n)`.
    stride: usize,
    start: usize,
    goal: usize,
    budget_s: f64,
    objective: Objective,
    adjacency: PerNode<NodeSet<W>, W>,
    excluded: NodeSet<W>,
    prize: PerNode<f64, W>,
    to_goal_s: PerNode<f64, W>,
    tables: Box<Tables<W>>,
}

impl<const W: usize> Problem<W> {
    /// Nodes this problem's class holds.
    pub const CAPACITY: usize = nodes_of(W);

    /// An empty problem with every buffer allocated. Load it with
    /// [`Problem::load_instance`] or `begin`/`set_edge`/`finish`.
    pub fn new() -> Self {
        Self {
            n: 0,
            stride: 0,
            start: 0,
            goal: 0,
            budget_s: 0.0,
            objective: Objective::MaxWeight,
            adjacency: PerNode::splat(NodeSet::EMPTY),
            excluded: NodeSet::EMPTY,
            prize: PerNode::splat(0.0),
            to_goal_s: PerNode::splat(f64::INFINITY),
            tables: Tables::new_boxed(),
        }
    }

    /// Builds a problem from an instance as it stands (its start, goal and budget).
    pub fn from_instance(inst: &Instance) -> Result<Self, ProblemError> {
        let mut p = Self::new();
        p.load_instance(inst, inst.start, NodeSet::EMPTY, inst.time_available_s)?;
        Ok(p)
    }

    /// Refills this problem from `inst`, starting at `start` with `budget_s`
    /// left and the `excluded` nodes removed (the re-planning case). Does not
    /// allocate.
    pub fn load_instance(
        &mut self,
        inst: &Instance,
        start: usize,
        excluded: NodeSet<W>,
        budget_s: f64,
    ) -> Result<(), ProblemError> {
        if !(inst.speed_mps.is_finite() && inst.speed_mps > 0.0) {
            return Err(ProblemError::BadSpeed(inst.speed_mps));
        }
        self.begin(inst.nodes.len(), start, inst.goal, budget_s, inst.objective, excluded)?;
        for (i, node) in inst.nodes.iter().enumerate() {
            self.prize[i] = node.prize;
        }
        for e in &inst.edges {
            let d = inst.distance(e.a, e.b);
            self.set_edge(
                e.a,
                e.b,
                d,
                edge_time_s(d, inst.speed_mps, e.task_time_s),
                e.priority,
                e.risk,
            );
        }
        self.finish()
    }

    /// Starts a fresh fill: `n` nodes, no edges, no prizes.
    pub fn begin(
        &mut self,
        n: usize,
        start: usize,
        goal: usize,
        budget_s: f64,
        objective: Objective,
        excluded: NodeSet<W>,
    ) -> Result<(), ProblemError> {
        if n > Self::CAPACITY {
            return Err(ProblemError::TooManyNodes {
                n,
                capacity: Self::CAPACITY,
            });
        }
        if n < 2 {
            return Err(ProblemError::TooFewNodes(n));
        }
        for node in [start, goal] {
            if node >= n {
                return Err(ProblemError::NodeOutOfRange { node, n });
            }
            if excluded.contains(node) {
                return Err(ProblemError::EndpointExcluded(node));
            }
        }
        if start == goal {
            return Err(ProblemError::StartIsGoal(start));
        }
        if !(budget_s.is_finite() && budget_s > 0.0) {
            return Err(ProblemError::BadBudget(budget_s));
        }
        // Clear only what the previous fill may have touched, and what this
        // one will use (its padding columns must read +∞).
        let stride = padded_len(n);
        let used = (self.n * self.stride).max(n * stride);
        flat_mut(&mut self.tables.time_s)[..used].fill(f64::INFINITY);
        flat_mut(&mut self.tables.merit)[..used].fill(0.0);
        flat_mut(&mut self.tables.reach_s)[..used].fill(f32::INFINITY);
        flat_mut(&mut self.tables.edge)[..used].fill(EdgeData::NONE);
        let rows = self.n.max(n);
        self.adjacency[..rows].fill(NodeSet::EMPTY);
        self.prize[..rows].fill(0.0);
        self.n = n;
        self.stride = stride;
        self.start = start;
        self.goal = goal;
        self.budget_s = budget_s;
        self.objective = objective;
        self.excluded = excluded & NodeSet::first(n);
        Ok(())
    }

    /// Sets the prize of node `i` (classic orienteering instances).
    pub fn set_prize(&mut self, i: usize, prize: f64) {
        self.prize[i] = prize;
    }

    /// Adds the undirected edge `a`–`b` (ids < n, a ≠ b) with its length,
    /// time and task. Edges touching an excluded node are ignored.
    pub fn set_edge(&mut self, a: usize, b: usize, distance_m: f64, time_s: f64, priority: f64, risk: f64) {
        debug_assert!(a < self.n && b < self.n && a != b);
        if self.excluded.contains(a) || self.excluded.contains(b) {
            return;
        }
        let weight = priority / risk;
        let ratio = if priority > 0.0 { risk / priority } else { 0.0 };
        let t = &mut self.tables;
        for (u, v) in [(a, b), (b, a)] {
            let cell = u * self.stride + v;
            flat_mut(&mut t.time_s)[cell] = time_s;
            // Prizes are added to the gain in `finish`, once every prize is known.
            flat_mut(&mut t.edge)[cell] = EdgeData {
                time_s,
                distance_m,
                gain: weight,
                risk_ratio: ratio,
            };
            self.adjacency[u].insert(v);
        }
    }

    /// Completes a fill: adds prizes to the gain table and computes the
    /// shortest time to the goal and the look-ahead table.
    pub fn finish(&mut self) -> Result<(), ProblemError> {
        let (n, stride) = (self.n, self.stride);
        let (edge, merit) = (flat_mut(&mut self.tables.edge), flat_mut(&mut self.tables.merit));
        for u in 0..n {
            for v in self.adjacency[u].iter() {
                let cell = u * stride + v;
                edge[cell].gain += self.prize[v];
                merit[cell] = match self.objective {
                    Objective::MaxWeight => edge[cell].gain,
                    Objective::PaperCost { .. } => edge[cell].risk_ratio,
                };
            }
        }
        self.shortest_times_to_goal();
        let (time, reach) = (flat(&self.tables.time_s), flat_mut(&mut self.tables.reach_s));
        for u in 0..n {
            for v in 0..n {
                let cell = u * stride + v;
                reach[cell] = f32_up(time[cell] + self.to_goal_s[v]);
            }
        }
        if !self.to_goal_s[self.start].is_finite() {
            return Err(ProblemError::GoalUnreachable {
                start: self.start,
                goal: self.goal,
            });
        }
        Ok(())
    }

    /// Dijkstra from the goal over non-excluded nodes (dense O(n²), no heap).
    fn shortest_times_to_goal(&mut self) {
        let n = self.n;
        let mut done = self.excluded;
        self.to_goal_s[..n].fill(f64::INFINITY);
        self.to_goal_s[self.goal] = 0.0;
        loop {
            let mut u = usize::MAX;
            let mut best = f64::INFINITY;
            for v in 0..n {
                if !done.contains(v) && self.to_goal_s[v] < best {
                    best = self.to_goal_s[v];
                    u = v;
                }
            }
            if u == usize::MAX {
                break;
            }
            done.insert(u);
            for v in self.adjacency[u].iter() {
                let cand = best + flat(&self.tables.time_s)[u * self.stride + v];
                if cand < self.to_goal_s[v] {
                    self.to_goal_s[v] = cand;
                }
            }
        }
    }

    /// Node count.
    #[inline]
    pub fn n(&self) -> usize {
        self.n
    }
    /// Start node.
    #[inline]
    pub fn start(&self) -> usize {
        self.start
    }
    /// Goal node.
    #[inline]
    pub fn goal(&self) -> usize {
        self.goal
    }
    /// Time budget, s.
    #[inline]
    pub fn budget_s(&self) -> f64 {
        self.budget_s
    }
    /// The budget with the feasibility tolerance applied: a route is
    /// feasible when its time is at most this.
    #[inline]
    pub fn budget_limit_s(&self) -> f64 {
        self.budget_s * (1.0 + FEASIBILITY_REL_TOL)
    }
    /// The objective.
    #[inline]
    pub fn objective(&self) -> Objective {
        self.objective
    }
    /// Neighbours of `u` (excluded nodes removed).
    #[inline]
    pub fn neighbours(&self, u: usize) -> NodeSet<W> {
        self.adjacency[u]
    }
    /// Nodes removed from this problem (already visited in a mission).
    #[inline]
    pub fn excluded(&self) -> NodeSet<W> {
        self.excluded
    }
    /// Whether `a`–`b` is an edge.
    #[inline]
    pub fn has_edge(&self, a: usize, b: usize) -> bool {
        self.adjacency[a].contains(b)
    }
    /// Row stride of the dense tables (`padded_len(n)`): the length of
    /// [`Problem::reach_row`] and [`Problem::time_row`].
    #[inline]
    pub fn stride(&self) -> usize {
        self.stride
    }
    /// Edge time, s (+∞ when no edge).
    #[inline]
    pub fn time_s(&self, a: usize, b: usize) -> f64 {
        flat(&self.tables.time_s)[a * self.stride + b]
    }
    /// Edge length, m.
    #[inline]
    pub fn distance_m(&self, a: usize, b: usize) -> f64 {
        self.edge(a, b).distance_m
    }
    /// Weight gained by travelling a→b: the edge's ρ/ξ plus b's prize.
    #[inline]
    pub fn gain(&self, a: usize, b: usize) -> f64 {
        self.edge(a, b).gain
    }
    /// Weight of edge a–b without the far node's prize: the same either way
    /// round, since the prizes of a route's nodes do not depend on the
    /// direction of travel.
    #[inline]
    pub fn edge_weight(&self, a: usize, b: usize) -> f64 {
        self.gain(a, b) - self.prize(b)
    }
    /// ξ/ρ of the edge's task (0 when ρ = 0).
    #[inline]
    pub fn risk_ratio(&self, a: usize, b: usize) -> f64 {
        self.edge(a, b).risk_ratio
    }
    /// Prize of node `i`.
    #[inline]
    pub fn prize(&self, i: usize) -> f64 {
        self.prize[i]
    }
    /// Shortest time from `u` to the goal over non-excluded nodes, s.
    #[inline]
    pub fn to_goal_s(&self, u: usize) -> f64 {
        self.to_goal_s[u]
    }
    /// Shortest time from every node to the goal, s (first `n` entries
    /// meaningful; the rest may be stale).
    #[inline]
    pub(crate) fn to_goal_row(&self) -> &[f64] {
        &self.to_goal_s
    }
    /// Row `u` (< n) of the look-ahead table (`f32`, rounded up):
    /// [`Problem::stride`] entries, +∞ in the padding columns n..stride.
    #[inline]
    pub fn reach_row(&self, u: usize) -> &[f32] {
        &flat(&self.tables.reach_s)[u * self.stride..(u + 1) * self.stride]
    }
    /// The look-ahead table from row `u` on (row `u` is its first
    /// [`Problem::stride`] entries): one bounds check where
    /// [`Problem::reach_row`] has two, for scans that check their length.
    #[inline]
    pub(crate) fn reach_from(&self, u: usize) -> &[f32] {
        &flat(&self.tables.reach_s)[u * self.stride..]
    }
    /// What the step `a → b` adds to the figure the objective ranks by
    /// (see [`Problem::ranked`]).
    #[inline]
    pub(crate) fn merit(&self, a: usize, b: usize) -> f64 {
        flat(&self.tables.merit)[a * self.stride + b]
    }
    /// The ranked figure of a route that has not left the start yet: the
    /// weight counts the start's prize.
    #[inline]
    pub(crate) fn merit_at_start(&self) -> f64 {
        self.merit_of(&RouteEval {
            weight: self.prize(self.start),
            ..RouteEval::default()
        })
    }
    /// The figure of `e` the objective ranks by: its weight (`max_weight`)
    /// or Σ ξ/ρ (`paper_cost`).
    #[inline]
    fn merit_of(&self, e: &RouteEval) -> f64 {
        match self.objective {
            Objective::MaxWeight => e.weight,
            Objective::PaperCost { .. } => e.risk_ratio_sum,
        }
    }
    /// The figures of a route as far as [`Problem::score`] and
    /// [`Problem::better`] read them, from its time and its merit (the
    /// [`Problem::merit`] of its steps summed in route order after
    /// [`Problem::merit_at_start`], so bit for bit the full figures' own
    /// sum): the time, feasibility and the weight (`max_weight`) or Σ ξ/ρ
    /// (`paper_cost`); the other figures are 0.
    #[inline]
    pub(crate) fn ranked(&self, time_s: f64, merit: f64) -> RouteEval {
        let mut e = RouteEval {
            time_s,
            feasible: time_s <= self.budget_limit_s(),
            ..RouteEval::default()
        };
        match self.objective {
            Objective::MaxWeight => e.weight = merit,
            Objective::PaperCost { .. } => e.risk_ratio_sum = merit,
        }
        e
    }
    /// [`Problem::ranked`] of a route with figures `e`.
    pub(crate) fn ranked_part(&self, e: &RouteEval) -> RouteEval {
        self.ranked(e.time_s, self.merit_of(e))
    }
    /// Everything the step `a → b` adds to a route (one cache line).
    #[inline]
    pub(crate) fn edge(&self, a: usize, b: usize) -> &EdgeData {
        &flat(&self.tables.edge)[a * self.stride + b]
    }
    /// Row `u` (< n) of the edge-time table: [`Problem::stride`] entries,
    /// +∞ in the padding columns.
    #[inline]
    pub fn time_row(&self, u: usize) -> &[f64] {
        &flat(&self.tables.time_s)[u * self.stride..(u + 1) * self.stride]
    }

    /// Nodes `v` whose detour `a → v → b` takes at most `within` s (edge
    /// times, +∞ where there is no edge, so only common neighbours of `a`
    /// and `b` qualify). One dense pass over two contiguous rows (edge
    /// times are symmetric), which vectorises: on a dense network it is
    /// cheaper than looking up both times of each candidate one by one.
    pub fn detours_within(&self, a: usize, b: usize, within: f64) -> NodeSet<W> {
        let (row_a, row_b) = (self.time_row(a), self.time_row(b));
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU runs AVX-512F (checked just above).
                return unsafe { detours_within_avx512(row_a, row_b, within) };
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU runs AVX2 (checked just above).
                return unsafe { detours_within_avx2(row_a, row_b, within) };
            }
        }
        detours_within_rows(row_a, row_b, within)
    }

    /// Whether [`Problem::reversals_within`] and
    /// [`Problem::relocations_within`] run eight lanes at once on this CPU
    /// (AVX-512 gathers); without, a caller tests one lane a time.
    pub fn route_scans_in_octets() -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512bw")
                && std::arch::is_x86_feature_detected!("avx512vl")
        }
        #[cfg(not(target_arch = "x86_64"))]
        false
    }

    /// Of the 2-opt reversals of a route (node ids `ids`) whose segment
    /// starts at node `ui` after node `a` and ends at a position
    /// `k ∈ j .. min(j + 8, end)` (`end` < `ids.len()`), those whose time
    /// change `t(a, ids[k]) + t(ui, ids[k + 1]) − t(a, ui) − t(ids[k], ids[k + 1])`
    /// is at most `eps`, as bit `k − j`. The sums run in that order, so a
    /// caller's own scalar test of a lane gives the same verdict.
    pub fn reversals_within(&self, ids: &[u16], a: usize, ui: usize, j: usize, end: usize, eps: f64) -> u8 {
        let end = end.min(ids.len().saturating_sub(1)).min(j + 8);
        #[cfg(target_arch = "x86_64")]
        if Self::route_scans_in_octets() && j < end {
            // SAFETY: the CPU runs AVX-512F, BW and VL (checked just above);
            // j < end < ids.len().
            return unsafe { self.route_scan_avx512(ids, a, ui, j, end, RouteScan::Reversal { eps }) };
        }
        let (row_a, row_ui, t_aui) = (self.time_row(a), self.time_row(ui), self.time_s(a, ui));
        let mut lanes = 0u8;
        for k in j..end {
            let (uk, b) = (usize::from(ids[k]), usize::from(ids[k + 1]));
            if row_a[uk] + row_ui[b] - t_aui - self.time_s(uk, b) <= eps {
                lanes |= 1 << (k - j);
            }
        }
        lanes
    }

    /// Of the places of a route (node ids `ids`) between positions `k` and
    /// `k + 1`, `k ∈ j .. min(j + 8, end)` (`end` < `ids.len()`), those where
    /// moving a segment that runs from node `x` to node `y` (taken out for
    /// `out_s` s) changes the route's time by at most `eps`:
    /// `t(ids[k], x) + t(y, ids[k + 1]) − t(ids[k], ids[k + 1]) − out_s ≤ eps`,
    /// as bit `k − j`, summed in that order (so a caller's own scalar test
    /// of a lane gives the same verdict).
    #[allow(clippy::too_many_arguments)]
    pub fn relocations_within(
        &self,
        ids: &[u16],
        x: usize,
        y: usize,
        j: usize,
        end: usize,
        out_s: f64,
        eps: f64,
    ) -> u8 {
        let end = end.min(ids.len().saturating_sub(1)).min(j + 8);
        #[cfg(target_arch = "x86_64")]
        if Self::route_scans_in_octets() && j < end {
            // SAFETY: the CPU runs AVX-512F, BW and VL (checked just above);
            // j < end < ids.len().
            return unsafe { self.route_scan_avx512(ids, x, y, j, end, RouteScan::Relocation { out_s, eps }) };
        }
        let mut lanes = 0u8;
        for k in j..end {
            let (c, d) = (usize::from(ids[k]), usize::from(ids[k + 1]));
            if self.time_s(c, x) + self.time_s(y, d) - self.time_s(c, d) - out_s <= eps {
                lanes |= 1 << (k - j);
            }
        }
        lanes
    }

    /// The route scans with gathers, eight lanes at once: for each position
    /// k, `t(x, ids[k])`, `t(y, ids[k + 1])` and the route's own edge time
    /// (the table is symmetric), combined as `scan` says.
    ///
    /// # Safety
    /// The CPU runs AVX-512F, BW and VL, and `j < end < ids.len()`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512bw,avx512vl")]
    unsafe fn route_scan_avx512(&self, ids: &[u16], x: usize, y: usize, j: usize, end: usize, scan: RouteScan) -> u8 {
        use core::arch::x86_64::*;
        let table = flat(&self.tables.time_s);
        let (row_x, row_y) = (self.time_row(x), self.time_row(y));
        let valid: __mmask8 = ((1u32 << (end - j)) - 1) as __mmask8;
        // SAFETY: lanes below end − j read ids[j ..= end] (end < ids.len());
        // masked-off lanes read nothing. Every id is a node < n, so the
        // gathers stay inside row x, row y (stride entries each) and the
        // n × stride table.
        unsafe {
            let here = _mm256_cvtepu16_epi32(_mm_maskz_loadu_epi16(valid, ids.as_ptr().add(j).cast()));
            let next = _mm256_cvtepu16_epi32(_mm_maskz_loadu_epi16(valid, ids.as_ptr().add(j + 1).cast()));
            let leg = _mm256_add_epi32(_mm256_mullo_epi32(here, _mm256_set1_epi32(self.stride as i32)), next);
            let zero = _mm512_setzero_pd();
            let t_x = _mm512_mask_i32gather_pd::<8>(zero, valid, here, row_x.as_ptr());
            let t_y = _mm512_mask_i32gather_pd::<8>(zero, valid, next, row_y.as_ptr());
            let t_leg = _mm512_mask_i32gather_pd::<8>(zero, valid, leg, table.as_ptr());
            let (dt, eps) = match scan {
                RouteScan::Reversal { eps } => (
                    _mm512_sub_pd(_mm512_sub_pd(_mm512_add_pd(t_x, t_y), _mm512_set1_pd(row_x[y])), t_leg),
                    eps,
                ),
                RouteScan::Relocation { out_s, eps } => (
                    _mm512_sub_pd(_mm512_sub_pd(_mm512_add_pd(t_x, t_y), t_leg), _mm512_set1_pd(out_s)),
                    eps,
                ),
            };
            _mm512_mask_cmp_pd_mask::<_CMP_LE_OQ>(valid, dt, _mm512_set1_pd(eps))
        }
    }

    /// The nodes `v` whose detour `a → v → b`, in place of `out_s` s of a
    /// route of `time_s` s, may keep the route within `limit`: a superset,
    /// its margin covering the rounding of summing the detour the other way
    /// round, so the caller's exact test still decides.
    pub fn detours_fitting(&self, a: usize, b: usize, out_s: f64, time_s: f64, limit: f64) -> NodeSet<W> {
        let room = limit - time_s + out_s;
        self.detours_within(a, b, room + 1e-9 * (limit.abs() + time_s.abs() + out_s.abs()))
    }
}

/// What [`Problem::route_scan_avx512`] sums per route position.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
enum RouteScan {
    /// [`Problem::reversals_within`].
    Reversal { eps: f64 },
    /// [`Problem::relocations_within`].
    Relocation { out_s: f64, eps: f64 },
}

impl<const W: usize> Default for Problem<W> {
    fn default() -> Self {
        Self::new()
    }
}

/// [`Problem::detours_within`] over two rows of whole [`SCAN_BLOCK`]s.
#[inline(always)]
fn detours_within_rows<const W: usize>(row_a: &[f64], row_b: &[f64], within: f64) -> NodeSet<W> {
    let mut set = NodeSet::EMPTY;
    for (block, (xa, xb)) in row_a
        .chunks_exact(SCAN_BLOCK)
        .zip(row_b.chunks_exact(SCAN_BLOCK))
        .enumerate()
    {
        let mut bits = 0u64;
        for k in 0..SCAN_BLOCK {
            bits |= u64::from(xa[k] + xb[k] <= within) << k;
        }
        let base = block * SCAN_BLOCK;
        set.0[base >> 6] |= bits << (base & 63);
    }
    set
}

/// A node set from `len` sums, `lanes` per step: `step_bits(k)` gives the
/// bits of nodes `k .. k + lanes` (k a multiple of `lanes`, `k + lanes ≤
/// len`). Each word is built in a register and stored once: OR-ing every
/// step into the set in memory made the kernels wait on their own stores.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn node_set_by_steps<const W: usize>(len: usize, lanes: usize, mut step_bits: impl FnMut(usize) -> u64) -> NodeSet<W> {
    let len = len.min(64 * W);
    let mut set = NodeSet::EMPTY;
    for (word, bits_out) in set.0.iter_mut().enumerate() {
        let base = 64 * word;
        let end = len.min(base + 64);
        let mut bits = 0u64;
        let mut k = base;
        while k + lanes <= end {
            bits |= step_bits(k) << (k - base);
            k += lanes;
        }
        *bits_out = bits;
    }
    set
}

/// [`detours_within_rows`] with AVX2: four sums and compares per
/// instruction, their signs gathered by `movemask`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn detours_within_avx2<const W: usize>(row_a: &[f64], row_b: &[f64], within: f64) -> NodeSet<W> {
    use core::arch::x86_64::{
        _CMP_LE_OQ, _mm256_add_pd, _mm256_cmp_pd, _mm256_loadu_pd, _mm256_movemask_pd, _mm256_set1_pd,
    };
    let limit = _mm256_set1_pd(within);
    node_set_by_steps(row_a.len().min(row_b.len()), 4, |k| {
        // SAFETY: k + 3 < the length of both rows.
        let (xa, xb) = unsafe {
            (
                _mm256_loadu_pd(row_a.as_ptr().add(k)),
                _mm256_loadu_pd(row_b.as_ptr().add(k)),
            )
        };
        _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(_mm256_add_pd(xa, xb), limit)) as u64
    })
}

/// [`detours_within_rows`] with AVX-512: eight sums and compares per
/// instruction straight into a mask.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn detours_within_avx512<const W: usize>(row_a: &[f64], row_b: &[f64], within: f64) -> NodeSet<W> {
    use core::arch::x86_64::{_CMP_LE_OQ, _mm512_add_pd, _mm512_cmp_pd_mask, _mm512_loadu_pd, _mm512_set1_pd};
    let limit = _mm512_set1_pd(within);
    // Rows come in whole scan blocks (16 entries), so in whole octets.
    node_set_by_steps(row_a.len().min(row_b.len()), 8, |k| {
        // SAFETY: k + 7 < the length of both rows.
        let (xa, xb) = unsafe {
            (
                _mm512_loadu_pd(row_a.as_ptr().add(k)),
                _mm512_loadu_pd(row_b.as_ptr().add(k)),
            )
        };
        u64::from(_mm512_cmp_pd_mask::<_CMP_LE_OQ>(_mm512_add_pd(xa, xb), limit))
    })
}

/// `x` rounded up to `f32`: the least `f32` ≥ x (+∞ above `f32::MAX`).
#[inline]
pub fn f32_up(x: f64) -> f32 {
    let r = x as f32;
    if f64::from(r) < x { r.next_up() } else { r }
}

/// `x` (not NaN) rounded down to `f32`: the greatest `f32` ≤ x (−∞ below
/// `f32::MIN`). Selects only (it sits on the decoder's step chain).
#[inline(always)]
pub fn f32_down(x: f64) -> f32 {
    let r = x as f32;
    let b = r.to_bits();
    // The next f32 below r: one step of the bits away from zero for a
    // negative r, towards zero for a positive one; below 0 is −2^-149.
    let below = if r > 0.0 {
        b - 1
    } else if r < 0.0 {
        b + 1
    } else {
        0x8000_0001
    };
    if f64::from(r) > x { f32::from_bits(below) } else { r }
}

/// Edge time T = d / v + δ (instance format, "Derived quantities"). The one
/// place this formula lives.
#[inline]
pub fn edge_time_s(distance_m: f64, speed_mps: f64, task_time_s: f64) -> f64 {
    distance_m / speed_mps + task_time_s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::line_instance;

    // The default capacity class unless a test names another.
    type Problem = crate::problem::Problem;
    type NodeSet = crate::problem::NodeSet;

    #[test]
    fn the_quickest_route_takes_the_shortest_time_to_the_goal() {
        let p = Problem::from_instance(&line_instance()).unwrap();
        let r = p.quickest_route().unwrap();
        assert_eq!(r.ids(), &[0, 3]);
        // Without the shortcut: along the line, in the time the tables give.
        let mut inst = line_instance();
        inst.edges.retain(|e| (e.a, e.b) != (0, 3));
        let p = Problem::from_instance(&inst).unwrap();
        let r = p.quickest_route().unwrap();
        assert_eq!(r.ids(), &[0, 1, 2, 3]);
        assert_eq!(p.evaluate(&r).unwrap().time_s, p.to_goal_s(0));
    }

    #[test]
    fn tables_follow_the_format_formulas() {
        let p = Problem::from_instance(&line_instance()).unwrap();
        assert_eq!(p.time_s(0, 1), 110.0);
        assert_eq!(p.time_s(0, 3), 310.0);
        assert_eq!(p.gain(1, 2), 6.0);
        assert!(!p.has_edge(0, 2));
        assert_eq!(p.time_s(0, 2), f64::INFINITY);
        assert_eq!(p.to_goal_s(0), 310.0);
        assert_eq!(p.to_goal_s(1), 220.0);
        assert_eq!(p.reach_row(0)[1], 110.0 + 220.0);
        assert_eq!(p.reach_row(0)[2], f32::INFINITY);
    }

    #[test]
    fn the_look_ahead_is_rounded_up_and_non_edges_never_fit() {
        let inst = crate::fixtures::random_instance(30, 0.4, 20_000.0, 5);
        let mut p = Problem::new();
        let mut excluded = NodeSet::EMPTY;
        excluded.insert(3);
        p.load_instance(&inst, 0, excluded, 20_000.0).unwrap();
        for u in 0..p.n() {
            for v in 0..p.stride() {
                let r = p.reach_row(u)[v];
                if v < p.n() && p.has_edge(u, v) {
                    let exact = p.time_s(u, v) + p.to_goal_s(v);
                    assert!(f64::from(r) >= exact && f64::from(r.next_down()) < exact, "{u}->{v}");
                } else {
                    assert_eq!(r, f32::INFINITY, "{u}->{v}");
                }
            }
        }
        assert!(!p.neighbours(0).contains(3));
    }

    #[test]
    fn f32_rounding_goes_the_named_way() {
        for x in [
            0.0,
            1.0,
            0.1,
            31_000.000_1,
            -0.1,
            -2.5e-3,
            1e300,
            -1e300,
            3.3e-42,
            -3.3e-42,
            1e-50,
            -1e-50,
        ] {
            let (up, down) = (f32_up(x), f32_down(x));
            assert!(f64::from(up) >= x && f64::from(down) <= x, "{x}");
            assert!(f64::from(up.next_down()) < x || up == f32::MIN, "{x}");
            assert!(f64::from(down.next_up()) > x, "{x}");
            assert_eq!(
                down,
                if f64::from(x as f32) > x {
                    (x as f32).next_down()
                } else {
                    x as f32
                },
                "{x}"
            );
        }
        assert_eq!(f32_up(f64::INFINITY), f32::INFINITY);
        assert_eq!(f32_up(2.0), 2.0);
        assert_eq!(f32_down(2.0), 2.0);
    }

    #[test]
    fn excluding_a_node_removes_its_edges_and_reroutes_the_lookahead() {
        let inst = line_instance();
        let mut p = Problem::new();
        let mut ex = NodeSet::EMPTY;
        ex.insert(2);
        p.load_instance(&inst, 1, ex, 1000.0).unwrap();
        assert!(!p.has_edge(1, 2));
        assert_eq!(p.to_goal_s(1), 110.0 + 310.0);
    }

    #[test]
    fn reloading_a_smaller_instance_clears_the_old_one() {
        let mut p = Problem::from_instance(&line_instance()).unwrap();
        let mut small = line_instance();
        small.nodes.truncate(2);
        small.goal = 1;
        small.edges = vec![small.edges[0]];
        p.load_instance(&small, 0, NodeSet::EMPTY, 500.0).unwrap();
        assert_eq!(p.n(), 2);
        assert_eq!(p.time_s(1, 2), f64::INFINITY);
        assert!(p.neighbours(2).is_empty());
    }

    #[test]
    fn bad_shapes_are_errors() {
        let mut inst = line_instance();
        inst.edges.retain(|e| e.b != 3);
        assert!(matches!(
            Problem::from_instance(&inst),
            Err(ProblemError::GoalUnreachable { .. })
        ));
        let mut big = line_instance();
        big.nodes = vec![big.nodes[0]; MAX_NODES + 1];
        assert!(matches!(
            Problem::from_instance(&big),
            Err(ProblemError::TooManyNodes { n: 129, capacity: 128 })
        ));
        let mut p = Problem::new();
        assert!(matches!(
            p.begin(4, 0, 3, f64::NAN, Objective::MaxWeight, NodeSet::EMPTY),
            Err(ProblemError::BadBudget(_))
        ));
    }

    /// Every kernel of the dense row filter this CPU runs, and the portable
    /// one, hold exactly the nodes whose two edge times sum within `within`.
    fn check_detours_within<const W: usize>(
        p: &crate::problem::Problem<W>,
        a: usize,
        b: usize,
        within: f64,
    ) -> Result<(), proptest::test_runner::TestCaseError> {
        let mut expected = crate::problem::NodeSet::<W>::EMPTY;
        for v in 0..p.n() {
            if p.time_s(a, v) + p.time_s(v, b) <= within {
                expected.insert(v);
            }
        }
        proptest::prop_assert_eq!(p.detours_within(a, b, within), expected);
        let (row_a, row_b) = (p.time_row(a), p.time_row(b));
        proptest::prop_assert_eq!(detours_within_rows::<W>(row_a, row_b, within), expected);
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU runs AVX2 (checked just above).
                proptest::prop_assert_eq!(unsafe { detours_within_avx2::<W>(row_a, row_b, within) }, expected);
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU runs AVX-512F (checked just above).
                proptest::prop_assert_eq!(unsafe { detours_within_avx512::<W>(row_a, row_b, within) }, expected);
            }
        }
        Ok(())
    }

    /// [`Problem::reversals_within`] (this CPU's kernel) holds exactly the
    /// ends whose time change, summed as the definition says, is ≤ `eps`.
    fn check_reversals_within<const W: usize>(
        p: &crate::problem::Problem<W>,
        ids: &[u16],
        a: usize,
        ui: usize,
        eps: f64,
    ) -> Result<(), proptest::test_runner::TestCaseError> {
        let end = ids.len() - 1;
        for j in 0..end {
            let mut expected = 0u8;
            for k in j..end.min(j + 8) {
                let (uk, b) = (usize::from(ids[k]), usize::from(ids[k + 1]));
                if p.time_s(a, uk) + p.time_s(ui, b) - p.time_s(a, ui) - p.time_s(uk, b) <= eps {
                    expected |= 1 << (k - j);
                }
            }
            proptest::prop_assert_eq!(p.reversals_within(ids, a, ui, j, end, eps), expected, "j = {}", j);
        }
        Ok(())
    }

    /// [`Problem::relocations_within`] (this CPU's kernel) holds exactly the
    /// places whose time change, summed as the definition says, is ≤ `eps`.
    fn check_relocations_within<const W: usize>(
        p: &crate::problem::Problem<W>,
        ids: &[u16],
        (x, y): (usize, usize),
        out_s: f64,
        eps: f64,
    ) -> Result<(), proptest::test_runner::TestCaseError> {
        let end = ids.len() - 1;
        for j in 0..end {
            let mut expected = 0u8;
            for k in j..end.min(j + 8) {
                let (c, d) = (usize::from(ids[k]), usize::from(ids[k + 1]));
                if p.time_s(c, x) + p.time_s(y, d) - p.time_s(c, d) - out_s <= eps {
                    expected |= 1 << (k - j);
                }
            }
            proptest::prop_assert_eq!(
                p.relocations_within(ids, x, y, j, end, out_s, eps),
                expected,
                "j = {}",
                j
            );
        }
        Ok(())
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// The dense row filter, in the 128-node class and (more words than
        /// the rows fill) the 512-node class.
        #[test]
        fn detours_within_is_the_row_sum_test(
            seed in 0u64..10_000,
            n in 2usize..=128,
            density in 0.05f64..1.0,
            pair in (0usize..128, 0usize..128),
            within in 0.0f64..20_000.0,
        ) {
            let inst = crate::fixtures::random_instance(n, density, 30_000.0, seed);
            // A network whose goal is out of reach is rejected before any table is read.
            let built = Problem::from_instance(&inst);
            proptest::prop_assume!(built.is_ok());
            let (a, b) = (pair.0 % n, pair.1 % n);
            check_detours_within(&built.unwrap(), a, b, within)?;
            let wide = crate::problem::Problem::<8>::from_instance(&inst).unwrap();
            check_detours_within(&wide, a, b, within)?;
        }

        /// The same in the 512-node class on networks of more than 128 nodes.
        #[test]
        fn detours_within_is_the_row_sum_on_large_networks(
            seed in 0u64..10_000,
            n in 129usize..=300,
            pair in (0usize..300, 0usize..300),
            within in 0.0f64..20_000.0,
        ) {
            let inst = crate::fixtures::random_instance(n, 0.5, 30_000.0, seed);
            let built = crate::problem::Problem::<8>::from_instance(&inst);
            proptest::prop_assume!(built.is_ok());
            check_detours_within(&built.unwrap(), pair.0 % n, pair.1 % n, within)?;
        }

        /// The 2-opt pre-filter, on routes of up to 300 nodes in the 128- and
        /// 512-node classes, at thresholds around the changes that occur.
        #[test]
        fn reversals_within_is_the_time_change_test(
            seed in 0u64..10_000,
            n in 3usize..=300,
            density in 0.1f64..1.0,
            picks in proptest::collection::vec(0usize..300, 2..300),
            ends in (0usize..300, 0usize..300),
            eps in -3_000.0f64..3_000.0,
        ) {
            let inst = crate::fixtures::random_instance(n, density, 30_000.0, seed);
            // A route's ids: any nodes, each once (the kernel reads only ids).
            let mut seen = std::collections::BTreeSet::new();
            let ids: Vec<u16> = picks.iter().map(|&v| (v % n) as u16).filter(|&v| seen.insert(v)).collect();
            proptest::prop_assume!(ids.len() >= 2);
            let (a, ui) = (ends.0 % n, ends.1 % n);
            if n <= 128 && let Ok(p) = Problem::from_instance(&inst) {
                check_reversals_within(&p, &ids, a, ui, eps)?;
            }
            if let Ok(p) = crate::problem::Problem::<8>::from_instance(&inst) {
                check_reversals_within(&p, &ids, a, ui, eps)?;
            }
        }

        /// The or-opt pre-filter, on routes of up to 300 nodes in the 128-
        /// and 512-node classes, at thresholds around the changes that occur.
        #[test]
        fn relocations_within_is_the_time_change_test(
            seed in 0u64..10_000,
            n in 3usize..=300,
            density in 0.1f64..1.0,
            picks in proptest::collection::vec(0usize..300, 2..300),
            ends in (0usize..300, 0usize..300),
            out_s in 0.0f64..6_000.0,
            eps in -3_000.0f64..3_000.0,
        ) {
            let inst = crate::fixtures::random_instance(n, density, 30_000.0, seed);
            let mut seen = std::collections::BTreeSet::new();
            let ids: Vec<u16> = picks.iter().map(|&v| (v % n) as u16).filter(|&v| seen.insert(v)).collect();
            proptest::prop_assume!(ids.len() >= 2);
            let segment = (ends.0 % n, ends.1 % n);
            if n <= 128 && let Ok(p) = Problem::from_instance(&inst) {
                check_relocations_within(&p, &ids, segment, out_s, eps)?;
            }
            if let Ok(p) = crate::problem::Problem::<8>::from_instance(&inst) {
                check_relocations_within(&p, &ids, segment, out_s, eps)?;
            }
        }
    }
}
