//! Particle swarm optimisation on priority vectors (the paper's PSO).
//!
//! Contract: [`Pso`] implements the anytime [`Solver`] contract. Each
//! particle is a vector of node priorities in
//! [[`PRIORITY_MIN`], [`PRIORITY_MAX`]], turned into a route by
//! [`Decoder`]; fitness is [`Problem::better`] (feasible beats infeasible,
//! then the instance's objective). Global-best topology, synchronous update:
//! every particle of generation k steers by the swarm's best as it stood
//! when generation k began. The paper's defaults are in
//! [`PsoSettings::paper`]. All buffers are allocated in [`Pso::new`];
//! `start` and `step` do not allocate. Same seed, same routes, on every
//! machine (no fused multiply-add, no transcendental functions, and the SIMD
//! and scalar paths perform identical IEEE operations).
//!
//! Update of particle i, dimension d, generation k (Kennedy & Eberhart 1995
//! with the linearly decreasing inertia of Shi & Eberhart 1998, as the paper
//! uses):
//!
//! ```text
//! v ← w_k·v + c1·r1·(pbest_i − x) + c2·r2·(gbest − x),   r1, r2 ~ U[0, 1) per d
//! v ← clamp(v, −v_max, v_max)                              v_max = 0.2·(P_max − P_min) = 60
//! x ← x + v;  if x leaves [P_min, P_max]: x ← the bound, v ← 0
//! w_k = w_start − (w_start − w_end)·k/(T − 1)              k = 0..T−1, then w_end
//! ```
//!
//! Our choices where the paper is silent, and why:
//! - **Velocity clamp at 20 % of the range.** With w > 1 for the first
//!   ~40 % of the budget the swarm would otherwise diverge; 10–50 % of the
//!   range is the usual advice. Mean best weight over 100 paper-budget
//!   solves (10 random networks × n ∈ {40, 80} × 5 seeds, density 0.4,
//!   31 000 s): 10 % → 425.8, **20 % → 440.5**, 50 % → 432.5,
//!   100 % → 416.9.
//! - **Absorbing walls.** A particle that leaves the priority range stops
//!   on the bound with zero velocity in that dimension. Decoding only uses
//!   the order of priorities, and a wall at the paper's range keeps the
//!   encoding the paper's; zeroing the velocity stops particles grinding
//!   against the wall for many iterations.
//! - **Initial velocities** uniform in [−v_max, v_max] (v_max at most the
//!   range for this draw, so an unclamped swarm starts finite).
//! - Both the clamp ([`PsoSettings::velocity_clamp`]) and the wall rule
//!   ([`PsoSettings::walls`]) are settings, so experiments can vary them;
//!   the defaults are the choices above.
//! - **Warm start.** A tenth of the swarm (15 of 150, at least one particle)
//!   starts near the warm route: particle 0 exactly on a vector that
//!   decodes to it (priorities falling along the route from P_max, every
//!   other node at P_min), the others on that vector plus U(±10 % of the
//!   range) noise per dimension. The warm route is also evaluated directly,
//!   so a warm solve never returns anything worse than it.
//! - **Single precision.** Positions, velocities and bests are `f32`: the
//!   decoder only compares priorities (as `f32`, at 16 bits of fraction),
//!   and twice the SIMD width halves the update's cost. Results are still
//!   exact functions of the seed, the same on every SIMD level.
//! - **Synchronous, streamed decode.** After the whole swarm is updated,
//!   it is decoded as one stream (`Decoder::decode_stream`, eight walks in
//!   flight) and each particle's result is taken as its walk finishes:
//!   personal best, then the best-so-far on strict improvement. The
//!   finishing order is a function of the positions alone.
//! - r1 and r2 come from sixteen interleaved xoshiro256++ lanes seeded from the
//!   caller's `PlannerRng` (see `lanes.rs`), 24 bits each (one 64-bit word
//!   per dimension).

use super::Solver;
use super::lanes::{LANES, LaneRng};
use crate::capacity::{DEFAULT_WORDS, PerNode, nodes_of};
use crate::decode::{Decoder, PRIORITY_MAX, PRIORITY_MIN, padded_len};
use crate::problem::Problem;
use crate::rng::PlannerRng;
use crate::route::{Route, RouteEval};

