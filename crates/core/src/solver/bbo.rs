//! Biogeography-based optimisation on priority vectors (the paper's BBO).
//!
//! Contract: [`Bbo`] implements the anytime [`Solver`] contract on the same
//! encoding, decoder and fitness as the PSO (a habitat is a priority vector
//! in [[`PRIORITY_MIN`], [`PRIORITY_MAX`]], kept in `f32` like the swarm:
//! half the bytes for the migration's scattered reads; [`Problem::better`]
//! ranks). All
//! buffers are allocated in [`Bbo::new`]; `start` and `step` do not
//! allocate. Same seed, same routes, on every machine (integer thresholds,
//! plain arithmetic, a total order for ranking).
//!
//! One generation (Simon, "Biogeography-based optimization", IEEE TEC 2008,
//! with the paper's settings, [`BboSettings::paper`]):
//! 1. Habitats are ranked best first (rank r = 0..N−1; ties by score, then
//!    shorter route time, then habitat index, so the order is total).
//! 2. Rates by rank: emigration μ_r = (N − r)/(N + 1) ∈ (0, 1), immigration
//!    λ_r = 1 − μ_r.
//! 3. The `elites` best habitats are kept unchanged. Every other habitat,
//!    per dimension, immigrates with probability λ_r: the value is copied
//!    from a source habitat picked by roulette on μ over the whole
//!    population as it stood before this generation (the receiving habitat
//!    itself included, as in Simon's reference code).
//! 4. Mutation, per dimension of the non-elite habitats, replaces the value
//!    by U[P_min, P_max) with probability m_r = m_max·(1 − P_r/P_max):
//!    Simon's species-count rule. With linear rates and equal maxima the
//!    steady-state species-count probabilities are binomial, P_r ∝
//!    C(N, N − r), so mediocre habitats mutate least and both extremes
//!    (the best, which elitism shields anyway, and the worst) most.
//! 5. The changed habitats are decoded and the population is re-ranked.
//!
//! Our choices where the paper is silent: 150 generations per budget
//! (matching the PSO's iteration count); elites are simply not modified
//! (rather than modified, then restored over the worst), which saves their
//! re-evaluation; warm start as in the PSO: a tenth of the habitats (5 of
//! 50) start on or near a vector that decodes to the warm route, and the
//! warm route is evaluated directly so a warm solve is never worse than it.
//! Random draws come from sixteen xoshiro256++ lanes seeded from the caller's
//! `PlannerRng` (see `lanes.rs`).

use core::cmp::Ordering;

use super::Solver;
use super::lanes::LaneRng;
use super::pso::{P_MAX, P_MIN, unit24, warm_count, warm_vector};
use crate::capacity::{DEFAULT_WORDS, PerNode, nodes_of};
use crate::decode::{Decoder, PRIORITY_MAX, PRIORITY_MIN, padded_len};
use crate::problem::Problem;
use crate::rng::PlannerRng;
use crate::route::{Route, RouteEval};

/// BBO settings; [`BboSettings::paper`] gives the paper's values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BboSettings {
    /// Population (paper: 50 habitats).
    pub habitats: usize,
    /// Best habitats kept unchanged each generation (paper: 10).
    pub elites: usize,
    /// Generations of a full budget (our choice: 150, matching the PSO; the paper is silent).
    pub generations: u32,
    /// Largest per-dimension mutation probability (paper: 0.1).
    pub max_mutation_rate: f64,
}

impl BboSettings {
    /// The paper's settings.
    pub fn paper() -> Self {
        Self {
            habitats: 50,
            elites: 10,
            generations: 150,
            max_mutation_rate: 0.1,
        }
    }
}

/// Noise on the perturbed warm habitats, as a fraction of the range.
const WARM_NOISE_FRACTION: f64 = 0.1;

/// A BBO solver with every buffer allocated up front.
pub struct Bbo<const W: usize = DEFAULT_WORDS> {
    settings: BboSettings,
    /// Decodes the changed habitats as one stream.
    decoder: Decoder<W>,
    lanes: LaneRng,
    n: usize,
    stride: usize,
    /// Habitats: `habitats` rows of `stride` priorities.
    pop: Vec<f32>,
    /// The population as the generation began (migration reads from it).
    old: Vec<f32>,
    /// Each habitat's route as far as the ranking reads it
    /// ([`crate::decode::Walked::ranked`]).
    eval: Vec<RouteEval>,
    /// Habitat indices, best first.
    order: Vec<usize>,
    /// Per habitat: (score, route time) for ranking.
    rank_key: Vec<(f64, f64)>,
    /// Roulette on μ by rank as a Walker/Vose alias table: bucket b keeps
    /// rank b when a 16-bit coin is below `alias_keep[b]`, else takes
    /// `alias_other[b]`.
    alias_keep: Vec<u32>,
    alias_other: Vec<u32>,
    /// By rank: immigration λ_r and mutation m_r as 16-bit thresholds.
    immigrate_below: Vec<u32>,
    mutate_below: Vec<u32>,
    /// Random words for the habitat being changed (two per dimension).
    words: Vec<u64>,
    best: Route<W>,
    best_eval: RouteEval,
}

