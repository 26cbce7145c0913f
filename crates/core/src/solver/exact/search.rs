//! The depth-first search, its bound and its dominance table.

use std::time::Instant;

use crate::instance::Objective;
use crate::problem::{NodeSet, Problem};
use crate::route::{Route, RouteEval};

use super::hull::{Item, Seg, hull_segments, sort_items, sort_segs};
use super::polish::polish;

/// The knapsack classes valid below one search node: every hull is built over
/// half-edges to `allowed` nodes only, so it stays valid for any completion
/// whose nodes lie in `allowed`.
#[derive(Clone, Default)]
pub(super) struct Level<const W: usize> {
    /// Which split of edge values the hulls use.
    pub(super) split: usize,
    /// Interior classes' segments, best slope first.
    pub(super) segs: Vec<Seg>,
    /// Per class: the neighbours its hull vertices use (a rebuild is needed
    /// only when one of them drops out).
    pub(super) hull_nb: Vec<NodeSet<W>>,
    /// Nodes the interior hulls may use as neighbours.
    pub(super) allowed: NodeSet<W>,
    /// Goal class: cheapest half-edge, the hull above it, and the neighbours they use.
    pub(super) goal_base: Item,
    pub(super) goal_segs: Vec<Seg>,
    pub(super) goal_nb: NodeSet<W>,
}

/// The half-edges of every node under one split of edge values between
/// their ends (time/2, the end's share of the value, the neighbour), sorted
/// by [`sort_items`] so that every hull is built by a sweep.
pub(super) struct Split {
    /// Node `v`'s half-edges are `halves[at[v]..at[v + 1]]`.
    pub(super) halves: Vec<Item>,
    pub(super) at: Vec<usize>,
}

impl Split {
    /// Builds the lists from `half[v·n + a]`, the share of edge v–a at v.
    pub(super) fn new<const W: usize>(p: &Problem<W>, half: &[f64]) -> Self {
        let n = p.n();
        let mut halves = Vec::new();
        let mut at = vec![0];
        for v in 0..n {
            let first = halves.len();
            for a in p.neighbours(v).iter() {
                halves.push(Item {
                    t: 0.5 * p.time_s(v, a),
                    v: half[v * n + a],
                    a: a as u16,
                    b: a as u16,
                });
            }
            sort_items(&mut halves[first..]);
            at.push(halves.len());
        }
        Self { halves, at }
    }

    /// The half-edges at `v`.
    #[inline]
    pub(super) fn of(&self, v: usize) -> &[Item] {
        &self.halves[self.at[v]..self.at[v + 1]]
    }
}

/// Reusable buffers of the bound computation.
#[derive(Default)]
pub(super) struct Scratch {
    pub(super) items: Vec<Item>,
    pub(super) stack: Vec<Item>,
    pub(super) segs: Vec<Seg>,
}

/// Per-depth scratch: children of one search node.
#[derive(Clone, Copy)]
pub(super) struct Child<const W: usize> {
    pub(super) node: u16,
    pub(super) bound: f64,
    pub(super) avail: NodeSet<W>,
}

/// Data and state of one solve.
pub(super) struct Search<'p, const W: usize> {
    pub(super) p: &'p Problem<W>,
    pub(super) n: usize,
    pub(super) goal: usize,
    pub(super) limit: f64,
    /// Edge surrogate value, row-major n×n (max_weight: ρ/ξ; paper: φ1·T − φ2·ξ/ρ).
    pub(super) val: Vec<f64>,
    /// Node value collected on arrival (prizes, max_weight only).
    pub(super) node_val: Vec<f64>,
    /// All-pairs shortest times, row-major n×n.
    pub(super) sp: Vec<f64>,
    /// Ways of splitting edge values between their ends; the bound is the
    /// smallest over them.
    pub(super) splits: Vec<Split>,
    /// Values are integers: bounds may be rounded down.
    pub(super) integral: bool,
    /// paper_cost: φ1 · T_available (0 for max_weight).
    pub(super) cost_offset: f64,
    /// Prove the smallest time among routes of the best value too.
    pub(super) break_ties: bool,
    /// Extra value a stored state needs to dominate (see [`Memo`]).
    pub(super) dom_margin: f64,
    pub(super) route: Route<W>,
    pub(super) best_route: Route<W>,
    pub(super) best_eval: RouteEval,
    pub(super) have_best: bool,
    pub(super) nodes: u64,
    pub(super) children: Vec<Vec<Child<W>>>,
    /// Per depth, one [`Level`] per split.
    pub(super) levels: Vec<Vec<Level<W>>>,
    pub(super) scratch: Scratch,
    pub(super) memo: Memo<W>,
    pub(super) deadline: Option<Instant>,
    pub(super) node_limit: u64,
    /// Nodes expanded plus bounds evaluated: the search's work, which paces
    /// the clock reads (an expansion at 400 nodes bounds up to 400 children,
    /// so counting expansions alone would let a time limit overrun by seconds).
    pub(super) work: u64,
    /// `work` at which the clock is read next.
    pub(super) next_clock_read: u64,
    pub(super) aborted: bool,
    /// Largest bound of subproblems left open by an abort.
    pub(super) open_bound: f64,
}

