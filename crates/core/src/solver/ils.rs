//! The fast moves of `auto`'s ruin-and-recreate search, for routes of up to
//! a capacity class's nodes on complete or sparse, metric or non-metric networks.
//!
//! - [`Moves::shorten`]: 2-opt (segment reversal) and or-opt (move a segment
//!   of 1–3 nodes, either way round), first improvement, until no move
//!   shortens the route without losing objective value apart from time
//!   (orienteering's "shorten, then insert": the time freed is what the next
//!   insertion spends).
//! - [`Moves::fill`]: greedy insertion by objective value per second
//!   ([`Value::insertion_ratio`]) with noise, each free node's best place
//!   cached and updated only where the route changed, so a fill costs about
//!   O(free nodes) per insertion instead of O(free · route).
//! - [`Moves::ruin`]: removes a random segment, random nodes, or the route
//!   nodes nearest a random one (the three usual ruin shapes).
//! - [`Moves::reroute`] and [`Moves::reroute_kick`]: replace up to three
//!   consecutive route nodes by the best path of 0–2 free nodes between the
//!   same two route nodes (exchanges at a constant route size, and no edge
//!   across the gap needed): what `paper_cost` routes that nearly use up
//!   their budget need.
//!
//! Contract: routes stay simple paths start → goal over existing edges; no
//! move makes a feasible route infeasible (times are checked against the
//! budget with a margin for rounding, and the figures are re-evaluated
//! exactly at the end of each call); no heap allocation; every random choice
//! from the caller's generator; nothing assumes the triangle inequality.

use super::objective::Value;
use crate::capacity::{DEFAULT_WORDS, PerNode};
use crate::problem::{NodeSet, Problem};
use crate::rng::PlannerRng;
use crate::route::{Route, RouteEval};

/// Scratch of the moves (no heap).
pub struct Moves<const W: usize = DEFAULT_WORDS> {
    /// The objective's value of route changes.
    value: Value,
    /// Route position of each node on the route.
    pos: PerNode<u16, W>,
    /// Best insertion ratio of each free node (−∞: none fits).
    ratio: PerNode<f64, W>,
    /// The route node after which that best insertion goes.
    after: PerNode<u16, W>,
    /// Its time change.
    dt: PerNode<f64, W>,
    /// Per-fill noise factor of each node.
    noise: PerNode<f64, W>,
    /// The route the last [`Moves::shorten`] left with no improving move:
    /// its nodes and the successor of each.
    settled: NodeSet<W>,
    settled_next: PerNode<u16, W>,
    /// The longest segment that call's or-opt moved.
    settled_segment: usize,
}

impl<const W: usize> Default for Moves<W> {
    fn default() -> Self {
        Self::new()
    }
}

/// Smallest change that counts (s, or objective units), against rounding.
const EPS: f64 = 1e-9;

/// Which ruin shape [`Moves::ruin`] used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ruin {
    /// A run of consecutive nodes.
    Segment,
    /// Nodes drawn at random.
    Random,
    /// The nodes nearest (by edge time) to a random route node.
    Cluster,
}

impl<const W: usize> Moves<W> {
    /// Scratch ready for use.
    pub fn new() -> Self {
        Self {
            value: Value::new(crate::instance::Objective::MaxWeight),
            pos: PerNode::splat(0),
            ratio: PerNode::splat(f64::NEG_INFINITY),
            after: PerNode::splat(0),
            dt: PerNode::splat(0.0),
            noise: PerNode::splat(1.0),
            settled: NodeSet::EMPTY,
            settled_next: PerNode::splat(0),
            settled_segment: 0,
        }
    }

    /// Sets the objective the moves value changes by (call once per problem).
    /// It also forgets the settled route [`Moves::shorten`] passes over
    /// moves by, which belongs to the previous problem.
    pub fn set_objective(&mut self, p: &Problem<W>) {
        self.value = Value::of(p);
        self.settled = NodeSet::EMPTY;
    }

