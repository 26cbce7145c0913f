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
//! Arithmetic (single precision where it only steers, double where it
//! decides feasibility):
//! - Priorities are compared as `f32` (an `f64` priority is rounded to the
//!   nearest `f32` first) at 16 bits of fraction (15 in the 256-node class,
//!   14 in the 512 one): values closer than about 2^-16 ≈ 1.5e-5 relative
//!   tie, and ties go to the lower node id; NaN counts as −∞.
//! - The look-ahead test is `reach ≤ slack` in `f32`, with the look-ahead
//!   rounded up and the time left rounded down ([`f32_up`], [`f32_down`]),
//!   so a step the `f32` test lets through also fits in exact `f64`: it
//!   never lets a route slip over the budget. Where the rounding refuses a
//!   step that `f64` would just allow (within about 1e-7 relative of the
//!   budget) the walk may stop short, and the repair (all `f64`) finishes
//!   it. The route's time, feasibility and other figures are `f64` sums.
//!
//! How it is fast:
//! - Each priority is packed once per decode into an `i32` *key* whose
//!   order is the priority order and whose lowest bits hold the node id
//!   ([`pack_key`]: 7 bits up to the 128-node class, 8 and 9 in the 256 and
//!   512 classes, see [`crate::capacity::id_bits`]). Choosing the next node is one masked max over the
//!   padded row: `key where reach ≤ slack and unvisited`; the winner's id is
//!   read back from its bits. With AVX-512 that is one compare and one
//!   masked integer max per sixteen nodes, the visited set a bit mask in
//!   the compare mask (keys are never rewritten, so no store sits in front
//!   of the next load); the AVX2 and portable copies set visited keys to
//!   the "no candidate" value instead. All compute the same max, so routes
//!   do not depend on the machine (tests hold them equal).
//! - One step of a walk is a short serial chain (time left → compare → max
//!   → id → next row), so [`Decoder::decode_stream`] keeps
//!   [`IN_FLIGHT`] walks going at once, one step of each in turn, and the
//!   core overlaps their chains; a walk that reaches the goal hands its lane
//!   straight to the next vector, so no lane waits for a batch's longest
//!   walk. The solvers decode their whole population as one stream.
//! - A step carries the route's time (the next step's slack needs it) and
//!   the one figure the objective ranks by (`Problem::merit`), so a
//!   finished walk is ranked at once ([`Walked::ranked`]); the other
//!   figures are summed only for a route its caller keeps
//!   ([`Walked::figures`]), in the same order, so bit for bit those of a
//!   step-by-step sum.
//! - The repair runs, per cut point, an A* search with the look-ahead's
//!   shortest time home as heuristic, pruned by the time left, so it only
//!   explores near-quickest paths (`Repair::repair`).
//! - Nothing allocates: every buffer is a fixed array in the [`Decoder`].

use crate::capacity::{DEFAULT_WORDS, NodeSet, PerNode, id_bits};
use crate::problem::{Problem, f32_down};
use crate::route::{Route, RouteEval};

/// A priority value the decoder accepts: `f32`, or `f64` (rounded to the
/// nearest `f32`, which keeps the order up to ties).
pub trait Priority: Copy + private::Sealed {
    /// The value as `f32`.
    fn to_f32(self) -> f32;
}

impl Priority for f64 {
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
}

impl Priority for f32 {
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
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
/// of `f32`/`i32`). Rows are scanned in whole blocks; columns ≥ n read +∞
/// reach, so no scan takes them.
pub const SCAN_BLOCK: usize = 16;

const _: () = assert!(64usize.is_multiple_of(SCAN_BLOCK), "a class is whole scan blocks");

/// Walks [`Decoder::decode_stream`] keeps going at once.
pub const IN_FLIGHT: usize = 8;

/// Number of entries a scan covers for `n` nodes (n rounded up to a whole
/// [`SCAN_BLOCK`]). Solvers size their per-node rows with it.
#[inline]
pub const fn padded_len(n: usize) -> usize {
    n.div_ceil(SCAN_BLOCK) * SCAN_BLOCK
}

/// The key of "no candidate": below every key [`pack_key`] makes.
pub const NO_KEY: i32 = i32::MIN;

/// The id field of a key for a class of `W` words: its low
/// [`id_bits`] bits all set.
#[inline(always)]
const fn id_mask<const W: usize>() -> i32 {
    (1 << id_bits(W)) - 1
}

/// Packs priority `p` of node `id` (< 64 · W) into a key: an `i32` that
/// orders like `p` (NaN as −∞) down to 2^-16 relative (2^-14 at 512 nodes,
/// where the id takes 9 bits), breaks ties towards the lower id, carries
/// the id in its [`id_bits`] lowest bits, and is above [`NO_KEY`].
#[inline(always)]
pub fn pack_key<const W: usize>(p: f32, id: usize) -> i32 {
    // Written with selects and shifts only, so a loop of these vectorises.
    let b = if p.is_nan() { f32::NEG_INFINITY } else { p }.to_bits() as i32;
    // The classic map of IEEE bits onto signed integers: negative values
    // flip every bit but the sign, so larger magnitudes sort lower.
    let mono = b ^ (((b >> 31) as u32) >> 1) as i32;
    let mask = id_mask::<W>();
    (mono & !mask) | (mask - id as i32)
}

/// The node id a key of class `W` carries.
#[inline(always)]
pub fn key_id<const W: usize>(key: i32) -> usize {
    let mask = id_mask::<W>();
    (mask - (key & mask)) as usize
}

/// The largest `key[c]` over columns with `reach[c] ≤ slack`, or
/// [`NO_KEY`] when there is none (visited keys are [`NO_KEY`]). Branch-free
/// over fixed blocks, so it vectorises.
#[inline(always)]
fn best_key(reach: &[f32], key: &[i32], slack: f32, len: usize) -> i32 {
    let mut acc = [NO_KEY; SCAN_BLOCK];
    for (r, k) in reach[..len]
        .chunks_exact(SCAN_BLOCK)
        .zip(key[..len].chunks_exact(SCAN_BLOCK))
    {
        for l in 0..SCAN_BLOCK {
            let v = if r[l] <= slack { k[l] } else { NO_KEY };
            acc[l] = acc[l].max(v);
        }
    }
    // Pairwise tree, so the reduction is log2(SCAN_BLOCK) vector steps.
    let mut width = SCAN_BLOCK;
    while width > 1 {
        width /= 2;
        for l in 0..width {
            acc[l] = acc[l].max(acc[l + width]);
        }
    }
    acc[0]
}

/// The AVX-512 scans, written with intrinsics. Visited nodes are left out
/// through the compare mask (bit set in `allowed` = unvisited), not by
/// rewriting their keys, so no store sits in front of the next load. Same
/// maxima as [`best_key`] on the same keys with visited keys at [`NO_KEY`].
/// The scans take the padded length as a constant too (`LEN`, 0: the
/// run-time `len`): each copy is then called from one place and unrolled,
/// and the inliner takes it into the stream.
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use core::arch::x86_64::*;