/// Units of [`Search::work`] between two reads of the clock: about 1 ms of
/// search at 263 nodes (measured: 3–4 µs per unit there, less on smaller
/// networks), so a time limit holds to the millisecond while the clock
/// costs nothing measurable.
pub(super) const WORK_PER_CLOCK_READ: u64 = 256;

/// Lossy dominance table: (node, visited set) → (time, value) of a partial
/// path seen there. A new path is dominated when a stored one reached the
/// same node with the same nodes used in no more time and with at least
/// `margin` more value: every completion of the new path is then a completion
/// of the stored one that is at least as good. (`margin` is 0 for
/// `max_weight`; for `paper_cost` it covers the |T_R − T_available| kink
/// inside the feasibility tolerance.)
pub(super) struct Memo<const W: usize> {
    pub(super) keys: Vec<(NodeSet<W>, u16)>,
    pub(super) vals: Vec<(f64, f64)>,
    pub(super) mask: usize,
}

impl<const W: usize> Memo<W> {
    pub(super) fn new(bits: u32) -> Self {
        let size = 1usize << bits;
        Self {
            keys: vec![(NodeSet::EMPTY, u16::MAX); size],
            vals: vec![(0.0, 0.0); size],
            mask: size - 1,
        }
    }

    #[inline]
    pub(super) fn slot(&self, set: NodeSet<W>, node: u16) -> usize {
        // Word k rotated by 29·k (at 128 nodes: the low word, the high one
        // rotated by 29).
        let mut h = (node as u64).wrapping_mul(0x9E37_79B9);
        for (k, w) in set.0.iter().enumerate() {
            h ^= w.rotate_left((29 * k % 64) as u32);
        }
        h = (h ^ (h >> 31)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 29;
        (h as usize) & self.mask
    }

    /// Whether a stored state dominates (t, v); otherwise records (t, v).
    #[inline]
    pub(super) fn dominated(&mut self, set: NodeSet<W>, node: u16, t: f64, v: f64, margin: f64) -> bool {
        let i = self.slot(set, node);
        if self.keys[i] == (set, node) {
            let (st, sv) = self.vals[i];
            if st <= t && sv >= v + margin {
                return true;
            }
            if t <= st && v >= sv {
                self.vals[i] = (t, v);
            }
            return false;
        }
        self.keys[i] = (set, node);
        self.vals[i] = (t, v);
        false
    }
}

/// Size of the dominance table, log2 of entries, for `n` nodes: 2^20
/// entries (48 MiB) from 16 nodes up, so that 40-node proofs rarely evict a
/// useful state; less for small problems, which have few states and are
/// solved often (tests).
pub(super) fn memo_bits(n: usize) -> u32 {
    (n as u32 + 4).clamp(8, 20)
}

impl<'p, const W: usize> Search<'p, W> {
    #[inline]
    pub(super) fn val(&self, a: usize, b: usize) -> f64 {
        self.val[a * self.n + b]
    }

    /// Nodes of `cand` that can still be visited from `u` with `rem` seconds
    /// left and the goal reached afterwards.
    #[inline]
    pub(super) fn reachable(&self, u: usize, cand: NodeSet<W>, rem: f64) -> NodeSet<W> {
        let mut out = NodeSet::EMPTY;
        let row = &self.sp[u * self.n..(u + 1) * self.n];
        for v in cand.iter() {
            if row[v] + self.p.to_goal_s(v) <= rem {
                out.insert(v);
            }
        }
        out
    }

