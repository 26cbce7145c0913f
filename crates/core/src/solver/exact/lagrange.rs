//! Tuning how each edge's value is split between its two ends.
//!
//! The bound gives every edge half of its value at each end. Any other split
//! `w/2 + μ` at one end and `w/2 − μ` at the other is as valid: on a real
//! route both ends of every edge take it, so the two parts add up to `w`
//! again. The split changes how much value the relaxation can claim through
//! half-edges whose other end does not take them (a node picking its two best
//! neighbours who would rather pair with others), so a good split tightens
//! the bound everywhere in the search. This is Lagrangian relaxation of the
//! constraint "both ends take the edge"; μ is tuned at the root by
//! subgradient descent with Polyak steps (Held & Karp 1971, Polyak 1969),
//! towards the incumbent's value.

use crate::problem::NodeSet;

use super::hull::{Item, hull_segments, sort_items};
use super::search::Search;

/// Subgradient iterations at the root. Each rebuilds every node's hull
/// (tens of µs at n = 40), so this costs milliseconds; on random 40-node
/// instances the bound settles within about 200.
pub(super) const ROOT_ITERATIONS: usize = 300;

/// One class of the root relaxation: its hull vertices (vertex 0 is the
/// origin or the cheapest item) and how far the greedy fill went along it.
struct Class {
    node: usize,
    first: usize,
    len: usize,
}

/// The root relaxation with the split `half` (row-major n×n: `half[v·n+a]`
/// is the value of the half-edge at `v` towards `a`). Returns the bound and
/// fills `x[v·n+a]` with the LP's use of that half-edge.
fn root_lp<const W: usize>(
    s: &Search<'_, W>,
    half: &[f64],
    avail: NodeSet<W>,
    x: &mut [f64],
    verts: &mut Vec<Item>,
) -> f64 {
    let (n, start, goal) = (s.n, s.p.start(), s.goal);
    let mut items: Vec<Item> = Vec::with_capacity(n * n);
    let mut singles: Vec<Item> = Vec::with_capacity(n);
    let mut stack = Vec::with_capacity(n);
    let mut segs = Vec::new();
    let mut classes: Vec<Class> = Vec::with_capacity(n + 2);
    verts.clear();
    let single = |v: usize, a: usize| Item {
        t: 0.5 * s.p.time_s(v, a),
        v: half[v * n + a],
        a: a as u16,
        b: a as u16,
    };
    // Interior classes: pairs of half-edges, with the filter of `build_class`.
    let allowed = avail | NodeSet::single(start) | NodeSet::single(goal);
    for v in avail.iter() {
        singles.clear();
        singles.extend((s.p.neighbours(v) & allowed).iter().map(|a| single(v, a)));
        sort_items(&mut singles);
        let (mut b1, mut b2) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
        singles.retain(|h| {
            if h.v <= b2 {
                return false;
            }
            if h.v > b1 {
                b2 = b1;
                b1 = h.v;
            } else {
                b2 = h.v;
            }
            true
        });
        items.clear();
        for (i, h1) in singles.iter().enumerate() {
            for h2 in &singles[i + 1..] {
                items.push(Item {
                    t: h1.t + h2.t,
                    v: h1.v + h2.v + s.node_val[v],
                    a: h1.a,
                    b: h2.a,
                });
            }
        }
        sort_items(&mut items);
        let origin = Item {
            t: 0.0,
            v: 0.0,
            a: v as u16,
            b: v as u16,
        };
        let class = classes.len() as u16;
        hull_segments::<W>(&items, origin, class, &mut stack, &mut segs);
        classes.push(Class {
            node: v,
            first: verts.len(),
            len: stack.len(),
        });
        verts.extend_from_slice(&stack);
    }
    // The start and the goal: one half-edge each, the cheapest as the base.
    let mut base_total = (0.0, s.node_val[start] + s.node_val[goal]);
    for (v, targets) in [
        (start, avail | NodeSet::single(goal)),
        (goal, avail | NodeSet::single(start)),
    ] {
        items.clear();
        for a in (s.p.neighbours(v) & targets).iter() {
            if v == start && s.p.time_s(v, a) + s.p.to_goal_s(a) > s.limit {
                continue;
            }
            items.push(single(v, a));
        }
        sort_items(&mut items);
        let Some(&base) = items.first() else {
            return f64::NEG_INFINITY;
        };
        base_total.0 += base.t;
        base_total.1 += base.v;
        let class = classes.len() as u16;
        hull_segments::<W>(&items, base, class, &mut stack, &mut segs);
        classes.push(Class {
            node: v,
            first: verts.len(),
            len: stack.len(),
        });
        verts.extend_from_slice(&stack);
    }
    super::hull::sort_segs(&mut segs);
    // Greedy LP fill; `taken[c]` = segments of class c taken, as a real number.
    let mut taken = vec![0.0f64; classes.len()];
    let mut cap = s.limit - base_total.0;
    if cap < 0.0 {
        return f64::NEG_INFINITY;
    }
    let mut total = base_total.1;
    for seg in &segs {
        let c = seg.class as usize;
        if seg.dt <= cap {
            cap -= seg.dt;
            total += seg.dv;
            taken[c] += 1.0;
        } else {
            let f = cap / seg.dt;
            total += seg.dv * f;
            taken[c] += f;
            break;
        }
    }
    // Half-edge use: the convex combination of the two hull vertices the fill
    // stopped between.
    x.fill(0.0);
    for (c, cl) in classes.iter().enumerate() {
        let k = taken[c].floor() as usize;
        let f = taken[c] - k as f64;
        let mut add = |idx: usize, w: f64| {
            if w > 0.0 && idx < cl.len {
                let it = verts[cl.first + idx];
                if it.a as usize != cl.node {
                    x[cl.node * n + it.a as usize] += w;
                }
                if it.b != it.a && it.b as usize != cl.node {
                    x[cl.node * n + it.b as usize] += w;
                }
            }
        };
        add(k, 1.0 - f);
        add(k + 1, f);
    }
    total
}

