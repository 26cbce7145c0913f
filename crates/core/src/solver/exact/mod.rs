//! Exact solver: a depth-first branch-and-bound over simple paths that proves
//! the optimum of a [`Problem`] (both objectives) or, when stopped early,
//! reports its best route with a valid bound and gap.
//!
//! Contract: [`solve_exact`] returns the best route under the problem's own
//! ordering ([`Problem::better`]: objective first, ties to the smaller route
//! time). When `proved_optimal` is true no feasible route is better; otherwise
//! `bound` is a valid bound on the optimal objective value (an upper bound
//! on the weight for `max_weight`, a lower bound on the cost for
//! `paper_cost`). Same input and settings (without a time limit) → same
//! result: the search order depends on the problem only.
//!
//! Method (why a search of our own rather than a MIP solver: see the
//! README; in short, on 40-node paper-like instances it proves optima
//! 10–100× faster than HiGHS on a flow model, with no C++ dependency):
//! - Branching extends a partial path start→…→u by one neighbour, best bound
//!   first. A neighbour is a candidate only if the shortest time from it to
//!   the goal still fits.
//! - Bound: the time-budgeted route from u to the goal is relaxed to a
//!   multiple-choice knapsack. Each edge's value is split between its two
//!   ends; an interior node of the path takes two half-edges of its own, u
//!   and the goal one each. The LP relaxation of that knapsack (upper concave
//!   hulls of each node's half-edge pairs, filled greedily by slope) bounds
//!   the value of every completion. Nodes that cannot be on a completion
//!   (visited, or too far to reach and still get home) are left out, and a
//!   node's hull is rebuilt below a search node only when a neighbour it
//!   used drops out.
//! - Two splits of edge values are used and the smaller bound is taken: the
//!   even one, and one tuned at the root by Lagrangian subgradient steps
//!   (`lagrange.rs`), which is much tighter at the root but was tuned there.
//! - Dominance: two partial paths at the same node with the same visited set
//!   are compared; the one with less time and no less value wins (a lossy
//!   fixed-size table remembers the states seen).
//! - Incumbents: the quickest route, an optional warm start, then a
//!   bound-guided beam search (`beam.rs`) before the proof; every new
//!   incumbent is polished by local search (`polish.rs`).
//!
//! Objectives are searched through one surrogate value V summed along the
//! route: the weight for `max_weight`, and φ1·T_e − φ2·ξ/ρ for `paper_cost`
//! (then cost = φ1·T_available − V whenever T_R ≤ T_available, and
//! cost ≥ φ1·T_available − V always, so bounds on V bound the cost).

mod beam;
mod hull;
mod lagrange;
mod polish;
mod search;
#[cfg(test)]
mod tests;

use std::time::{Duration, Instant};

use crate::capacity::DEFAULT_WORDS;
use crate::capacity::nodes_of;
use crate::instance::Objective;
use crate::problem::{NodeSet, Problem};
use crate::route::{Route, RouteEval};

use search::{Level, Memo, Scratch, Search, Split, memo_bits};

/// How long the exact search may run.
#[derive(Clone, Copy, Debug)]
pub struct ExactSettings<const W: usize = DEFAULT_WORDS> {
    /// Wall-clock limit; `None` runs to proof.
    pub time_limit: Option<Duration>,
    /// Limit on search nodes (deterministic stop); `None` for no limit.
    pub node_limit: Option<u64>,
    /// A route of this problem to start from (for example a heuristic's
    /// answer); ignored when not a feasible route. A good one speeds the
    /// proof up, since the bound prunes against the best route known.
    pub warm_start: Option<Route<W>>,
    /// Prove the format's full order: among routes of the best objective
    /// value, the one with the smallest time. `true` in
    /// [`ExactSettings::default`]; `false` proves the objective value only
    /// (what benchmark tables compare), which can be much faster when many
    /// routes share the best value (integer prizes).
    pub break_ties: bool,
    /// Run a bound-guided beam search for a strong first incumbent before
    /// the proof; `true` in [`ExactSettings::default`].
    pub beam: bool,
    /// Tune the split of edge values between their ends at the root
    /// (Lagrangian bound tightening); `true` in [`ExactSettings::default`].
    pub tune_split: bool,
}

impl<const W: usize> Default for ExactSettings<W> {
    fn default() -> Self {
        Self {
            time_limit: None,
            node_limit: None,
            warm_start: None,
            break_ties: true,
            beam: true,
            tune_split: true,
        }
    }
}