/// PSO settings; [`PsoSettings::paper`] gives the paper's values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PsoSettings {
    /// Swarm size (paper: 150).
    pub particles: usize,
    /// Iterations of a full budget (paper: 150).
    pub iterations: u32,
    /// Cognitive coefficient c1 (paper: 2.0).
    pub c1: f64,
    /// Social coefficient c2 (paper: 2.5).
    pub c2: f64,
    /// Inertia at the first iteration (paper: 1.4).
    pub inertia_start: f64,
    /// Inertia at the last iteration (paper: 0.5).
    pub inertia_end: f64,
    /// Largest velocity per dimension as a fraction of the priority range
    /// (our choice, [`VELOCITY_CLAMP_FRACTION`]; `f64::INFINITY`: no clamp).
    pub velocity_clamp: f64,
    /// What a particle leaving the priority range does (our choice,
    /// [`Walls::Absorb`]).
    pub walls: Walls,
}

/// The rule at the edges of the priority range (the paper is silent).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Walls {
    /// Stop on the bound with zero velocity in that dimension (default).
    Absorb,
    /// Stop on the bound, keep the velocity.
    Clamp,
    /// No walls: positions may leave the range (decoding only compares them).
    Free,
}

impl PsoSettings {
    /// The paper's settings.
    pub fn paper() -> Self {
        Self {
            particles: 150,
            iterations: 150,
            c1: 2.0,
            c2: 2.5,
            inertia_start: 1.4,
            inertia_end: 0.5,
            velocity_clamp: VELOCITY_CLAMP_FRACTION,
            walls: Walls::Absorb,
        }
    }
}

/// Largest velocity per dimension, as a fraction of the priority range
/// (our choice; see the module notes).
pub const VELOCITY_CLAMP_FRACTION: f64 = 0.2;

/// Fraction of the swarm seeded from a warm route (our choice).
pub const WARM_FRACTION: f64 = 0.1;

/// Noise on the perturbed warm particles, as a fraction of the range.
const WARM_NOISE_FRACTION: f64 = 0.1;

/// The priority range in the swarm's precision.
pub(crate) const P_MIN: f32 = PRIORITY_MIN as f32;
pub(crate) const P_MAX: f32 = PRIORITY_MAX as f32;

/// Number of population members seeded from a warm route: a tenth, at least 1.
pub(crate) fn warm_count(population: usize) -> usize {
    ((population as f64 * WARM_FRACTION) as usize).clamp(1, population)
}

/// Writes into `out[..n]` a priority vector that decodes to `warm` on any
/// problem where `warm` is a feasible route: priorities fall from
/// [`PRIORITY_MAX`] along the route (steps of at least 300/129 ≈ 2.3 in
/// the 128-node class, 300/513 ≈ 0.58 in the 512 one: far above the
/// decoder's key precision, so they stay distinct and ordered), every other node sits at
/// [`PRIORITY_MIN`]. Ids ≥ n are skipped.
pub(crate) fn warm_vector<const W: usize>(warm: &Route<W>, n: usize, out: &mut [f64]) {
    out[..n].fill(PRIORITY_MIN);
    let step = (PRIORITY_MAX - PRIORITY_MIN) / (warm.len() as f64 + 1.0);
    for (k, node) in warm.iter().enumerate() {
        if node < n {
            out[node] = PRIORITY_MAX - step * k as f64;
        }
    }
}

/// Maps the low 24 bits of `u` onto [0, 1) exactly in `f32`.
#[inline(always)]
pub(crate) fn unit24(u: u64) -> f32 {
    ((u & 0xFF_FFFF) as i32) as f32 * (1.0 / 16_777_216.0)
}

