//! A resumable depth-first branch-and-bound over the low-risk edges, for
//! objectives that value time (`paper_cost`).
//!
//! Why: under `paper_cost` a good route runs on the tasks of lowest ξ/ρ,
//! and the best routes use almost only edges among the few lowest-risk
//! ones at one of their ends. On dense networks they spend the budget to
//! the second (every second idle costs φ1), and finding the combination
//! whose times add up to the budget is a subset-sum-like search that
//! ruin-and-recreate kicks rarely complete; on sparse networks with a
//! small φ1 the best route is a short low-risk path that shares few nodes
//! with the kicks' routes. Restricted to those candidate edges, a plain
//! depth-first search with bounds on risk and idle time finds the routes
//! the kicks miss; over each node's 8 lowest-risk edges it finishes in
//! 0.05–0.4 million expansions on dense 40-node networks and 1–4 million
//! on dense 64-node ones (about 30 ns each).
//!
//! Contract: [`RiskSearch::start`] builds the candidate graph of a problem
//! and the bound's tables (no allocation: every buffer is sized for the
//! capacity class in [`RiskSearch::new`]); [`RiskSearch::run`] expands at
//! most a given number of partial paths and reports a route that beats the
//! cost it was given, then resumes where it stopped on the next call. The
//! search order depends on the problem only, so it is deterministic.
//!
//! Candidate graph: each node's `candidates` lowest-ξ/ρ edges (at most
//! [`CANDIDATES`]), both ends keeping the pair while either has room for
//! it (at most [`DEGREE`] per node), neighbours tried lowest bound first.
//!
//! Bounds of a partial path start → … → v at time t with Σ ξ/ρ = R, both
//! valid for every completion within the budget B:
//! - risk: its cost is at least φ2 · (R + least Σ ξ/ρ from v to the goal
//!   over candidate edges) (the idle term is at least 0);
//! - risk and idle time: with μ = min(φ1, φ2 · least ξ/ρ per second of any
//!   candidate edge), every second left is either idle (φ1 ≥ μ) or spent on
//!   an edge whose risk costs at least μ per second, so the cost is at least
//!   φ2 · R + μ · (B − t) + least Σ (φ2 · ξ/ρ − μ · time) from v to the
//!   goal (weights ≥ 0 by the choice of μ).
//!
//! Rows run by the second bound's edge term, so a row stops at the first
//! edge that reaches the best cost; the first bound cuts single edges. On
//! the 12 untuned 40-node `bc40-pc` seeds the pair cut the expansions of a
//! complete search at 8 candidates by 2.7× (sum of times) against the risk
//! bound alone. (A fractional knapsack of the time left cut a tenth more
//! partial paths than the risk bound and doubled the cost of each; a table
//! of finished partial paths by node set and end, to cut those that another
//! order of the same nodes dominates, cut almost none.) Partial paths that
//! cannot reach the goal within the budget (shortest time over the whole
//! network) are cut as well.
//!
//! Aspiration (iterative deepening on the cost): the root's bound is often
//! half the best cost or less, and a search that prunes against a weak
//! incumbent (at first the kicks' routes, 10–50 % above the optimum on the
//! dense training networks at a few milliseconds) expands far more partial
//! paths than one that knows a cost near the optimum (told a cost within
//! 5–10 % of it, the search reached the optimum of the untuned 50- and
//! 64-node dense networks that took it 25–50 ms in under 10–20 ms). So the
//! search first runs passes that prune at an aspiration, a cost it has no
//! route for yet: 1/16 above the root's bound, each pass that finds no
//! route below it aspiring 1.5 times as far above the bound, until a pass
//! finds one (it then prunes at that route, so the pass is complete: no
//! route better than its best is left unexplored) or the aspiration passes
//! twice the bound, after which it runs without one. A failed pass costs
//! little next to the first pass that succeeds, which prunes at a cost
//! close to the optimum instead of at the incumbent. A route a pass
//! reaches above its aspiration but below the best cost is still taken
//! and reported: without that, the passes held back the mediocre routes a
//! search without aspirations reports within a millisecond, which the
//! kicks improve on (5 ms mean gaps of 20–40 % on the untuned dense
//! families, against 2–7 % with it).

use crate::capacity::nodes_of;
use crate::instance::Objective;
use crate::problem::{NodeSet, Problem};
use crate::route::{Route, RouteEval};

