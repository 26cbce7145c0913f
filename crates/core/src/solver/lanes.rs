//! Sixteen interleaved xoshiro256++ streams for the solvers' bulk draws.
//!
//! Contract: a [`LaneRng`] is seeded from the caller's
//! [`PlannerRng`](crate::rng::PlannerRng) (32 draws) at the start of every
//! solve, so every number it yields is fixed by the user's seed; it never
//! touches another source. It exists for speed: a PSO generation on 128
//! nodes needs ~40 000 uniforms, and sixteen independent states stepped in
//! lock-step let the compiler run them as one vector (a fast
//! seeded RNG), where one xoshiro state is a serial dependency chain (two
//! vectors of eight lanes give the core two chains to overlap). Each
//! lane is the same algorithm as `PlannerRng` (Blackman & Vigna, ACM TOMS
//! 2021); lanes are seeded by independent 64-bit draws, which for a
//! 2^256-period generator makes overlap negligible.

use crate::rng::PlannerRng;

/// Number of interleaved streams (two AVX-512 vectors of `u64`).
pub(crate) const LANES: usize = 16;

/// Sixteen xoshiro256++ states, word-major so each step is vector ops.
#[derive(Clone, Debug)]
pub(crate) struct LaneRng {
    s: [[u64; LANES]; 4],
    /// Unused 32-bit halves of the last block, for [`LaneRng::next_u32`].
    buf: [u32; 2 * LANES],
    used: usize,
}

impl LaneRng {
    /// A generator in a fixed state; call [`LaneRng::seed`] before use.
    pub(crate) const fn new() -> Self {
        Self {
            s: [[1; LANES]; 4],
            buf: [0; 2 * LANES],
            used: 2 * LANES,
        }
    }

    /// Reseeds every lane from `rng` (64 draws) and drops buffered values.
    pub(crate) fn seed(&mut self, rng: &mut PlannerRng) {
        for lane in 0..LANES {
            for word in 0..4 {
                self.s[word][lane] = rng.next_u64();
            }
            // An all-zero state is xoshiro's one fixed point; vanishingly
            // unlikely, but cheap to rule out.
            if (0..4).all(|w| self.s[w][lane] == 0) {
                self.s[0][lane] = 1;
            }
        }
        self.used = 2 * LANES;
    }

    /// One step of every lane: sixteen 64-bit outputs.
    #[inline(always)]
    pub(crate) fn next_block(&mut self) -> [u64; LANES] {
        let [s0, s1, s2, s3] = &mut self.s;
        let mut out = [0u64; LANES];
        for l in 0..LANES {
            out[l] = s0[l].wrapping_add(s3[l]).rotate_left(23).wrapping_add(s0[l]);
            let t = s1[l] << 17;
            s2[l] ^= s0[l];
            s3[l] ^= s1[l];
            s1[l] ^= s2[l];
            s0[l] ^= s3[l];
            s2[l] ^= t;
            s3[l] = s3[l].rotate_left(45);
        }
        out
    }

    /// Fills `out` (a whole number of blocks) with random words, block by
    /// block: `out[16j + l]` is lane l's j-th output, exactly as repeated
    /// [`LaneRng::next_block`] calls would give. Uses AVX-512 or AVX2 when
    /// the CPU has them (the same integer operations, so the same words).
    #[inline]
    pub(crate) fn fill(&mut self, out: &mut [u64]) {
        debug_assert_eq!(out.len() % LANES, 0);
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has AVX-512F (checked just above).
                return unsafe { simd::fill_avx512(self, out) };
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2 (checked just above).
                return unsafe { simd::fill_avx2(&mut self.s, out) };
            }
        }
        self.fill_portable(out);
    }

    /// [`LaneRng::fill`] in plain Rust (the reference the SIMD copies match).
    pub(crate) fn fill_portable(&mut self, out: &mut [u64]) {
        for chunk in out.chunks_exact_mut(LANES) {
            chunk.copy_from_slice(&self.next_block());
        }
    }

    /// Next 32 random bits, served from a buffered block.
    #[inline(always)]
    pub(crate) fn next_u32(&mut self) -> u32 {
        if self.used == 2 * LANES {
            let block = self.next_block();
            for (l, w) in block.iter().enumerate() {
                self.buf[2 * l] = (*w >> 32) as u32;
                self.buf[2 * l + 1] = *w as u32;
            }
            self.used = 0;
        }
        let v = self.buf[self.used];
        self.used += 1;
        v
    }
}