/// Result of an exact solve.
#[derive(Clone, Copy, Debug)]
pub struct ExactOutcome<const W: usize = DEFAULT_WORDS> {
    /// Best route found (feasible).
    pub route: Route<W>,
    /// Its figures.
    pub eval: RouteEval,
    /// No feasible route is better than `route` (with `break_ties` off: no
    /// feasible route has a better objective value). A stopped search with
    /// `gap` 0 has proved the value but not the time tie-break.
    pub proved_optimal: bool,
    /// Bound on the optimal objective value: an upper bound on the weight
    /// (`max_weight`) or a lower bound on the cost (`paper_cost`). Equals the
    /// route's value when proved.
    pub bound: f64,
    /// Relative gap |bound − value| / max(|value|, 1e-9); 0 when proved.
    pub gap: f64,
    /// The bound before any branching (same units as `bound`): how tight the
    /// relaxation is on this problem.
    pub root_bound: f64,
    /// Search nodes (partial paths) expanded.
    pub nodes_explored: u64,
    /// Wall-clock time of the solve.
    pub elapsed: Duration,
}

/// Why the exact solver could not answer.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum ExactError {
    /// Even the quickest path to the goal exceeds the budget.
    #[error("no feasible route: the quickest path to the goal takes {quickest_s} s, the budget is {budget_s} s")]
    NoFeasibleRoute {
        /// Shortest time start→goal, s.
        quickest_s: f64,
        /// The budget, s.
        budget_s: f64,
    },
    /// An objective weight that is negative or not finite.
    #[error("paper_cost weights must be finite and >= 0 (phi1 = {phi1}, phi2 = {phi2})")]
    BadObjective {
        /// Time-use weight.
        phi1: f64,
        /// Risk weight.
        phi2: f64,
    },
    /// A figure of the problem that the search cannot handle (not finite).
    #[error("edge {a}-{b} has a non-finite or negative time or value")]
    BadEdge {
        /// One end.
        a: usize,
        /// Other end.
        b: usize,
    },
}