/// Most lowest-risk edges a node contributes to the candidate graph.
pub const CANDIDATES: usize = 16;

/// The first aspiration, as a fraction above the root's bound (see
/// [`RiskSearch::run`]).
const FIRST_ASPIRATION: f64 = 1.0 / 16.0;

/// Each pass that finds no route below its aspiration multiplies the
/// fraction by this.
const ASPIRATION_GROWTH: f64 = 1.5;

/// Past this fraction the search runs without an aspiration.
const LAST_ASPIRATION: f64 = 2.0;

/// Most candidate neighbours a node keeps.
pub const DEGREE: usize = 2 * CANDIDATES;

/// A candidate edge as the search reads it: the far node, the edge's
/// time and ξ/ρ (copied next to each other: the search's inner loop reads
/// nothing else of the edge).
#[derive(Clone, Copy, Default)]
struct Candidate {
    to: usize,
    time_s: f64,
    risk: f64,
    /// `risk` plus the least Σ ξ/ρ from `to` to the goal: the risk bound's
    /// term for taking the edge.
    risk_key: f64,
    /// The edge's φ2 · ξ/ρ − μ · time plus the least such sum from `to` to
    /// the goal: the order of a row and the idle bound's term.
    key: f64,
}

/// The search's state and buffers, for problems of capacity class `W`.
pub struct RiskSearch<const W: usize> {
    /// Candidate neighbours by node.
    adjacency: Vec<[u16; DEGREE]>,
    /// The same rows with each edge's figures, by [`Candidate::key`].
    rows: Vec<[Candidate; DEGREE]>,
    /// Valid entries of each `adjacency` row.
    degree: Vec<u8>,
    /// Least Σ ξ/ρ from each node to the goal over candidate edges.
    risk_to_goal: Vec<f64>,
    /// Least Σ (φ2 · ξ/ρ − μ · time) from each node to the goal over
    /// candidate edges.
    priced_to_goal: Vec<f64>,
    /// Per depth of the path: its node, the next candidate to try there,
    /// and the path's time and Σ ξ/ρ up to that node.
    path: Vec<u16>,
    next: Vec<u8>,
    time_s: Vec<f64>,
    risk: Vec<f64>,
    /// Path length (0: the search is over).
    depth: usize,
    on_path: NodeSet<W>,
    /// φ2 of the problem (the bounds' price of risk).
    phi2: f64,
    /// μ: the idle bound's price of a second of budget left.
    idle_price: f64,
    /// The budget B, s.
    budget_s: f64,
    /// Cost of the best route the search found or was told of.
    best_cost: f64,
    /// The aspiration: a cost the search prunes at as if a route of that
    /// cost were known (∞: none). See [`RiskSearch::run`].
    cap: f64,
    /// The root's lower bound on the cost of any candidate route.
    root_bound: f64,
    found: Route<W>,
}

impl<const W: usize> Default for RiskSearch<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> RiskSearch<W> {
    /// Allocates every buffer for the capacity class.
    pub fn new() -> Self {
        let n = nodes_of(W);
        Self {
            adjacency: vec![[0; DEGREE]; n],
            rows: vec![[Candidate::default(); DEGREE]; n],
            degree: vec![0; n],
            risk_to_goal: vec![0.0; n],
            priced_to_goal: vec![0.0; n],
            path: vec![0; n],
            next: vec![0; n],
            time_s: vec![0.0; n],
            risk: vec![0.0; n],
            depth: 0,
            on_path: NodeSet::EMPTY,
            phi2: 0.0,
            idle_price: 0.0,
            budget_s: 0.0,
            best_cost: f64::INFINITY,
            cap: f64::INFINITY,
            root_bound: 0.0,
            found: Route::new(),
        }
    }