    /// Rebuilds interior class `v` over half-edge pairs to `allowed` nodes;
    /// appends its segments to `out` and returns the neighbours it uses.
    ///
    /// A pair on the hull is the best two half-edges for some price of time
    /// λ ≥ 0 (it maximises v − λ·t). A half-edge with two others that take no
    /// more time and give no less value is never needed for that, so only the
    /// half-edges that beat the second-best value seen so far in time order
    /// are paired (typically a handful instead of all neighbours).
    pub(super) fn build_class(
        &self,
        k: usize,
        v: usize,
        allowed: NodeSet<W>,
        sc: &mut Scratch,
        out: &mut Vec<Seg>,
    ) -> NodeSet<W> {
        sc.stack.clear();
        let (mut best1, mut best2) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
        for &h in self.splits[k].of(v) {
            if !allowed.contains(h.a as usize) || h.v <= best2 {
                continue;
            }
            if h.v > best1 {
                best2 = best1;
                best1 = h.v;
            } else {
                best2 = h.v;
            }
            sc.stack.push(h);
        }
        sc.items.clear();
        for (x, h1) in sc.stack.iter().enumerate() {
            for h2 in &sc.stack[x + 1..] {
                let t = h1.t + h2.t;
                if t > self.limit {
                    continue;
                }
                sc.items.push(Item {
                    t,
                    v: h1.v + h2.v + self.node_val[v],
                    a: h1.a.min(h2.a),
                    b: h1.a.max(h2.a),
                });
            }
        }
        sort_items(&mut sc.items);
        let origin = Item {
            t: 0.0,
            v: 0.0,
            a: v as u16,
            b: v as u16,
        };
        let mut named = hull_segments(&sc.items, origin, v as u16, &mut sc.stack, out);
        named.remove(v);
        named
    }

    /// Appends the single half-edges at `v` to neighbours in `allowed` whose
    /// far end can still reach the goal (`reach(a)` true) to `sc.items`, in
    /// [`sort_items`] order; returns the first (the class's cheapest item).
    #[inline]
    pub(super) fn singles(
        &self,
        k: usize,
        v: usize,
        allowed: NodeSet<W>,
        sc: &mut Scratch,
        reach: impl Fn(usize, f64) -> bool,
    ) -> Option<Item> {
        sc.items.clear();
        for &h in self.splits[k].of(v) {
            if allowed.contains(h.a as usize) && reach(h.a as usize, h.t) {
                sc.items.push(h);
            }
        }
        sc.items.first().copied()
    }

    /// Rebuilds the goal class over half-edges to `allowed` nodes.
    pub(super) fn build_goal(&self, allowed: NodeSet<W>, sc: &mut Scratch, lvl: &mut Level<W>) {
        let k = lvl.split;
        let g = self.goal;
        lvl.goal_segs.clear();
        let mut stack = std::mem::take(&mut sc.stack);
        match self.singles(k, g, allowed, sc, |_, _| true) {
            Some(base) => {
                lvl.goal_nb = hull_segments(&sc.items, base, g as u16, &mut stack, &mut lvl.goal_segs);
                lvl.goal_base = base;
                lvl.goal_base.v += self.node_val[g];
            }
            None => {
                lvl.goal_nb = NodeSet::EMPTY;
                lvl.goal_base = Item {
                    t: f64::INFINITY,
                    ..Item::default()
                };
            }
        }
        sc.stack = stack;
    }

    /// A level from scratch: interior classes `classes`, neighbours `allowed`
    /// for them and `goal_allowed` for the goal.
    pub(super) fn fresh_level(
        &self,
        k: usize,
        classes: NodeSet<W>,
        allowed: NodeSet<W>,
        goal_allowed: NodeSet<W>,
        sc: &mut Scratch,
    ) -> Level<W> {
        let mut lvl = Level {
            split: k,
            hull_nb: vec![NodeSet::EMPTY; self.n],
            allowed,
            ..Level::default()
        };
        let mut segs = Vec::new();
        for v in classes.iter() {
            lvl.hull_nb[v] = self.build_class(k, v, allowed, sc, &mut segs);
        }
        sort_segs(&mut segs);
        lvl.segs = segs;
        self.build_goal(goal_allowed, sc, &mut lvl);
        lvl
    }

    /// Derives `child` from `parent` for a search node whose completions use
    /// interior nodes of `avail` only: drops other classes, and rebuilds the
    /// hulls that used a neighbour no longer allowed.
    pub(super) fn derive_level(&self, parent: &Level<W>, avail: NodeSet<W>, child: &mut Level<W>, sc: &mut Scratch) {
        let allowed = avail | NodeSet::single(self.goal);
        let gone = parent.allowed - allowed;
        let k = parent.split;
        child.split = k;
        child.allowed = allowed;
        child.hull_nb.clear();
        child.hull_nb.extend_from_slice(&parent.hull_nb);
        let mut stale = NodeSet::<W>::EMPTY;
        for v in avail.iter() {
            if !(parent.hull_nb[v] & gone).is_empty() {
                stale.insert(v);
            }
        }
        child.segs.clear();
        child.segs.extend(parent.segs.iter().filter(|s| {
            let c = s.class as usize;
            avail.contains(c) && !stale.contains(c)
        }));
        if !stale.is_empty() {
            let mut segs = std::mem::take(&mut child.segs);
            for v in stale.iter() {
                child.hull_nb[v] = self.build_class(k, v, allowed, sc, &mut segs);
            }
            sort_segs(&mut segs);
            child.segs = segs;
        }
        if !(parent.goal_nb & gone).is_empty() {
            self.build_goal(avail, sc, child);
        } else {
            child.goal_base = parent.goal_base;
            child.goal_nb = parent.goal_nb;
            child.goal_segs.clear();
            child.goal_segs.extend_from_slice(&parent.goal_segs);
        }
    }