/// A PSO solver with every buffer allocated up front.
pub struct Pso<const W: usize = DEFAULT_WORDS> {
    settings: PsoSettings,
    /// Decodes the swarm as one stream.
    decoder: Decoder<W>,
    lanes: LaneRng,
    /// Node count of the current problem and its padded row length.
    n: usize,
    stride: usize,
    /// Positions, velocities and personal bests: `particles` rows of
    /// `stride` values each (the class's capacity per row).
    x: Vec<f32>,
    v: Vec<f32>,
    pbest: Vec<f32>,
    pbest_eval: Vec<RouteEval>,
    /// The swarm's best position as generation `iteration` began.
    gbest: Vec<f32>,
    /// Random words for the row being updated (one per dimension).
    bits: Vec<u64>,
    best: Route<W>,
    best_eval: RouteEval,
    /// Particle whose personal best is `best` (its position is `gbest`).
    best_particle: usize,
    /// Generations completed since `start`.
    iteration: u32,
}

impl<const W: usize> Pso<W> {
    /// Builds the solver (allocates all buffers). A swarm of 0 particles is
    /// taken as 1.
    pub fn new(settings: PsoSettings) -> Self {
        let settings = PsoSettings {
            particles: settings.particles.max(1),
            ..settings
        };
        let cells = settings.particles * nodes_of(W);
        Self {
            settings,
            decoder: Decoder::new(),
            lanes: LaneRng::new(),
            n: 0,
            stride: 0,
            x: vec![0.0; cells],
            v: vec![0.0; cells],
            pbest: vec![0.0; cells],
            pbest_eval: vec![RouteEval::default(); settings.particles],
            gbest: vec![0.0; nodes_of(W)],
            bits: vec![0; nodes_of(W)],
            best: Route::new(),
            best_eval: RouteEval::default(),
            best_particle: 0,
            iteration: 0,
        }
    }

    /// The settings.
    pub fn settings(&self) -> &PsoSettings {
        &self.settings
    }

    /// Inertia of generation `k` (0-based): linear from `inertia_start` to
    /// `inertia_end` over the iteration budget, then held.
    pub fn inertia(&self, k: u32) -> f64 {
        let s = &self.settings;
        if s.iterations <= 1 {
            return s.inertia_start;
        }
        let last = s.iterations - 1;
        let k = k.min(last);
        s.inertia_start - (s.inertia_start - s.inertia_end) * f64::from(k) / f64::from(last)
    }

    /// Largest speed per dimension.
    fn v_max(&self) -> f32 {
        (self.settings.velocity_clamp * (PRIORITY_MAX - PRIORITY_MIN)) as f32
    }

    /// Lamarckian write-back for the memetic `auto` planner: makes `route`
    /// (figures `e`) the position and personal best of the swarm's best
    /// particle and the swarm's best, encoded by [`warm_vector`] so the
    /// particle decodes back to it. Never called by the paper-faithful PSO.
    pub(crate) fn adopt(&mut self, route: &Route<W>, e: RouteEval) {
        let mut v = PerNode::<f64, W>::splat(0.0);
        warm_vector(route, self.n, &mut v);
        let row = self.best_particle * self.stride..self.best_particle * self.stride + self.n;
        for ((x, b), src) in self.x[row.clone()].iter_mut().zip(&mut self.pbest[row]).zip(&v) {
            *x = *src as f32;
            *b = *src as f32;
        }
        self.pbest_eval[self.best_particle] = e;
        self.best = *route;
        self.best_eval = e;
        self.refresh_gbest();
    }

    /// Decodes the whole swarm as one stream ([`Decoder::decode_stream`])
    /// and takes each particle's result as its walk finishes: its personal
    /// best and the best-so-far, each on strict improvement. `true` when the
    /// best-so-far improved. (The order walks finish in is a function of the
    /// positions alone, so this stays a function of the seed.)
    fn evaluate_all(&mut self, problem: &Problem<W>) -> bool {
        let stride = self.stride;
        let x = &self.x;
        let (pbest, pbest_eval) = (&mut self.pbest, &mut self.pbest_eval);
        let (best, best_eval, best_particle) = (&mut self.best, &mut self.best_eval, &mut self.best_particle);
        let mut improved = false;
        self.decoder.decode_stream(
            problem,
            self.settings.particles,
            &|i| &x[i * stride..(i + 1) * stride],
            &mut |i, walked| {
                if !problem.better(walked.ranked(), &pbest_eval[i]) {
                    return;
                }
                let e = walked.figures();
                let row = i * stride..(i + 1) * stride;
                pbest[row.clone()].copy_from_slice(&x[row]);
                pbest_eval[i] = e;
                if problem.better(&e, best_eval) {
                    *best = *walked.route();
                    *best_eval = e;
                    *best_particle = i;
                    improved = true;
                }
            },
        );
        improved
    }