    /// 2-opt and or-opt until no move shortens the route without a loss of
    /// time-independent value (or improves that value without lengthening
    /// it), or `max_rounds` rounds. `e` is re-evaluated exactly. Returns
    /// whether the route changed.
    ///
    /// Moves that would only take and make edges of the last route a call
    /// left with no improving move (its settled route, same problem, edges
    /// in the same direction, segments no longer than its) are passed over:
    /// a 2-opt or or-opt move's worth depends on its edges alone, so there
    /// it was refused. The same moves are made in the same order as by a
    /// full scan, found sooner on a route that changed in a few places.
    pub fn shorten(
        &mut self,
        p: &Problem<W>,
        route: &mut Route<W>,
        e: &mut RouteEval,
        max_rounds: u32,
        max_segment: usize,
    ) -> bool {
        // The route's edges (by position, `k → k + 1`) the settled route did
        // not have in that direction; the settled route is forgotten until
        // this call settles.
        let settled = core::mem::replace(&mut self.settled, NodeSet::EMPTY);
        let mut new_edges = NodeSet::EMPTY;
        if settled.is_empty() || max_segment > self.settled_segment {
            new_edges = NodeSet::FULL;
        }
        for (k, pair) in route.ids().windows(2).enumerate() {
            let u = usize::from(pair[0]);
            if !(settled.contains(u) && self.settled_next[u] == pair[1]) {
                new_edges.insert(k);
            }
        }
        let v = &self.value;
        let accept = |dt: f64, sd: f64| (sd > EPS && dt <= EPS) || (sd >= -EPS && dt < -EPS);
        let ew = |a: usize, b: usize| p.edge_weight(a, b);
        let mut changed = false;
        let mut converged = false;
        let octets = Problem::<W>::route_scans_in_octets();
        for _ in 0..max_rounds {
            let mut improved = false;
            let len = route.len();
            // 2-opt: reverse i..=j; only the two boundary edges change
            // (edges are undirected; prizes stay with their nodes). Every
            // improving reversal met in the sweep is applied at once.
            for i in 1..len.saturating_sub(2) {
                let a = route.get(i - 1);
                let row_a = p.time_row(a);
                // The first node of the reversal, its row and the time of
                // the edge into it change only when a reversal is applied.
                let mut ui = route.get(i);
                let (mut row_ui, mut t_aui) = (p.time_row(ui), row_a[ui]);
                let mut j = i + 1;
                while j < len - 1 {
                    let all_new = new_edges.contains(i - 1);
                    if !all_new && !new_edges.contains(j) {
                        match new_edges.first_from(j) {
                            Some(next) => j = next,
                            None => break,
                        }
                        continue;
                    }
                    // The ends j.. worth a closer look: with gathers eight
                    // at a time where eight remain (shorter stretches cost
                    // more in gathers than they save), those whose time
                    // change alone may be accepted (the test below, in the
                    // same sums) and that touch a new edge; else just j.
                    let (mut lanes, width) = if octets && j + 8 < len {
                        let fit = p.reversals_within(route.ids(), a, ui, j, len - 1, EPS);
                        (if all_new { fit } else { fit & new_edges.octet_from(j) }, 8)
                    } else {
                        (1, 1)
                    };
                    let mut next = j + width;
                    while lanes != 0 {
                        let k = j + lanes.trailing_zeros() as usize;
                        lanes &= lanes - 1;
                        let (uk, b) = (usize::from(route.ids()[k]), usize::from(route.ids()[k + 1]));
                        // `accept` never takes a move that lengthens the
                        // route, so the time table alone rules most
                        // reversals out before the larger edge records are
                        // read.
                        let dt = row_a[uk] + row_ui[b] - t_aui - p.time_s(uk, b);
                        if dt <= EPS && p.has_edge(a, uk) && p.has_edge(ui, b) {
                            let dw = ew(a, uk) + ew(ui, b) - ew(a, ui) - ew(uk, b);
                            let dr =
                                p.risk_ratio(a, uk) + p.risk_ratio(ui, b) - p.risk_ratio(a, ui) - p.risk_ratio(uk, b);
                            if accept(dt, v.static_delta(dw, dr)) {
                                route.reverse(i, k);
                                improved = true;
                                ui = uk;
                                (row_ui, t_aui) = (p.time_row(ui), row_a[ui]);
                                // Its two new edges, and the reversed ones,
                                // whose order against the rest changed.
                                for q in i - 1..=k {
                                    new_edges.insert(q);
                                }
                                // The lanes after k were judged against the
                                // route before this reversal.
                                next = k + 1;
                                break;
                            }
                        }
                    }
                    j = next;
                }
            }
            if !improved {
                improved = Self::or_opt(p, v, route, &mut new_edges, max_segment.min(3), &accept);
            }
            if !improved {
                converged = true;
                break;
            }
            changed = true;
        }
        if converged {
            self.settled_segment = max_segment;
            for pair in route.ids().windows(2) {
                let u = usize::from(pair[0]);
                self.settled.insert(u);
                self.settled_next[u] = pair[1];
            }
        }
        if changed && let Some(x) = p.evaluate(route) {
            *e = x;
        }
        changed
    }

