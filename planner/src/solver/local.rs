//! Local search on decoded routes: the polishing step of the default `auto`
//! planner (issue 5). Works on any route of a [`Problem`] and any objective.
//!
//! Moves, each applied only on strict improvement under [`Problem::better`]:
//! - **insert** an unvisited node, or a pair of them, between two
//!   consecutive route nodes;
//! - **replace** a route node by an unvisited one;
//! - **remove** a route node (its neighbours must share an edge);
//! - **2-opt**: reverse a segment (frees time on a Euclidean-like network,
//!   which later insertions spend);
//!
//! Contract: the route stays a valid simple path start→goal over existing
//! edges; feasibility is never lost (an infeasible route may only get less
//! infeasible); no heap allocation; deterministic (moves are scanned in a
//! fixed order, best improvement per pass). [`LocalSearch::improve`] runs
//! passes until none improves or `max_passes` is reached, so its cost is
//! bounded: one pass is O(len · n) for insert/replace and O(len²) for 2-opt.

use crate::problem::{MAX_NODES, NodeSet, Problem};
use crate::route::{Route, RouteEval};

/// Reusable scratch for local search (no heap).
pub struct LocalSearch {
    scratch: Route,
}

impl Default for LocalSearch {
    fn default() -> Self {
        Self::new()
    }
}

/// A candidate move found by a pass.
#[derive(Clone, Copy)]
enum Move {
    /// Insert node `v` after position `i`.
    Insert { i: usize, v: usize },
    /// Insert nodes `v` then `w` after position `i`.
    InsertPair { i: usize, v: usize, w: usize },
    /// Replace the node at position `i` by `v`.
    Replace { i: usize, v: usize },
    /// Remove the node at position `i`.
    Remove { i: usize },
    /// Reverse positions `i..=j`.
    Reverse { i: usize, j: usize },
}

impl LocalSearch {
    /// Scratch ready for use.
    pub const fn new() -> Self {
        Self { scratch: Route::new() }
    }

    /// Improves `route` (whose figures are `eval`) in place; returns whether
    /// anything changed. At most `max_passes` best-improvement passes.
    pub fn improve(&mut self, p: &Problem, route: &mut Route, eval: &mut RouteEval, max_passes: u32) -> bool {
        let mut changed = false;
        for _ in 0..max_passes {
            let Some(mv) = self.best_move(p, route, eval) else {
                break;
            };
            apply(route, &mut self.scratch, mv);
            // Re-evaluate exactly (the deltas may round differently from a
            // fresh sum) and keep the move only if it truly improves.
            match p.evaluate(&self.scratch) {
                Some(exact) if p.better(&exact, eval) => {
                    core::mem::swap(route, &mut self.scratch);
                    *eval = exact;
                    changed = true;
                }
                _ => break,
            }
        }
        changed
    }