    use super::{IN_FLIGHT, NO_KEY, NodeSet, SCAN_BLOCK};

    /// Per column of one row: the running max of the keys of allowed
    /// columns whose reach fits in `slack`, sixteen columns a register
    /// (not yet reduced across the register).
    ///
    /// # Safety
    /// The CPU has AVX-512F and the caller is compiled with it enabled
    /// (no `#[target_feature]` here, so that it inlines into the stream's
    /// loop: as a function of its own it was called once per round of
    /// eight walks, with the eight rows passed through the stack).
    #[inline(always)]
    unsafe fn scan<const W: usize, const LEN: usize>(
        reach: &[f32],
        key: &[i32],
        slack: f32,
        len: usize,
        allowed: NodeSet<W>,
    ) -> __m512i {
        let len = if LEN == 0 { len } else { LEN };
        // The loads below rely on this (raw pointers, no bounds checks).
        assert!(len <= reach.len() && len <= key.len() && len <= 64 * W && len.is_multiple_of(SCAN_BLOCK));
        // SAFETY: base + 16 ≤ len ≤ both lengths (asserted above).
        unsafe {
            let s = _mm512_set1_ps(slack);
            let mut acc = _mm512_set1_epi32(NO_KEY);
            let mut base = 0;
            for word in allowed.0 {
                // Shifted by a constant each block: cheaper than a variable
                // shift per block.
                let mut rest = word;
                for _ in 0..64 / SCAN_BLOCK {
                    if base >= len {
                        return acc;
                    }
                    let m = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(
                        rest as u16,
                        _mm512_loadu_ps(reach.as_ptr().add(base)),
                        s,
                    );
                    acc = _mm512_mask_max_epi32(acc, m, acc, _mm512_loadu_si512(key.as_ptr().add(base).cast()));
                    rest >>= SCAN_BLOCK;
                    base += SCAN_BLOCK;
                }
            }
            acc
        }
    }

    /// The best key of one row (see [`super::best_key`]).
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(super) fn best_key<const W: usize>(
        reach: &[f32],
        key: &[i32],
        slack: f32,
        len: usize,
        allowed: NodeSet<W>,
    ) -> i32 {
        // SAFETY: this function is compiled with AVX-512F, which its
        // callers check.
        _mm512_reduce_max_epi32(unsafe { scan::<W, 0>(reach, key, slack, len, allowed) })
    }

    /// [`best_keys`] as a function of its own, for rows longer than
    /// [`INLINE_MAX_LEN`]: inlined there, eight unrolled scans of 128
    /// columns measured no faster (PSO at 128 nodes: per-round ratios
    /// 0.91–1.56 against the call).
    #[target_feature(enable = "avx512f")]
    #[inline(never)]
    pub(super) fn best_keys_call<const W: usize, const LEN: usize>(
        rows: &[&[f32]; IN_FLIGHT],
        keys: &[super::PerNode<i32, W>; IN_FLIGHT],
        slack: &[f32; IN_FLIGHT],
        len: usize,
        allowed: &[NodeSet<W>; IN_FLIGHT],
    ) -> [i32; IN_FLIGHT] {
        // SAFETY: compiled with AVX-512F.
        unsafe { best_keys::<W, LEN>(rows, keys, slack, len, allowed) }
    }

    /// Longest row (padded length) whose eight scans inline into the
    /// stream's loop (40-node networks have rows of 48).
    pub(super) const INLINE_MAX_LEN: usize = 64;

    /// `f32_down(left)` in one scalar conversion with rounding towards −∞
    /// (the same value as the portable helper). Per lane rather than one
    /// eight-wide conversion: a vector load of the eight times just
    /// stored one by one would stall on store forwarding.
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(super) fn slack(left: f64) -> f32 {
        _mm_cvtss_f32(_mm_cvt_roundsd_ss::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(
            _mm_setzero_ps(),
            _mm_set_sd(left),
        ))
    }