    fn refresh_gbest(&mut self) {
        let row = self.best_particle * self.stride..(self.best_particle + 1) * self.stride;
        self.gbest[..self.stride].copy_from_slice(&self.pbest[row]);
    }
}

/// Constants of one generation's update.
#[derive(Clone, Copy)]
struct Coefficients {
    w: f32,
    c1: f32,
    c2: f32,
    v_max: f32,
    /// The walls: positions stay in [lo, hi]; `absorb` zeroes the velocity
    /// of a dimension that hit one.
    lo: f32,
    hi: f32,
    absorb: bool,
}

/// One velocity-and-position update of a particle row; dimension `d` draws
/// r1 from bits 40–63 and r2 from bits 8–31 of `bits[d]`. Padding
/// dimensions move too but are never decoded. A plain elementwise loop
/// written with selects (no branches), so it vectorises.
#[inline(always)]
fn update_row(x: &mut [f32], v: &mut [f32], pbest: &[f32], gbest: &[f32], bits: &[u64], k: Coefficients) {
    let len = x.len();
    let (v, pbest, gbest, bits) = (&mut v[..len], &pbest[..len], &gbest[..len], &bits[..len]);
    for d in 0..len {
        let r1 = unit24(bits[d] >> 40);
        let r2 = unit24(bits[d] >> 8);
        let pos = x[d];
        let mut vel = k.w * v[d] + k.c1 * r1 * (pbest[d] - pos) + k.c2 * r2 * (gbest[d] - pos);
        vel = if vel > k.v_max { k.v_max } else { vel };
        vel = if vel < -k.v_max { -k.v_max } else { vel };
        let next = pos + vel;
        let outside = !(k.lo..=k.hi).contains(&next);
        let next = if next > k.hi { k.hi } else { next };
        x[d] = if next < k.lo { k.lo } else { next };
        v[d] = if outside & k.absorb { 0.0 } else { vel };
    }
}