    /// Scans every move and returns the best strictly improving one.
    fn best_move(&mut self, p: &Problem, route: &Route, eval: &RouteEval) -> Option<Move> {
        let n = p.n();
        let len = route.len();
        let limit = p.budget_limit_s();
        let mut on_route = NodeSet::EMPTY;
        for u in route.iter() {
            on_route.insert(u);
        }
        let free = NodeSet(all_nodes(n) & !on_route.0 & !p.excluded().0);
        let mut best: Option<(Move, RouteEval)> = None;
        let mut consider = |mv: Move, e: RouteEval| {
            let incumbent = best.as_ref().map_or(eval, |(_, b)| b);
            if p.better(&e, incumbent) {
                best = Some((mv, e));
            }
        };
        let with = |e: &RouteEval, dt: f64, dd: f64, dw: f64, dr: f64, dtasks: i32| {
            let time_s = e.time_s + dt;
            RouteEval {
                time_s,
                distance_m: e.distance_m + dd,
                weight: e.weight + dw,
                risk_ratio_sum: e.risk_ratio_sum + dr,
                tasks: (e.tasks as i32 + dtasks) as u32,
                feasible: time_s <= limit,
            }
        };

        for i in 0..len - 1 {
            let (a, b) = (route.get(i), route.get(i + 1));
            let (t_ab, d_ab, w_ab, r_ab) = (p.time_s(a, b), p.distance_m(a, b), p.gain(a, b), p.risk_ratio(a, b));
            // Insert v between a and b: candidates are common neighbours.
            let common = NodeSet(p.neighbours(a).0 & p.neighbours(b).0 & free.0);
            for v in common.iter() {
                let e = with(
                    eval,
                    p.time_s(a, v) + p.time_s(v, b) - t_ab,
                    p.distance_m(a, v) + p.distance_m(v, b) - d_ab,
                    p.gain(a, v) + p.gain(v, b) - w_ab,
                    p.risk_ratio(a, v) + p.risk_ratio(v, b) - r_ab,
                    1,
                );
                consider(Move::Insert { i, v }, e);
            }
            // Insert v, w between a and b: reaches detours a single insertion
            // cannot on sparse (coastal) networks.
            for v in NodeSet(p.neighbours(a).0 & free.0).iter() {
                let (t_av, d_av, w_av, r_av) = (p.time_s(a, v), p.distance_m(a, v), p.gain(a, v), p.risk_ratio(a, v));
                if eval.feasible && eval.time_s + t_av - t_ab > limit {
                    continue;
                }
                let mut ws = NodeSet(p.neighbours(v).0 & p.neighbours(b).0 & free.0);
                ws.remove(v);
                for w in ws.iter() {
                    let e = with(
                        eval,
                        t_av + p.time_s(v, w) + p.time_s(w, b) - t_ab,
                        d_av + p.distance_m(v, w) + p.distance_m(w, b) - d_ab,
                        w_av + p.gain(v, w) + p.gain(w, b) - w_ab,
                        r_av + p.risk_ratio(v, w) + p.risk_ratio(w, b) - r_ab,
                        2,
                    );
                    consider(Move::InsertPair { i, v, w }, e);
                }
            }
        }

        for i in 1..len - 1 {
            let (a, u, b) = (route.get(i - 1), route.get(i), route.get(i + 1));
            let out_t = p.time_s(a, u) + p.time_s(u, b);
            let out_d = p.distance_m(a, u) + p.distance_m(u, b);
            let out_w = p.gain(a, u) + p.gain(u, b);
            let out_r = p.risk_ratio(a, u) + p.risk_ratio(u, b);
            // Replace u by v.
            let common = NodeSet(p.neighbours(a).0 & p.neighbours(b).0 & free.0);
            for v in common.iter() {
                let e = with(
                    eval,
                    p.time_s(a, v) + p.time_s(v, b) - out_t,
                    p.distance_m(a, v) + p.distance_m(v, b) - out_d,
                    p.gain(a, v) + p.gain(v, b) - out_w,
                    p.risk_ratio(a, v) + p.risk_ratio(v, b) - out_r,
                    0,
                );
                consider(Move::Replace { i, v }, e);
            }
            // Remove u.
            if p.has_edge(a, b) {
                let e = with(
                    eval,
                    p.time_s(a, b) - out_t,
                    p.distance_m(a, b) - out_d,
                    p.gain(a, b) - out_w,
                    p.risk_ratio(a, b) - out_r,
                    -1,
                );
                consider(Move::Remove { i }, e);
            }
        }

        // 2-opt: reverse route[i..=j] (1 ≤ i < j ≤ len-2); only the two
        // boundary edges change because edges are undirected. Gains are
        // direction-dependent only through node prizes, which reversal keeps.
        for i in 1..len.saturating_sub(2) {
            let a = route.get(i - 1);
            let ui = route.get(i);
            for j in i + 1..len - 1 {
                let (uj, b) = (route.get(j), route.get(j + 1));
                if !(p.has_edge(a, uj) && p.has_edge(ui, b)) {
                    continue;
                }
                let e = with(
                    eval,
                    p.time_s(a, uj) + p.time_s(ui, b) - p.time_s(a, ui) - p.time_s(uj, b),
                    p.distance_m(a, uj) + p.distance_m(ui, b) - p.distance_m(a, ui) - p.distance_m(uj, b),
                    edge_weight(p, a, uj) + edge_weight(p, ui, b) - edge_weight(p, a, ui) - edge_weight(p, uj, b),
                    p.risk_ratio(a, uj) + p.risk_ratio(ui, b) - p.risk_ratio(a, ui) - p.risk_ratio(uj, b),
                    0,
                );
                consider(Move::Reverse { i, j }, e);
            }
        }
        best.map(|(mv, _)| mv)
    }
}