    /// Builds the candidate graph of each node's `candidates` (at most
    /// [`CANDIDATES`]) lowest-risk edges and the bound's tables of `p`, and
    /// puts the search at its root. Under an objective that does not value
    /// time the search is over at once.
    pub fn start(&mut self, p: &Problem<W>, candidates: usize) {
        let k = candidates.clamp(1, CANDIDATES);
        self.depth = 0;
        self.best_cost = f64::INFINITY;
        let Objective::PaperCost { phi1, phi2 } = p.objective() else {
            return;
        };
        let (n, goal) = (p.n(), p.goal());
        if p.start() == goal || phi1 <= 0.0 {
            return;
        }
        self.phi2 = phi2;
        self.degree[..n].fill(0);
        let mut own = [0u16; CANDIDATES];
        for u in 0..n {
            // This node's lowest-risk edges, by insertion into a short list.
            let mut len = 0;
            for v in p.neighbours(u).iter() {
                let r = p.risk_ratio(u, v);
                if len == k && r >= p.risk_ratio(u, own[len - 1] as usize) {
                    continue;
                }
                let mut i = len.min(k - 1);
                while i > 0 && p.risk_ratio(u, own[i - 1] as usize) > r {
                    own[i] = own[i - 1];
                    i -= 1;
                }
                own[i] = v as u16;
                len = (len + 1).min(k);
            }
            for &v in &own[..len] {
                let v = v as usize;
                self.link(u, v);
            }
        }
        let mut least_rate = f64::INFINITY;
        for u in 0..n {
            for &v in &self.adjacency[u][..self.degree[u] as usize] {
                let t = p.time_s(u, v as usize);
                let rate = if t > 0.0 { p.risk_ratio(u, v as usize) / t } else { 0.0 };
                least_rate = least_rate.min(rate);
            }
        }
        let mu = if least_rate.is_finite() {
            (phi2 * least_rate).min(phi1)
        } else {
            0.0
        };
        self.idle_price = mu;
        self.budget_s = p.budget_s();
        // Rounding may leave a weight a hair below 0; Dijkstra needs ≥ 0.
        let priced = |u: usize, v: usize| (phi2 * p.risk_ratio(u, v) - mu * p.time_s(u, v)).max(0.0);
        least_to_goal(
            p,
            &self.adjacency,
            &self.degree,
            |u, v| p.risk_ratio(u, v),
            &mut self.risk_to_goal,
        );
        least_to_goal(p, &self.adjacency, &self.degree, priced, &mut self.priced_to_goal);
        for u in 0..n {
            let row = &mut self.adjacency[u][..self.degree[u] as usize];
            let key = |v: u16| priced(u, v as usize) + self.priced_to_goal[v as usize];
            row.sort_unstable_by(|&a, &b| key(a).total_cmp(&key(b)));
            for (c, &v) in self.rows[u].iter_mut().zip(row.iter()) {
                let (v, risk) = (v as usize, p.risk_ratio(u, v as usize));
                *c = Candidate {
                    to: v,
                    time_s: p.time_s(u, v),
                    risk,
                    risk_key: risk + self.risk_to_goal[v],
                    key: key(v as u16),
                };
            }
        }
        let s = p.start();
        self.root_bound = (mu * self.budget_s + self.priced_to_goal[s]).max(phi2 * self.risk_to_goal[s]);
        self.cap = if self.root_bound > 0.0 && self.root_bound.is_finite() {
            self.root_bound * (1.0 + FIRST_ASPIRATION)
        } else {
            f64::INFINITY
        };
        self.reset_to_root(s);
    }

    /// Puts the search at its root, the path holding the start `s` alone.
    fn reset_to_root(&mut self, s: usize) {
        self.path[0] = s as u16;
        self.next[0] = 0;
        self.time_s[0] = 0.0;
        self.risk[0] = 0.0;
        self.on_path = NodeSet::single(s);
        self.depth = 1;
    }

    /// Adds the pair u–v to both candidate rows when both have room and it
    /// is not there yet.
    fn link(&mut self, u: usize, v: usize) {
        let (du, dv) = (self.degree[u] as usize, self.degree[v] as usize);
        if du == DEGREE || dv == DEGREE || self.adjacency[u][..du].contains(&(v as u16)) {
            return;
        }
        self.adjacency[u][du] = v as u16;
        self.adjacency[v][dv] = u as u16;
        self.degree[u] += 1;
        self.degree[v] += 1;
    }

    /// Whether the search has looked at every candidate path.
    pub fn is_done(&self) -> bool {
        self.depth == 0
    }

