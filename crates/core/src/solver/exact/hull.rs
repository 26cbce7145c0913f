//! Upper concave hulls of (time, value) items: the LP relaxation of picking
//! one item per class in a multiple-choice knapsack (Sinha & Zoltners 1979).

use crate::problem::NodeSet;

/// One segment of a node's upper concave hull: taking it costs `dt` seconds
/// and adds `dv` value (`dt` may be 0, then the slope is +∞).
#[derive(Clone, Copy, Debug)]
pub(super) struct Seg {
    pub(super) dt: f64,
    pub(super) dv: f64,
    pub(super) slope: f64,
    pub(super) class: u16,
}

/// A point (time, value) of a node's half-edge items, with the neighbours
/// `a`, `b` whose half-edges make it up (`a == b` for a single half-edge).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Item {
    pub(super) t: f64,
    pub(super) v: f64,
    pub(super) a: u16,
    pub(super) b: u16,
}

/// Time first, then more value first, then by neighbours: the order the hull
/// construction needs, and a function of the data alone.
pub(super) fn sort_items(items: &mut [Item]) {
    items.sort_unstable_by(|x, y| {
        x.t.total_cmp(&y.t)
            .then(y.v.total_cmp(&x.v))
            .then(x.a.cmp(&y.a))
            .then(x.b.cmp(&y.b))
    });
}

/// Appends to `out` the segments of the upper concave hull of `items`
/// (sorted by [`sort_items`]) that starts at `base` and rises (positive
/// slope); returns the neighbours named by its vertices. `stack` is scratch.
pub(super) fn hull_segments<const W: usize>(
    items: &[Item],
    base: Item,
    class: u16,
    stack: &mut Vec<Item>,
    out: &mut Vec<Seg>,
) -> NodeSet<W> {
    stack.clear();
    stack.push(base);
    for &p in items.iter() {
        if p.v <= stack[stack.len() - 1].v {
            continue; // no more value for more time: never on the rising hull
        }
        while stack.len() >= 2 {
            let (a, b) = (stack[stack.len() - 2], stack[stack.len() - 1]);
            // b on or below the chord a→p: drop it.
            if (b.t - a.t) * (p.v - a.v) - (b.v - a.v) * (p.t - a.t) >= 0.0 {
                stack.pop();
            } else {
                break;
            }
        }
        stack.push(p);
    }
    let mut named = NodeSet::EMPTY;
    named.insert(base.a as usize);
    named.insert(base.b as usize);
    for w in stack.windows(2) {
        let (dt, dv) = (w[1].t - w[0].t, w[1].v - w[0].v);
        out.push(Seg {
            dt,
            dv,
            slope: dv / dt,
            class,
        });
        named.insert(w[1].a as usize);
        named.insert(w[1].b as usize);
    }
    named
}

/// Best slope first; ties by class, so the order is a function of the data.
pub(super) fn sort_segs(segs: &mut [Seg]) {
    segs.sort_unstable_by(|x, y| {
        y.slope
            .total_cmp(&x.slope)
            .then(x.class.cmp(&y.class))
            .then(y.dt.total_cmp(&x.dt))
    });
}
