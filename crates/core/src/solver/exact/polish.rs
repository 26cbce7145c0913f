//! Local search that polishes each new incumbent of the exact search.

use crate::capacity::PerNode;
use crate::problem::Problem;
use crate::route::{Route, RouteEval};
use crate::solver::local::{Move, apply};

/// Change of (time, edge weight, Σ ξ/ρ) of a move, the node prizes apart.
type Delta = (f64, f64, f64);

/// Smallest change of score or time a move must bring (against rounding in
/// the summed deltas; the move is checked by a full evaluation anyway).
const EPS: f64 = 1e-9;

/// Local search on a feasible route: repeatedly applies the best improving
/// move among inserting an unused node, replacing a node by an unused one,
/// removing a node, moving a node, swapping two nodes and reversing a
/// stretch, until none improves or `stop` says so. Moves are ranked by the
/// change of the few edges they touch (constant work each, where evaluating
/// every candidate route took seconds per incumbent at 263 nodes); the
/// chosen one is evaluated in full before it is taken. Deterministic without
/// a stop (fixed scan order, strict improvement only).
pub(super) fn polish<const W: usize>(
    p: &Problem<W>,
    mut route: Route<W>,
    mut eval: RouteEval,
    stop: impl Fn() -> bool,
) -> (Route<W>, RouteEval) {
    let limit = p.budget_limit_s();
    // Edges are undirected; a node's prize is counted apart.
    let fig = |a: usize, b: usize| -> Delta { (p.time_s(a, b), p.edge_weight(a, b), p.risk_ratio(a, b)) };
    let sum = |add: &[(usize, usize)], sub: &[(usize, usize)]| -> Delta {
        let mut d = (0.0, 0.0, 0.0);
        for &(a, b) in add {
            let f = fig(a, b);
            d = (d.0 + f.0, d.1 + f.1, d.2 + f.2);
        }
        for &(a, b) in sub {
            let f = fig(a, b);
            d = (d.0 - f.0, d.1 - f.1, d.2 - f.2);
        }
        d
    };
    let edges = |pairs: &[(usize, usize)]| pairs.iter().all(|&(a, b)| p.has_edge(a, b));
    let mut cur = PerNode::<usize, W>::splat(0);
    loop {
        if stop() {
            return (route, eval);
        }
        let len = route.len();
        for (k, v) in route.iter().enumerate() {
            cur[k] = v;
        }
        let c = &cur[..len];
        let free = p.free_nodes(&route);
        let (score0, time0) = (p.score(&eval), eval.time_s);
        // The best candidate so far: its move and its estimated figures.
        let mut best: Option<(Move, RouteEval)> = None;
        let mut offer = |mv: Move, (dt, dw, dr): Delta, prize: f64| {
            let est = RouteEval {
                time_s: eval.time_s + dt,
                weight: eval.weight + dw + prize,
                risk_ratio_sum: eval.risk_ratio_sum + dr,
                feasible: eval.time_s + dt <= limit,
                ..eval
            };
            if !est.feasible {
                return;
            }
            let (s, t) = (p.score(&est), est.time_s);
            let gains = s > score0 + EPS * score0.abs().max(1.0) || (s >= score0 && t < time0 - EPS);
            if gains && best.as_ref().is_none_or(|b| p.better(&est, &b.1)) {
                best = Some((mv, est));
            }
        };
        for i in 0..len - 1 {
            let (a, b) = (c[i], c[i + 1]);
            for v in free.iter() {
                let new = [(a, v), (v, b)];
                if edges(&new) {
                    offer(Move::Insert { i, v }, sum(&new, &[(a, b)]), p.prize(v));
                }
            }
        }
        for i in 1..len - 1 {
            let (a, x, b) = (c[i - 1], c[i], c[i + 1]);
            let old = [(a, x), (x, b)];
            for v in free.iter() {
                let new = [(a, v), (v, b)];
                if edges(&new) {
                    offer(Move::Replace { i, v }, sum(&new, &old), p.prize(v) - p.prize(x));
                }
            }
            if p.has_edge(a, b) {
                offer(Move::Remove { i }, sum(&[(a, b)], &old), -p.prize(x));
            }
        }
        for i in 1..len - 1 {
            for j in i + 1..len - 1 {
                let (a, b) = (c[i - 1], c[j + 1]);
                let (old, new) = ([(a, c[i]), (c[j], b)], [(a, c[j]), (c[i], b)]);
                if edges(&new) {
                    offer(Move::Reverse { i, j }, sum(&new, &old), 0.0);
                }
                // Swapping neighbours is the reversal above.
                if j > i + 1 {
                    let (x, y) = (c[i], c[j]);
                    let old = [(c[i - 1], x), (x, c[i + 1]), (c[j - 1], y), (y, c[j + 1])];
                    let new = [(c[i - 1], y), (y, c[i + 1]), (c[j - 1], x), (x, c[j + 1])];
                    if edges(&new) {
                        offer(Move::Swap { i, j }, sum(&new, &old), 0.0);
                    }
                }
            }
            let (a, x, b) = (c[i - 1], c[i], c[i + 1]);
            if !p.has_edge(a, b) {
                continue;
            }
            let out = sum(&[(a, b)], &[(a, x), (x, b)]);
            for j in 1..len - 1 {
                if j == i {
                    continue;
                }
                // Before c[j] (j < i) or after it (j > i): after position k.
                let k = if j < i { j - 1 } else { j };
                let (u, w) = (c[k], c[k + 1]);
                let new = [(u, x), (x, w)];
                if edges(&new) {
                    let d = sum(&new, &[(u, w)]);
                    let mv = Move::Relocate { i, l: 1, k, rev: false };
                    offer(mv, (out.0 + d.0, out.1 + d.1, out.2 + d.2), 0.0);
                }
            }
        }
        let Some((mv, _)) = best else {
            return (route, eval);
        };
        let mut next = Route::new();
        apply(&route, &mut next, mv);
        match p.evaluate(&next) {
            Some(e) if e.feasible && p.better(&e, &eval) => {
                route = next;
                eval = e;
            }
            // The summed deltas and the full sum disagree by rounding: stop.
            _ => return (route, eval),
        }
    }
}