    /// The smallest bound over the splits (see [`Search::bound_one`]); stops
    /// early once one falls below the incumbent's target, which is all the
    /// caller needs to know then.
    pub(super) fn bound(
        &self,
        lvls: &[Level<W>],
        sc: &mut Scratch,
        u: usize,
        v0: f64,
        rem: f64,
        avail: NodeSet<W>,
    ) -> f64 {
        let target = self.target();
        let mut ub = f64::INFINITY;
        for lvl in lvls {
            ub = ub.min(self.bound_one(lvl, sc, u, v0, rem, avail));
            if ub < target {
                break;
            }
        }
        ub
    }

    /// Upper bound on the final surrogate value of any completion of a path
    /// that stands at `u` with value `v0` and `rem` seconds left, using
    /// interior nodes of `avail` only (all of which `lvl` covers).
    pub(super) fn bound_one(
        &self,
        lvl: &Level<W>,
        sc: &mut Scratch,
        u: usize,
        v0: f64,
        rem: f64,
        avail: NodeSet<W>,
    ) -> f64 {
        if !lvl.goal_base.t.is_finite() {
            return f64::NEG_INFINITY;
        }
        // The current node's class: exactly one half-edge, to an available
        // node or to the goal, from which the goal is still reachable in time.
        let targets = avail | NodeSet::single(self.goal);
        let Some(base) = self.singles(lvl.split, u, targets, sc, |a, half_t| {
            2.0 * half_t + self.p.to_goal_s(a) <= rem
        }) else {
            return f64::NEG_INFINITY;
        };
        let mut cap = rem - base.t - lvl.goal_base.t;
        if cap < 0.0 {
            return f64::NEG_INFINITY;
        }
        sc.segs.clear();
        hull_segments::<W>(&sc.items, base, u as u16, &mut sc.stack, &mut sc.segs);
        let mut total = v0 + base.v + lvl.goal_base.v;
        // Fill the LP greedily: merge three slope-sorted streams (interior
        // classes, goal, current node); within each class slopes fall, so
        // the merge takes every class's segments in hull order.
        let (segs, gsegs, usegs) = (&lvl.segs, &lvl.goal_segs, &sc.segs);
        let (mut i, mut j, mut k) = (0usize, 0usize, 0usize);
        loop {
            while i < segs.len() && !avail.contains(segs[i].class as usize) {
                i += 1;
            }
            let si = segs.get(i).map_or(f64::NEG_INFINITY, |s| s.slope);
            let sj = gsegs.get(j).map_or(f64::NEG_INFINITY, |s| s.slope);
            let sk = usegs.get(k).map_or(f64::NEG_INFINITY, |s| s.slope);
            let seg = if i < segs.len() && si >= sj && si >= sk {
                i += 1;
                segs[i - 1]
            } else if j < gsegs.len() && sj >= sk {
                j += 1;
                gsegs[j - 1]
            } else if k < usegs.len() {
                k += 1;
                usegs[k - 1]
            } else {
                break;
            };
            if seg.dt <= cap {
                cap -= seg.dt;
                total += seg.dv;
            } else {
                total += seg.dv * (cap / seg.dt);
                break;
            }
        }
        // Guard against rounding: the bound must not fall below a real route's sum.
        let ub = total + 1e-9 * (1.0 + total.abs() + self.cost_offset);
        if self.integral { (ub + 1e-6).floor() } else { ub }
    }

    /// The surrogate value a completion must reach to compete with the incumbent.
    #[inline]
    pub(super) fn target(&self) -> f64 {
        if !self.have_best {
            return f64::NEG_INFINITY;
        }
        match self.p.objective() {
            Objective::MaxWeight => self.best_eval.weight,
            o @ Objective::PaperCost { .. } => self.cost_offset - self.best_eval.cost(o, self.p.budget_s()),
        }
    }