impl<const W: usize> Bbo<W> {
    /// Builds the solver (allocates all buffers). At least 2 habitats are
    /// kept and at most `habitats − 1` elites, so something always evolves.
    pub fn new(settings: BboSettings) -> Self {
        let habitats = settings.habitats.max(2);
        let settings = BboSettings {
            habitats,
            elites: settings.elites.min(habitats - 1),
            ..settings
        };
        let n_f = habitats as f64;
        let mu: Vec<f64> = (0..habitats).map(|r| (n_f - r as f64) / (n_f + 1.0)).collect();
        let (alias_keep, alias_other) = alias_table(&mu);
        let immigrate_below = mu.iter().map(|m| threshold16(1.0 - m)).collect();
        let mutate_below = species_mutation_rates(habitats, settings.max_mutation_rate)
            .into_iter()
            .map(threshold16)
            .collect();
        let cells = habitats * nodes_of(W);
        Self {
            settings,
            decoder: Decoder::new(),
            lanes: LaneRng::new(),
            n: 0,
            stride: 0,
            pop: vec![0.0; cells],
            old: vec![0.0; cells],
            eval: vec![RouteEval::default(); habitats],
            order: (0..habitats).collect(),
            rank_key: vec![(0.0, 0.0); habitats],
            alias_keep,
            alias_other,
            immigrate_below,
            mutate_below,
            words: vec![0; 2 * nodes_of(W)],
            best: Route::new(),
            best_eval: RouteEval::default(),
        }
    }

    /// The settings.
    pub fn settings(&self) -> &BboSettings {
        &self.settings
    }

    /// Decodes habitats `order[from..]` (`ranked`) or all habitats (not
    /// `ranked`) as one stream, records their figures, and updates the
    /// best-so-far on strict improvement as each walk finishes.
    fn evaluate(&mut self, problem: &Problem<W>, ranked: bool, from: usize) {
        let stride = self.stride;
        let habitat = |i: usize| if ranked { self.order[from + i] } else { i };
        let count = if ranked {
            self.settings.habitats.saturating_sub(from)
        } else {
            self.settings.habitats
        };
        let pop = &self.pop;
        let (eval, rank_key) = (&mut self.eval, &mut self.rank_key);
        let (best, best_eval) = (&mut self.best, &mut self.best_eval);
        self.decoder.decode_stream(
            problem,
            count,
            &|i| &pop[habitat(i) * stride..(habitat(i) + 1) * stride],
            &mut |i, walked| {
                let (h, e) = (habitat(i), walked.ranked());
                eval[h] = *e;
                rank_key[h] = (problem.score(e), e.time_s);
                if problem.better(e, best_eval) {
                    *best = *walked.route();
                    *best_eval = walked.figures();
                }
            },
        );
    }

    /// Sorts `order` best first under a total order.
    fn rank(&mut self) {
        let key = &self.rank_key;
        self.order.sort_unstable_by(|&a, &b| {
            let (sa, ta) = key[a];
            let (sb, tb) = key[b];
            // Higher score first, then shorter time, then lower index.
            sb.partial_cmp(&sa)
                .unwrap_or(Ordering::Equal)
                .then(ta.partial_cmp(&tb).unwrap_or(Ordering::Equal))
                .then(a.cmp(&b))
        });
    }
}

/// Probability `p` ∈ [0, 1] as a threshold on a 16-bit draw (`draw < t`
/// has probability `p` to 2^-16, ample for rates like 1/51 or 0.1).
fn threshold16(p: f64) -> u32 {
    (p.clamp(0.0, 1.0) * 65_536.0).round() as u32
}