    /// The first improving or-opt move found, applied.
    /// Only moves that take or make an edge in `new_edges` (by position)
    /// are tried; the edges the applied move changes are added to it.
    fn or_opt(
        p: &Problem<W>,
        v: &Value,
        route: &mut Route<W>,
        new_edges: &mut NodeSet<W>,
        max_segment: usize,
        accept: &impl Fn(f64, f64) -> bool,
    ) -> bool {
        let len = route.len();
        let octets = Problem::<W>::route_scans_in_octets();
        let ew = |a: usize, b: usize| p.edge_weight(a, b);
        let fig = |a: usize, b: usize| (p.time_s(a, b), ew(a, b), p.risk_ratio(a, b));
        let wr = |a: usize, b: usize| (ew(a, b), p.risk_ratio(a, b));
        for l in 1..=max_segment {
            for i in 1..len.saturating_sub(l) {
                let (a, b) = (route.get(i - 1), route.get(i + l));
                if !p.has_edge(a, b) {
                    continue;
                }
                let (h, t) = (route.get(i), route.get(i + l - 1));
                let (ah, tb, ab) = (fig(a, h), fig(t, b), fig(a, b));
                let out = (ah.0 + tb.0 - ab.0, ah.1 + tb.1 - ab.1, ah.2 + tb.2 - ab.2);
                // A move that changes only edges the settled route had, in
                // the same order, was refused there: with the segment's
                // edges all old, only new target edges are tried.
                let segment_new = (i - 1..i + l).any(|q| new_edges.contains(q));
                // The segment's own edges, as bits of an octet from `k`.
                let own = |k: usize| {
                    let (lo, hi) = ((i - 1).saturating_sub(k).min(8), (i + l).saturating_sub(k).min(8));
                    ((1u16 << hi) - (1u16 << lo)) as u8
                };
                let mut k = 0;
                while k < len - 1 {
                    if !segment_new && !new_edges.contains(k) {
                        match new_edges.first_from(k) {
                            Some(next) => k = next,
                            None => break,
                        }
                        continue;
                    }
                    // The target edges k.. worth a closer look: with gathers
                    // eight at a time where eight remain, those where either
                    // orientation's time change may be accepted (the test
                    // below, in the same sums), off the segment and, unless
                    // the segment is new, new; else just k.
                    let (mut lanes, width) = if octets && k + 8 < len {
                        let ids = route.ids();
                        let mut fit = p.relocations_within(ids, h, t, k, len - 1, out.0, EPS);
                        if l > 1 {
                            fit |= p.relocations_within(ids, t, h, k, len - 1, out.0, EPS);
                        }
                        let new = if segment_new { u8::MAX } else { new_edges.octet_from(k) };
                        (fit & new & !own(k), 8)
                    } else {
                        (u8::from(!(i - 1..i + l).contains(&k)), 1)
                    };
                    while lanes != 0 {
                        let k = k + lanes.trailing_zeros() as usize;
                        lanes &= lanes - 1;
                        let (c, d) = (route.get(k), route.get(k + 1));
                        let t_cd = p.time_s(c, d);
                        for rev in [false, true] {
                            if rev && l == 1 {
                                break;
                            }
                            let (x, y) = if rev { (t, h) } else { (h, t) };
                            // Times first, as in the 2-opt sweep: a move that
                            // lengthens the route is never accepted.
                            let dt = p.time_s(c, x) + p.time_s(y, d) - t_cd - out.0;
                            if dt > EPS || !(p.has_edge(c, x) && p.has_edge(y, d)) {
                                continue;
                            }
                            let (cx, yd, cd) = (wr(c, x), wr(y, d), wr(c, d));
                            let dw = cx.0 + yd.0 - cd.0 - out.1;
                            let dr = cx.1 + yd.1 - cd.1 - out.2;
                            if accept(dt, v.static_delta(dw, dr)) {
                                route.relocate(i, l, k, rev);
                                // Every edge between the segment's old and
                                // new places moved or changed.
                                for q in (i - 1).min(k)..=(i + l - 1).max(k) {
                                    new_edges.insert(q);
                                }
                                return true;
                            }
                        }
                    }
                    k += width;
                }
            }
        }
        false
    }

    /// Best place to insert `u` on `route` (its ratio, the node before and
    /// the time change), given `time_s` of route time and `limit`.
    #[inline]
    fn best_place(
        p: &Problem<W>,
        v: &Value,
        route: &Route<W>,
        u: usize,
        noise: f64,
        time_s: f64,
        limit: f64,
    ) -> (f64, u16, f64) {
        let nu = p.neighbours(u);
        let row_u = p.time_row(u);
        let mut best = (f64::NEG_INFINITY, 0u16, 0.0);
        for pair in route.ids().windows(2) {
            let (a, b) = (usize::from(pair[0]), usize::from(pair[1]));
            // Most places do not fit: their time, read from u's own row
            // (edge times are symmetric), rules them out first.
            if time_s + (row_u[a] + row_u[b] - p.time_s(a, b)) > limit {
                continue;
            }
            if let Some((r, dt)) = Self::insertion(p, v, nu, u, (a, b), noise, time_s, limit)
                && r > best.0
            {
                best = (r, a as u16, dt);
            }
        }
        best
    }