    /// The best keys of eight rows at once: the eight scans, then one
    /// joint reduction (a butterfly over the eight registers, a third of
    /// the shuffles of eight separate reductions).
    ///
    /// # Safety
    /// As for [`scan`]: AVX-512F, and a caller compiled with it (it inlines
    /// into the stream's loop).
    #[inline(always)]
    pub(super) unsafe fn best_keys<const W: usize, const LEN: usize>(
        rows: &[&[f32]; IN_FLIGHT],
        keys: &[super::PerNode<i32, W>; IN_FLIGHT],
        slack: &[f32; IN_FLIGHT],
        len: usize,
        allowed: &[NodeSet<W>; IN_FLIGHT],
    ) -> [i32; IN_FLIGHT] {
        // SAFETY: AVX-512F (the caller's contract); `out` is two rows of
        // 16 i32s (unaligned stores).
        unsafe {
            let mut a = [_mm512_setzero_si512(); IN_FLIGHT];
            for l in 0..IN_FLIGHT {
                a[l] = scan::<W, LEN>(rows[l], &keys[l], slack[l], len, allowed[l]);
            }
            // Halves of two lanes' registers side by side, then their max:
            // each result holds lane 2j in 128-bit chunks 0–1, 2j+1 in 2–3.
            let halves = |x: __m512i, y: __m512i| {
                _mm512_max_epi32(
                    _mm512_shuffle_i64x2::<0b01_00_01_00>(x, y),
                    _mm512_shuffle_i64x2::<0b11_10_11_10>(x, y),
                )
            };
            let h = [
                halves(a[0], a[1]),
                halves(a[2], a[3]),
                halves(a[4], a[5]),
                halves(a[6], a[7]),
            ];
            // Again: chunk k now holds lane k of the four.
            let quarters = |x: __m512i, y: __m512i| {
                _mm512_max_epi32(
                    _mm512_shuffle_i64x2::<0b10_00_10_00>(x, y),
                    _mm512_shuffle_i64x2::<0b11_01_11_01>(x, y),
                )
            };
            let q = [quarters(h[0], h[1]), quarters(h[2], h[3])];
            // Within each chunk: four values to one (every position).
            let within = |x: __m512i| {
                let x = _mm512_max_epi32(x, _mm512_shuffle_epi32::<0b01_00_11_10>(x));
                _mm512_max_epi32(x, _mm512_shuffle_epi32::<0b10_11_00_01>(x))
            };
            let mut out = [[0i32; 16]; 2];
            for (o, x) in out.iter_mut().zip(q) {
                _mm512_storeu_si512(o.as_mut_ptr().cast(), within(x));
            }
            [
                out[0][0], out[0][4], out[0][8], out[0][12], out[1][0], out[1][4], out[1][8], out[1][12],
            ]
        }
    }
}

/// The AVX2 scan, written with intrinsics: left to itself the compiler
/// turned [`best_key`] into a compare and a branch per column on AVX2 (no
/// faster than the portable copy). Eight columns a compare, two registers
/// in flight; visited keys are [`NO_KEY`] as in the portable copy. Same
/// maxima as [`best_key`]. (A joint reduction of the eight walks' registers,
/// as on AVX-512, measured no faster here.)
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use core::arch::x86_64::*;

    use super::{NO_KEY, SCAN_BLOCK};

    /// The best key of one row (see [`super::best_key`]).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) fn best_key(reach: &[f32], key: &[i32], slack: f32, len: usize) -> i32 {
        // The loads below rely on this (raw pointers, no bounds checks).
        assert!(len <= reach.len() && len <= key.len() && len.is_multiple_of(SCAN_BLOCK));
        const _: () = assert!(SCAN_BLOCK == 16, "one block is two registers of eight");
        // SAFETY: base + 16 ≤ len ≤ both lengths (asserted above).
        unsafe {
            let s = _mm256_set1_ps(slack);
            let none = _mm256_set1_epi32(NO_KEY);
            let (mut a0, mut a1) = (none, none);
            let mut base = 0;
            while base < len {
                let (r, k) = (reach.as_ptr().add(base), key.as_ptr().add(base));
                // All ones where reach ≤ slack (false for NaN, as `<=`).
                let m0 = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_loadu_ps(r), s));
                let m1 = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_loadu_ps(r.add(8)), s));
                a0 = _mm256_max_epi32(a0, _mm256_blendv_epi8(none, _mm256_loadu_si256(k.cast()), m0));
                a1 = _mm256_max_epi32(a1, _mm256_blendv_epi8(none, _mm256_loadu_si256(k.add(8).cast()), m1));
                base += SCAN_BLOCK;
            }
            let a = _mm256_max_epi32(a0, a1);
            let h = _mm_max_epi32(_mm256_castsi256_si128(a), _mm256_extracti128_si256::<1>(a));
            let h = _mm_max_epi32(h, _mm_shuffle_epi32::<0b01_00_11_10>(h));
            let h = _mm_max_epi32(h, _mm_shuffle_epi32::<0b10_11_00_01>(h));
            _mm_cvtsi128_si32(h)
        }
    }
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

/// The walks in flight, one column per lane (struct of arrays, so one
/// round steps every lane with independent chains side by side).
struct Lanes<const W: usize> {
    /// Packed priority keys; with the AVX2/portable scan, [`NO_KEY`] for
    /// visited nodes.
    key: [PerNode<i32, W>; IN_FLIGHT],
    route: [Route<W>; IN_FLIGHT],
    /// Visited nodes; all ones for an idle lane (so its scan finds nothing).
    visited: [NodeSet<W>; IN_FLIGHT],
    /// Time of the route so far, s (the next step's slack needs it).
    time_s: [f64; IN_FLIGHT],
    /// The figure the objective ranks by, so far ([`Problem::merit`]).
    merit: [f64; IN_FLIGHT],
    cur: [usize; IN_FLIGHT],
    /// Which vector of the stream each lane decodes.
    item: [usize; IN_FLIGHT],
}

impl<const W: usize> Lanes<W> {
    const EMPTY: Self = Self {
        key: [PerNode::splat(NO_KEY); IN_FLIGHT],
        route: [Route::new(); IN_FLIGHT],
        visited: [NodeSet::FULL; IN_FLIGHT],
        time_s: [0.0; IN_FLIGHT],
        merit: [0.0; IN_FLIGHT],
        cur: [0; IN_FLIGHT],
        item: [0; IN_FLIGHT],
    };

    /// Packs the keys of `priorities` into lane `l` and puts its walk on
    /// the start. Keys in the padding (n..len) are anything: their reach is
    /// +∞, so no scan ever takes them. A vector of at least `len` values
    /// (the solvers' padded rows) is packed whole, in straight vector code.
    #[inline(always)]
    fn begin<const AVX512: bool, P: Priority>(
        &mut self,
        l: usize,
        p: &Problem<W>,
        len: usize,
        priorities: &[P],
        item: usize,
    ) {
        let m = if priorities.len() >= len { len } else { p.n() };
        let (keys, prio) = (&mut self.key[l][..m], &priorities[..m]);
        for c in 0..m {
            keys[c] = pack_key::<W>(prio[c].to_f32(), c);
        }
        let cur = p.start();
        self.route[l].clear();
        self.route[l].push(cur);
        if !AVX512 {
            self.key[l][cur] = NO_KEY;
        }
        self.visited[l] = NodeSet::single(cur);
        self.time_s[l] = 0.0;
        self.merit[l] = p.merit_at_start();
        self.cur[l] = cur;
        self.item[l] = item;
    }