/// Walker/Vose alias table for sampling index i with probability
/// ∝ `weights[i]`: draw a bucket b uniformly and a 16-bit coin c; take b
/// when c < keep[b], else other[b]. Built with plain arithmetic in a fixed
/// order, so the table (and every draw) is the same on every machine.
fn alias_table(weights: &[f64]) -> (Vec<u32>, Vec<u32>) {
    let k = weights.len();
    let total: f64 = weights.iter().sum();
    let mut scaled: Vec<f64> = weights.iter().map(|w| w * k as f64 / total).collect();
    let mut keep = vec![65_536u32; k];
    let mut other: Vec<u32> = (0..k as u32).collect();
    let mut small: Vec<usize> = (0..k).filter(|&i| scaled[i] < 1.0).collect();
    let mut large: Vec<usize> = (0..k).filter(|&i| scaled[i] >= 1.0).collect();
    while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
        keep[s] = threshold16(scaled[s]);
        other[s] = l as u32;
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // Leftovers (rounding) keep their own bucket.
    (keep, other)
}

/// Simon's species-count mutation rates by rank (0 = best):
/// m_r = m_max·(1 − P_r / max P) with P_r ∝ C(N, N − r). Computed by
/// ratios of neighbouring binomials outwards from the mode, so no
/// factorial overflows and no `ln`/`exp` (whose last bits vary by libm)
/// enters the results.
fn species_mutation_rates(habitats: usize, max_rate: f64) -> Vec<f64> {
    // Species count k = N − r ranges over 1..=N; P_k ∝ C(N, k).
    let n = habitats;
    let mode = n / 2;
    let mut rel = vec![0.0f64; n + 1]; // rel[k] = C(N, k) / C(N, mode)
    rel[mode] = 1.0;
    for k in mode + 1..=n {
        rel[k] = rel[k - 1] * (n - k + 1) as f64 / k as f64;
    }
    for k in (0..mode).rev() {
        rel[k] = rel[k + 1] * (k + 1) as f64 / (n - k) as f64;
    }
    (0..n).map(|r| max_rate * (1.0 - rel[n - r])).collect()
}