    /// Inserting `u` (neighbours `nu`) into the edge `a`–`b` of a route of
    /// `time_s`: its noisy value ratio and added time, s, when it fits in
    /// `limit` and gains; `None` otherwise.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn insertion(
        p: &Problem<W>,
        v: &Value,
        nu: NodeSet<W>,
        u: usize,
        (a, b): (usize, usize),
        noise: f64,
        time_s: f64,
        limit: f64,
    ) -> Option<(f64, f64)> {
        // The time first: a missing edge's +∞ fails it as well.
        let dt = p.time_s(a, u) + p.time_s(u, b) - p.time_s(a, b);
        if time_s + dt > limit || !(nu.contains(a) && nu.contains(b)) {
            return None;
        }
        let dw = p.gain(a, u) + p.gain(u, b) - p.gain(a, b);
        let dr = p.risk_ratio(a, u) + p.risk_ratio(u, b) - p.risk_ratio(a, b);
        if v.delta(dt, dw, dr) <= 0.0 {
            return None;
        }
        Some((v.noisy_insertion_ratio(dt, dw, dr, noise), dt))
    }

    /// Greedy insertion: while some free node (not on the route, not
    /// excluded, not `barred`) fits and is worth inserting, inserts the one
    /// with the best value per second, its time-independent part scaled by
    /// a noise factor in [1, 1 + `noise`) drawn per node and call
    /// ([`Value::noisy_insertion_ratio`]); only insertions that gain are made. `route` must be feasible
    /// with figures `e`; `e` is re-evaluated exactly. Returns the number of
    /// nodes inserted.
    pub fn fill(
        &mut self,
        p: &Problem<W>,
        route: &mut Route<W>,
        e: &mut RouteEval,
        barred: NodeSet<W>,
        noise: f64,
        rng: &mut PlannerRng,
    ) -> u32 {
        let v = self.value;
        let v = &v;
        if !e.feasible {
            return 0;
        }
        // A margin below the budget so that rounding in the running sum
        // never makes the exact re-evaluation infeasible.
        let limit = p.budget_limit_s() - EPS * p.budget_s();
        for (k, u) in route.iter().enumerate() {
            self.pos[u] = k as u16;
        }
        let mut free = p.free_nodes(route) - barred;
        let mut time_s = e.time_s;
        for u in free.iter() {
            self.noise[u] = if noise > 0.0 { 1.0 + noise * rng.next_f64() } else { 1.0 };
            (self.ratio[u], self.after[u], self.dt[u]) = (f64::NEG_INFINITY, 0, 0.0);
        }
        // Each free node's best place ([`Moves::best_place`] for all of
        // them at once, route edge by route edge, so that one row pass per
        // edge rules out the nodes whose detour cannot fit; `insertion`
        // decides exactly).
        for pair in route.ids().windows(2) {
            let (a, b) = (usize::from(pair[0]), usize::from(pair[1]));
            let fit = p.detours_fitting(a, b, p.time_s(a, b), time_s, limit);
            for u in (free & fit).iter() {
                if let Some((r, dt)) = Self::insertion(p, v, p.neighbours(u), u, (a, b), self.noise[u], time_s, limit)
                    && r > self.ratio[u]
                {
                    (self.ratio[u], self.after[u], self.dt[u]) = (r, a as u16, dt);
                }
            }
        }
        let mut inserted = 0;
        loop {
            let mut pick = usize::MAX;
            let mut best = 0.0;
            for u in free.iter() {
                if self.ratio[u] > best {
                    best = self.ratio[u];
                    pick = u;
                }
            }
            if pick == usize::MAX {
                break;
            }
            let a = self.after[pick] as usize;
            let k = self.pos[a] as usize;
            let b = route.get(k + 1);
            route.insert(k + 1, pick);
            time_s += self.dt[pick];
            free.remove(pick);
            inserted += 1;
            for (j, u) in route.iter().enumerate().skip(k + 1) {
                self.pos[u] = j as u16;
            }
            // Update the other free nodes: a node whose best place was the
            // edge a–b just split, or which no longer fits there, is placed
            // afresh; the others only compare the two new edges.
            for u in free.iter() {
                let placed = self.ratio[u] > f64::NEG_INFINITY;
                let stale = placed && (self.after[u] as usize == a || time_s + self.dt[u] > limit);
                if stale {
                    (self.ratio[u], self.after[u], self.dt[u]) =
                        Self::best_place(p, v, route, u, self.noise[u], time_s, limit);
                    continue;
                }
                let nu = p.neighbours(u);
                for (x, y) in [(a, pick), (pick, b)] {
                    if let Some((r, dt)) = Self::insertion(p, v, nu, u, (x, y), self.noise[u], time_s, limit)
                        && r > self.ratio[u]
                    {
                        (self.ratio[u], self.after[u], self.dt[u]) = (r, x as u16, dt);
                    }
                }
            }
        }
        if inserted > 0
            && let Some(x) = p.evaluate(route)
        {
            *e = x;
        }
        inserted
    }

    /// Removes up to `size` interior nodes of `route` in the given shape
    /// (a removal is skipped where the neighbours share no edge or where it
    /// would make a feasible route infeasible) and returns the removed set.
    /// `e` is re-evaluated exactly.
    pub fn ruin(
        &mut self,
        p: &Problem<W>,
        route: &mut Route<W>,
        e: &mut RouteEval,
        shape: Ruin,
        size: usize,
        rng: &mut PlannerRng,
    ) -> NodeSet<W> {
        let mut removed = NodeSet::EMPTY;
        let interior = route.len().saturating_sub(2);
        if interior == 0 || size == 0 {
            return removed;
        }
        let size = size.min(interior);
        // Without the triangle inequality (task times on edges, rounded or
        // explicit distances) a removal can lengthen the route: only those
        // that keep a feasible route feasible are made.
        let limit = if e.feasible {
            p.budget_limit_s() - EPS * p.budget_s()
        } else {
            f64::INFINITY
        };
        let mut time_s = e.time_s;
        let remove_at = |route: &mut Route<W>, i: usize, removed: &mut NodeSet<W>, time_s: &mut f64| -> bool {
            let (a, u, b) = (route.get(i - 1), route.get(i), route.get(i + 1));
            if !p.has_edge(a, b) {
                return false;
            }
            let t = *time_s + p.time_s(a, b) - p.time_s(a, u) - p.time_s(u, b);
            if t > limit {
                return false;
            }
            *time_s = t;
            removed.insert(u);
            route.remove(i);
            true
        };
        match shape {
            Ruin::Segment => {
                // Nodes one by one from a random position: the gap closes
                // over each removal, so the result is the same segment
                // removed where every step is allowed.
                let i = 1 + rng.below(interior as u32) as usize;
                for _ in 0..size {
                    if i + 1 >= route.len() || !remove_at(route, i, &mut removed, &mut time_s) {
                        break;
                    }
                }
            }
            Ruin::Random => {
                for _ in 0..size {
                    let inner = route.len() - 2;
                    if inner == 0 {
                        break;
                    }
                    let i = 1 + rng.below(inner as u32) as usize;
                    remove_at(route, i, &mut removed, &mut time_s);
                }
            }
            Ruin::Cluster => {
                let c = route.get(1 + rng.below(interior as u32) as usize);
                let mut tried = NodeSet::<W>::EMPTY;
                for _ in 0..size {
                    // The nearest remaining interior node to c (c first).
                    let mut best = (f64::INFINITY, 0usize);
                    for i in 1..route.len() - 1 {
                        let u = route.get(i);
                        let t = if u == c { -1.0 } else { p.time_s(c, u) };
                        if t < best.0 && !tried.contains(u) {
                            best = (t, i);
                        }
                    }
                    if best.1 == 0 {
                        break;
                    }
                    tried.insert(route.get(best.1));
                    remove_at(route, best.1, &mut removed, &mut time_s);
                }
            }
        }
        if !removed.is_empty()
            && let Some(x) = p.evaluate(route)
        {
            *e = x;
        }
        removed
    }
}