    /// Expands at most `expansions` partial paths, pruning against
    /// `incumbent_cost` (the best route known elsewhere), the search's own
    /// best or the present pass's aspiration, whichever is lowest. Returns
    /// the best route found in this call that beats the incumbent and the
    /// search's best (above the aspiration or not), if any. A pass that
    /// ends with its aspiration below the best cost starts the next one
    /// from the root (within the same call).
    pub fn run(&mut self, p: &Problem<W>, incumbent_cost: f64, expansions: u32) -> Option<&Route<W>> {
        self.best_cost = self.best_cost.min(incumbent_cost);
        let (goal, limit) = (p.goal(), p.budget_limit_s());
        let mut found = false;
        let mut left = expansions;
        loop {
            if self.depth == 0 {
                // A pass under an aspiration below the best cost left routes
                // between the two unexplored: the next pass aspires higher.
                if self.cap < self.best_cost {
                    let gap = (self.cap / self.root_bound - 1.0) * ASPIRATION_GROWTH;
                    self.cap = if gap > LAST_ASPIRATION {
                        f64::INFINITY
                    } else {
                        self.root_bound * (1.0 + gap)
                    };
                    self.reset_to_root(p.start());
                } else {
                    break;
                }
            }
            if left == 0 {
                break;
            }
            let prune_at = self.best_cost.min(self.cap);
            let level = self.depth - 1;
            let u = self.path[level] as usize;
            let i = self.next[level] as usize;
            if i >= self.degree[u] as usize {
                self.on_path.remove(u);
                self.depth -= 1;
                continue;
            }
            self.next[level] += 1;
            let c = self.rows[u][i];
            // The idle bound; rows run by it ascending, so once an edge
            // reaches the cost pruned at, so does every later one.
            let priced_so_far = self.phi2 * self.risk[level] + self.idle_price * (self.budget_s - self.time_s[level]);
            if priced_so_far + c.key >= prune_at {
                self.next[level] = DEGREE as u8;
                continue;
            }
            let v = c.to;
            if self.on_path.contains(v) || self.phi2 * (self.risk[level] + c.risk_key) >= prune_at {
                continue;
            }
            left -= 1;
            let t = self.time_s[level] + c.time_s;
            if t + p.to_goal_s(v) > limit {
                continue;
            }
            let r = self.risk[level] + c.risk;
            if v == goal {
                let route = RouteEval {
                    time_s: t,
                    risk_ratio_sum: r,
                    ..RouteEval::default()
                };
                let cost = route.cost(p.objective(), p.budget_s());
                if cost < self.best_cost {
                    self.best_cost = cost;
                    self.found.clear();
                    for &w in &self.path[..self.depth] {
                        self.found.push(w as usize);
                    }
                    self.found.push(goal);
                    found = true;
                }
                continue;
            }
            self.path[self.depth] = v as u16;
            self.next[self.depth] = 0;
            self.time_s[self.depth] = t;
            self.risk[self.depth] = r;
            self.on_path.insert(v);
            self.depth += 1;
        }
        found.then_some(&self.found)
    }
}

