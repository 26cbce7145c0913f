//! Priority-vector decoding (the paper's route generation): one priority per
//! node; the route grows from the start by stepping to the unvisited
//! neighbour with the highest priority, and ends when it steps onto the goal.
//!
//! Contract: [`Decoder::decode`] turns *any* slice of `n` priorities (NaN and
//! infinities included) into a valid route — a simple path start→goal over
//! existing edges — without allocating. A neighbour is a candidate only if
//! the time so far, the edge, and the shortest time from it to the goal fit
//! in the budget (the look-ahead of [`Problem::reach_row`]), so routes stay
//! within budget whenever one exists. When the greedy walk paints itself into
//! a corner (the shortest way home ran through nodes already visited) the
//! route is cut back to the latest node from which a quickest path home
//! still fits, and that path is appended. If no route fits the budget at all,
//! the result is the quickest path (reported infeasible).
//!
//! Ordering details: NaN counts as −∞; priorities are compared at 43 bits of
//! mantissa (values closer than about 1e-13 relative tie); ties go to the
//! lower node id.
//!
//! How it is fast:
//! - Each priority is packed once per decode into a positive `f64` *key*
//!   whose order is the priority order and whose lowest 7 bits hold the node
//!   id ([`pack_key`]). Choosing the next node is one branch-free max over
//!   `key where reach ≤ slack and unvisited, else 0` across the padded row
//!   (the look-ahead table of [`Problem`] already carries edge time plus
//!   shortest time home, +∞ for non-edges), and the winner's id is read back
//!   from its bits.
//! - That scan is compiled three times (AVX-512 with intrinsics and the
//!   visited set as a bit mask in the compare mask; AVX2 and baseline with
//!   visited keys zeroed) and picked at run time. All three compute exactly
//!   the same max, so routes do not depend on the machine (tests hold them
//!   equal).
//! - The AVX-512 walk skips the look-ahead row whenever the time left
//!   covers the row's largest look-ahead ([`Problem::reach_max_s`]): every
//!   neighbour fits, so the pick is the largest key among the unvisited
//!   neighbours, a scan of keys under the adjacency bit mask. On the chart's
//!   dense networks that is about 70 % of all steps (all but the last few
//!   of a route).
//! - [`Decoder::decode_pair`] advances two walks in lock-step so the core
//!   overlaps their serial scan → pick → next-row chains; the solvers decode
//!   in pairs.
//! - A step carries only the route's time (the next step's slack needs
//!   it; read from the dense time table, a quarter of the edge records'
//!   size, so it stays in L1 on small networks); distance, weight, risk
//!   and tasks are summed once the route is known, in the same order, so
//!   the figures are bit-for-bit those of a step-by-step sum.
//! - The repair runs, per cut point, an A* search with the look-ahead's
//!   shortest time home as heuristic, pruned by the time left, so it only
//!   explores near-quickest paths (`Decoder::repair`).
//! - Nothing allocates: every buffer is a fixed array in the [`Decoder`].

use crate::problem::{MAX_NODES, Problem};
use crate::route::{Route, RouteEval};

/// A priority value the decoder accepts: `f64`, or `f32` (widened exactly,
/// so an `f32` vector decodes exactly like its `f64` copy; the PSO keeps
/// its swarm in `f32` for twice the SIMD width).
pub trait Priority: Copy + private::Sealed {
    /// The value as `f64` (exact).
    fn to_f64(self) -> f64;
}

impl Priority for f64 {
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
}

impl Priority for f32 {
    #[inline(always)]
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}

mod private {
    pub trait Sealed {}
    impl Sealed for f64 {}
    impl Sealed for f32 {}
}

/// Lower end of the paper's priority range.
pub const PRIORITY_MIN: f64 = -200.0;
/// Upper end of the paper's priority range.
pub const PRIORITY_MAX: f64 = 100.0;

/// Width of one step of the candidate scan, in nodes (one AVX-512 vector
/// of `f64`). Rows are scanned in whole blocks; columns ≥ n read +∞ reach,
/// so no scan takes them.
pub const SCAN_BLOCK: usize = 8;

const _: () = assert!(
    MAX_NODES.is_multiple_of(SCAN_BLOCK) && MAX_NODES <= 128,
    "ids must fit the key's 7 low bits"
);

/// Number of entries a scan covers for `n` nodes (n rounded up to a whole
/// [`SCAN_BLOCK`]). Solvers size their per-node rows with it.
#[inline]
pub const fn padded_len(n: usize) -> usize {
    n.div_ceil(SCAN_BLOCK) * SCAN_BLOCK
}

/// Packs priority `p` of node `id` (< 128) into a key: a normal positive
/// `f64` in [2^-1022, 4) that orders like `p` (NaN as −∞) down to 2^-43
/// relative, breaks ties towards the lower id, and carries the id in its 7
/// lowest bits. Key 0.0 means "not a candidate" and is below every key.
#[inline(always)]
pub fn pack_key(p: f64, id: usize) -> f64 {
    // Written with selects and shifts only, so a loop of these vectorises.
    let b = if p.is_nan() {
        f64::NEG_INFINITY.to_bits()
    } else {
        p.to_bits()
    };
    // The classic monotone map of IEEE bits onto unsigned integers:
    // negative values flip every bit, others flip the sign bit.
    let sign = ((b as i64) >> 63) as u64;
    let mono = b ^ (sign | (1 << 63));
    // Two bits down keeps the exponent field below all-ones (finite, < 4);
    // adding 2^52 keeps the result normal (no subnormal slow paths).
    let k = ((mono >> 2) + (1 << 52)) & !0x7F;
    f64::from_bits(k | (127 - id as u64))
}