/// Most route nodes one reroute takes out, and most free nodes the new
/// path between the same two route nodes carries (our choice: 3 out, 2 in,
/// so one reroute covers the 1↔1, 2↔1, 1↔2, 2↔2 and 3↔2 exchanges; a path
/// of 3 would cost deg³ evaluations per window).
pub const REROUTE_OUT: usize = 3;

impl<const W: usize> Moves<W> {
    /// The best path of 0–2 nodes of `allowed` from `a` to `b` that replaces
    /// figures `out` (time, weight, Σ ξ/ρ of the sub-path it stands in for)
    /// and keeps the route time within `avail` of `out.0` more: its score
    /// change, nodes and node count. `skip_direct` leaves the bare edge out
    /// (it is the window itself when nothing is taken out).
    fn best_path(
        &self,
        p: &Problem<W>,
        (a, b): (usize, usize),
        allowed: NodeSet<W>,
        out: (f64, f64, f64),
        avail: f64,
        skip_direct: bool,
    ) -> Option<(f64, [u16; 2], usize)> {
        let v = &self.value;
        let mut best: Option<(f64, [u16; 2], usize)> = None;
        let mut take = |t: f64, w: f64, r: f64, nodes: [u16; 2], m: usize| {
            if t - out.0 > avail {
                return;
            }
            let d = v.delta(t - out.0, w - out.1, r - out.2);
            if best.is_none_or(|(bd, _, _)| d > bd) {
                best = Some((d, nodes, m));
            }
        };
        let fig = |x: usize, y: usize| (p.time_s(x, y), p.gain(x, y), p.risk_ratio(x, y));
        if !skip_direct && p.has_edge(a, b) {
            let (t, w, r) = fig(a, b);
            take(t, w, r, [0, 0], 0);
        }
        let nb = p.neighbours(b);
        for x in (p.neighbours(a) & allowed).iter() {
            let ax = fig(a, x);
            if ax.0 - out.0 > avail {
                continue;
            }
            if nb.contains(x) {
                let xb = fig(x, b);
                take(ax.0 + xb.0, ax.1 + xb.1, ax.2 + xb.2, [x as u16, 0], 1);
            }
            let mut ys = p.neighbours(x) & nb & allowed;
            ys.remove(x);
            for y in ys.iter() {
                let (xy, yb) = (fig(x, y), fig(y, b));
                take(
                    ax.0 + xy.0 + yb.0,
                    ax.1 + xy.1 + yb.1,
                    ax.2 + xy.2 + yb.2,
                    [x as u16, y as u16],
                    2,
                );
            }
        }
        best
    }