/// [`update_row`] written with AVX-512 intrinsics, sixteen dimensions a
/// register (the compiler's own vectorisation of the plain loop stops at
/// eight): the same IEEE operations in the same order, and the same
/// selects (NaN compares false, as in the plain loop), so the same bits.
/// The random words are drawn as they are used, the generator's state
/// held in registers across the rows (one `LaneRng::fill` per row
/// loaded and stored the state for three blocks of draws at n = 40).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn update_row_avx512(
    x: &mut [f32],
    v: &mut [f32],
    pbest: &[f32],
    gbest: &[f32],
    rng: &mut [[core::arch::x86_64::__m512i; 2]; 4],
    k: Coefficients,
) {
    use core::arch::x86_64::*;
    let len = x.len();
    // The raw loads and stores below rely on this.
    assert!(len.is_multiple_of(16) && v.len() >= len && pbest.len() >= len && gbest.len() >= len);
    let (w, c1, c2) = (_mm512_set1_ps(k.w), _mm512_set1_ps(k.c1), _mm512_set1_ps(k.c2));
    let (v_max, v_min) = (_mm512_set1_ps(k.v_max), _mm512_set1_ps(-k.v_max));
    let (lo, hi) = (_mm512_set1_ps(k.lo), _mm512_set1_ps(k.hi));
    let scale = _mm512_set1_ps(1.0 / 16_777_216.0);
    // Even 32-bit halves of sixteen u64 words (the low halves), and odd.
    let even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
    let odd = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
    for d in (0..len).step_by(16) {
        // SAFETY: d + 16 ≤ len ≤ every length (asserted above); unaligned
        // loads and stores.
        unsafe {
            // The words `LaneRng::fill` would have put in bits[d..d + 16].
            let [b0, b1] = super::lanes::simd::next_avx512(rng);
            // r1 from bits 40–63 (high half >> 8), r2 from bits 8–31.
            let r1 = _mm512_mul_ps(
                _mm512_cvtepi32_ps(_mm512_srli_epi32::<8>(_mm512_permutex2var_epi32(b0, odd, b1))),
                scale,
            );
            let r2 = _mm512_mul_ps(
                _mm512_cvtepi32_ps(_mm512_srli_epi32::<8>(_mm512_permutex2var_epi32(b0, even, b1))),
                scale,
            );
            let pos = _mm512_loadu_ps(x.as_ptr().add(d));
            let vel0 = _mm512_loadu_ps(v.as_ptr().add(d));
            let pb = _mm512_loadu_ps(pbest.as_ptr().add(d));
            let gb = _mm512_loadu_ps(gbest.as_ptr().add(d));
            let mut vel = _mm512_add_ps(
                _mm512_add_ps(
                    _mm512_mul_ps(w, vel0),
                    _mm512_mul_ps(_mm512_mul_ps(c1, r1), _mm512_sub_ps(pb, pos)),
                ),
                _mm512_mul_ps(_mm512_mul_ps(c2, r2), _mm512_sub_ps(gb, pos)),
            );
            vel = _mm512_mask_blend_ps(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(vel, v_max), vel, v_max);
            vel = _mm512_mask_blend_ps(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(vel, v_min), vel, v_min);
            let next = _mm512_add_ps(pos, vel);
            let inside = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(lo, next) & _mm512_cmp_ps_mask::<_CMP_LE_OQ>(next, hi);
            let next = _mm512_mask_blend_ps(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(next, hi), next, hi);
            let next = _mm512_mask_blend_ps(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(next, lo), next, lo);
            _mm512_storeu_ps(x.as_mut_ptr().add(d), next);
            let keep = if k.absorb { inside } else { !0 };
            _mm512_storeu_ps(v.as_mut_ptr().add(d), _mm512_maskz_mov_ps(keep, vel));
        }
    }
}

/// The swarm update compiled per SIMD level; every copy performs the same
/// IEEE operations in the same order (no fused multiply-add), so results
/// are identical.
fn update_swarm<const W: usize>(pso: &mut Pso<W>, w: f32) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F (checked just above).
            return unsafe { update_swarm_avx512(pso, w) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked just above).
            return unsafe { update_swarm_avx2(pso, w) };
        }
    }
    update_swarm_generic::<false, W>(pso, w)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl")]