/// The node id a key carries.
#[inline(always)]
pub fn key_id(key: f64) -> usize {
    127 - (key.to_bits() & 0x7F) as usize
}

/// The largest `key[c]` over columns with `reach[c] ≤ slack`, or 0.0 when
/// there is none. Branch-free over fixed blocks (the comparison becomes a
/// bit mask ANDed onto the key), so it vectorises.
#[inline(always)]
fn best_key(reach: &[f64], key: &[f64; MAX_NODES], slack: f64, len: usize) -> f64 {
    let mut acc = [0.0f64; SCAN_BLOCK];
    for (r, k) in reach[..len]
        .chunks_exact(SCAN_BLOCK)
        .zip(key[..len].chunks_exact(SCAN_BLOCK))
    {
        for l in 0..SCAN_BLOCK {
            let mask = u64::from(r[l] <= slack).wrapping_neg();
            let v = f64::from_bits(k[l].to_bits() & mask);
            acc[l] = if v > acc[l] { v } else { acc[l] };
        }
    }
    // Pairwise tree, so the reduction is log2(SCAN_BLOCK) vector steps.
    let mut width = SCAN_BLOCK;
    while width > 1 {
        width /= 2;
        for l in 0..width {
            acc[l] = if acc[l + width] > acc[l] {
                acc[l + width]
            } else {
                acc[l]
            };
        }
    }
    acc[0]
}

/// [`best_key`] for AVX-512, written with intrinsics, over the columns
/// whose bit is set in `allowed`: with `FIT`, those whose reach fits in
/// `slack` (the caller allows the unvisited ones); without, all of them
/// (the caller allows the unvisited neighbours, having checked that every
/// neighbour fits, so the row is not even read). Visited nodes are left
/// out through the bit mask, not by zeroing their keys, so the walk never
/// stores into the key row it is about to load (that would stall store
/// forwarding). Same result as [`best_key`] on the same keys with visited
/// keys zeroed.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn best_key_avx512<const FIT: bool>(
    reach: &[f64],
    key: &[f64; MAX_NODES],
    slack: f64,
    len: usize,
    allowed: u128,
) -> f64 {
    use core::arch::x86_64::*;
    // The loads below rely on this (raw pointers, no bounds checks).
    assert!(len <= reach.len() && len <= MAX_NODES && len.is_multiple_of(SCAN_BLOCK));
    let s = _mm512_set1_pd(slack);
    // One block: allowed lanes (that fit) fold into `acc` by max. Keys are
    // positive normal doubles, so they order like their bits as unsigned
    // integers, and the integer max is the quicker instruction.
    #[inline(always)]
    fn fold<const FIT: bool>(
        acc: __m512i,
        reach: &[f64],
        key: &[f64; MAX_NODES],
        s: __m512d,
        base: usize,
        allowed: u8,
    ) -> __m512i {
        // SAFETY: the caller keeps base + 8 ≤ len ≤ both lengths, and AVX-512F is
        // enabled in every caller (this is inlined into one).
        unsafe {
            let m = if FIT {
                _mm512_mask_cmp_pd_mask::<_CMP_LE_OQ>(allowed, _mm512_loadu_pd(reach.as_ptr().add(base)), s)
            } else {
                allowed
            };
            _mm512_mask_max_epu64(acc, m, acc, _mm512_loadu_si512(key.as_ptr().add(base).cast()))
        }
    }
    // Two accumulators (even and odd blocks) halve the max chain's latency.
    let (mut a0, mut a1) = (_mm512_setzero_si512(), _mm512_setzero_si512());
    let mut base = 0;
    // Shifted by a constant each round: a variable 128-bit shift costs
    // several instructions per block.
    let mut rest = allowed;
    while base + 2 * SCAN_BLOCK <= len {
        let pair = rest as u16;
        rest >>= 2 * SCAN_BLOCK;
        a0 = fold::<FIT>(a0, reach, key, s, base, pair as u8);
        a1 = fold::<FIT>(a1, reach, key, s, base + SCAN_BLOCK, (pair >> 8) as u8);
        base += 2 * SCAN_BLOCK;
    }
    if base < len {
        a0 = fold::<FIT>(a0, reach, key, s, base, rest as u8);
    }
    f64::from_bits(_mm512_reduce_max_epu64(_mm512_max_epu64(a0, a1)))
}

/// Which compiled copy of the walk to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// Baseline x86-64 / any target.
    Portable,
    /// x86-64 with AVX2.
    Avx2,
    /// x86-64 with AVX-512F.
    Avx512,
}

impl Kernel {
    /// The fastest kernel this CPU runs.
    #[inline]
    pub fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                return Self::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return Self::Avx2;
            }
        }
        Self::Portable
    }

    /// This kernel if the CPU runs it, else the portable one.
    #[inline]
    pub fn usable(self) -> Self {
        let best = Self::detect();
        if self as u8 <= best as u8 { self } else { Self::Portable }
    }

    /// Every kernel this CPU runs (for tests that hold them equal).
    pub fn available() -> impl Iterator<Item = Self> {
        let best = Self::detect();
        [Self::Portable, Self::Avx2, Self::Avx512]
            .into_iter()
            .filter(move |k| *k as u8 <= best as u8)
    }
}

