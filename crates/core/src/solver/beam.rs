//! A resumable forward beam search over simple paths, for `max_weight`.
//!
//! Why: on sparse networks (Bay of Islands charts, 30–45 % of node pairs
//! are edges) the best route often runs through a region the current route
//! does not touch, or through a cluster the other way round, for ten nodes
//! and more. A ruin removes at most a third of the route and needs an edge
//! across its gap, and the refill inserts one node at a time between route
//! neighbours that must both be adjacent to it, so the iterated local
//! search stays in its basin (untuned 40–80-node families: 12–18 % below
//! the proved optimum from 20 ms to 1 s). A beam builds whole routes
//! forward from the start, keeps many different ones alive, and hands the
//! best to the local search as a new basin.
//!
//! Contract: [`Beam::start`] prepares a problem (no allocation: every
//! buffer is sized for the capacity class in [`Beam::new`]); [`Beam::step`]
//! expands one level (every partial path by one node) and, once no partial
//! path is left, returns the best complete route it met, once. The order
//! depends on the problem and the price only, so the search is
//! deterministic.
//!
//! Guide: a partial path start → … → u with weight v at time t is ranked by
//! v + price · (T − t), T the budget: time left is worth `price` weight a
//! second. An optimistic bound (a fractional knapsack of the nodes that can
//! still reach the goal, each at its best incoming gain over its quickest
//! incoming edge) ranked short paths first whatever they had collected:
//! its beams' routes were 30 % below the best known on the Bay of Islands
//! families, a price of 0.6–0.8 times the best known weight per second of
//! budget 5–6 % below. No single price suits every network, so the caller
//! runs beams at several.

use crate::capacity::{DEFAULT_WORDS, nodes_of};
use crate::problem::{NodeSet, Problem};
use crate::route::Route;

/// Most partial paths a level keeps (the widest beam [`Beam::start`] takes).
pub const MAX_WIDTH: usize = 32;

/// One partial path of a level.
#[derive(Clone, Copy)]
struct Entry<const W: usize> {
    /// Index of the parent in the previous level.
    parent: u16,
    /// Last node.
    node: u16,
    /// Time so far, s.
    t: f64,
    /// Weight so far.
    v: f64,
    /// Nodes on the path.
    visited: NodeSet<W>,
}

/// An extension of a level's entry, before selection.
#[derive(Clone, Copy)]
struct Candidate {
    parent: u16,
    node: u16,
    t: f64,
    v: f64,
    rank: f64,
}

/// The beam's order: higher rank first, ties by node, then by parent (a
/// strict total order: one candidate per parent and node).
fn beam_order(a: &Candidate, b: &Candidate) -> core::cmp::Ordering {
    b.rank
        .total_cmp(&a.rank)
        .then(a.node.cmp(&b.node))
        .then(a.parent.cmp(&b.parent))
}

/// Moves the best `count` candidates of `rest` to its front, in order, and
/// returns how many that is.
fn rank_best(rest: &mut [Candidate], count: usize) -> usize {
    let count = count.min(rest.len());
    if count > 0 && count < rest.len() {
        rest.select_nth_unstable_by(count - 1, beam_order);
    }
    rest[..count].sort_unstable_by(beam_order);
    count
}

/// The beam's state and buffers, for problems of capacity class `W`.
pub struct Beam<const W: usize = DEFAULT_WORDS> {
    /// Partial paths by level, `MAX_WIDTH` slots each.
    levels: Vec<[Entry<W>; MAX_WIDTH]>,
    /// Filled slots by level.
    sizes: Vec<usize>,
    /// Extensions of the current level.
    candidates: Vec<Candidate>,
    /// Weight a second of time left is worth in the ranking.
    price: f64,
    /// Partial paths kept per level in this search.
    width: usize,
    /// Current level.
    depth: usize,
    /// Best complete route met, its weight and time.
    best: Route<W>,
    best_v: f64,
    best_t: f64,
    done: bool,
    handed: bool,
}

impl<const W: usize> Default for Beam<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> Beam<W> {
    /// Allocates every buffer for the class.
    pub fn new() -> Self {
        let n = nodes_of(W);
        let empty = Entry {
            parent: 0,
            node: 0,
            t: 0.0,
            v: 0.0,
            visited: NodeSet::EMPTY,
        };
        Self {
            levels: vec![[empty; MAX_WIDTH]; n + 1],
            sizes: vec![0; n + 1],
            candidates: Vec::with_capacity(MAX_WIDTH * n),
            width: 1,
            price: 0.0,
            depth: 0,
            best: Route::new(),
            best_v: f64::NEG_INFINITY,
            best_t: f64::INFINITY,
            done: true,
            handed: true,
        }
    }

    /// Prepares a search of `p` from its start that keeps `width` partial
    /// paths per level (at most [`MAX_WIDTH`]) and prices a second of time
    /// left at `price` weight.
    pub fn start(&mut self, p: &Problem<W>, width: usize, price: f64) {
        self.width = width.clamp(1, MAX_WIDTH);
        self.price = if price.is_finite() { price.max(0.0) } else { 0.0 };
        let s = p.start();
        self.levels[0][0] = Entry {
            parent: 0,
            node: s as u16,
            t: 0.0,
            v: p.prize(s),
            visited: NodeSet::single(s),
        };
        self.sizes[0] = 1;
        self.depth = 0;
        self.best.clear();
        self.best_v = f64::NEG_INFINITY;
        self.best_t = f64::INFINITY;
        self.done = false;
        self.handed = false;
    }

    /// Whether the search has ended and its route was handed over.
    pub fn is_done(&self) -> bool {
        self.done && self.handed
    }