    /// Whether a subproblem with bound `ub` and route-time lower bound `t_lb`
    /// may still hold a route better than the incumbent (ties on the
    /// objective go to the smaller time, unless `break_ties` is off).
    #[inline]
    pub(super) fn promising(&self, ub: f64, t_lb: f64) -> bool {
        let target = self.target();
        ub > target || (self.break_ties && ub >= target && t_lb < self.best_eval.time_s)
    }

    /// Offers the route in `self.route` (which ends at the goal) as the
    /// incumbent; an improvement is polished by local search at once, since
    /// the better the incumbent, the more the bound prunes.
    pub(super) fn offer(&mut self) {
        if let Some(e) = self.p.evaluate(&self.route)
            && e.feasible
            && (!self.have_best || self.p.better(&e, &self.best_eval))
        {
            let (r, e) = polish(self.p, self.route, e, || self.past_deadline());
            self.best_route = r;
            self.best_eval = e;
            self.have_best = true;
        }
    }

    pub(super) fn tick(&mut self) -> bool {
        self.nodes += 1;
        self.work += 1;
        if self.nodes >= self.node_limit {
            self.aborted = true;
        } else if self.work >= self.next_clock_read {
            self.next_clock_read = self.work + WORK_PER_CLOCK_READ;
            self.aborted = self.past_deadline();
        }
        self.aborted
    }

    /// Whether the time limit has passed (the clock is read only here).
    pub(super) fn past_deadline(&self) -> bool {
        self.deadline.is_some_and(|d| Instant::now() >= d)
    }

    /// Expands the path in `self.route`, which ends at `u` after `t` seconds
    /// with value `v`; `avail` are its candidate interior nodes, `ub` its
    /// bound, `levels[depth]` the classes valid for it.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn dfs(
        &mut self,
        u: usize,
        t: f64,
        v: f64,
        visited: NodeSet<W>,
        avail: NodeSet<W>,
        depth: usize,
        ub: f64,
    ) {
        if self.tick() {
            self.open_bound = self.open_bound.max(ub);
            return;
        }
        let k_splits = self.splits.len();
        if self.levels.len() < depth + 2 {
            self.levels.resize_with(depth + 2, || vec![Level::default(); k_splits]);
        }
        let mut sc = std::mem::take(&mut self.scratch);
        let mut lvl = std::mem::take(&mut self.levels[depth + 1]);
        for (child, parent) in lvl.iter_mut().zip(&self.levels[depth]) {
            self.derive_level(parent, avail, child, &mut sc);
        }
        let mut kids = std::mem::take(&mut self.children[depth]);
        kids.clear();
        let cands = self.p.neighbours(u) & (avail | NodeSet::single(self.goal));
        for c in cands.iter() {
            let tc = t + self.p.time_s(u, c);
            if tc + self.p.to_goal_s(c) > self.limit {
                continue;
            }
            if c == self.goal {
                self.route.push(c);
                self.offer();
                self.route.truncate(self.route.len() - 1);
                continue;
            }
            let vc = v + self.val(u, c) + self.node_val[c];
            let mut vis = visited;
            vis.insert(c);
            let mut rest = avail;
            rest.remove(c);
            let rest = self.reachable(c, rest, self.limit - tc);
            let cub = self.bound(&lvl, &mut sc, c, vc, self.limit - tc, rest);
            self.work += 1;
            if !self.promising(cub, tc + self.p.to_goal_s(c)) {
                continue;
            }
            if self.memo.dominated(vis, c as u16, tc, vc, self.dom_margin) {
                continue;
            }
            kids.push(Child {
                node: c as u16,
                bound: cub,
                avail: rest,
            });
        }
        self.scratch = sc;
        self.levels[depth + 1] = lvl;
        // Best bound first; ties by node id for determinism.
        kids.sort_unstable_by(|a, b| b.bound.total_cmp(&a.bound).then(a.node.cmp(&b.node)));
        for idx in 0..kids.len() {
            let ch = kids[idx];
            let c = ch.node as usize;
            let tc = t + self.p.time_s(u, c);
            if !self.promising(ch.bound, tc + self.p.to_goal_s(c)) {
                continue;
            }
            let vc = v + self.val(u, c) + self.node_val[c];
            let mut vis = visited;
            vis.insert(c);
            self.route.push(c);
            self.dfs(c, tc, vc, vis, ch.avail, depth + 1, ch.bound);
            self.route.truncate(self.route.len() - 1);
            if self.aborted {
                // Later siblings are still open; the current one reported its own open parts.
                for k in &kids[idx + 1..] {
                    self.open_bound = self.open_bound.max(k.bound);
                }
                break;
            }
        }
        self.children[depth] = kids;
    }
}