/// Where a greedy walk stands.
struct Walk {
    cur: usize,
    visited: u128,
    /// Figures of the route so far.
    e: RouteEval,
    running: bool,
    dead_end: bool,
}

#[inline(always)]
fn walk_pair<const AVX512: bool, P: Priority>(
    da: &mut Decoder,
    db: &mut Decoder,
    p: &Problem,
    a: &[P],
    b: &[P],
    out_a: &mut Route,
    out_b: &mut Route,
) -> (RouteEval, RouteEval) {
    let mut wa = da.begin::<AVX512, P>(p, a, out_a);
    let mut wb = db.begin::<AVX512, P>(p, b, out_b);
    while wa.running && wb.running {
        da.step::<AVX512>(p, &mut wa, out_a);
        db.step::<AVX512>(p, &mut wb, out_b);
    }
    while wa.running {
        da.step::<AVX512>(p, &mut wa, out_a);
    }
    while wb.running {
        db.step::<AVX512>(p, &mut wb, out_b);
    }
    (da.finish(p, &wa, out_a), db.finish(p, &wb, out_b))
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl")]
fn walk_pair_avx512<P: Priority>(
    da: &mut Decoder,
    db: &mut Decoder,
    p: &Problem,
    a: &[P],
    b: &[P],
    out_a: &mut Route,
    out_b: &mut Route,
) -> (RouteEval, RouteEval) {
    walk_pair::<true, P>(da, db, p, a, b, out_a, out_b)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn walk_pair_avx2<P: Priority>(
    da: &mut Decoder,
    db: &mut Decoder,
    p: &Problem,
    a: &[P],
    b: &[P],
    out_a: &mut Route,
    out_b: &mut Route,
) -> (RouteEval, RouteEval) {
    walk_pair::<false, P>(da, db, p, a, b, out_a, out_b)
}

/// Scratch space for decoding; build once, reuse for every decode.
pub struct Decoder {
    /// Packed priority keys of the decode in hand; 0 for visited nodes.
    key: [f64; MAX_NODES],
    /// Figures of the route's first i edges, for i = 0..len (filled by
    /// `sum_figures` when a walk needs repair).
    prefix: [RouteEval; MAX_NODES],
    /// Repair's A* search (see [`Decoder::astar_home`]).
    open: [f64; MAX_NODES],
    done: [f64; MAX_NODES],
    order: [u64; MAX_NODES],
    stamp: u64,
    /// Nodes the last search settled, in order.
    settled: [u8; MAX_NODES],
    settled_len: usize,
    path: [u8; MAX_NODES],
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// A decoder with its buffers ready.
    pub const fn new() -> Self {
        Self {
            key: [0.0; MAX_NODES],
            prefix: [RouteEval {
                time_s: 0.0,
                distance_m: 0.0,
                weight: 0.0,
                risk_ratio_sum: 0.0,
                tasks: 0,
                feasible: false,
            }; MAX_NODES],
            open: [0.0; MAX_NODES],
            done: [0.0; MAX_NODES],
            order: [0; MAX_NODES],
            stamp: 0,
            settled: [0; MAX_NODES],
            settled_len: 0,
            path: [0; MAX_NODES],
        }
    }

    /// Decodes `priorities` (at least `p.n()` values) into `out` and returns
    /// the route's figures.
    #[inline]
    pub fn decode<P: Priority>(&mut self, p: &Problem, priorities: &[P], out: &mut Route) -> RouteEval {
        self.decode_with(Kernel::detect(), p, priorities, out)
    }

    /// [`Decoder::decode`] on a chosen kernel; a kernel this CPU lacks falls
    /// back to the portable one. Every kernel gives the same route.
    pub fn decode_with<P: Priority>(
        &mut self,
        kernel: Kernel,
        p: &Problem,
        priorities: &[P],
        out: &mut Route,
    ) -> RouteEval {
        let priorities = &priorities[..p.n()];
        match kernel.usable() {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `usable` only yields Avx512 on CPUs with AVX-512F.
            Kernel::Avx512 => unsafe { self.walk_avx512(p, priorities, out) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `usable` only yields Avx2 on CPUs with AVX2.
            Kernel::Avx2 => unsafe { self.walk_avx2(p, priorities, out) },
            _ => self.walk::<false, P>(p, priorities, out),
        }
    }

    /// Decodes two vectors with two decoders at once: the two greedy walks
    /// advance in lock-step, so the processor overlaps their (otherwise
    /// serial) scan → pick → next-row chains. Exactly the results of
    /// `self.decode(p, a, out_a)` and `other.decode(p, b, out_b)`.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn decode_pair<P: Priority>(
        &mut self,
        other: &mut Decoder,
        p: &Problem,
        a: &[P],
        b: &[P],
        out_a: &mut Route,
        out_b: &mut Route,
    ) -> (RouteEval, RouteEval) {
        let (a, b) = (&a[..p.n()], &b[..p.n()]);
        match Kernel::detect() {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `detect` only yields Avx512 on CPUs with AVX-512F.
            Kernel::Avx512 => unsafe { walk_pair_avx512(self, other, p, a, b, out_a, out_b) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `detect` only yields Avx2 on CPUs with AVX2.
            Kernel::Avx2 => unsafe { walk_pair_avx2(self, other, p, a, b, out_a, out_b) },
            _ => walk_pair::<false, P>(self, other, p, a, b, out_a, out_b),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl")]
    fn walk_avx512<P: Priority>(&mut self, p: &Problem, priorities: &[P], out: &mut Route) -> RouteEval {
        self.walk::<true, P>(p, priorities, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn walk_avx2<P: Priority>(&mut self, p: &Problem, priorities: &[P], out: &mut Route) -> RouteEval {
        self.walk::<false, P>(p, priorities, out)
    }

    /// Packs the keys, then walks greedily over them.
    #[inline(always)]
    fn walk<const AVX512: bool, P: Priority>(&mut self, p: &Problem, priorities: &[P], out: &mut Route) -> RouteEval {
        let mut w = self.begin::<AVX512, P>(p, priorities, out);
        while w.running {
            self.step::<AVX512>(p, &mut w, out);
        }
        self.finish(p, &w, out)
    }

    /// Packs the keys and puts the walk on the start. `AVX512`: visited
    /// nodes are tracked only as a bit mask for [`best_key_avx512`];
    /// otherwise their keys are also zeroed for [`best_key`]. Keys in the
    /// padding (n..len) are left as they are: their reach is +∞, so no scan
    /// ever takes them.
    #[inline(always)]
    fn begin<const AVX512: bool, P: Priority>(&mut self, p: &Problem, priorities: &[P], out: &mut Route) -> Walk {
        let n = p.n();
        let (keys, prio) = (&mut self.key[..n], &priorities[..n]);
        for c in 0..n {
            keys[c] = pack_key(prio[c].to_f64(), c);
        }
        let cur = p.start();
        out.clear();
        out.push(cur);
        if !AVX512 {
            self.key[cur] = 0.0;
        }
        let e = RouteEval {
            weight: p.prize(cur),
            ..RouteEval::default()
        };
        Walk {
            cur,
            visited: 1u128 << cur,
            e,
            running: cur != p.goal(),
            dead_end: false,
        }
    }

    /// One greedy step: the highest-key neighbour that fits, or a dead end.
    #[inline(always)]
    fn step<const AVX512: bool>(&mut self, p: &Problem, w: &mut Walk, out: &mut Route) {
        let len = padded_len(p.n());
        let slack = p.budget_limit_s() - w.e.time_s;
        let best = if AVX512 {
            #[cfg(target_arch = "x86_64")]
            {
                // SAFETY: only the `*_avx512` walks instantiate AVX512 =
                // true, and they run only on CPUs with AVX-512F.
                unsafe {
                    // Most steps (about 70 % on the chart's networks) have
                    // time for every neighbour: then only keys are scanned.
                    let row = p.reach_row(w.cur);
                    if slack >= p.reach_max_s(w.cur) {
                        best_key_avx512::<false>(row, &self.key, slack, len, p.neighbours(w.cur).0 & !w.visited)
                    } else {
                        best_key_avx512::<true>(row, &self.key, slack, len, !w.visited)
                    }
                }
            }
            #[cfg(not(target_arch = "x86_64"))]
            unreachable!()
        } else {
            best_key(p.reach_row(w.cur), &self.key, slack, len)
        };
        if best == 0.0 {
            w.running = false;
            w.dead_end = true;
            return;
        }
        let next = key_id(best);
        // Only the time is kept while walking (the next step waits for it);
        // the other figures are summed once the route is known (`finish`).
        w.e.time_s += p.time_s(w.cur, next);
        out.push(next);
        w.visited |= 1 << next;
        if !AVX512 {
            self.key[next] = 0.0;
        }
        w.cur = next;
        w.running = next != p.goal();
    }

    /// The figures of a finished walk, repairing a dead end.
    #[inline(always)]
    fn finish(&mut self, p: &Problem, w: &Walk, out: &mut Route) -> RouteEval {
        if w.dead_end {
            return self.repair(p, out);
        }
        let e = self.sum_figures::<false>(p, out);
        debug_assert_eq!(e.time_s.to_bits(), w.e.time_s.to_bits());
        let e = RouteEval {
            feasible: e.time_s <= p.budget_limit_s(),
            ..e
        };
        debug_assert_eq!(p.evaluate(out), Some(e));
        e
    }

    /// Sums the figures of `out` edge by edge in route order (the order,
    /// and so the rounding, of a walk accumulating them step by step) and
    /// returns them, not marked feasible; with `PREFIX`, also stores the
    /// figures of the first i edges in `prefix[i]` for every i.
    #[inline(always)]
    fn sum_figures<const PREFIX: bool>(&mut self, p: &Problem, out: &Route) -> RouteEval {
        let nodes = out.as_bytes();
        let mut e = RouteEval {
            weight: p.prize(usize::from(nodes[0])),
            ..RouteEval::default()
        };
        if PREFIX {
            self.prefix[0] = e;
        }
        for (i, hop) in nodes.windows(2).enumerate() {
            let step = p.edge(usize::from(hop[0]), usize::from(hop[1]));
            e.time_s += step.time_s;
            e.distance_m += step.distance_m;
            e.weight += step.gain;
            e.risk_ratio_sum += step.risk_ratio;
            e.tasks += 1;
            if PREFIX {
                self.prefix[i + 1] = e;
            }
        }
        e
    }

    /// Cuts `out` back to the latest node r_k with a quickest path home
    /// (avoiding r_0..r_{k−1} and excluded nodes) that fits in the time
    /// left at r_k, and appends that path; if there is none, returns the
    /// quickest path from the start (over budget).
    ///
    /// Each r_k is tried with an A* search whose heuristic is the
    /// unrestricted shortest time home (consistent, so each node settles
    /// once and the path found is a quickest one) and which gives up as
    /// soon as the best open estimate exceeds the time left, so it explores
    /// only near-quickest paths.
    #[inline(always)]
    fn repair(&mut self, p: &Problem, out: &mut Route) -> RouteEval {
        self.sum_figures::<true>(p, out);
        let limit = p.budget_limit_s();
        let len = padded_len(p.n());
        let mut cut = None;
        // k = last is skipped: its search would first relax exactly the
        // sums T(r_k, c) + h(c) = reach(r_k, c) that the walk just found
        // all over the slack, with the same blocked set, and fail.
        for k in (0..out.len() - 1).rev() {
            if self.astar_home(p, out, k, limit - self.prefix[k].time_s, len) {
                cut = Some(k);
                break;
            }
        }
        let k = match cut {
            Some(k) => k,
            None => {
                // Nothing fits: the quickest path from the start, over budget.
                let found = self.astar_home(p, out, 0, f64::INFINITY, len);
                debug_assert!(found, "Problem::finish guarantees the goal is reachable");
                0
            }
        };
        // Walk the settled tree back from the goal, then append in order.
        let from = out.get(k);
        let mut hops = 0;
        let mut v = p.goal();
        while v != from {
            self.path[hops] = v as u8;
            hops += 1;
            v = self.astar_prev(p, v);
        }
        out.truncate(k + 1);
        let mut e = self.prefix[k];
        let mut u = from;
        for i in (0..hops).rev() {
            let v = usize::from(self.path[i]);
            let step = p.edge(u, v);
            e.time_s += step.time_s;
            e.distance_m += step.distance_m;
            e.weight += step.gain;
            e.risk_ratio_sum += step.risk_ratio;
            e.tasks += 1;
            out.push(v);
            u = v;
        }
        e.feasible = e.time_s <= limit;
        debug_assert_eq!(p.evaluate(out), Some(e));
        e
    }

    /// A* from `route[k]` to the goal avoiding excluded nodes and
    /// `route[..k]`; `true` when it reaches the goal within `slack`.
    ///
    /// `open[v]`: best time found from the source to an unsettled, allowed
    /// node (+∞ until reached), NaN for settled or blocked nodes so every
    /// comparison skips them. Settled nodes record their time in `done`
    /// and a stamp in `order`, and are listed in `settled`.
    #[inline(always)]
    fn astar_home(&mut self, p: &Problem, route: &Route, k: usize, slack: f64, len: usize) -> bool {
        let n = p.n();
        let goal = p.goal();
        self.open[..n].fill(f64::INFINITY);
        self.open[n..len].fill(f64::NAN);
        for v in p.excluded().iter() {
            self.open[v] = f64::NAN;
        }
        for &v in &route.as_bytes()[..k] {
            self.open[usize::from(v)] = f64::NAN;
        }
        self.open[route.get(k)] = 0.0;
        self.settled_len = 0;
        let h = p.to_goal_row();
        loop {
            // Pop the least estimate g + h; the node id rides in the low
            // bits of the key (ties within ~1e-13 relative go to the lower
            // id), and NaN (settled, blocked, or +∞ + id bits) never wins.
            let open = &self.open;
            let best = min_of(len, |v| {
                let f = open[v] + h[v];
                f64::from_bits(f.to_bits() & !0x7F | v as u64)
            });
            // +∞ (only node 0's key can be +∞ rather than NaN): unreachable.
            if !(best <= slack && best < f64::INFINITY) {
                return false;
            }
            let u = (best.to_bits() & 0x7F) as usize;
            let g = self.open[u];
            self.done[u] = g;
            self.order[u] = self.stamp;
            self.stamp += 1;
            self.settled[self.settled_len] = u as u8;
            self.settled_len += 1;
            if u == goal {
                return true;
            }
            self.open[u] = f64::NAN;
            let row = &p.time_row(u)[..len];
            let open = &mut self.open[..len];
            for v in 0..len {
                let cand = g + row[v];
                open[v] = if cand < open[v] { cand } else { open[v] };
            }
        }
    }

    /// The node before `v` on the last search's path: a node settled
    /// earlier in that search whose time plus the edge is exactly `v`'s
    /// (the node that set `v`'s time qualifies; settle order rules out
    /// cycles even across zero-time edges).
    #[inline(always)]
    fn astar_prev(&self, p: &Problem, v: usize) -> usize {
        let row = p.time_row(v);
        let (dv, ov) = (self.done[v], self.order[v]);
        for &u in &self.settled[..self.settled_len] {
            let u = usize::from(u);
            if self.order[u] < ov && self.done[u] + row[u] == dv {
                return u;
            }
        }
        unreachable!("the node that set a settled node's time was settled before it")
    }
}

/// Minimum of `f(0..len)` (NaN entries ignored; +∞ when all are), as a
/// branch-free blocked reduction.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // indexed lanes are what vectorises
fn min_of(len: usize, f: impl Fn(usize) -> f64) -> f64 {
    let mut acc = [f64::INFINITY; SCAN_BLOCK];
    for base in (0..len).step_by(SCAN_BLOCK) {
        for l in 0..SCAN_BLOCK {
            let x = f(base + l);
            acc[l] = if x < acc[l] { x } else { acc[l] };
        }
    }
    let mut width = SCAN_BLOCK;
    while width > 1 {
        width /= 2;
        for l in 0..width {
            acc[l] = if acc[l + width] < acc[l] {
                acc[l + width]
            } else {
                acc[l]
            };
        }
    }
    acc[0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{line_instance, random_instance};
    use crate::instance::{Edge, Instance, Node, Objective};
    use crate::problem::NodeSet;
    use proptest::prelude::*;

    #[test]
    fn decodes_the_highest_priority_walk() {
        // 0-1-2-3 line plus shortcut 0-3; favouring 1 and 2 walks the line.
        let inst = line_instance();
        let p = Problem::from_instance(&inst).unwrap();
        let mut d = Decoder::new();
        let mut r = Route::new();
        let e = d.decode(&p, &[0.0, 50.0, 40.0, -10.0], &mut r);
        assert_eq!(r.to_vec(), vec![0, 1, 2, 3]);
        assert!(e.feasible);
        assert_eq!(e.weight, 4.0 + 6.0 + 8.0);
        let e = d.decode(&p, &[0.0, -50.0, 40.0, 10.0], &mut r);
        assert_eq!(r.to_vec(), vec![0, 3]);
        assert_eq!(e.tasks, 1);
    }

    #[test]
    fn lookahead_refuses_steps_that_cannot_get_home_in_time() {
        let mut inst = line_instance();
        inst.time_available_s = 320.0; // line takes 330 s, shortcut 310 s
        let p = Problem::from_instance(&inst).unwrap();
        let mut r = Route::new();
        let e = Decoder::new().decode(&p, &[0.0, 50.0, 40.0, -10.0], &mut r);
        assert_eq!(r.to_vec(), vec![0, 3]);
        assert!(e.feasible);
    }

    #[test]
    fn infeasible_instances_yield_the_quickest_path_marked_infeasible() {
        let mut inst = line_instance();
        inst.time_available_s = 100.0;
        let p = Problem::from_instance(&inst).unwrap();
        let mut r = Route::new();
        let e = Decoder::new().decode(&p, &[0.0, 50.0, 40.0, -10.0], &mut r);
        assert_eq!(r.to_vec(), vec![0, 3]);
        assert!(!e.feasible);
    }

    #[test]
    fn dead_ends_are_repaired() {
        // 0 - 1 - 2(goal) and 1 - 3 dead end; favouring 3 walks into it.
        let nodes = vec![
            Node {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                prize: 0.0,
            },
            Node {
                x: 100.0,
                y: 0.0,
                z: 0.0,
                prize: 0.0,
            },
            Node {
                x: 200.0,
                y: 0.0,
                z: 0.0,
                prize: 0.0,
            },
            Node {
                x: 100.0,
                y: 100.0,
                z: 0.0,
                prize: 0.0,
            },
        ];
        let e = |a, b| Edge {
            a,
            b,
            priority: 1.0,
            risk: 1.0,
            task_time_s: 0.0,
        };
        let inst = Instance {
            name: "dead-end".into(),
            speed_mps: 1.0,
            time_available_s: 10_000.0,
            start: 0,
            goal: 2,
            nodes,
            edges: vec![e(0, 1), e(1, 2), e(1, 3)],
            objective: Objective::MaxWeight,
        };
        let p = Problem::from_instance(&inst).unwrap();
        let mut r = Route::new();
        let ev = Decoder::new().decode(&p, &[0.0, 10.0, -100.0, 90.0], &mut r);
        assert_eq!(r.to_vec(), vec![0, 1, 2]);
        assert!(ev.feasible);
    }

    /// Plain Dijkstra from `from` to the goal avoiding `blocked`: (time, path).
    fn plain_quickest(p: &Problem, from: usize, blocked: &[bool]) -> Option<(f64, Vec<usize>)> {
        let n = p.n();
        let mut dist = vec![f64::INFINITY; n];
        let mut prev = vec![usize::MAX; n];
        let mut done = blocked.to_vec();
        done[from] = false;
        dist[from] = 0.0;
        loop {
            let u = (0..n)
                .filter(|&v| !done[v] && dist[v] < f64::INFINITY)
                .min_by(|&a, &b| dist[a].total_cmp(&dist[b]))?;
            if u == p.goal() {
                break;
            }
            done[u] = true;
            for v in p.neighbours(u).iter() {
                if !done[v] && dist[u] + p.time_s(u, v) < dist[v] {
                    dist[v] = dist[u] + p.time_s(u, v);
                    prev[v] = u;
                }
            }
        }
        let mut path = vec![p.goal()];
        while *path.last().unwrap() != from {
            path.push(prev[*path.last().unwrap()]);
        }
        path.reverse();
        Some((dist[p.goal()], path))
    }

    /// The paper's rule and the module's repair rule written plainly:
    /// highest priority (NaN as −∞, ties to the lower id) among unvisited
    /// neighbours that fit; at a dead end, cut back to the latest r_k whose
    /// quickest path home avoiding r_0..r_{k−1} fits, else the quickest path.
    fn reference_decode(p: &Problem, prio: &[f64]) -> Vec<usize> {
        let mut visited = vec![false; p.n()];
        for v in p.excluded().iter() {
            visited[v] = true;
        }
        let excluded = visited.clone();
        let mut cur = p.start();
        let mut time = 0.0;
        let mut route = vec![cur];
        let mut prefix = vec![0.0];
        visited[cur] = true;
        while cur != p.goal() {
            let slack = p.budget_limit_s() - time;
            let mut best: Option<(f64, usize)> = None;
            for c in 0..p.n() {
                if visited[c] || p.reach_row(cur)[c] > slack {
                    continue;
                }
                let v = if prio[c].is_nan() { f64::NEG_INFINITY } else { prio[c] };
                if best.is_none_or(|(b, _)| v > b) {
                    best = Some((v, c));
                }
            }
            let Some((_, next)) = best else {
                for k in (0..route.len()).rev() {
                    let mut blocked = excluded.clone();
                    for &u in &route[..k] {
                        blocked[u] = true;
                    }
                    if let Some((t, path)) = plain_quickest(p, route[k], &blocked)
                        && t <= p.budget_limit_s() - prefix[k]
                    {
                        route.truncate(k);
                        route.extend(path);
                        return route;
                    }
                }
                return plain_quickest(p, p.start(), &excluded).unwrap().1;
            };
            time += p.time_s(cur, next);
            visited[next] = true;
            route.push(next);
            prefix.push(time);
            cur = next;
        }
        route
    }

    #[test]
    fn keys_order_like_priorities_and_carry_the_id() {
        let values = [
            f64::NEG_INFINITY,
            -1e300,
            -200.0,
            -3.5,
            -1e-300,
            0.0,
            1e-300,
            2.0,
            100.0,
            1e300,
            f64::INFINITY,
        ];
        for (i, &a) in values.iter().enumerate() {
            for (j, &b) in values.iter().enumerate() {
                for (ia, ib) in [(3usize, 90usize), (90, 3), (0, 127)] {
                    let (ka, kb) = (pack_key(a, ia), pack_key(b, ib));
                    assert!(ka.is_normal() && ka > 0.0 && ka < 4.0, "{a}");
                    assert_eq!(key_id(ka), ia);
                    if i != j {
                        assert_eq!(ka > kb, a > b, "{a} vs {b}");
                    } else {
                        // Equal priorities: the lower id wins.
                        assert_eq!(ka > kb, ia < ib);
                    }
                }
            }
        }
        // NaN ranks with −∞ (below every other value, ties by id).
        assert_eq!(pack_key(f64::NAN, 5), pack_key(f64::NEG_INFINITY, 5));
        assert!(pack_key(f64::NAN, 5) < pack_key(-1e300, 100));
        // Ten-digit differences survive the packing.
        assert!(pack_key(-199.999_999_9, 9) > pack_key(-200.0, 1));
        assert!(pack_key(50.000_000_01, 9) > pack_key(50.0, 1));
    }

    #[test]
    fn budgets_at_the_edge_of_a_step_decode_alike_on_every_kernel() {
        // The look-ahead of the first step equals the budget to within a
        // few ulps: every kernel must make the plain rule's f64 decision on
        // either side of the edge (no kernel may decide in lower precision).
        let mut inst = line_instance();
        // Times that are not f32 values, so lower precision would show.
        for (i, node) in inst.nodes.iter_mut().enumerate() {
            node.x += 0.1 * i as f64 + 0.012_345_678_9;
        }
        let base = Problem::from_instance(&inst).unwrap().reach_row(0)[1]; // via node 1
        assert_ne!(f64::from(base as f32), base);
        let mut checked = 0;
        for k in -40i64..=40 {
            let limit = base + (k as f64) * base * f64::EPSILON;
            let mut inst = inst.clone();
            inst.time_available_s = limit / (1.0 + crate::problem::FEASIBILITY_REL_TOL);
            let Ok(p) = Problem::from_instance(&inst) else { continue };
            let prio = [0.0, 50.0, 40.0, -10.0];
            let plain = reference_decode(&p, &prio);
            for kernel in Kernel::available() {
                let mut r = Route::new();
                Decoder::new().decode_with(kernel, &p, &prio, &mut r);
                assert_eq!(r.to_vec(), plain, "k={k} {kernel:?}");
            }
            checked += 1;
        }
        assert!(checked > 60);
    }

    #[test]
    fn ties_go_to_the_lower_id() {
        // Nodes 1 and 2 both neighbour 0 in this little diamond; equal
        // priorities must pick 1 whatever the kernel.
        let inst = crate::fixtures::random_instance(4, 1.0, 1e9, 3);
        let p = Problem::from_instance(&inst).unwrap();
        for kernel in Kernel::available() {
            let mut r = Route::new();
            Decoder::new().decode_with(kernel, &p, &[0.0, 7.0, 7.0, -100.0], &mut r);
            assert_eq!(r.to_vec(), vec![0, 1, 2, 3], "{kernel:?}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        /// Any priority vector, even NaN and infinities, decodes to a valid
        /// route, feasible whenever the quickest path is.
        #[test]
        fn any_vector_decodes_to_a_valid_route(
            seed in 0u64..10_000,
            n in 2usize..=MAX_NODES,
            density in 0.05f64..1.0,
            budget in 1_000.0f64..60_000.0,
            raw in proptest::collection::vec(
                prop_oneof![
                    8 => -200.0f64..100.0,
                    1 => Just(f64::NAN),
                    1 => Just(f64::INFINITY),
                    1 => Just(f64::NEG_INFINITY),
                ],
                MAX_NODES,
            ),
        ) {
            let mut inst = random_instance(n, density, budget, seed);
            // Guarantee connectivity: a chain through every node.
            for a in 0..n - 1 {
                if inst.edge_between(a, a + 1).is_none() {
                    inst.edges.push(Edge { a, b: a + 1, priority: 1.0, risk: 1.0, task_time_s: 0.0 });
                }
            }
            let p = Problem::from_instance(&inst).unwrap();
            let mut r = Route::new();
            let e = Decoder::new().decode(&p, &raw, &mut r);
            // Every compiled kernel picks exactly the same route.
            for kernel in Kernel::available() {
                let mut other = Route::new();
                let e2 = Decoder::new().decode_with(kernel, &p, &raw, &mut other);
                prop_assert_eq!(other.as_bytes(), r.as_bytes(), "kernel {:?}", kernel);
                prop_assert_eq!(e2, e);
            }
            prop_assert_eq!(reference_decode(&p, &raw), r.to_vec());
            // Paired decoding gives each vector's own result.
            let flipped: Vec<f64> = raw.iter().rev().copied().collect();
            let mut r2 = Route::new();
            let e2 = Decoder::new().decode(&p, &flipped, &mut r2);
            let (mut pa, mut pb) = (Route::new(), Route::new());
            let (ea, eb) = Decoder::new().decode_pair(&mut Decoder::new(), &p, &raw, &flipped, &mut pa, &mut pb);
            prop_assert_eq!((pa.as_bytes(), pb.as_bytes()), (r.as_bytes(), r2.as_bytes()));
            prop_assert_eq!((ea, eb), (e, e2));
            let checked = p.evaluate(&r);
            prop_assert_eq!(checked, Some(e));
            let stats = crate::route::RouteStats::from_instance(&inst, &r.to_vec()).unwrap();
            prop_assert_eq!(stats.feasible, e.feasible);
            prop_assert_eq!(stats.time_s, e.time_s);
            let quickest_fits = p.to_goal_s(p.start()) <= p.budget_limit_s();
            prop_assert_eq!(e.feasible, quickest_fits);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(96))]
        /// Dense networks with many exact ties (walls, repeated values),
        /// NaN and infinities, in `f32` as the PSO keeps them: single and
        /// paired decodes give the plain rule's route.
        #[test]
        fn tied_f32_vectors_on_dense_networks_decode_like_the_plain_rule(
            seed in 0u64..10_000,
            n in 2usize..=MAX_NODES,
            density in 0.3f64..1.0,
            budget in 1_000.0f64..60_000.0,
            count in 1usize..8,
            raw in proptest::collection::vec(
                prop_oneof![
                    4 => -200.0f32..100.0,
                    2 => Just(100.0f32),
                    2 => Just(-200.0f32),
                    1 => Just(7.5f32),
                    1 => Just(f32::NAN),
                    1 => Just(f32::INFINITY),
                    1 => Just(f32::NEG_INFINITY),
                ],
                8 * MAX_NODES,
            ),
        ) {
            let mut inst = random_instance(n, density, budget, seed);
            for a in 0..n - 1 {
                if inst.edge_between(a, a + 1).is_none() {
                    inst.edges.push(Edge { a, b: a + 1, priority: 1.0, risk: 1.0, task_time_s: 0.0 });
                }
            }
            let p = Problem::from_instance(&inst).unwrap();
            let stride = padded_len(n);
            let mut single = Decoder::new();
            let (mut da, mut db) = (Decoder::new(), Decoder::new());
            for i in 0..count {
                let row = &raw[i * stride..i * stride + n];
                let mut r = Route::new();
                let e = single.decode(&p, row, &mut r);
                // Paired with the next vector (or itself for the last).
                let other = &raw[((i + 1) % count) * stride..][..n];
                let (mut pa, mut pb) = (Route::new(), Route::new());
                let (ea, _) = da.decode_pair(&mut db, &p, row, other, &mut pa, &mut pb);
                prop_assert_eq!(pa.as_bytes(), r.as_bytes(), "vector {}", i);
                prop_assert_eq!(ea, e);
                let wide: Vec<f64> = row.iter().map(|&x| f64::from(x)).collect();
                prop_assert_eq!(reference_decode(&p, &wide), r.to_vec());
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        /// The re-planning shape: another start, some nodes excluded, tight
        /// budgets (so the repair runs often); still the plain rule's route.
        #[test]
        fn replanning_problems_decode_like_the_plain_rule(
            seed in 0u64..10_000,
            n in 3usize..=MAX_NODES,
            density in 0.05f64..0.6,
            budget in 3_000.0f64..40_000.0,
            start_pick in 0usize..1000,
            exclude_bits in proptest::collection::vec(0usize..MAX_NODES, 0..20),
            raw in proptest::collection::vec(-200.0f64..100.0, MAX_NODES),
        ) {
            let inst = random_instance(n, density, budget, seed);
            let start = start_pick % (n - 1);
            let mut ex = NodeSet::EMPTY;
            for b in exclude_bits {
                if b < n && b != start && b != n - 1 {
                    ex.insert(b);
                }
            }
            let mut p = Problem::new();
            prop_assume!(p.load_instance(&inst, start, ex, budget).is_ok());
            let mut r = Route::new();
            let e = Decoder::new().decode(&p, &raw, &mut r);
            prop_assert_eq!(p.evaluate(&r), Some(e));
            prop_assert!(r.iter().all(|v| !ex.contains(v)));
            prop_assert_eq!(reference_decode(&p, &raw), r.to_vec());
            prop_assert_eq!(e.feasible, p.to_goal_s(start) <= p.budget_limit_s());
        }
    }
}