/// Tunes `half` (see [`root_lp`]) to lower the root bound towards `target`,
/// the incumbent's value. Keeps the best split found; returns its bound.
pub(super) fn tune_split<const W: usize>(s: &Search<'_, W>, half: &mut [f64], avail: NodeSet<W>, target: f64) -> f64 {
    let n = s.n;
    let mut x = vec![0.0; n * n];
    let mut verts = Vec::new();
    let mut best_half = half.to_vec();
    let mut best = root_lp(s, half, avail, &mut x, &mut verts);
    let mut current = best;
    let mut theta = 1.0;
    let mut stall = 0;
    for _ in 0..ROOT_ITERATIONS {
        if !current.is_finite() || current <= target || s.past_deadline() {
            break;
        }
        // Subgradient of the bound in μ_ab (a < b): x_ab − x_ba.
        let mut norm = 0.0;
        for a in 0..n {
            for b in s.p.neighbours(a).iter().filter(|&b| b > a) {
                let g = x[a * n + b] - x[b * n + a];
                norm += g * g;
            }
        }
        if norm == 0.0 {
            break; // every edge is taken by both ends or neither: nothing to trade
        }
        let step = theta * (current - target) / norm;
        for a in 0..n {
            for b in s.p.neighbours(a).iter().filter(|&b| b > a) {
                let g = x[a * n + b] - x[b * n + a];
                half[a * n + b] -= step * g;
                half[b * n + a] += step * g;
            }
        }
        current = root_lp(s, half, avail, &mut x, &mut verts);
        if current < best {
            best = current;
            best_half.copy_from_slice(half);
            stall = 0;
        } else {
            stall += 1;
            if stall >= 5 {
                theta *= 0.5;
                stall = 0;
                half.copy_from_slice(&best_half);
                current = root_lp(s, half, avail, &mut x, &mut verts);
            }
        }
    }
    half.copy_from_slice(&best_half);
    best
}