fn update_swarm_avx512<const W: usize>(pso: &mut Pso<W>, w: f32) {
    update_swarm_generic::<true, W>(pso, w)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn update_swarm_avx2<const W: usize>(pso: &mut Pso<W>, w: f32) {
    update_swarm_generic::<false, W>(pso, w)
}

/// With `AVX512` (only from the AVX-512 copy) the rows run
/// [`update_row_avx512`].
#[inline(always)]
fn update_swarm_generic<const AVX512: bool, const W: usize>(pso: &mut Pso<W>, w: f32) {
    let stride = pso.stride;
    let (lo, hi) = match pso.settings.walls {
        Walls::Absorb | Walls::Clamp => (P_MIN, P_MAX),
        Walls::Free => (f32::NEG_INFINITY, f32::INFINITY),
    };
    let k = Coefficients {
        w,
        c1: pso.settings.c1 as f32,
        c2: pso.settings.c2 as f32,
        v_max: pso.v_max(),
        lo,
        hi,
        absorb: pso.settings.walls == Walls::Absorb,
    };
    let gbest = &pso.gbest[..stride];
    #[cfg(target_arch = "x86_64")]
    if AVX512 {
        // A row takes `stride` words, a whole number of blocks (so the
        // same words as the fill below).
        const { assert!(crate::decode::SCAN_BLOCK.is_multiple_of(LANES)) };
        // SAFETY: only `update_swarm_avx512` instantiates AVX512 = true,
        // and it runs only on CPUs with AVX-512F.
        unsafe {
            let mut st = super::lanes::simd::load_avx512(&pso.lanes);
            for i in 0..pso.settings.particles {
                let row = i * stride..(i + 1) * stride;
                let (x, v, pbest) = (&mut pso.x[row.clone()], &mut pso.v[row.clone()], &pso.pbest[row]);
                update_row_avx512(x, v, pbest, gbest, &mut st, k);
            }
            super::lanes::simd::store_avx512(&mut pso.lanes, &st);
        }
        return;
    }
    // The fill runs in whole blocks of the lane count; words past `stride`
    // are drawn and left unused.
    let bits = &mut pso.bits[..stride.next_multiple_of(LANES)];
    for i in 0..pso.settings.particles {
        let row = i * stride..(i + 1) * stride;
        pso.lanes.fill(bits);
        update_row(
            &mut pso.x[row.clone()],
            &mut pso.v[row.clone()],
            &pso.pbest[row],
            gbest,
            bits,
            k,
        );
    }
}

impl<const W: usize> Solver<W> for Pso<W> {
    fn name(&self) -> &'static str {
        "pso"
    }

    fn start(&mut self, problem: &Problem<W>, rng: &mut PlannerRng, warm: Option<&Route<W>>) {
        let n = problem.n();
        let stride = padded_len(n);
        self.n = n;
        self.stride = stride;
        self.iteration = 0;
        self.lanes.seed(rng);
        let particles = self.settings.particles;
        let range = P_MAX - P_MIN;
        let v_max = self.v_max().min(P_MAX - P_MIN);

        for i in 0..particles {
            let row = i * stride..(i + 1) * stride;
            for (x, v) in self.x[row.clone()].iter_mut().zip(&mut self.v[row]) {
                let u = self.lanes.next_u32();
                *x = P_MIN + range * unit24(u64::from(u));
                *v = v_max * (2.0 * unit24(u64::from(self.lanes.next_u32())) - 1.0);
            }
        }
        let mut warm_eval = None;
        if let Some(route) = warm {
            let seeded = warm_count(particles);
            // Particle 0 exactly on the warm vector; the others near it.
            let mut exact = PerNode::<f64, W>::splat(0.0);
            warm_vector(route, n, &mut exact);
            for (x, e) in self.x[..n].iter_mut().zip(&exact) {
                *x = *e as f32;
            }
            let noise = (WARM_NOISE_FRACTION * (PRIORITY_MAX - PRIORITY_MIN)) as f32;
            for i in 1..seeded {
                let (head, rest) = self.x.split_at_mut(i * stride);
                for (d, x) in rest[..n].iter_mut().enumerate() {
                    let u = unit24(u64::from(self.lanes.next_u32()));
                    *x = (head[d] + noise * (2.0 * u - 1.0)).clamp(P_MIN, P_MAX);
                }
            }
            warm_eval = problem.evaluate(route);
        }

        // The first decode of each particle is its personal best: against
        // `WORST`, the evaluation below takes every one.
        self.best_eval = super::WORST;
        self.best_particle = 0;
        self.pbest_eval[..particles].fill(super::WORST);
        self.evaluate_all(problem);
        if let (Some(route), Some(e)) = (warm, warm_eval)
            && problem.better(&e, &self.best_eval)
        {
            // Normally particle 0 decodes to the warm route itself; if
            // rounding at the budget's edge made it decode elsewhere, the
            // warm route still counts (particle 0 carries it).
            self.best = *route;
            self.best_eval = e;
            self.pbest_eval[0] = e;
            self.best_particle = 0;
        }
        self.refresh_gbest();
    }

    fn step(&mut self, problem: &Problem<W>, _rng: &mut PlannerRng) -> bool {
        let w = self.inertia(self.iteration) as f32;
        update_swarm(self, w);
        if self.evaluate_all(problem) {
            self.refresh_gbest();
        }
        self.iteration += 1;
        true
    }

    fn best(&self) -> (&Route<W>, &RouteEval) {
        (&self.best, &self.best_eval)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::random_instance;

    // The default capacity class unless a test names another.
    type Problem = crate::problem::Problem;
    type Pso = crate::solver::pso::Pso;

    #[test]
    fn inertia_falls_linearly_over_the_budget_then_holds() {
        let pso = Pso::new(PsoSettings::paper());
        assert_eq!(pso.inertia(0), 1.4);
        assert!((pso.inertia(149) - 0.5).abs() < 1e-12);
        assert!((pso.inertia(75) - (1.4 - 0.9 * 75.0 / 149.0)).abs() < 1e-12);
        assert_eq!(pso.inertia(500), pso.inertia(149));
    }

    #[test]
    fn positions_stay_in_range_and_speeds_under_the_clamp() {
        let inst = random_instance(40, 0.4, 31_000.0, 2);
        let p = Problem::from_instance(&inst).unwrap();
        let mut pso = Pso::new(PsoSettings {
            particles: 20,
            ..PsoSettings::paper()
        });
        let mut rng = PlannerRng::new(1);
        pso.start(&p, &mut rng, None);
        for _ in 0..30 {
            pso.step(&p, &mut rng);
            let cells = 20 * pso.stride;
            assert!(pso.x[..cells].iter().all(|x| (P_MIN..=P_MAX).contains(x)));
            assert!(pso.v[..cells].iter().all(|v| v.abs() <= pso.v_max()));
        }
        // Some particles have hit a wall and been stopped there.
        assert!(pso.x[..20 * pso.stride].contains(&P_MAX));
    }

    #[test]
    fn the_wall_rule_and_clamp_are_settings() {
        let inst = random_instance(40, 0.4, 31_000.0, 2);
        let p = Problem::from_instance(&inst).unwrap();
        let swarm = |walls, velocity_clamp| {
            let mut pso = Pso::new(PsoSettings {
                particles: 20,
                walls,
                velocity_clamp,
                ..PsoSettings::paper()
            });
            let mut rng = PlannerRng::new(1);
            pso.start(&p, &mut rng, None);
            for _ in 0..30 {
                pso.step(&p, &mut rng);
            }
            pso
        };
        let cells = 20 * padded_len(40);
        // Free walls: positions leave the range, the routes stay valid.
        let free = swarm(Walls::Free, VELOCITY_CLAMP_FRACTION);
        assert!(free.x[..cells].iter().any(|x| !(P_MIN..=P_MAX).contains(x)));
        assert!(p.evaluate(free.best().0).is_some_and(|e| e.feasible));
        let clamp = swarm(Walls::Clamp, VELOCITY_CLAMP_FRACTION);
        assert!(clamp.x[..cells].iter().all(|x| (P_MIN..=P_MAX).contains(x)));
        // One dimension pushed through the top wall (w = 1, no pull): each
        // rule's result.
        let through = |walls| {
            let (lo, hi) = match walls {
                Walls::Free => (f32::NEG_INFINITY, f32::INFINITY),
                _ => (P_MIN, P_MAX),
            };
            let k = Coefficients {
                w: 1.0,
                c1: 0.0,
                c2: 0.0,
                v_max: 60.0,
                lo,
                hi,
                absorb: walls == Walls::Absorb,
            };
            let (mut x, mut v) = ([95.0f32], [20.0f32]);
            update_row(&mut x, &mut v, &[0.0], &[0.0], &[0], k);
            (x[0], v[0])
        };
        assert_eq!(through(Walls::Absorb), (P_MAX, 0.0));
        assert_eq!(through(Walls::Clamp), (P_MAX, 20.0));
        assert_eq!(through(Walls::Free), (115.0, 20.0));
        // No clamp: speeds exceed the default clamp and stay finite.
        let unclamped = swarm(Walls::Absorb, f64::INFINITY);
        let v_default = (VELOCITY_CLAMP_FRACTION * (PRIORITY_MAX - PRIORITY_MIN)) as f32;
        assert!(unclamped.v[..cells].iter().any(|v| v.abs() > v_default));
        assert!(unclamped.v[..cells].iter().all(|v| v.is_finite()));
    }

    #[test]
    fn the_update_is_identical_on_every_simd_level() {
        let inst = random_instance(37, 0.4, 31_000.0, 5);
        let p = Problem::from_instance(&inst).unwrap();
        // Every wall rule, with and without the clamp (the selects differ).
        for (walls, velocity_clamp) in [
            (Walls::Absorb, VELOCITY_CLAMP_FRACTION),
            (Walls::Clamp, VELOCITY_CLAMP_FRACTION),
            (Walls::Free, f64::INFINITY),
            (Walls::Absorb, f64::INFINITY),
        ] {
            let make = || {
                let mut pso = Pso::new(PsoSettings {
                    particles: 12,
                    walls,
                    velocity_clamp,
                    ..PsoSettings::paper()
                });
                let mut rng = PlannerRng::new(9);
                pso.start(&p, &mut rng, None);
                pso.step(&p, &mut rng);
                pso
            };
            let mut reference = make();
            update_swarm_generic::<false, 2>(&mut reference, 0.9);
            let mut dispatched = make();
            update_swarm(&mut dispatched, 0.9);
            assert_eq!(dispatched.x, reference.x, "{walls:?}");
            assert_eq!(dispatched.v, reference.v, "{walls:?}");
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx2") {
                    let mut avx2 = make();
                    // SAFETY: AVX2 checked just above.
                    unsafe { update_swarm_avx2(&mut avx2, 0.9) };
                    assert_eq!(avx2.x, reference.x, "{walls:?}");
                    assert_eq!(avx2.v, reference.v, "{walls:?}");
                }
                if std::arch::is_x86_feature_detected!("avx512f") {
                    let mut avx512 = make();
                    // SAFETY: AVX-512F checked just above.
                    unsafe { update_swarm_avx512(&mut avx512, 0.9) };
                    assert_eq!(avx512.x, reference.x, "{walls:?}");
                    assert_eq!(avx512.v, reference.v, "{walls:?}");
                    // It draws its words as it goes: the generator ends in
                    // the same state as after the row-by-row fills.
                    assert_eq!(avx512.lanes.next_block(), reference.lanes.next_block());
                }
            }
        }
    }

    #[test]
    fn the_warm_vector_decodes_to_the_warm_route_in_both_precisions() {
        warm_round_trip::<2>(30, 0.5);
        // Longer routes, so closer steps between the warm priorities.
        warm_round_trip::<8>(400, 0.05);
    }

    /// Random routes on a network of `n` nodes in class `W` decode back
    /// from their warm vector, in `f64` and in `f32`.
    fn warm_round_trip<const W: usize>(n: usize, density: f64) {
        let inst = random_instance(n, density, 31_000.0, 4);
        let p = crate::problem::Problem::<W>::from_instance(&inst).unwrap();
        let mut d = crate::decode::Decoder::<W>::new();
        let mut rng = PlannerRng::new(3);
        let mut prio = PerNode::<f64, W>::splat(0.0);
        for _ in 0..50 {
            for x in &mut prio[..n] {
                *x = rng.uniform(PRIORITY_MIN, PRIORITY_MAX);
            }
            let mut route = crate::route::Route::<W>::new();
            let e = d.decode(&p, &prio, &mut route);
            assert!(e.feasible);
            let mut again = crate::route::Route::<W>::new();
            warm_vector(&route, n, &mut prio);
            d.decode(&p, &prio, &mut again);
            assert_eq!(again.ids(), route.ids());
            let single: Vec<f32> = prio.iter().map(|&x| x as f32).collect();
            d.decode(&p, &single, &mut again);
            assert_eq!(again.ids(), route.ids());
        }
    }

    #[test]
    fn the_bit_to_unit_map_covers_the_unit_interval() {
        assert_eq!(unit24(0), 0.0);
        assert_eq!(unit24(0xFF_FFFF), 1.0 - 1.0 / 16_777_216.0);
        assert_eq!(unit24(0xABFF_FFFF), unit24(0xFF_FFFF));
    }
}