    /// One greedy step of lanes 0..W; returns the lanes whose walk ended
    /// (reached the goal, or a dead end: their route is left as it was).
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // lanes are indexed across several arrays
    fn round<const AVX512: bool, const AVX2: bool, const L: usize, const LEN: usize>(
        &mut self,
        p: &Problem<W>,
        limit: f64,
    ) -> u32 {
        // A fixed length unrolls the scans into straight code.
        let len = if LEN == 0 { p.stride() } else { LEN };
        let mut slack = [0.0f32; IN_FLIGHT];
        let mut best = [NO_KEY; IN_FLIGHT];
        if AVX512 {
            #[cfg(target_arch = "x86_64")]
            {
                // SAFETY: only the `*_avx512` streams instantiate AVX512 =
                // true, and they run only on CPUs with AVX-512F.
                unsafe {
                    if L == IN_FLIGHT {
                        // Plain loops, not `array::from_fn`: the compiler
                        // left that out of line here, a call per round.
                        let mut rows: [&[f32]; IN_FLIGHT] = [&[]; IN_FLIGHT];
                        let mut allowed = [NodeSet::EMPTY; IN_FLIGHT];
                        for l in 0..IN_FLIGHT {
                            slack[l] = avx512::slack(limit - self.time_s[l]);
                            rows[l] = p.reach_from(self.cur[l]);
                            allowed[l] = !self.visited[l];
                        }
                        best = if LEN != 0 && LEN <= avx512::INLINE_MAX_LEN {
                            avx512::best_keys::<W, LEN>(&rows, &self.key, &slack, len, &allowed)
                        } else {
                            avx512::best_keys_call::<W, LEN>(&rows, &self.key, &slack, len, &allowed)
                        };
                    } else {
                        for l in 0..L {
                            slack[l] = avx512::slack(limit - self.time_s[l]);
                            let row = p.reach_row(self.cur[l]);
                            best[l] = avx512::best_key(row, &self.key[l], slack[l], len, !self.visited[l]);
                        }
                    }
                }
            }
        } else {
            for l in 0..L {
                slack[l] = f32_down(limit - self.time_s[l]);
                let row = p.reach_row(self.cur[l]);
                #[cfg(target_arch = "x86_64")]
                if AVX2 {
                    // SAFETY: only `stream_avx2` instantiates AVX2 = true,
                    // and it runs only on CPUs with AVX2.
                    best[l] = unsafe { avx2::best_key(row, &self.key[l], slack[l], len) };
                    continue;
                }
                best[l] = best_key(row, &self.key[l], slack[l], len);
            }
        }
        let goal = p.goal();
        let mut ended = 0u32;
        for l in 0..L {
            if best[l] == NO_KEY {
                ended |= 1 << l;
                continue;
            }
            let next = key_id::<W>(best[l]);
            // The time (which the next step's slack waits for) and the
            // objective's figure are summed as the walk goes, in route
            // order (so bit for bit those of `sum_figures`), each from a
            // table of 8 bytes a pair. The other figures wait until a
            // caller asks ([`Walked::figures`]): summing them here measured
            // slower at 128 nodes (their records are four times the size),
            // and after the walk they were a serial chain of adds per route.
            self.time_s[l] += p.time_s(self.cur[l], next);
            self.merit[l] += p.merit(self.cur[l], next);
            self.route[l].push(next);
            self.visited[l].insert(next);
            if !AVX512 {
                self.key[l][next] = NO_KEY;
            }
            self.cur[l] = next;
            ended |= u32::from(next == goal) << l;
        }
        ended
    }
}