    /// Figures (time, weight, Σ ξ/ρ) of `route` from position `i` to `j`.
    fn span(p: &Problem<W>, route: &Route<W>, i: usize, j: usize) -> (f64, f64, f64) {
        let mut f = (0.0, 0.0, 0.0);
        for k in i..j {
            let (x, y) = (route.get(k), route.get(k + 1));
            f = (f.0 + p.time_s(x, y), f.1 + p.gain(x, y), f.2 + p.risk_ratio(x, y));
        }
        f
    }

    /// Replaces positions `i + 1 .. j` of `route` by `nodes[..m]`.
    fn splice(route: &mut Route<W>, i: usize, j: usize, nodes: [u16; 2], m: usize) {
        for _ in i + 1..j {
            route.remove(i + 1);
        }
        for (k, &u) in nodes[..m].iter().enumerate() {
            route.insert(i + 1 + k, u as usize);
        }
    }

    /// Reroute local search: replaces the nodes between two route nodes
    /// (up to [`REROUTE_OUT`] of them, consecutive) by the best path of 0–2
    /// free nodes between the same two, best improvement per round, until
    /// none improves or `max_rounds`. Unlike insertion and removal it needs
    /// no edge across the gap, and it exchanges nodes at a constant route
    /// size: what a route that already spends nearly all of its budget
    /// needs under `paper_cost`. `route` must be feasible; `e` is
    /// re-evaluated exactly. Returns whether the route changed.
    pub fn reroute(&mut self, p: &Problem<W>, route: &mut Route<W>, e: &mut RouteEval, max_rounds: u32) -> bool {
        if !e.feasible {
            return false;
        }
        let limit = p.budget_limit_s() - EPS * p.budget_s();
        let mut changed = false;
        for _ in 0..max_rounds {
            let free = p.free_nodes(route);
            let len = route.len();
            let mut best = (EPS, 0, 0, [0u16; 2], 0);
            for i in 0..len - 1 {
                let mut window = NodeSet::EMPTY;
                for j in i + 1..len.min(i + 2 + REROUTE_OUT) {
                    if j > i + 1 {
                        window.insert(route.get(j - 1));
                    }
                    let out = Self::span(p, route, i, j);
                    let avail = limit - e.time_s;
                    let ends = (route.get(i), route.get(j));
                    if let Some((d, nodes, m)) = self.best_path(p, ends, free | window, out, avail, j == i + 1)
                        && d > best.0
                    {
                        best = (d, i, j, nodes, m);
                    }
                }
            }
            if best.0 <= EPS {
                break;
            }
            let (_, i, j, nodes, m) = best;
            let keep = *route;
            Self::splice(route, i, j, nodes, m);
            match p.evaluate(route) {
                Some(x) if x.feasible && p.better(&x, e) => {
                    *e = x;
                    changed = true;
                }
                _ => {
                    *route = keep;
                    break;
                }
            }
        }
        changed
    }