/// Hand-vectorised [`LaneRng::fill`]: LLVM will not vectorise xoshiro's
/// 64-bit rotates on AVX2 by itself, and this fill is a third of a PSO
/// generation's instructions.
#[cfg(target_arch = "x86_64")]
pub(crate) mod simd {
    use core::arch::x86_64::*;

    use super::LANES;

    /// AVX-512: two registers per state word (lanes 0–7 and 8–15).
    #[target_feature(enable = "avx512f")]
    pub(super) fn fill_avx512(rng: &mut super::LaneRng, out: &mut [u64]) {
        let mut st = load_avx512(rng);
        for chunk in out.chunks_exact_mut(LANES) {
            for (h, r) in next_avx512(&mut st).into_iter().enumerate() {
                // SAFETY: a 16-word chunk holds 8 words at offset 0 and 8;
                // unaligned store.
                unsafe { _mm512_storeu_si512(chunk[8 * h..].as_mut_ptr().cast(), r) };
            }
        }
        store_avx512(rng, &st);
    }

    /// The sixteen states in AVX-512 registers, as [`fill_avx512`] holds
    /// them (word, then lanes 0–7 / 8–15), for callers that draw and use
    /// the words in one pass; [`next_avx512`] steps them and
    /// [`store_avx512`] writes them back.
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(crate) fn load_avx512(rng: &super::LaneRng) -> [[__m512i; 2]; 4] {
        // SAFETY: each row is sixteen u64s; unaligned loads at 0 and 8.
        unsafe {
            core::array::from_fn(|w| core::array::from_fn(|h| _mm512_loadu_si512(rng.s[w][8 * h..].as_ptr().cast())))
        }
    }

    /// Writes states from [`load_avx512`] back into `rng`.
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(crate) fn store_avx512(rng: &mut super::LaneRng, st: &[[__m512i; 2]; 4]) {
        for (word, regs) in st.iter().enumerate() {
            for (h, reg) in regs.iter().enumerate() {
                // SAFETY: as in `load_avx512`.
                unsafe { _mm512_storeu_si512(rng.s[word][8 * h..].as_mut_ptr().cast(), *reg) };
            }
        }
    }

    /// One block of sixteen words (lanes 0–7, 8–15): exactly one chunk of
    /// [`fill_avx512`], with the same state steps.
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(crate) fn next_avx512(st: &mut [[__m512i; 2]; 4]) -> [__m512i; 2] {
        core::array::from_fn(|h| {
            let [s0, s1, s2, s3] = [st[0][h], st[1][h], st[2][h], st[3][h]];
            let r = _mm512_add_epi64(_mm512_rol_epi64::<23>(_mm512_add_epi64(s0, s3)), s0);
            let t = _mm512_slli_epi64::<17>(s1);
            let s2 = _mm512_xor_si512(s2, s0);
            let s3 = _mm512_xor_si512(s3, s1);
            let s1 = _mm512_xor_si512(s1, s2);
            let s0 = _mm512_xor_si512(s0, s3);
            let s2 = _mm512_xor_si512(s2, t);
            let s3 = _mm512_rol_epi64::<45>(s3);
            st[0][h] = s0;
            st[1][h] = s1;
            st[2][h] = s2;
            st[3][h] = s3;
            r
        })
    }

    #[inline(always)]
    fn rotl<const L: i32, const R: i32>(x: __m256i) -> __m256i {
        // SAFETY: only reached from `fill_avx2`, which requires AVX2.
        unsafe { _mm256_or_si256(_mm256_slli_epi64::<L>(x), _mm256_srli_epi64::<R>(x)) }
    }