impl<const W: usize> Solver<W> for Bbo<W> {
    fn name(&self) -> &'static str {
        "bbo"
    }

    fn start(&mut self, problem: &Problem<W>, rng: &mut PlannerRng, warm: Option<&Route<W>>) {
        let n = problem.n();
        let stride = padded_len(n);
        self.n = n;
        self.stride = stride;
        self.lanes.seed(rng);
        let habitats = self.settings.habitats;
        let range = P_MAX - P_MIN;
        for x in &mut self.pop[..habitats * stride] {
            *x = P_MIN + range * unit24(u64::from(self.lanes.next_u32()));
        }
        let mut warm_eval = None;
        if let Some(route) = warm {
            let mut exact = PerNode::<f64, W>::splat(0.0);
            warm_vector(route, n, &mut exact);
            for (x, e) in self.pop[..n].iter_mut().zip(&exact) {
                *x = *e as f32;
            }
            let noise = (WARM_NOISE_FRACTION * (PRIORITY_MAX - PRIORITY_MIN)) as f32;
            for h in 1..warm_count(habitats) {
                let (head, rest) = self.pop.split_at_mut(h * stride);
                for (d, x) in rest[..n].iter_mut().enumerate() {
                    let u = unit24(u64::from(self.lanes.next_u32()));
                    *x = (head[d] + noise * (2.0 * u - 1.0)).clamp(P_MIN, P_MAX);
                }
            }
            warm_eval = problem.evaluate(route);
        }
        self.best_eval = super::WORST;
        self.evaluate(problem, false, 0);
        if let (Some(route), Some(e)) = (warm, warm_eval)
            && problem.better(&e, &self.best_eval)
        {
            // Habitat 0 holds the warm vector; let it carry the warm
            // route's figures in the ranking too.
            self.best = *route;
            self.best_eval = e;
            self.eval[0] = e;
            self.rank_key[0] = (problem.score(&e), e.time_s);
        }
        for (i, o) in self.order.iter_mut().enumerate() {
            *o = i;
        }
        self.rank();
    }

    fn step(&mut self, problem: &Problem<W>, _rng: &mut PlannerRng) -> bool {
        let (n, stride) = (self.n, self.stride);
        let habitats = self.settings.habitats;
        self.old[..habitats * stride].copy_from_slice(&self.pop[..habitats * stride]);
        let range = P_MAX - P_MIN;
        let buckets = habitats as u64;
        // Locals, so the stores into `pop` cannot make the compiler reload
        // (and re-check) the tables on every dimension.
        let (keep, other) = (&self.alias_keep[..habitats], &self.alias_other[..habitats]);
        let (order, old) = (&self.order[..habitats], &self.old[..habitats * stride]);
        for r in self.settings.elites..habitats {
            let h = order[r];
            let (immigrate, mutate) = (self.immigrate_below[r], self.mutate_below[r]);
            let words = &mut self.words[..2 * stride];
            self.lanes.fill(words);
            let row = &mut self.pop[h * stride..h * stride + n];
            // Branch-free per dimension: word a holds the immigration test
            // (bits 0–15), the mutation test (16–31), the alias coin
            // (32–47) and the alias bucket (48–63, multiply-shift onto
            // 0..N); word b is the mutated value.
            for (d, (x, w)) in row.iter_mut().zip(words.chunks_exact(2)).enumerate() {
                let (a, b) = (w[0], w[1]);
                let bucket = (((a >> 48) * buckets) >> 16) as usize;
                let coin = ((a >> 32) & 0xFFFF) as u32;
                let rank = if coin < keep[bucket] {
                    bucket
                } else {
                    other[bucket] as usize
                };
                let source = old[order[rank] * stride + d];
                let moved = if ((a & 0xFFFF) as u32) < immigrate { source } else { *x };
                let fresh = P_MIN + range * unit24(b);
                *x = if (((a >> 16) & 0xFFFF) as u32) < mutate {
                    fresh
                } else {
                    moved
                };
            }
        }
        // Decode the changed habitats (the non-elite ranks) as one stream.
        self.evaluate(problem, true, self.settings.elites);
        self.rank();
        true
    }

    fn best(&self) -> (&Route<W>, &RouteEval) {
        (&self.best, &self.best_eval)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // The default capacity class unless a test names another.
    type Problem = crate::problem::Problem;
    type Bbo = crate::solver::bbo::Bbo;

    #[test]
    fn rates_follow_rank_and_the_roulette_follows_mu() {
        let b = Bbo::new(BboSettings::paper());
        // λ by rank rises from 1/51 to 50/51 (as 16-bit thresholds).
        assert_eq!(b.immigrate_below[0], threshold16(1.0 / 51.0));
        assert_eq!(b.immigrate_below[49], threshold16(50.0 / 51.0));
        assert!(b.immigrate_below.windows(2).all(|w| w[0] < w[1]));
        // The alias table reproduces μ_r / Σμ = (50 − r) / 1275 exactly
        // enough: tally its probability mass per rank.
        let mut mass = [0.0f64; 50];
        for bucket in 0..50 {
            let keep = f64::from(b.alias_keep[bucket]) / 65_536.0;
            mass[bucket] += keep / 50.0;
            mass[b.alias_other[bucket] as usize] += (1.0 - keep) / 50.0;
        }
        for (r, m) in mass.iter().enumerate() {
            let want = (50 - r) as f64 / 1275.0;
            assert!((m - want).abs() < 1e-4, "rank {r}: {m} vs {want}");
        }
    }

    #[test]
    fn species_mutation_is_largest_at_the_extremes_and_capped() {
        let m = species_mutation_rates(50, 0.1);
        assert_eq!(m.len(), 50);
        assert!(m.iter().all(|&x| (0.0..=0.1).contains(&x)));
        // Species count 25 (rank 25) is the binomial mode: no mutation.
        assert_eq!(m[25], 0.0);
        assert!(m[0] > 0.099 && m[49] > 0.099);
        assert!(m[10] > m[20] && m[40] > m[30]);
    }

    #[test]
    fn elites_are_never_modified() {
        let inst = crate::fixtures::random_instance(30, 0.4, 31_000.0, 8);
        let p = Problem::from_instance(&inst).unwrap();
        let mut b = Bbo::new(BboSettings::paper());
        let mut rng = PlannerRng::new(2);
        b.start(&p, &mut rng, None);
        for _ in 0..20 {
            let elites: Vec<usize> = b.order[..10].to_vec();
            let before: Vec<Vec<f32>> = elites
                .iter()
                .map(|&h| b.pop[h * b.stride..(h + 1) * b.stride].to_vec())
                .collect();
            b.step(&p, &mut rng);
            for (h, row) in elites.iter().zip(before) {
                assert_eq!(&b.pop[h * b.stride..(h + 1) * b.stride], &row[..]);
            }
            // Ranking is consistent with `better`.
            for w in b.order.windows(2) {
                assert!(!p.better(&b.eval[w[1]], &b.eval[w[0]]));
            }
        }
    }
}