    /// A reroute kick: takes out 1–[`REROUTE_OUT`] consecutive route nodes
    /// at a random place and puts in the best path of 0–2 other free nodes
    /// between the two route nodes around them, worse or not (no edge across
    /// the gap needed, unlike [`Moves::ruin`]). Returns the nodes taken out
    /// (empty when the route is too short or no path fits; `route` is then
    /// unchanged). `e` is re-evaluated exactly.
    pub fn reroute_kick(
        &mut self,
        p: &Problem<W>,
        route: &mut Route<W>,
        e: &mut RouteEval,
        rng: &mut PlannerRng,
    ) -> NodeSet<W> {
        let len = route.len();
        if !e.feasible || len < 3 {
            return NodeSet::EMPTY;
        }
        let limit = p.budget_limit_s() - EPS * p.budget_s();
        let i = rng.below((len - 2) as u32) as usize;
        let most = REROUTE_OUT.min(len - 2 - i);
        let j = i + 2 + rng.below(most as u32) as usize;
        let free = p.free_nodes(route);
        let out = Self::span(p, route, i, j);
        let Some((_, nodes, m)) = self.best_path(p, (route.get(i), route.get(j)), free, out, limit - e.time_s, false)
        else {
            return NodeSet::EMPTY;
        };
        let mut gone = NodeSet::EMPTY;
        for k in i + 1..j {
            gone.insert(route.get(k));
        }
        let keep = *route;
        Self::splice(route, i, j, nodes, m);
        match p.evaluate(route) {
            Some(x) if x.feasible => {
                *e = x;
                gone
            }
            _ => {
                *route = keep;
                NodeSet::EMPTY
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::random_instance;
    use crate::instance::Objective;

    // The default capacity class unless a test names another.
    type Problem = crate::problem::Problem;
    type NodeSet = crate::problem::NodeSet;
    type Route = crate::route::Route;
    type Moves = crate::solver::ils::Moves;

    fn problems() -> Vec<Problem> {
        let mut out = Vec::new();
        for seed in 0..16u64 {
            for objective in [Objective::MaxWeight, Objective::PaperCost { phi1: 0.01, phi2: 1.0 }] {
                let mut inst = random_instance(20 + (seed as usize * 7) % 80, 0.3 + 0.04 * seed as f64, 31_000.0, seed);
                inst.objective = objective;
                if let Ok(p) = Problem::from_instance(&inst) {
                    out.push(p);
                }
            }
        }
        out
    }

    /// The route start → goal and its figures, when it is feasible.
    fn direct_route(p: &Problem) -> Option<(Route, RouteEval)> {
        let r = Route::from_slice(&[p.start(), p.goal()])?;
        let e = p.evaluate(&r)?;
        e.feasible.then_some((r, e))
    }

    #[test]
    fn moves_keep_routes_valid_feasible_and_their_figures_exact() {
        let mut m = Moves::new();
        let mut rng = PlannerRng::new(3);
        let mut filled = 0;
        for p in problems() {
            let v = Value::of(&p);
            m.set_objective(&p);
            let Some((mut r, mut e)) = direct_route(&p) else {
                continue;
            };
            for round in 0..20 {
                let before = e;
                filled += m.fill(&p, &mut r, &mut e, NodeSet::EMPTY, 0.3, &mut rng);
                assert_eq!(p.evaluate(&r), Some(e));
                assert!(e.feasible);
                assert!(
                    v.delta(
                        e.time_s - before.time_s,
                        e.weight - before.weight,
                        e.risk_ratio_sum - before.risk_ratio_sum
                    ) >= -1e-9
                );
                let t = e.time_s;
                m.shorten(&p, &mut r, &mut e, 1000, 3);
                assert_eq!(p.evaluate(&r), Some(e));
                assert!(e.time_s <= t + 1e-6 && e.feasible);
                let shape = [Ruin::Segment, Ruin::Random, Ruin::Cluster][round % 3];
                let gone = m.ruin(&p, &mut r, &mut e, shape, 1 + round % 5, &mut rng);
                assert_eq!(p.evaluate(&r), Some(e));
                assert!(gone.iter().all(|u| !r.iter().any(|x| x == u)));
            }
        }
        assert!(filled > 100, "{filled}");
    }

    #[test]
    fn reroute_keeps_routes_exact_and_leaves_no_improving_window() {
        let mut m = Moves::new();
        let mut rng = PlannerRng::new(6);
        let mut windows = 0;
        let mut kicked = 0;
        for p in problems().into_iter().filter(|p| Value::of(p).values_time()) {
            m.set_objective(&p);
            let Some((mut r, mut e)) = direct_route(&p) else {
                continue;
            };
            m.fill(&p, &mut r, &mut e, NodeSet::EMPTY, 0.3, &mut rng);
            for _ in 0..4 {
                let gone = m.reroute_kick(&p, &mut r, &mut e, &mut rng);
                assert_eq!(p.evaluate(&r), Some(e));
                assert!(e.feasible);
                assert!(gone.iter().all(|u| !r.iter().any(|x| x == u)));
                kicked += usize::from(!gone.is_empty());
                let before = e;
                m.reroute(&p, &mut r, &mut e, 10_000);
                assert_eq!(p.evaluate(&r), Some(e));
                assert!(e.feasible && !p.better(&before, &e));
            }
            // Brute force: no replacement of up to REROUTE_OUT consecutive
            // nodes by a path of at most two others beats the result.
            let ids = r.to_vec();
            let free: Vec<usize> = (0..p.n())
                .filter(|u| !ids.contains(u) && !p.excluded().contains(*u))
                .collect();
            for i in 0..ids.len() - 1 {
                for j in i + 1..ids.len().min(i + 2 + REROUTE_OUT) {
                    let mut paths: Vec<Vec<usize>> = vec![vec![]];
                    let pool: Vec<usize> = free.iter().copied().chain(ids[i + 1..j].iter().copied()).collect();
                    for &x in &pool {
                        paths.push(vec![x]);
                        for &y in pool.iter().filter(|&&y| y != x) {
                            paths.push(vec![x, y]);
                        }
                    }
                    for path in paths {
                        let c: Vec<usize> = ids[..=i].iter().chain(&path).chain(&ids[j..]).copied().collect();
                        let Some(ce) = Route::from_slice(&c).and_then(|cr| p.evaluate(&cr)) else {
                            continue;
                        };
                        windows += 1;
                        assert!(
                            !ce.feasible || p.score(&ce) <= p.score(&e) + 1e-9,
                            "{c:?} beats {ids:?}"
                        );
                    }
                }
            }
        }
        assert!(kicked > 20 && windows > 1000, "{kicked} kicks, {windows} windows");
    }

    #[test]
    fn shorten_leaves_no_improving_two_opt() {
        let mut m = Moves::new();
        let mut rng = PlannerRng::new(4);
        for p in problems() {
            let v = Value::of(&p);
            m.set_objective(&p);
            let Some((mut r, mut e)) = direct_route(&p) else {
                continue;
            };
            m.fill(&p, &mut r, &mut e, NodeSet::EMPTY, 0.5, &mut rng);
            m.shorten(&p, &mut r, &mut e, 100_000, 3);
            let ids = r.to_vec();
            for i in 1..ids.len().saturating_sub(2) {
                for j in i + 1..ids.len() - 1 {
                    let mut c = ids.clone();
                    c[i..=j].reverse();
                    let Some(ce) = Route::from_slice(&c).and_then(|cr| p.evaluate(&cr)) else {
                        continue;
                    };
                    let sd = v.static_delta(ce.weight - e.weight, ce.risk_ratio_sum - e.risk_ratio_sum);
                    let dt = ce.time_s - e.time_s;
                    assert!(
                        !((sd > 1e-6 && dt <= 0.0) || (sd >= 0.0 && dt < -1e-6)),
                        "{c:?} beats {ids:?}"
                    );
                }
            }
        }
    }

    /// Shortening a route that changed in a few places since the last
    /// settled call (a polish, a ruin, a fill) makes the same moves as
    /// shortening it afresh: the moves over old edges it passes over were
    /// refused before.
    #[test]
    fn shortening_a_changed_route_makes_the_same_moves_as_afresh() {
        let (mut settled, mut afresh) = (Moves::new(), Moves::new());
        let mut ls = crate::solver::local::LocalSearch::new();
        let mut rng = PlannerRng::new(7);
        let mut changed = 0;
        for p in problems() {
            settled.set_objective(&p);
            let Some((mut r, mut e)) = direct_route(&p) else {
                continue;
            };
            let mut compare = |settled: &mut Moves, r: &mut Route, e: &mut RouteEval| {
                let (mut fresh, mut fresh_e) = (*r, *e);
                let by_settled = settled.shorten(&p, r, e, 100_000, 3);
                // A new problem's scratch: no settled route, a full scan.
                afresh.set_objective(&p);
                let by_fresh = afresh.shorten(&p, &mut fresh, &mut fresh_e, 100_000, 3);
                assert_eq!(r.to_vec(), fresh.to_vec());
                assert_eq!((by_settled, *e), (by_fresh, fresh_e));
                usize::from(by_settled)
            };
            for round in 0..16 {
                settled.fill(&p, &mut r, &mut e, NodeSet::EMPTY, 0.5, &mut rng);
                if round % 2 == 1 {
                    ls.improve(&p, &mut r, &mut e, 50);
                } else if r.len() > 4 {
                    // Turn a stretch round (whatever that is worth): its
                    // edges run the other way from the settled route's.
                    let ids = r.to_vec();
                    let i = 1 + rng.below(ids.len() as u32 - 3) as usize;
                    let j = i + 1 + rng.below((ids.len() - 2 - i) as u32) as usize;
                    let mut turned = ids.clone();
                    turned[i..=j].reverse();
                    if let Some((tr, te)) = Route::from_slice(&turned).and_then(|tr| Some((tr, p.evaluate(&tr)?)))
                        && te.feasible
                    {
                        (r, e) = (tr, te);
                    }
                }
                let shape = [Ruin::Segment, Ruin::Random, Ruin::Cluster][round % 3];
                settled.ruin(&p, &mut r, &mut e, shape, 2 + round, &mut rng);
                changed += compare(&mut settled, &mut r, &mut e);
                // Grow it by a few nodes only, so that most edges are old.
                let mut barred = p.free_nodes(&r);
                for _ in 0..1 + round % 2 {
                    let free: Vec<usize> = barred.iter().collect();
                    if !free.is_empty() {
                        barred.remove(free[rng.below(free.len() as u32) as usize]);
                    }
                }
                settled.fill(&p, &mut r, &mut e, barred, 0.5, &mut rng);
                changed += compare(&mut settled, &mut r, &mut e);
            }
        }
        assert!(changed > 20, "only {changed} shortenings changed a route");
    }
}
