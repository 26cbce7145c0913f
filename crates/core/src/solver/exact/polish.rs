//! Local search that polishes each new incumbent of the exact search.

use crate::capacity::PerNode;
use crate::problem::{NodeSet, Problem};
use crate::route::{Route, RouteEval};

/// Local search on a feasible route: repeatedly applies the best improving
/// move among inserting an unused node, replacing a node by an unused one,
/// removing a node, moving a node, swapping two nodes and reversing a
/// stretch, until none improves. Deterministic (fixed scan order, strict
/// improvement only).
pub(super) fn polish<const W: usize>(
    p: &Problem<W>,
    mut route: Route<W>,
    mut eval: RouteEval,
) -> (Route<W>, RouteEval) {
    let n = p.n();
    let mut buf = PerNode::<usize, W>::splat(0);
    loop {
        let len = route.len();
        let mut used = NodeSet::<W>::EMPTY;
        for v in route.iter() {
            used.insert(v);
        }
        let mut best: Option<(Route<W>, RouteEval)> = None;
        let mut consider = |ids: &[usize]| {
            let Some(cand) = Route::from_slice(ids) else { return };
            if let Some(e) = p.evaluate(&cand)
                && e.feasible
                && p.better(&e, best.as_ref().map_or(&eval, |b| &b.1))
            {
                best = Some((cand, e));
            }
        };
        let cur: Vec<usize> = route.iter().collect();
        // Insert an unused node between positions i and i + 1.
        for i in 0..len - 1 {
            for v in 0..n {
                if used.contains(v) || p.excluded().contains(v) || !p.has_edge(cur[i], v) || !p.has_edge(v, cur[i + 1])
                {
                    continue;
                }
                buf[..=i].copy_from_slice(&cur[..=i]);
                buf[i + 1] = v;
                buf[i + 2..len + 1].copy_from_slice(&cur[i + 1..]);
                consider(&buf[..len + 1]);
            }
        }
        // Replace or remove an interior node.
        for i in 1..len - 1 {
            buf[..len].copy_from_slice(&cur);
            for v in 0..n {
                if used.contains(v)
                    || p.excluded().contains(v)
                    || !p.has_edge(cur[i - 1], v)
                    || !p.has_edge(v, cur[i + 1])
                {
                    continue;
                }
                buf[i] = v;
                consider(&buf[..len]);
            }
            if p.has_edge(cur[i - 1], cur[i + 1]) {
                buf[..i].copy_from_slice(&cur[..i]);
                buf[i..len - 1].copy_from_slice(&cur[i + 1..]);
                consider(&buf[..len - 1]);
            }
        }
        // Reverse an interior stretch i..=j (2-opt), swap i and j, move i to j.
        for i in 1..len - 1 {
            for j in i + 1..len - 1 {
                buf[..len].copy_from_slice(&cur);
                buf[i..=j].reverse();
                consider(&buf[..len]);
                buf[..len].copy_from_slice(&cur);
                buf.swap(i, j);
                consider(&buf[..len]);
            }
            for j in 1..len - 1 {
                if j == i {
                    continue;
                }
                let mut k = 0;
                for (x, &c) in cur.iter().enumerate() {
                    if x == i {
                        continue;
                    }
                    if x == j && j < i {
                        buf[k] = cur[i];
                        k += 1;
                    }
                    buf[k] = c;
                    k += 1;
                    if x == j && j > i {
                        buf[k] = cur[i];
                        k += 1;
                    }
                }
                consider(&buf[..len]);
            }
        }
        match best {
            Some((r, e)) => {
                route = r;
                eval = e;
            }
            None => return (route, eval),
        }
    }
}