/// The stream loop: [`IN_FLIGHT`] walks at once, stepped in rounds; a
/// finished walk's lane takes the next vector at once. `done(i, walked)`
/// is called once per vector, in the order walks finish (a function of the
/// vectors alone, the same on every kernel).
#[inline(always)]
fn stream<
    'a,
    const AVX512: bool,
    const AVX2: bool,
    const W: usize,
    P: Priority + 'a,
    V: Fn(usize) -> &'a [P] + ?Sized,
    D: FnMut(usize, Walked<'_, W>) + ?Sized,
>(
    d: &mut Decoder<W>,
    p: &Problem<W>,
    count: usize,
    vector: &V,
    done: &mut D,
) {
    // Streams of eight walks on AVX-512 get a copy per padded length up
    // to 128 nodes (the scan loops unrolled); other cases read the length
    // at run time.
    macro_rules! by_len {
        ($($len:literal)*) => {
            match p.stride() {
                $($len if AVX512 && $len <= 64 * W => {
                    stream_l::<AVX512, AVX2, W, IN_FLIGHT, $len, P, V, D>(d, p, count, vector, done)
                })*
                _ => stream_l::<AVX512, AVX2, W, IN_FLIGHT, 0, P, V, D>(d, p, count, vector, done),
            }
        };
    }
    // One or two vectors (single and paired decodes) use that many lanes.
    match count {
        1 => stream_l::<AVX512, AVX2, W, 1, 0, P, V, D>(d, p, count, vector, done),
        2 => stream_l::<AVX512, AVX2, W, 2, 0, P, V, D>(d, p, count, vector, done),
        _ => by_len!(16 32 48 64 80 96 112 128),
    }
}

/// [`stream`] on lanes 0..L, rows of `LEN` entries (0: [`Problem::stride`]).
#[inline(always)]
fn stream_l<
    'a,
    const AVX512: bool,
    const AVX2: bool,
    const W: usize,
    const L: usize,
    const LEN: usize,
    P: Priority + 'a,
    V: Fn(usize) -> &'a [P] + ?Sized,
    D: FnMut(usize, Walked<'_, W>) + ?Sized,
>(
    d: &mut Decoder<W>,
    p: &Problem<W>,
    count: usize,
    vector: &V,
    done: &mut D,
) {
    let limit = p.budget_limit_s();
    let len = if LEN == 0 { p.stride() } else { LEN };
    let Decoder { lanes, repair } = d;
    let mut live = 0u32;
    for l in 0..L {
        if l < count {
            lanes.begin::<AVX512, P>(l, p, len, vector(l), l);
            live |= 1 << l;
        } else {
            lanes.visited[l] = NodeSet::FULL;
        }
    }
    let mut next = count.min(L);
    while live != 0 {
        let mut ended = lanes.round::<AVX512, AVX2, L, LEN>(p, limit) & live;
        while ended != 0 {
            let l = ended.trailing_zeros() as usize;
            ended &= ended - 1;
            let route = &mut lanes.route[l];
            let walked = if route.last() == Some(p.goal()) {
                Walked {
                    problem: p,
                    route,
                    ranked: p.ranked(lanes.time_s[l], lanes.merit[l]),
                    complete: false,
                }
            } else {
                let e = repair.repair(p, route);
                Walked {
                    problem: p,
                    route,
                    ranked: e,
                    complete: true,
                }
            };
            debug_assert_eq!(p.evaluate(walked.route), Some(walked.figures()));
            debug_assert!(walked.complete || *walked.ranked() == p.ranked_part(&walked.figures()));
            done(lanes.item[l], walked);
            if next < count {
                lanes.begin::<AVX512, P>(l, p, len, vector(next), next);
                next += 1;
            } else {
                live &= !(1 << l);
                lanes.visited[l] = NodeSet::FULL;
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl")]
fn stream_avx512<
    'a,
    const W: usize,
    P: Priority + 'a,
    V: Fn(usize) -> &'a [P] + ?Sized,
    D: FnMut(usize, Walked<'_, W>) + ?Sized,
>(
    d: &mut Decoder<W>,
    p: &Problem<W>,
    count: usize,
    vector: &V,
    done: &mut D,
) {
    stream::<true, false, W, P, V, D>(d, p, count, vector, done)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn stream_avx2<
    'a,
    const W: usize,
    P: Priority + 'a,
    V: Fn(usize) -> &'a [P] + ?Sized,
    D: FnMut(usize, Walked<'_, W>) + ?Sized,
>(
    d: &mut Decoder<W>,
    p: &Problem<W>,
    count: usize,
    vector: &V,
    done: &mut D,
) {
    stream::<false, true, W, P, V, D>(d, p, count, vector, done)
}
/// Sums the figures of `out` edge by edge in route order (the order, and
/// so the rounding, of a walk accumulating them step by step) and returns
/// them, not marked feasible; with `PREFIX`, also stores the figures of the
/// first i edges in `prefix[i]` for every i.
#[inline(always)]
fn sum_figures<const W: usize, const PREFIX: bool>(
    p: &Problem<W>,
    out: &Route<W>,
    prefix: &mut [RouteEval],
) -> RouteEval {
    let nodes = out.ids();
    let mut e = RouteEval {
        weight: p.prize(usize::from(nodes[0])),
        ..RouteEval::default()
    };
    if PREFIX {
        prefix[0] = e;
    }
    for (i, hop) in nodes.windows(2).enumerate() {
        let step = p.edge(usize::from(hop[0]), usize::from(hop[1]));
        e.time_s += step.time_s;
        e.distance_m += step.distance_m;
        e.weight += step.gain;
        e.risk_ratio_sum += step.risk_ratio;
        e.tasks += 1;
        if PREFIX {
            prefix[i + 1] = e;
        }
    }
    e
}

/// A finished walk as a stream hands it over: its route, ranked at once,
/// and its other figures on request (most walks of a swarm are compared
/// and dropped, so summing every figure of every route would be wasted).
pub struct Walked<'s, const W: usize> {
    problem: &'s Problem<W>,
    route: &'s Route<W>,
    ranked: RouteEval,
    /// `ranked` holds every figure (the repair summed them).
    complete: bool,
}

impl<const W: usize> Walked<'_, W> {
    /// The route.
    #[inline]
    pub fn route(&self) -> &Route<W> {
        self.route
    }

    /// The figures [`Problem::score`] and [`Problem::better`] read, exact:
    /// rank or compare by these; the others may be 0 ([`Walked::figures`]
    /// has them all).
    #[inline]
    pub fn ranked(&self) -> &RouteEval {
        &self.ranked
    }

    /// Every figure of the route, exactly those of [`Decoder::decode`].
    #[inline]
    pub fn figures(&self) -> RouteEval {
        if self.complete {
            return self.ranked;
        }
        RouteEval {
            feasible: self.ranked.feasible,
            ..sum_figures::<W, false>(self.problem, self.route, &mut [])
        }
    }
}

/// The repair's scratch space (see [`Repair::repair`]).
struct Repair<const W: usize> {
    /// Figures of the route's first i edges, for i = 0..len (filled by
    /// `sum_figures` when a walk needs repair).
    prefix: PerNode<RouteEval, W>,
    /// The A* search (see [`Repair::astar_home`]).
    open: PerNode<f64, W>,
    done: PerNode<f64, W>,
    order: PerNode<u64, W>,
    stamp: u64,
    /// Nodes the last search settled, in order.
    settled: PerNode<u16, W>,
    settled_len: usize,
    path: PerNode<u16, W>,
}

/// Scratch space for decoding problems of a class of `W` words (see
/// [`crate::capacity`]); build once, reuse for every decode.
pub struct Decoder<const W: usize = DEFAULT_WORDS> {
    lanes: Lanes<W>,
    repair: Repair<W>,
}

impl<const W: usize> Default for Decoder<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> Decoder<W> {
    /// A decoder with its buffers ready.
    pub const fn new() -> Self {
        Self {
            lanes: Lanes::EMPTY,
            repair: Repair {
                prefix: PerNode::splat(RouteEval {
                    time_s: 0.0,
                    distance_m: 0.0,
                    weight: 0.0,
                    risk_ratio_sum: 0.0,
                    tasks: 0,
                    feasible: false,
                }),
                open: PerNode::splat(0.0),
                done: PerNode::splat(0.0),
                order: PerNode::splat(0),
                stamp: 0,
                settled: PerNode::splat(0),
                settled_len: 0,
                path: PerNode::splat(0),
            },
        }
    }

    /// Decodes `priorities` (at least `p.n()` values) into `out` and returns
    /// the route's figures.
    #[inline]
    pub fn decode<P: Priority>(&mut self, p: &Problem<W>, priorities: &[P], out: &mut Route<W>) -> RouteEval {
        self.decode_with(Kernel::detect(), p, priorities, out)
    }

    /// [`Decoder::decode`] on a chosen kernel; a kernel this CPU lacks falls
    /// back to the portable one. Every kernel gives the same route.
    pub fn decode_with<P: Priority>(
        &mut self,
        kernel: Kernel,
        p: &Problem<W>,
        priorities: &[P],
        out: &mut Route<W>,
    ) -> RouteEval {
        let priorities = &priorities[..p.n()];
        let mut result = RouteEval::default();
        self.stream_with(kernel, p, 1, &|_| priorities, &mut |_, w| {
            *out = *w.route();
            result = w.figures();
        });
        result
    }

    /// Decodes two vectors at once (two walks in flight): exactly the
    /// results of `self.decode(p, a, out_a)` and `self.decode(p, b, out_b)`.
    #[inline]
    pub fn decode_pair<P: Priority>(
        &mut self,
        p: &Problem<W>,
        a: &[P],
        b: &[P],
        out_a: &mut Route<W>,
        out_b: &mut Route<W>,
    ) -> (RouteEval, RouteEval) {
        let (a, b) = (&a[..p.n()], &b[..p.n()]);
        let mut result = [RouteEval::default(); 2];
        self.stream_with(Kernel::detect(), p, 2, &|i| if i == 0 { a } else { b }, &mut |i, w| {
            if i == 0 {
                *out_a = *w.route();
            } else {
                *out_b = *w.route();
            }
            result[i] = w.figures();
        });
        (result[0], result[1])
    }

    /// Decodes `count` vectors, `vector(i)` for i in 0..count (each at
    /// least `p.n()` values), with [`IN_FLIGHT`] walks going at once, and
    /// calls `done(i, walked)` once for each as its walk finishes.
    /// Each vector's route and [`Walked::figures`] are exactly those of
    /// [`Decoder::decode`]; its [`Walked::ranked`] figures are the ones the
    /// objective compares, with no further pass over the route. The order
    /// of the calls depends only on the vectors (not on the kernel).
    #[inline]
    pub fn decode_stream<
        'a,
        P: Priority + 'a,
        V: Fn(usize) -> &'a [P] + ?Sized,
        D: FnMut(usize, Walked<'_, W>) + ?Sized,
    >(
        &mut self,
        p: &Problem<W>,
        count: usize,
        vector: &V,
        done: &mut D,
    ) {
        self.stream_with(Kernel::detect(), p, count, vector, done)
    }

    /// [`Decoder::decode_stream`] on a chosen kernel (a kernel this CPU
    /// lacks falls back to the portable one).
    pub fn stream_with<
        'a,
        P: Priority + 'a,
        V: Fn(usize) -> &'a [P] + ?Sized,
        D: FnMut(usize, Walked<'_, W>) + ?Sized,
    >(
        &mut self,
        kernel: Kernel,
        p: &Problem<W>,
        count: usize,
        vector: &V,
        done: &mut D,
    ) {
        match kernel.usable() {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `usable` only yields Avx512 on CPUs with AVX-512F.
            Kernel::Avx512 => unsafe { stream_avx512(self, p, count, vector, done) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `usable` only yields Avx2 on CPUs with AVX2.
            Kernel::Avx2 => unsafe { stream_avx2(self, p, count, vector, done) },
            _ => stream::<false, false, W, P, V, D>(self, p, count, vector, done),
        }
    }
}

impl<const W: usize> Repair<W> {
    /// [`sum_figures`], also storing the figures of the first i edges in
    /// `prefix[i]` for every i.
    fn sum_prefixes(&mut self, p: &Problem<W>, out: &Route<W>) -> RouteEval {
        sum_figures::<W, true>(p, out, &mut self.prefix)
    }

    /// Cuts `out` back to the latest node r_k with a quickest path home
    /// (avoiding r_0..r_{k−1} and excluded nodes) that fits in the time
    /// left at r_k, and appends that path; if there is none, returns the
    /// quickest path from the start (over budget). All in `f64`.
    ///
    /// Each r_k is tried with an A* search whose heuristic is the
    /// unrestricted shortest time home (consistent, so each node settles
    /// once and the path found is a quickest one) and which gives up as
    /// soon as the best open estimate exceeds the time left, so it explores
    /// only near-quickest paths. The last node is tried too: the walk's
    /// `f32` test may have refused a step that just fits in `f64`.
    #[inline(never)]
    fn repair(&mut self, p: &Problem<W>, out: &mut Route<W>) -> RouteEval {
        self.sum_prefixes(p, out);
        let limit = p.budget_limit_s();
        let len = padded_len(p.n());
        let mut cut = None;
        for k in (0..out.len()).rev() {
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
            self.path[hops] = v as u16;
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
    fn astar_home(&mut self, p: &Problem<W>, route: &Route<W>, k: usize, slack: f64, len: usize) -> bool {
        let n = p.n();
        let goal = p.goal();
        self.open[..n].fill(f64::INFINITY);
        self.open[n..len].fill(f64::NAN);
        for v in p.excluded().iter() {
            self.open[v] = f64::NAN;
        }
        for &v in &route.ids()[..k] {
            self.open[usize::from(v)] = f64::NAN;
        }
        self.open[route.get(k)] = 0.0;
        self.settled_len = 0;
        let h = p.to_goal_row();
        loop {
            // Pop the least estimate g + h; the node id rides in the low
            // bits of the key (ties within ~1e-13 relative go to the lower
            // id, ~4e-13 at 512 nodes), and NaN (settled, blocked, or +∞ +
            // id bits) never wins.
            let open = &self.open;
            let mask = (1u64 << id_bits(W)) - 1;
            let best = min_of(len, |v| {
                let f = open[v] + h[v];
                f64::from_bits(f.to_bits() & !mask | v as u64)
            });
            // +∞ (only node 0's key can be +∞ rather than NaN): unreachable.
            if !(best <= slack && best < f64::INFINITY) {
                return false;
            }
            let u = (best.to_bits() & mask) as usize;
            let g = self.open[u];
            self.done[u] = g;
            self.order[u] = self.stamp;
            self.stamp += 1;
            self.settled[self.settled_len] = u as u16;
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
    fn astar_prev(&self, p: &Problem<W>, v: usize) -> usize {
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
    use crate::problem::MAX_NODES;
    use proptest::prelude::*;

    // The default capacity class unless a test names another.
    type Problem = crate::problem::Problem;
    type NodeSet = crate::problem::NodeSet;
    type Route = crate::route::Route;
    type Decoder = crate::decode::Decoder;

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_avx2_scan_takes_the_same_max_as_the_plain_one_at_every_edge_case() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let mut rng = crate::rng::PlannerRng::new(11);
        let slack = 100.0f32;
        // Reach exactly at the slack, just above and below it, +∞ (padding), NaN.
        let pick = [
            slack,
            slack.next_up(),
            slack.next_down(),
            0.0,
            f32::INFINITY,
            f32::NAN,
            250.0,
        ];
        for len in [16usize, 48, 128] {
            for _ in 0..200 {
                let reach: Vec<f32> = (0..len).map(|_| pick[rng.below(pick.len() as u32) as usize]).collect();
                let key: Vec<i32> = (0..len)
                    .map(|c| {
                        if rng.below(4) == 0 {
                            NO_KEY
                        } else {
                            pack_key::<2>(rng.uniform(-5.0, 5.0) as f32, c)
                        }
                    })
                    .collect();
                // SAFETY: AVX2 was detected above.
                let fast = unsafe { avx2::best_key(&reach, &key, slack, len) };
                assert_eq!(fast, best_key(&reach, &key, slack, len), "{reach:?} {key:?}");
            }
        }
    }

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
    fn plain_quickest<const W: usize>(
        p: &crate::problem::Problem<W>,
        from: usize,
        blocked: &[bool],
    ) -> Option<(f64, Vec<usize>)> {
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
    /// highest key (priority order, NaN as −∞, ties to the lower id; the
    /// key's own order is tested apart) among unvisited neighbours that
    /// fit by the f32 test; at a dead end, cut back to the latest r_k whose
    /// quickest path home avoiding r_0..r_{k−1} fits, else the quickest path.
    fn reference_decode<const W: usize>(p: &crate::problem::Problem<W>, prio: &[f64]) -> Vec<usize> {
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
            // The walk's f32 test: look-ahead rounded up, time left down.
            let slack = crate::problem::f32_down(p.budget_limit_s() - time);
            let mut best: Option<(i32, usize)> = None;
            for c in 0..p.n() {
                if visited[c] || p.reach_row(cur)[c] > slack {
                    continue;
                }
                let v = pack_key::<W>(prio[c] as f32, c);
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
            f32::NEG_INFINITY,
            -1e30,
            -200.0,
            -3.5,
            -1e-30,
            0.0,
            1e-30,
            2.0,
            100.0,
            1e30,
            f32::INFINITY,
        ];
        for (i, &a) in values.iter().enumerate() {
            for (j, &b) in values.iter().enumerate() {
                for (ia, ib) in [(3usize, 90usize), (90, 3), (0, 127)] {
                    let (ka, kb) = (pack_key::<2>(a, ia), pack_key::<2>(b, ib));
                    assert!(ka > NO_KEY, "{a}");
                    assert_eq!(key_id::<2>(ka), ia);
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
        assert_eq!(pack_key::<2>(f32::NAN, 5), pack_key::<2>(f32::NEG_INFINITY, 5));
        assert_eq!(pack_key::<2>(-f32::NAN, 5), pack_key::<2>(f32::NEG_INFINITY, 5));
        assert!(pack_key::<2>(f32::NAN, 5) < pack_key::<2>(-1e30, 100));
        // Differences of 2^-15 relative survive the packing; 2^-18 tie.
        assert!(pack_key::<2>(-199.99, 9) > pack_key::<2>(-200.0, 1));
        assert!(pack_key::<2>(50.002, 9) > pack_key::<2>(50.0, 1));
        assert!(pack_key::<2>(50.0002, 9) < pack_key::<2>(50.0, 1));
    }

    #[test]
    fn budgets_at_the_edge_of_a_step_decode_alike_on_every_kernel_and_never_over() {
        // The exact look-ahead of the first step equals the budget to
        // within a few ulps: every kernel makes the same decision as the
        // plain rule, and none takes a step the exact f64 test refuses.
        let mut inst = line_instance();
        // Times that are not f32 values, so lower precision would show.
        for (i, node) in inst.nodes.iter_mut().enumerate() {
            node.x += 0.1 * i as f64 + 0.012_345_678_9;
        }
        let p0 = Problem::from_instance(&inst).unwrap();
        let exact = p0.time_s(0, 1) + p0.to_goal_s(1); // via node 1
        assert_ne!(f64::from(exact as f32), exact);
        let mut checked = 0;
        for k in -40i64..=40 {
            let limit = exact + (k as f64) * exact * f64::EPSILON;
            let mut inst = inst.clone();
            inst.time_available_s = limit / (1.0 + crate::problem::FEASIBILITY_REL_TOL);
            let Ok(p) = Problem::from_instance(&inst) else { continue };
            let prio = [0.0, 50.0, 40.0, -10.0];
            let plain = reference_decode(&p, &prio);
            for kernel in Kernel::available() {
                let mut r = Route::new();
                let e = Decoder::new().decode_with(kernel, &p, &prio, &mut r);
                assert_eq!(r.to_vec(), plain, "k={k} {kernel:?}");
                if p.budget_limit_s() < exact {
                    assert_ne!(r.to_vec(), vec![0, 1, 2, 3], "k={k}: over the budget");
                }
                assert!(e.feasible && e.time_s <= p.budget_limit_s(), "k={k}");
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
            let inst = chained(n, density, budget, seed);
            let p = Problem::from_instance(&inst).unwrap();
            let mut r = Route::new();
            let e = Decoder::new().decode(&p, &raw, &mut r);
            // Every compiled kernel picks exactly the same route.
            for kernel in Kernel::available() {
                let mut other = Route::new();
                let e2 = Decoder::new().decode_with(kernel, &p, &raw, &mut other);
                prop_assert_eq!(other.ids(), r.ids(), "kernel {:?}", kernel);
                prop_assert_eq!(e2, e);
            }
            prop_assert_eq!(reference_decode(&p, &raw), r.to_vec());
            // Paired decoding gives each vector's own result.
            let flipped: Vec<f64> = raw.iter().rev().copied().collect();
            let mut r2 = Route::new();
            let e2 = Decoder::new().decode(&p, &flipped, &mut r2);
            let (mut pa, mut pb) = (Route::new(), Route::new());
            let (ea, eb) = Decoder::new().decode_pair(&p, &raw, &flipped, &mut pa, &mut pb);
            prop_assert_eq!((pa.ids(), pb.ids()), (r.ids(), r2.ids()));
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
            count in 1usize..12,
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
                12 * MAX_NODES,
            ),
        ) {
            let inst = chained(n, density, budget, seed);
            let p = Problem::from_instance(&inst).unwrap();
            let stride = padded_len(n);
            let mut single = Decoder::new();
            let mut da = Decoder::new();
            let mut singles = Vec::new();
            for i in 0..count {
                let row = &raw[i * stride..i * stride + n];
                let mut r = Route::new();
                let e = single.decode(&p, row, &mut r);
                // Paired with the next vector (or itself for the last).
                let other = &raw[((i + 1) % count) * stride..][..n];
                let (mut pa, mut pb) = (Route::new(), Route::new());
                let (ea, _) = da.decode_pair(&p, row, other, &mut pa, &mut pb);
                prop_assert_eq!(pa.ids(), r.ids(), "vector {}", i);
                prop_assert_eq!(ea, e);
                let wide: Vec<f64> = row.iter().map(|&x| f64::from(x)).collect();
                prop_assert_eq!(reference_decode(&p, &wide), r.to_vec());
                singles.push((r, e));
            }
            // The whole set as one stream (more vectors than walks in
            // flight): each vector's own result, once, in an order that
            // is the same on every kernel.
            let mut order = None;
            for kernel in Kernel::available() {
                let mut seen = Vec::new();
                let mut bad = None;
                da.stream_with(kernel, &p, count, &|i| &raw[i * stride..i * stride + n], &mut |i, w| {
                    let e = w.figures();
                    if (w.route().ids(), e) != (singles[i].0.ids(), singles[i].1)
                        || p.ranked_part(w.ranked()) != p.ranked_part(&e)
                    {
                        bad = Some(i);
                    }
                    seen.push(i);
                });
                prop_assert_eq!(bad, None, "kernel {:?}", kernel);
                let mut sorted = seen.clone();
                sorted.sort_unstable();
                prop_assert_eq!(sorted, (0..count).collect::<Vec<_>>());
                if let Some(o) = &order {
                    prop_assert_eq!(o, &seen, "kernel {:?}", kernel);
                }
                order = Some(seen);
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

    /// Decodes `raw` on `inst` in class `W` on every kernel; checks the
    /// route against the plain rule and returns it.
    fn decode_in_class<const W: usize>(inst: &Instance, raw: &[f64]) -> Vec<usize> {
        let p = crate::problem::Problem::<W>::from_instance(inst).unwrap();
        let mut d = super::Decoder::<W>::new();
        let mut r = crate::route::Route::<W>::new();
        let e = d.decode(&p, raw, &mut r);
        for kernel in Kernel::available() {
            let mut other = crate::route::Route::<W>::new();
            assert_eq!(d.decode_with(kernel, &p, raw, &mut other), e, "{kernel:?}");
            assert_eq!(other, r, "{kernel:?}");
        }
        assert_eq!(p.evaluate(&r), Some(e));
        assert_eq!(reference_decode(&p, raw), r.to_vec());
        r.to_vec()
    }

    /// A chain through every node keeps a random network connected.
    fn chained(n: usize, density: f64, budget: f64, seed: u64) -> Instance {
        let mut inst = random_instance(n, density, budget, seed);
        for a in 0..n - 1 {
            if inst.edge_between(a, a + 1).is_none() {
                inst.edges.push(Edge {
                    a,
                    b: a + 1,
                    priority: 1.0,
                    risk: 1.0,
                    task_time_s: 0.0,
                });
            }
        }
        inst
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// The 256- and 512-node classes decode like the plain rule on
        /// networks that need their ids above 128 and 256.
        #[test]
        fn large_classes_decode_like_the_plain_rule(
            seed in 0u64..10_000,
            n in 129usize..=512,
            density in 0.02f64..0.2,
            budget in 3_000.0f64..60_000.0,
            raw in proptest::collection::vec(-200.0f64..100.0, 512),
        ) {
            let inst = chained(n, density, budget, seed);
            // Each class is held to the plain rule at its own key precision
            // (ids take 8 bits at 256 nodes, 9 at 512).
            decode_in_class::<8>(&inst, &raw);
            if n <= 256 {
                decode_in_class::<4>(&inst, &raw);
            }
        }

        /// The 64- and 128-node classes keep the same key precision, so
        /// they decode every vector to the same route.
        #[test]
        fn the_64_and_128_classes_decode_alike(
            seed in 0u64..10_000,
            n in 2usize..=64,
            density in 0.05f64..1.0,
            budget in 1_000.0f64..60_000.0,
            raw in proptest::collection::vec(-200.0f64..100.0, 64),
        ) {
            let inst = chained(n, density, budget, seed);
            prop_assert_eq!(decode_in_class::<1>(&inst, &raw), decode_in_class::<2>(&inst, &raw));
        }
    }
}