/// Least sum of `weight` (≥ 0) from each node to the goal over the
/// candidate graph, into `out` (Dijkstra by linear scans: n ≤ 512 and one
/// start per solve).
fn least_to_goal<const W: usize>(
    p: &Problem<W>,
    adjacency: &[[u16; DEGREE]],
    degree: &[u8],
    weight: impl Fn(usize, usize) -> f64,
    out: &mut [f64],
) {
    let n = p.n();
    out[..n].fill(f64::INFINITY);
    out[p.goal()] = 0.0;
    let mut settled = NodeSet::<W>::EMPTY;
    loop {
        let mut u = usize::MAX;
        let mut best = f64::INFINITY;
        for (i, &d) in out[..n].iter().enumerate() {
            if d < best && !settled.contains(i) {
                (u, best) = (i, d);
            }
        }
        if u == usize::MAX {
            return;
        }
        settled.insert(u);
        for &v in &adjacency[u][..degree[u] as usize] {
            let v = v as usize;
            let d = best + weight(u, v);
            if d < out[v] {
                out[v] = d;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::random_instance;
    use crate::solver::exact::{ExactSettings, solve_exact};

    type Problem = crate::problem::Problem;

    fn cost_instance(n: usize, density: f64, seed: u64) -> crate::instance::Instance {
        let mut inst = random_instance(n, density, 31_000.0, seed);
        inst.objective = Objective::PaperCost { phi1: 0.01, phi2: 1.0 };
        inst
    }

    #[test]
    fn every_route_it_reports_is_valid_feasible_and_costs_what_it_says() {
        for seed in 0..6 {
            let p = Problem::from_instance(&cost_instance(24, 0.9, seed)).unwrap();
            let mut s = RiskSearch::new();
            s.start(&p, 8);
            let mut reported = 0;
            while !s.is_done() {
                if let Some(r) = s.run(&p, f64::INFINITY, 500) {
                    let e = p.evaluate(r).expect("a valid route");
                    assert!(e.feasible, "seed {seed}");
                    let cost = e.cost(p.objective(), p.budget_s());
                    assert!((cost - s.best_cost).abs() <= 1e-9 * cost.max(1.0), "seed {seed}");
                    reported += 1;
                }
            }
            assert!(reported > 0, "seed {seed}: a dense network has a candidate route");
        }
    }

    #[test]
    fn on_the_full_graph_it_proves_what_the_exact_solver_proves() {
        // With every edge a candidate (small networks: degree ≤ DEGREE) the
        // search is complete, so its best equals the proved optimum.
        for seed in 0..4 {
            let p = Problem::from_instance(&cost_instance(9, 0.9, seed)).unwrap();
            assert!((0..p.n()).all(|u| p.neighbours(u).len() as usize <= CANDIDATES));
            let mut s = RiskSearch::new();
            s.start(&p, 8);
            while !s.is_done() {
                s.run(&p, f64::INFINITY, 1000);
            }
            let exact = solve_exact(&p, &ExactSettings::default()).unwrap();
            assert!(exact.proved_optimal);
            let opt = exact.eval.cost(p.objective(), p.budget_s());
            assert!(
                (s.best_cost - opt).abs() <= 1e-9 * opt.max(1.0),
                "seed {seed}: {} vs {opt}",
                s.best_cost
            );
        }
    }

    #[test]
    fn it_resumes_where_it_stopped_and_reports_only_what_beats_the_incumbent() {
        let p = Problem::from_instance(&cost_instance(30, 0.9, 3)).unwrap();
        let (mut whole, mut sliced) = (RiskSearch::new(), RiskSearch::new());
        whole.start(&p, 8);
        sliced.start(&p, 8);
        while !whole.is_done() {
            whole.run(&p, f64::INFINITY, u32::MAX);
        }
        while !sliced.is_done() {
            sliced.run(&p, f64::INFINITY, 7);
        }
        assert_eq!(whole.found.to_vec(), sliced.found.to_vec());
        assert_eq!(whole.best_cost, sliced.best_cost);
        // Told of a route as good as its best, it reports nothing.
        let mut told = RiskSearch::new();
        told.start(&p, 8);
        while !told.is_done() {
            assert!(told.run(&p, whole.best_cost, 100).is_none());
        }
    }

    /// Expansions until the search has looked at every candidate route,
    /// and the cost it ends at.
    fn run_to_end(s: &mut RiskSearch<{ crate::capacity::DEFAULT_WORDS }>, p: &Problem) -> (u64, f64) {
        let mut calls = 0u64;
        while !s.is_done() {
            s.run(p, f64::INFINITY, 64);
            calls += 1;
        }
        (calls * 64, s.best_cost)
    }

    #[test]
    fn aspirations_end_at_the_same_optimum_in_fewer_expansions() {
        let (mut aspiring_total, mut plain_total) = (0, 0);
        for seed in 0..4 {
            let p = Problem::from_instance(&cost_instance(36, 0.9, seed)).unwrap();
            let mut aspiring = RiskSearch::new();
            aspiring.start(&p, CANDIDATES);
            assert!(aspiring.cap.is_finite(), "seed {seed}: the first pass aspires");
            let mut plain = RiskSearch::new();
            plain.start(&p, CANDIDATES);
            plain.cap = f64::INFINITY;
            let (a, a_cost) = run_to_end(&mut aspiring, &p);
            let (b, b_cost) = run_to_end(&mut plain, &p);
            assert_eq!(a_cost, b_cost, "seed {seed}");
            aspiring_total += a;
            plain_total += b;
        }
        assert!(aspiring_total < plain_total, "{aspiring_total} against {plain_total}");
    }

    #[test]
    fn max_weight_is_not_searched() {
        let p = Problem::from_instance(&random_instance(20, 0.9, 31_000.0, 1)).unwrap();
        let mut s = RiskSearch::new();
        s.start(&p, 8);
        assert!(s.is_done());
        assert!(s.run(&p, f64::INFINITY, 100).is_none());
    }
}