    /// AVX2: four registers per state word (lanes 0–3, 4–7, 8–11, 12–15).
    #[target_feature(enable = "avx2")]
    pub(super) fn fill_avx2(s: &mut [[u64; LANES]; 4], out: &mut [u64]) {
        // SAFETY: as in `fill_avx512`; each half is four in-bounds words.
        unsafe {
            let ld = |w: &[u64; LANES], h: usize| _mm256_loadu_si256(w[4 * h..].as_ptr().cast());
            let mut st = [[_mm256_setzero_si256(); 4]; 4];
            for (word, regs) in st.iter_mut().enumerate() {
                for (h, reg) in regs.iter_mut().enumerate() {
                    *reg = ld(&s[word], h);
                }
            }
            for chunk in out.chunks_exact_mut(LANES) {
                for h in 0..4 {
                    let [s0, s1, s2, s3] = [st[0][h], st[1][h], st[2][h], st[3][h]];
                    let r = _mm256_add_epi64(rotl::<23, 41>(_mm256_add_epi64(s0, s3)), s0);
                    _mm256_storeu_si256(chunk[4 * h..].as_mut_ptr().cast(), r);
                    let t = _mm256_slli_epi64::<17>(s1);
                    let s2 = _mm256_xor_si256(s2, s0);
                    let s3 = _mm256_xor_si256(s3, s1);
                    let s1 = _mm256_xor_si256(s1, s2);
                    let s0 = _mm256_xor_si256(s0, s3);
                    let s2 = _mm256_xor_si256(s2, t);
                    let s3 = rotl::<45, 19>(s3);
                    st[0][h] = s0;
                    st[1][h] = s1;
                    st[2][h] = s2;
                    st[3][h] = s3;
                }
            }
            for (word, regs) in st.iter().enumerate() {
                for (h, reg) in regs.iter().enumerate() {
                    _mm256_storeu_si256(s[word][4 * h..].as_mut_ptr().cast(), *reg);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_lane_is_xoshiro256plusplus() {
        // Lane l with state words (a, b, c, d) must follow xoshiro256++,
        // i.e. PlannerRng's algorithm; check against PlannerRng's own step.
        let mut lanes = LaneRng::new();
        lanes.seed(&mut PlannerRng::new(5));
        let mut scalar = PlannerRng::from_state([lanes.s[0][3], lanes.s[1][3], lanes.s[2][3], lanes.s[3][3]]);
        for _ in 0..100 {
            assert_eq!(lanes.next_block()[3], scalar.next_u64());
        }
    }

    #[test]
    fn fill_is_the_same_stream_as_blocks_on_every_simd_level() {
        let mut a = LaneRng::new();
        a.seed(&mut PlannerRng::new(4));
        let mut reference = a.clone();
        let mut expect = [0u64; 96];
        reference.fill_portable(&mut expect);
        let mut blocks = a.clone();
        for j in 0..6 {
            assert_eq!(expect[16 * j..16 * j + 16], blocks.next_block());
        }
        let mut buf = [0u64; 96];
        a.clone().fill(&mut buf);
        assert_eq!(buf, expect);
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                let mut b = a.clone();
                // SAFETY: AVX2 checked just above.
                unsafe { simd::fill_avx2(&mut b.s, &mut buf) };
                assert_eq!(buf, expect);
                assert_eq!(b.s, reference.s);
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                let mut b = a.clone();
                // SAFETY: AVX-512F checked just above.
                unsafe { simd::fill_avx512(&mut b, &mut buf) };
                assert_eq!(buf, expect);
                assert_eq!(b.s, reference.s);
            }
        }
    }

    #[test]
    fn same_seed_same_draws_and_plausible_words() {
        let mut a = LaneRng::new();
        let mut b = LaneRng::new();
        a.seed(&mut PlannerRng::new(9));
        b.seed(&mut PlannerRng::new(9));
        let mut ones = 0u64;
        for _ in 0..10_000 {
            let u = a.next_u32();
            assert_eq!(u, b.next_u32());
            ones += u64::from(u.count_ones());
        }
        // Half the bits set, within a few standard deviations (σ ≈ 283).
        assert!((ones as i64 - 160_000).abs() < 1_500, "{ones}");
        let mut c = LaneRng::new();
        c.seed(&mut PlannerRng::new(10));
        assert_ne!(c.next_block(), a.next_block());
    }
}