    /// Expands one level. Returns the best complete route once the search
    /// has ended (and `None` before and after).
    pub fn step(&mut self, p: &Problem<W>) -> Option<&Route<W>> {
        if self.done {
            let first = !self.handed;
            self.handed = true;
            return (first && !self.best.is_empty()).then_some(&self.best);
        }
        let limit = p.budget_limit_s();
        let goal = p.goal();
        let d = self.depth;
        self.candidates.clear();
        for i in 0..self.sizes[d] {
            let m = self.levels[d][i];
            let u = m.node as usize;
            let open = p.neighbours(u) - m.visited - p.excluded();
            for c in open.iter() {
                let tc = m.t + p.time_s(u, c);
                if tc + p.to_goal_s(c) > limit {
                    continue;
                }
                let vc = m.v + p.gain(u, c);
                if c == goal {
                    if vc > self.best_v || (vc == self.best_v && tc < self.best_t) {
                        self.best_v = vc;
                        self.best_t = tc;
                        self.trace(d, i, goal);
                    }
                    continue;
                }
                let rank = vc + self.price * (limit - tc);
                self.candidates.push(Candidate {
                    parent: i as u16,
                    node: c as u16,
                    t: tc,
                    v: vc,
                    rank,
                });
            }
        }
        let mut size = 0;
        if d + 1 < self.levels.len() {
            // Only the best few candidates are ever looked at: rank them in
            // batches instead of sorting every one (the order is total, so the
            // batches are exactly a full sort's prefix).
            let mut ranked = 0;
            for k in 0..self.candidates.len() {
                if size == self.width {
                    break;
                }
                if k == ranked {
                    ranked += rank_best(&mut self.candidates[ranked..], 2 * self.width);
                }
                let c = self.candidates[k];
                let mut visited = self.levels[d][c.parent as usize].visited;
                visited.insert(c.node as usize);
                // One path per last node and node set: the better ranked.
                let twin = self.levels[d + 1][..size]
                    .iter()
                    .any(|e| e.node == c.node && e.visited == visited);
                if !twin {
                    self.levels[d + 1][size] = Entry {
                        parent: c.parent,
                        node: c.node,
                        t: c.t,
                        v: c.v,
                        visited,
                    };
                    size += 1;
                }
            }
            self.sizes[d + 1] = size;
        }
        self.depth = d + 1;
        self.done = size == 0;
        None
    }

    /// Writes the route of entry `i` of level `d`, then `last`, into `best`.
    fn trace(&mut self, d: usize, i: usize, last: usize) {
        self.best.clear();
        let (mut level, mut k) = (d, i);
        loop {
            let e = self.levels[level][k];
            self.best.push(e.node as usize);
            if level == 0 {
                break;
            }
            k = e.parent as usize;
            level -= 1;
        }
        let len = self.best.len();
        self.best.reverse(0, len - 1);
        self.best.push(last);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::random_instance;
    use crate::solver::exact::{ExactSettings, solve_exact};

    type Problem = crate::problem::Problem;

    #[test]
    fn the_beam_hands_over_one_feasible_simple_route_with_its_weight() {
        let mut beam = Beam::new();
        let mut found = 0;
        for seed in 0..12u64 {
            let inst = random_instance(20 + 5 * seed as usize, 0.35, 31_000.0, seed);
            let Ok(p) = Problem::from_instance(&inst) else {
                continue;
            };
            let opt = solve_exact(&p, &ExactSettings::default()).expect("solvable");
            // No price, and the prices `auto` uses.
            for factor in [0.0, 0.5, 0.9] {
                beam.start(&p, 16, factor * opt.eval.weight / p.budget_limit_s());
                let mut route = None;
                for _ in 0..=p.n() + 1 {
                    if let Some(r) = beam.step(&p) {
                        assert!(route.is_none(), "handed over twice");
                        route = Some(*r);
                    }
                }
                assert!(beam.is_done());
                let Some(r) = route else {
                    continue;
                };
                found += 1;
                let e = p.evaluate(&r).expect("a valid route");
                assert!(e.feasible);
                assert_eq!(r.get(0), p.start());
                assert_eq!(r.last(), Some(p.goal()));
                assert!((e.weight - beam.best_v).abs() < 1e-6 * e.weight.max(1.0));
                // Never better than the proved optimum.
                assert!(e.weight <= opt.eval.weight + 1e-6);
            }
        }
        assert!(found >= 30, "{found}");
    }

    proptest::proptest! {
        /// Ranking in batches gives exactly a full sort's order, ties in
        /// rank included.
        #[test]
        fn batches_of_the_best_are_a_full_sorts_prefix(
            cands in proptest::collection::vec((0u16..6, 0u16..40, 0u8..5), 1..200),
            batch in 1usize..20,
        ) {
            let mut seen = std::collections::BTreeSet::new();
            let mut all: Vec<Candidate> = cands
                .into_iter()
                .filter(|&(parent, node, _)| seen.insert((parent, node)))
                .map(|(parent, node, r)| Candidate { parent, node, t: 0.0, v: 0.0, rank: f64::from(r) })
                .collect();
            let mut full = all.clone();
            full.sort_unstable_by(beam_order);
            let mut ranked = 0;
            while ranked < all.len() {
                ranked += rank_best(&mut all[ranked..], batch);
            }
            let key = |c: &Candidate| (c.parent, c.node);
            proptest::prop_assert_eq!(
                all.iter().map(key).collect::<Vec<_>>(),
                full.iter().map(key).collect::<Vec<_>>()
            );
        }
    }
}