/// Solves `problem` exactly (or until the settings stop it).
pub fn solve_exact<const W: usize>(
    problem: &Problem<W>,
    settings: &ExactSettings<W>,
) -> Result<ExactOutcome<W>, ExactError> {
    let t0 = Instant::now();
    let n = problem.n();
    let (s, g) = (problem.start(), problem.goal());
    let limit = problem.budget_limit_s();
    let quickest = problem.to_goal_s(s);
    if quickest > limit {
        return Err(ExactError::NoFeasibleRoute {
            quickest_s: quickest,
            budget_s: problem.budget_s(),
        });
    }
    let (phi1, phi2, paper) = match problem.objective() {
        Objective::MaxWeight => (0.0, 0.0, false),
        Objective::PaperCost { phi1, phi2 } => {
            if !(phi1.is_finite() && phi2.is_finite() && phi1 >= 0.0 && phi2 >= 0.0) {
                return Err(ExactError::BadObjective { phi1, phi2 });
            }
            (phi1, phi2, true)
        }
    };
    let mut val = vec![0.0; n * n];
    let mut node_val = vec![0.0; n];
    let mut integral = !paper;
    for a in 0..n {
        if !paper {
            node_val[a] = problem.prize(a);
            integral &= node_val[a].fract() == 0.0 && node_val[a].abs() < 1e15;
        }
        for b in problem.neighbours(a).iter() {
            let t = problem.time_s(a, b);
            let x = if paper {
                phi1 * t - phi2 * problem.risk_ratio(a, b)
            } else {
                problem.edge_weight(a, b)
            };
            if !(t.is_finite() && t >= 0.0 && x.is_finite()) {
                return Err(ExactError::BadEdge { a, b });
            }
            integral &= x.fract() == 0.0 && x.abs() < 1e15;
            val[a * n + b] = x;
        }
    }
    // All-pairs shortest times (Floyd–Warshall; n ≤ 128).
    let mut sp = vec![f64::INFINITY; n * n];
    for a in 0..n {
        sp[a * n + a] = 0.0;
        for b in problem.neighbours(a).iter() {
            sp[a * n + b] = problem.time_s(a, b);
        }
    }
    for k in 0..n {
        for a in 0..n {
            let dak = sp[a * n + k];
            if !dak.is_finite() {
                continue;
            }
            for b in 0..n {
                let c = dak + sp[k * n + b];
                if c < sp[a * n + b] {
                    sp[a * n + b] = c;
                }
            }
        }
    }
    let mut usable = NodeSet::EMPTY;
    for v in 0..n {
        if v != s && v != g && !problem.excluded().contains(v) && sp[s * n + v] + problem.to_goal_s(v) <= limit {
            usable.insert(v);
        }
    }
    // Each edge's value split evenly between its ends, until tuned below.
    let mut half: Vec<f64> = val.iter().map(|&x| 0.5 * x).collect();
    let cost_offset = phi1 * problem.budget_s();
    let mut search = Search {
        p: problem,
        n,
        goal: g,
        limit,
        val,
        node_val,
        sp,
        splits: vec![Split::new(problem, &half)],
        integral,
        cost_offset,
        break_ties: settings.break_ties,
        dom_margin: 2.0 * phi1 * (limit - problem.budget_s()),
        route: Route::new(),
        best_route: Route::new(),
        best_eval: RouteEval::default(),
        have_best: false,
        nodes: 0,
        children: (0..=nodes_of(W)).map(|_| Vec::with_capacity(nodes_of(W))).collect(),
        levels: Vec::with_capacity(nodes_of(W) + 2),
        scratch: Scratch::default(),
        memo: Memo::new(memo_bits(n)),
        deadline: settings.time_limit.map(|d| t0 + d),
        node_limit: settings.node_limit.unwrap_or(u64::MAX),
        work: 0,
        next_clock_read: 0,
        aborted: false,
        open_bound: f64::NEG_INFINITY,
    };
    // The quickest route is the first incumbent, so one always exists.
    // Reachable: checked above.
    search.route = problem.quickest_route().unwrap_or_default();
    search.offer();
    if let Some(r) = settings.warm_start {
        search.route = r;
        search.offer();
    }
    search.route.clear();
    search.route.push(s);
    let v0 = search.node_val[s];
    let mut visited = NodeSet::EMPTY;
    visited.insert(s);
    let avail = search.reachable(s, usable, limit);
    if settings.tune_split {
        // The tuned split is kept beside the even one: it is tighter at the
        // root but, tuned for the root, not always deeper down.
        lagrange::tune_split(&search, &mut half, avail, search.target());
        search.splits.push(Split::new(problem, &half));
    }
    // Classes valid at the root: interior nodes may neighbour the start too.
    let mut sc = Scratch::default();
    let root_levels: Vec<Level<W>> = (0..search.splits.len())
        .map(|k| {
            search.fresh_level(
                k,
                avail,
                avail | NodeSet::single(s) | NodeSet::single(g),
                avail | NodeSet::single(s),
                &mut sc,
            )
        })
        .collect();
    let root_bound = search.bound(&root_levels, &mut sc, s, v0, limit, avail);
    if settings.beam && search.promising(root_bound, quickest) {
        let root = search.route;
        beam::beam(&mut search, root, v0, avail, &root_levels, &mut sc);
        search.route.clear();
        search.route.push(s);
    }
    search.levels.push(root_levels);
    search.scratch = sc;
    if search.promising(root_bound, quickest) {
        search.dfs(s, 0.0, v0, visited, avail, 0, root_bound);
    }
    let eval = search.best_eval;
    let proved = !search.aborted;
    let root_bound = match problem.objective() {
        Objective::MaxWeight => root_bound,
        Objective::PaperCost { .. } => (cost_offset - root_bound).max(0.0),
    };
    let (value, bound) = match problem.objective() {
        Objective::MaxWeight => {
            let b = if proved {
                eval.weight
            } else {
                search.open_bound.max(eval.weight)
            };
            (eval.weight, b)
        }
        o @ Objective::PaperCost { .. } => {
            let c = eval.cost(o, problem.budget_s());
            let b = if proved {
                c
            } else {
                (cost_offset - search.open_bound).min(c).max(0.0)
            };
            (c, b)
        }
    };
    let gap = (bound - value).abs() / value.abs().max(1e-9);
    Ok(ExactOutcome {
        route: search.best_route,
        eval,
        proved_optimal: proved,
        bound,
        gap,
        root_bound,
        nodes_explored: search.nodes,
        elapsed: t0.elapsed(),
    })
}