/// Weight of edge a–b without the far node's prize (prizes of the nodes on a
/// route do not depend on the direction of travel).
#[inline]
fn edge_weight(p: &Problem, a: usize, b: usize) -> f64 {
    p.gain(a, b) - p.prize(b)
}

#[inline]
fn all_nodes(n: usize) -> u128 {
    if n >= MAX_NODES { u128::MAX } else { (1u128 << n) - 1 }
}

fn apply(route: &Route, scratch: &mut Route, mv: Move) {
    scratch.clear();
    match mv {
        Move::Insert { i, v } => {
            for k in 0..route.len() {
                scratch.push(route.get(k));
                if k == i {
                    scratch.push(v);
                }
            }
        }
        Move::InsertPair { i, v, w } => {
            for k in 0..route.len() {
                scratch.push(route.get(k));
                if k == i {
                    scratch.push(v);
                    scratch.push(w);
                }
            }
        }
        Move::Replace { i, v } => {
            for k in 0..route.len() {
                scratch.push(if k == i { v } else { route.get(k) });
            }
        }
        Move::Remove { i } => {
            for k in (0..route.len()).filter(|&k| k != i) {
                scratch.push(route.get(k));
            }
        }
        Move::Reverse { i, j } => {
            for k in 0..route.len() {
                let src = if (i..=j).contains(&k) { i + j - k } else { k };
                scratch.push(route.get(src));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decode::Decoder;
    use crate::fixtures::{line_instance, random_instance};
    use crate::instance::Objective;
    use crate::rng::PlannerRng;

    #[test]
    fn inserts_the_profitable_detour() {
        let p = Problem::from_instance(&line_instance()).unwrap();
        // Start from the shortcut 0-3: inserting 1 and 2 (line) pays more.
        let mut r = Route::from_slice(&[0, 3]).unwrap();
        let mut e = p.evaluate(&r).unwrap();
        assert!(LocalSearch::new().improve(&p, &mut r, &mut e, 10));
        assert_eq!(r.to_vec(), vec![0, 1, 2, 3]);
        assert_eq!(
            Some(e),
            p.evaluate(&r).map(|mut x| {
                x.distance_m = e.distance_m;
                x
            })
        );
    }

    #[test]
    fn never_breaks_validity_or_feasibility_and_never_gets_worse() {
        let mut rng = PlannerRng::new(5);
        let mut dec = Decoder::new();
        let mut ls = LocalSearch::new();
        for seed in 0..40 {
            for objective in [Objective::MaxWeight, Objective::PaperCost { phi1: 1e-3, phi2: 1.0 }] {
                let mut inst = random_instance(10 + (seed as usize * 3) % 60, 0.4, 31_000.0, seed);
                inst.objective = objective;
                let Ok(p) = crate::problem::Problem::from_instance(&inst) else {
                    continue;
                };
                let prio: Vec<f64> = (0..p.n()).map(|_| rng.uniform(-200.0, 100.0)).collect();
                let mut r = Route::new();
                let mut e = dec.decode(&p, &prio, &mut r);
                let before = e;
                ls.improve(&p, &mut r, &mut e, 50);
                let checked = p.evaluate(&r).expect("valid route");
                assert_eq!(checked, e);
                assert!(!before.feasible || e.feasible, "feasibility lost");
                assert!(!p.better(&before, &checked), "got worse");
            }
        }
    }
}
