//! The default planner `auto`: a memetic PSO with iterated
//! local search, tuned for route quality per microsecond.
//!
//! Contract: [`Auto`] implements the anytime [`Solver`] contract like PSO
//! and BBO: `start` yields a valid best-so-far at once, each `step` is one
//! bounded quantum of work, the best-so-far changes only on strict
//! improvement, every buffer is allocated in [`Auto::new`], `start` and
//! `step` do not allocate, and the same seed gives the same route.
//!
//! One step:
//! 1. one generation of a small paper-style PSO swarm ([`AutoSettings`]);
//! 2. when the swarm's best improved, it is polished by [`LocalSearch`]
//!    and written back into the swarm (Lamarckian: encoded as priorities
//!    falling along the route, every other node low, which decode back to
//!    the route — see `pso::warm_vector`);
//! 3. a few ruin-and-recreate kicks on the current route of an iterated
//!    local search: remove a random segment (at most a third of the route
//!    and at most `ruin_max` nodes, a quarter of the waypoints on large
//!    dense networks), re-insert free nodes greedily by
//!    weight per second (with noise, the removed nodes barred from the
//!    first refill), polish; accept when within `accept` of the best, go
//!    back to the best after a run of kicks without improvement (every
//!    fourth time rebuilding from the shortest start → goal leg instead). A
//!    better ILS route is also written back into the swarm, so the swarm
//!    steers by it.
//!
//! Under objectives that value time (`paper_cost`) a route nearly uses up
//! its budget, so inserting a node means removing another, and on sparse
//! networks a ruin often cannot close its gap at all. There every other
//! kick is a reroute kick instead ([`Moves::reroute_kick`]: 1–3
//! consecutive nodes out, the best path of 0–2 others in between the same
//! two route nodes), and every kick's result and new best route is
//! polished by rerouting too ([`Moves::reroute`]). On dense networks
//! ([`REROUTE_MAX_DENSITY`]) one kick in four reroutes, nothing is
//! polished by rerouting and the recreate step does not shorten
//! ([`AutoSettings::dense_cost_shorten`]). Under `max_weight` nothing of
//! this runs (same routes, same random draws as without it).
//!
//! Under objectives that value time, each step also runs a quantum of a
//! depth-first search over the low-risk edges ([`RiskSearch`]): the best
//! routes there use edges among each node's lowest ξ/ρ ones, on dense
//! networks spending the budget to the second, on sparse ones (where a
//! small φ1 makes idle time cheap) as a short low-risk path that kicks,
//! which insert and exchange nodes of the current route, do not reach.
//! Its routes are offered like a kick's, polished on the whole network,
//! and the iterated local search continues from them.
//!
//! Under `max_weight`, the steps also run forward beam searches ([`Beam`],
//! a level per step, one beam after another): on sparse networks the best
//! route often runs through a region the current route does not touch, or
//! through a cluster the other way round, which kicks that remove a third
//! of the route at most and refill one node at a time do not reach; on
//! dense ones a beam's route is a different basin too. Each beam prices
//! time differently, so the beams end in different regions; each one's
//! best route, polished, becomes the current route of the iterated local
//! search.
//!
//! Kicks are polished with the cheap moves ([`LocalSearch::improve`]);
//! every new best route also gets the deep polish (or-opt, swap, pair
//! insertion: [`LocalSearch::improve_deep`]), under `max_weight` only once
//! it has stood [`AutoSettings::deep_after`] kicks (early in a search new
//! bests come nearly every kick, and deep-polishing each one took most of
//! a 20 ms solve on 100-city OPLib files). On dense networks above
//! [`AutoSettings::first_above`] nodes a young search (before its first
//! return to the best) polishes kicks by first improvement
//! ([`LocalSearch::improve_first`]): more kicks while they still find new
//! bests, the full polish once they stop. One step stays well under a
//! millisecond on 40-node snapshots (measured max 0.4–0.7 ms); on the
//! 64–66-node classic instances with long routes a deep polish can take
//! 2–3 ms, which is how far past a deadline a solve may end there.
//!
//! Why this shape: the paper's PSO at its full budget stays 15–25 % below
//! long-run optima on 40-node networks; the decoder's greedy walk rarely
//! finds the detours that local search (insertion, 2-opt) and segment
//! re-building find in microseconds.

use super::Solver;
use super::beam::Beam;
use super::ils::{Moves, Ruin};
use super::local::LocalSearch;
use super::objective::Value;
use super::pso::{Pso, PsoSettings};
use super::risk_search::{self, RiskSearch};
use crate::capacity::DEFAULT_WORDS;
use crate::problem::{MAX_NODES, NodeSet, Problem};
use crate::rng::PlannerRng;
use crate::route::{Route, RouteEval};

/// Settings of [`Auto`]; [`AutoSettings::default`] is the tuned default
/// (chosen on 30 default-scenario 40-node snapshots, seeds 1–30, three
/// solver seeds each, and the 89 classic instances, at 20 ms and 5 ms of
/// thread CPU time; differences between nearby values were within
/// run-to-run noise on this shared machine). A small swarm (4 particles)
/// and two kicks per step: at these deadlines the iterated local search
/// does most of the work, and a 20-particle swarm's generations only took
/// kicks away (mean gap 0.70 % against 0.72–0.91 % at 20 ms; 1.4 % against
/// 2.2 % at 5 ms).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutoSettings {
    /// Swarm size.
    pub particles: usize,
    /// Length of the swarm's inertia schedule, in steps (then held at its end).
    pub swarm_iterations: u32,
    /// Ruin-and-recreate kicks per step.
    pub kicks: u32,
    /// Local-search passes per polish, at most.
    pub polish_passes: u32,
    /// Kicks without a new best before the search returns to the best.
    pub restart_after: u32,
    /// Every this many returns, rebuild from the shortest start → goal leg
    /// instead of returning to the best. 4: on the snapshots returning to
    /// the best did better than rebuilding (mean gap about 0.6 % against
    /// 0.7 % with every other return a rebuild), but never rebuilding left
    /// some classic instances stuck far from their optimum (28 % on one).
    pub fresh_every: u32,
    /// Record-to-record acceptance: a kick's result becomes the current
    /// route when its score is within this fraction of the best's.
    pub accept: f64,
    /// Most route nodes one kick removes (also at most a third of the
    /// route's interior, and at least 2). 10: on the long routes of the
    /// Chao sets a third of the route was too large a ruin (171 of 178
    /// solves at the best-known score against 164 uncapped, 2 seeds); the
    /// 40-node snapshots' routes are short enough not to notice.
    pub ruin_max: usize,
    /// The ruin size cap after a new best (it grows by one every
    /// `grow_every` kicks without one, up to `ruin_max`).
    pub ruin_min: usize,
    /// On dense networks the ruin size cap may grow past `ruin_max`, to
    /// one node per this many waypoints (0: never; 40 nodes or fewer are
    /// never affected at 4). There the best route of a large network can
    /// differ from a route by a whole cluster of waypoints, which ten
    /// removed nodes do not reach. Decided on the training sets (OPLib ≤
    /// 127 cities, the dense training families, OPLib generation 1 above
    /// 127), mean gap at 100 ms / 1 s: none 0.68 / 0.30 % on OPLib ≤ 127,
    /// 6: 0.61 / 0.30 %, 5: 0.50 / 0.25 %, 4: 0.60 / 0.13 %; generation 1
    /// above 127 at 1 s: none 3.47 %, 8: 2.41 %, 6: 2.18 %, 4: 2.09 %. Sparse
    /// networks stay at `ruin_max`: there a fixed cap of 20 doubled the
    /// 20 ms gap of the training families (a large ruin rarely closes its
    /// gaps with the few edges there are).
    pub ruin_nodes_per_waypoints: usize,
    /// Kicks without a new best per step of the ruin size cap.
    pub grow_every: u32,
    /// Noise of greedy insertion: each node's value per second is scaled
    /// by a factor in [1, 1 + noise), so kicks differ.
    pub noise: f64,
    /// A swarm generation every this many steps (0: never).
    pub swarm_every: u32,
    /// Largest network whose new best routes get the deep polish.
    pub deep_polish_max_n: usize,
    /// Longest segment the kicks' or-opt moves (0–3).
    pub or_opt_segment: usize,
    /// Objectives that value time (`paper_cost`): some kicks are reroute
    /// kicks ([`Moves::reroute_kick`]; every other one, or one in four on
    /// dense networks), and on sparse networks routes are polished by
    /// rerouting too ([`Moves::reroute`], see [`REROUTE_MAX_DENSITY`]). No
    /// effect under `max_weight`.
    pub reroute: bool,
    /// Dense networks (edge density above [`REROUTE_MAX_DENSITY`]) of more
    /// than this many nodes polish kicks with first improvement
    /// ([`LocalSearch::improve_first`]) while the search is young (fewer
    /// than `young_restarts` returns to the best). 64: the 100–127-city
    /// OPLib files gained (gen1 at 20 ms, 10 seeds: mean gap 2.44 → 2.10 %),
    /// and on the sparse 100–128-node Bay of Islands networks first
    /// improvement looked worse at 20 ms (bi100-mw −2.1 %, bi128-pc −3.2 %
    /// of score, 3 seeds; about the noise of two runs of one binary there),
    /// so sparse networks keep best improvement.
    pub first_above: usize,
    /// Returns to the best after which the search is no longer young. 1:
    /// first improvement for the whole search lost at 1000 ms in an earlier
    /// measurement (OPLib 34 → 31 of 46 at the best-known score).
    pub young_restarts: u32,
    /// Under `max_weight`, new best routes get the cheap polish and the
    /// deep one runs on the best once it has stood this many kicks (0:
    /// deep polish at once, as under `paper_cost`, where deferring it lost
    /// on a held-out dense family at 20 ms). 5: OPLib gen1 at 20 ms, 10
    /// seeds, 111 → 123 of 230 solves at the best-known score.
    pub deep_after: u32,
    /// Objectives that value time on dense networks (edge density above
    /// [`REROUTE_MAX_DENSITY`]): whether the recreate step shortens the
    /// route (2-opt, or-opt) around its refills. Off: shortening gives up
    /// route time, which `paper_cost` pays for by the second, and on dense
    /// networks the refills did not buy it back at a lower risk (`bc40-pc`,
    /// 16 instances, 4 seeds: mean gap 32.0 → 19.8 % at 20 ms, 16.5 →
    /// 10.4 % at 100 ms; held out `bc64-pc-perturbed` 54.8 → 29.4 %, 20.0 →
    /// 2.3 %). Sparse networks and `max_weight` always shorten.
    pub dense_cost_shorten: bool,
    /// Objectives that value time: partial paths the low-risk search
    /// ([`RiskSearch`]) expands per step, resuming where it stopped, until
    /// it has looked at every candidate route (0: never). 16 384: about
    /// 0.5 ms, most of a step on dense networks; on the `bc40-pc` training
    /// instances it found better routes than the kicks in the same time (at
    /// 4 096 a 20 ms solve ended before the search reached the routes it
    /// finds at 16 384). On sparse networks it runs too: on the `bi128-pc`
    /// training family the kicks stayed 17 % above the best-known cost from
    /// 20 to 100 ms, and with the search they reach it within 20 ms.
    pub risk_search: u32,
    /// `max_weight` on sparse networks (edge density at most
    /// [`REROUTE_MAX_DENSITY`]): partial paths each forward beam search
    /// ([`Beam`]) keeps per level (0: no beams there; at most
    /// [`super::beam::MAX_WIDTH`]). Decided on the training families
    /// `bi60-mw-loose` and `bi90-mw` (20 instances, 3 seeds, mean / worst
    /// gap at 20 ms): 8: 0.79 / 7.7 %, 16: 0.48 / 2.9 %, 32: 0.56 / 7.7 %.
    pub beam_width: usize,
    /// The same on dense networks, where a level has a candidate for
    /// nearly every node; solves without a warm start only. Training
    /// families `bc40-mw` and `bc90-mw-tight-perturbed` (8 instances, 8
    /// seeds, mean gap at 20 / 100 ms): no beams 1.13 / 0.70 %, width 8
    /// 0.61 / 0.41 %, 16 0.87 / 0.49 %.
    pub dense_beam_width: usize,
    /// Beams run one after the other, a level per step, each continuing
    /// the iterated local search from its route. Training families, 6
    /// seeds, mean gap at 20 / 100 ms: one 1.13 / 0.68 % (3 seeds), 5
    /// 0.88 / 0.33 %, 8 0.64 / 0.22 %, 12 0.57 / 0.25 %.
    pub beam_rounds: usize,
    /// The price of a second of time left in beam `k`'s ranking is factor
    /// `k mod 5` times the best route's weight per second of the budget
    /// when the beam starts. Different prices end in different regions of
    /// the network: a single factor 0.7 for every round gave 1.01 / 0.59 %,
    /// 0.6 and 0.8 in turn 0.64 / 0.27 %, these five 0.64 / 0.22 %.
    pub beam_price_factors: [f64; 5],
}

impl Default for AutoSettings {
    fn default() -> Self {
        Self {
            swarm_iterations: 60,
            particles: 4,
            kicks: 2,
            polish_passes: 16,
            restart_after: 40,
            fresh_every: 4,
            accept: 0.03,
            ruin_max: 10,
            ruin_min: 3,
            ruin_nodes_per_waypoints: 4,
            grow_every: 8,
            noise: 0.3,
            swarm_every: 1,
            deep_polish_max_n: MAX_NODES,
            or_opt_segment: 1,
            reroute: true,
            first_above: 64,
            young_restarts: 1,
            deep_after: 5,
            dense_cost_shorten: false,
            risk_search: 16_384,
            beam_width: 16,
            dense_beam_width: 8,
            beam_rounds: 8,
            beam_price_factors: [0.7, 0.6, 0.8, 0.5, 0.9],
        }
    }
}

/// Iterations of `auto`'s full budget when no deadline cuts it.
pub const AUTO_ITERATIONS: u32 = 300;

/// The memetic planner with every buffer allocated up front.
pub struct Auto<const W: usize = DEFAULT_WORDS> {
    settings: AutoSettings,
    pso: Pso<W>,
    ls: LocalSearch<W>,
    moves: Moves<W>,
    risk: RiskSearch<W>,
    /// Whether this problem runs the low-risk search ([`AutoSettings::risk_search`]).
    risk_searching: bool,
    /// Lowest-risk edges per node of the present search's candidate graph.
    /// Current ruin size cap: grows while kicks find nothing, back to its
    /// base on a new best (adaptive removal size).
    ruin_cap: usize,
    /// The ruin size cap's ceiling on this problem.
    ruin_top: usize,
    /// The swarm's best figures when last polished.
    polished_from: RouteEval,
    /// Iterated local search: current route and figures.
    cur: Route<W>,
    cur_eval: RouteEval,
    trial: Route<W>,
    best: Route<W>,
    best_eval: RouteEval,
    stale: u32,
    /// Steps since `start`.
    steps: u32,
    /// Restarts since `start`.
    restarts: u32,
    /// Whether this problem's kicks reroute ([`AutoSettings::reroute`]).
    rerouting: bool,
    /// One kick in this many reroutes (2, or 4 on dense networks).
    reroute_every: u32,
    /// Whether routes are polished by rerouting (sparse networks only, see
    /// [`REROUTE_MAX_DENSITY`]).
    reroute_polish: bool,
    /// Whether `best` has had the deep polish.
    best_deep: bool,
    /// Whether new bests wait [`AutoSettings::deep_after`] kicks for their
    /// deep polish (objectives that do not value time only).
    defer_deep: bool,
    /// Whether kicks of a young search are polished by first improvement
    /// (dense networks above [`AutoSettings::first_above`] nodes).
    first_polish: bool,
    /// Whether the recreate step shortens ([`AutoSettings::dense_cost_shorten`]).
    shorten: bool,
    /// The forward beam search (`max_weight`).
    beam: Beam<W>,
    /// Its width on this problem (sparse or dense).
    beam_width: usize,
    /// Whether this solve runs beams (`max_weight`; on dense networks only
    /// without a warm start).
    beaming: bool,
    /// Beams started on this problem.
    beams_started: usize,
}

impl<const W: usize> Auto<W> {
    /// Builds the solver (allocates all buffers).
    pub fn new(settings: AutoSettings) -> Self {
        Self {
            settings,
            pso: Pso::new(PsoSettings {
                particles: settings.particles,
                iterations: settings.swarm_iterations,
                ..PsoSettings::paper()
            }),
            ls: LocalSearch::new(),
            moves: Moves::new(),
            risk: RiskSearch::new(),
            risk_searching: false,
            ruin_cap: 2,
            ruin_top: 2,
            polished_from: super::WORST,
            cur: Route::new(),
            cur_eval: super::WORST,
            trial: Route::new(),
            best: Route::new(),
            best_eval: super::WORST,
            stale: 0,
            steps: 0,
            restarts: 0,
            rerouting: false,
            reroute_every: 2,
            reroute_polish: false,
            best_deep: true,
            first_polish: false,
            defer_deep: false,
            shorten: true,
            beam: Beam::new(),
            beam_width: 0,
            beaming: false,
            beams_started: 0,
        }
    }

    /// The settings.
    pub fn settings(&self) -> &AutoSettings {
        &self.settings
    }

    /// Takes `route` as best-so-far on strict improvement, deep-polished
    /// first (or-opt and swap as well): new bests are rare, so the larger
    /// neighbourhood is affordable there.
    fn offer(&mut self, p: &Problem<W>, route: &Route<W>, e: RouteEval) -> bool {
        if p.better(&e, &self.best_eval) {
            let (mut r, mut e) = (*route, e);
            let deep_ok = self.settings.deep_polish_max_n >= p.n();
            let deep = deep_ok && !self.defer_deep;
            self.best_deep = deep || !deep_ok;
            let changed = self.polish_best(p, &mut r, &mut e, deep);
            if changed && p.better(&e, &self.cur_eval) {
                self.cur = r;
                self.cur_eval = e;
            }
            self.best = r;
            self.best_eval = e;
            return true;
        }
        false
    }

    /// The polish of a best route: the local search (deep or cheap), then
    /// rerouting; returns whether the route changed.
    fn polish_best(&mut self, p: &Problem<W>, r: &mut Route<W>, e: &mut RouteEval, deep: bool) -> bool {
        let changed = if deep {
            self.ls.improve_deep(p, r, e, self.settings.polish_passes)
        } else {
            self.ls.improve(p, r, e, self.settings.polish_passes)
        };
        self.reroute_polish(p, r, e, deep) || changed
    }

    /// The deep polish of a best route that got only the cheap one when it
    /// was found: it runs once the route has stood `deep_after` kicks.
    fn deep_polish_best(&mut self, p: &Problem<W>) {
        self.best_deep = true;
        let (mut r, mut e) = (self.best, self.best_eval);
        let changed = self.polish_best(p, &mut r, &mut e, true);
        if changed && p.better(&e, &self.best_eval) {
            self.best = r;
            self.best_eval = e;
            if p.better(&e, &self.cur_eval) {
                self.cur = r;
                self.cur_eval = e;
            }
            self.stale = 0;
            self.ruin_cap = self.settings.ruin_min;
        }
    }

    /// Rebuilds `trial` after a ruin: shorten, refill (the removed nodes
    /// barred first, so the route changes), shorten, refill, polish; without
    /// the shortening where [`AutoSettings::dense_cost_shorten`] turns it off.
    fn recreate(&mut self, p: &Problem<W>, e: &mut RouteEval, barred: NodeSet<W>, rng: &mut PlannerRng) {
        let (noise, seg) = (self.settings.noise, self.settings.or_opt_segment);
        if self.shorten {
            self.moves.shorten(p, &mut self.trial, e, SHORTEN_ROUNDS, seg);
        }
        self.moves.fill(p, &mut self.trial, e, barred, noise, rng);
        self.moves.fill(p, &mut self.trial, e, NodeSet::EMPTY, noise, rng);
        if self.shorten && self.moves.shorten(p, &mut self.trial, e, SHORTEN_ROUNDS, seg) {
            self.moves.fill(p, &mut self.trial, e, NodeSet::EMPTY, 0.0, rng);
        }
        if self.first_polish && self.restarts < self.settings.young_restarts {
            self.ls
                .improve_first(p, &mut self.trial, e, self.settings.polish_passes);
        } else {
            self.ls.improve(p, &mut self.trial, e, self.settings.polish_passes);
        }
        let mut trial = self.trial;
        self.reroute_polish(p, &mut trial, e, false);
        self.trial = trial;
    }

    /// Under objectives that value time, reroutes `route` and polishes
    /// again when that changed it (`deep`: with the deep neighbourhood).
    /// Returns whether the route changed.
    fn reroute_polish(&mut self, p: &Problem<W>, route: &mut Route<W>, e: &mut RouteEval, deep: bool) -> bool {
        if !self.reroute_polish || !self.moves.reroute(p, route, e, REROUTE_ROUNDS) {
            return false;
        }
        if deep {
            self.ls.improve_deep(p, route, e, self.settings.polish_passes);
        } else {
            self.ls.improve(p, route, e, self.settings.polish_passes);
        }
        true
    }

    /// One ruin-and-recreate kick of the iterated local search.
    fn kick(&mut self, p: &Problem<W>, rng: &mut PlannerRng) {
        let len = self.cur.len();
        self.trial = self.cur;
        let mut e = self.cur_eval;
        let interior = len.saturating_sub(2);
        // Short routes (paper_cost favours few long edges) may lose their
        // whole interior: a cap of half the route would never leave them.
        let cap = self.ruin_cap.min(interior).max(1);
        let size = 1 + rng.below(cap as u32) as usize;
        let shape = match rng.below(3) {
            0 => Ruin::Segment,
            1 => Ruin::Random,
            _ => Ruin::Cluster,
        };
        // A route that spends nearly all of its budget can only change at a
        // constant size, and a ruin needs an edge across every gap it
        // makes: under paper_cost some kicks reroute instead.
        let mut barred = NodeSet::EMPTY;
        if self.rerouting && rng.below(self.reroute_every) == 0 {
            barred = self.moves.reroute_kick(p, &mut self.trial, &mut e, rng);
        }
        if barred.is_empty() {
            barred = self.moves.ruin(p, &mut self.trial, &mut e, shape, size, rng);
        }
        self.recreate(p, &mut e, barred, rng);
        // Record-to-record travel: take the trial when within `accept` of
        // the best score, so the search can cross shallow valleys.
        let floor = p.score(&self.best_eval) - self.settings.accept * p.score(&self.best_eval).abs();
        if e.feasible && p.score(&e) >= floor {
            self.cur = self.trial;
            self.cur_eval = e;
        }
        let trial = self.trial;
        if self.offer(p, &trial, e) {
            self.stale = 0;
            self.ruin_cap = self.settings.ruin_min;
        } else {
            self.stale += 1;
            if !self.best_deep && self.stale >= self.settings.deep_after {
                self.deep_polish_best(p);
            }
            if self.stale.is_multiple_of(self.settings.grow_every.max(1)) {
                self.ruin_cap = (self.ruin_cap + 1).min(self.ruin_top);
            }
            if self.stale >= self.settings.restart_after {
                self.stale = 0;
                self.cur = self.best;
                self.cur_eval = self.best_eval;
                self.restarts += 1;
                // Every `fresh_every`-th restart builds afresh from the
                // shortest leg (noisy greedy, polished): a different basin.
                if self.restarts.is_multiple_of(self.settings.fresh_every.max(1))
                    && let Some(r) = seed_leg(p)
                    && let Some(mut e) = p.evaluate(&r)
                {
                    self.trial = r;
                    self.recreate(p, &mut e, NodeSet::EMPTY, rng);
                    if e.feasible {
                        self.cur = self.trial;
                        self.cur_eval = e;
                        let trial = self.trial;
                        self.offer(p, &trial, e);
                    }
                }
            }
        }
    }

    /// The constructive start: greedy insertion by value per second from
    /// the shortest leg, shortened and refilled, polished.
    fn construct(&mut self, p: &Problem<W>, rng: &mut PlannerRng) {
        let Some(r) = seed_leg(p) else {
            return;
        };
        let Some(mut e) = p.evaluate(&r) else {
            return;
        };
        self.trial = r;
        self.recreate(p, &mut e, NodeSet::EMPTY, rng);
        if p.better(&e, &self.best_eval) {
            self.best = self.trial;
            self.best_eval = e;
        }
    }
}

/// Where a fresh build starts: the bare start → goal edge, or, on a network
/// without one (sparse charts often have none), the quickest path to the goal.
fn seed_leg<const W: usize>(p: &Problem<W>) -> Option<Route<W>> {
    if p.has_edge(p.start(), p.goal()) {
        Route::from_slice(&[p.start(), p.goal()])
    } else {
        p.quickest_route()
    }
}

/// The low-risk search's candidate graph: each node's 16 lowest-risk
/// edges. With the idle bound a complete search over 16 took about as many
/// expansions as over 8 on the 40- and 64-node training networks (64:
/// 278 000 against 316 000 on one, 471 000 against 654 000 on another) and
/// found better routes on half of the 64-node ones; starting at 16 rather
/// than widening 8 → 12 → 16 left no gap at 20 ms there (8 first: mean
/// 2.9–3.1 %, worst 12 %).
const RISK_CANDIDATES: usize = risk_search::CANDIDATES;

/// Rounds of [`Moves::shorten`] per call, at most (a bound on a step's
/// work; a route that needs more keeps shortening in the next kick).
const SHORTEN_ROUNDS: u32 = 8;

/// Rounds of [`Moves::reroute`] per polish, at most (the same bound).
const REROUTE_ROUNDS: u32 = 8;

/// Largest edge density (edges over node pairs) at which `auto` polishes
/// by rerouting (one reroute round costs about route length × degree²
/// evaluations) and every other kick reroutes. On the sparse Bay of Islands
/// networks (density 0.35–0.47), where a ruin often finds no edge across
/// its gap, that is what reaches the proved optima. On the dense Benoit's
/// Cove ones (about 0.9) ruins close their gaps anyway; there polishing
/// every kick cut the kicks per solve by 5–10×, polishing new bests only
/// doubled `bc40-pc`'s mean gap at 1000 ms (7 % → 14–16 %), and one
/// reroute kick in four without the polish did best (mean gap 53 → 39 %,
/// 22 → 14 %, 7.1 → 3.3 % at 20, 100, 1000 ms). 0.75: between the two (the
/// small random networks of the quality regression test, edge probability
/// 0.6 plus a connecting path, count as sparse). Above it the recreate step
/// of those objectives does not shorten either
/// ([`AutoSettings::dense_cost_shorten`]).
const REROUTE_MAX_DENSITY: f64 = 0.75;

impl<const W: usize> Default for Auto<W> {
    fn default() -> Self {
        Self::new(AutoSettings::default())
    }
}

impl<const W: usize> Solver<W> for Auto<W> {
    fn name(&self) -> &'static str {
        "auto"
    }

    fn start(&mut self, problem: &Problem<W>, rng: &mut PlannerRng, warm: Option<&Route<W>>) {
        // No polishing here: `start` stays as cheap as the swarm's start.
        self.pso.start(problem, rng, warm);
        let (r, e) = self.pso.best();
        self.best = *r;
        self.best_eval = *e;
        self.cur = *r;
        self.cur_eval = *e;
        self.polished_from = super::WORST;
        self.stale = 0;
        self.steps = 0;
        self.restarts = 0;
        self.moves.set_objective(problem);
        let degrees: u32 = (0..problem.n()).map(|u| problem.neighbours(u).len()).sum();
        let pairs = (problem.n() * problem.n().saturating_sub(1)).max(1) as f64;
        let sparse = degrees as f64 <= REROUTE_MAX_DENSITY * pairs;
        let values_time = Value::of(problem).values_time();
        self.rerouting = self.settings.reroute && values_time;
        self.reroute_polish = self.rerouting && sparse;
        self.reroute_every = if sparse { 2 } else { 4 };
        self.shorten = sparse || !values_time || self.settings.dense_cost_shorten;
        self.ruin_cap = self.settings.ruin_min;
        let per = self.settings.ruin_nodes_per_waypoints;
        let scaled = if per > 0 && !sparse && prizes_only(problem) {
            problem.n() / per
        } else {
            0
        };
        self.ruin_top = self.settings.ruin_max.max(scaled).max(2);
        self.best_deep = true;
        // On sparse networks the cheap polish is cheap already (few common
        // neighbours), and first improvement only cost quality there.
        self.first_polish = problem.n() > self.settings.first_above && !sparse;
        self.defer_deep = self.settings.deep_after > 0 && !values_time;
        self.risk_searching = self.settings.risk_search > 0 && values_time;
        if self.risk_searching {
            self.risk.start(problem, RISK_CANDIDATES);
        }
        self.beam_width = if sparse {
            self.settings.beam_width
        } else {
            self.settings.dense_beam_width
        };
        // On dense networks a warm start (a re-plan from the previous plan)
        // runs no beams: each hand-over replaced the warm route, and the
        // default mission's warm-started re-plans of 150 steps lost weight.
        let cold_or_sparse = sparse || warm.is_none();
        self.beaming = self.beam_width > 0 && self.settings.beam_rounds > 0 && !values_time && cold_or_sparse;
        self.beams_started = 0;
    }

    fn step(&mut self, problem: &Problem<W>, rng: &mut PlannerRng) -> bool {
        self.steps += 1;
        // The constructive start runs in the first step, so `start` stays as
        // cheap as the swarm's.
        if self.steps == 1 {
            self.construct(problem, rng);
            if problem.better(&self.best_eval, &self.cur_eval) {
                self.cur = self.best;
                self.cur_eval = self.best_eval;
            }
            if self.beaming {
                self.start_beam(problem);
            }
        }
        if self.settings.swarm_every > 0 && self.steps.is_multiple_of(self.settings.swarm_every) {
            self.swarm_step(problem, rng);
        }
        if self.risk_searching {
            self.risk_search_step(problem);
        }
        if self.beaming {
            self.beam_step(problem);
        }
        if self.best_eval.feasible {
            for _ in 0..self.settings.kicks {
                self.kick(problem, rng);
            }
            if problem.better(&self.best_eval, self.pso.best().1) {
                let (b, be) = (self.best, self.best_eval);
                self.pso.adopt(&b, be);
                self.polished_from = be;
            }
        }
        true
    }

    fn best(&self) -> (&Route<W>, &RouteEval) {
        (&self.best, &self.best_eval)
    }
}

/// Whether every edge's weight is 0, so a route collects only the
/// waypoints' prizes (the orienteering problem, e.g. the OPLib files).
fn prizes_only<const W: usize>(p: &Problem<W>) -> bool {
    (0..p.n()).all(|u| p.neighbours(u).iter().all(|v| p.edge_weight(u, v) == 0.0))
}

impl<const W: usize> Auto<W> {
    /// One quantum of the low-risk search; a route it finds that beats the
    /// best is offered (and polished on the whole network), and the
    /// iterated local search moves there.
    fn risk_search_step(&mut self, problem: &Problem<W>) {
        if self.risk.is_done() {
            return;
        }
        let best_cost = if self.best_eval.feasible {
            self.best_eval.cost(problem.objective(), problem.budget_s())
        } else {
            f64::INFINITY
        };
        let Some(route) = self.risk.run(problem, best_cost, self.settings.risk_search).copied() else {
            return;
        };
        if let Some(e) = problem.evaluate(&route)
            && self.offer(problem, &route, e)
        {
            self.cur = self.best;
            self.cur_eval = self.best_eval;
            self.stale = 0;
            self.ruin_cap = self.settings.ruin_min;
        }
    }

    /// Starts the next beam, its time priced from the best route so far.
    fn start_beam(&mut self, problem: &Problem<W>) {
        let factors = &self.settings.beam_price_factors;
        let factor = factors[self.beams_started % factors.len()];
        let weight = if self.best_eval.feasible {
            self.best_eval.weight
        } else {
            0.0
        };
        let price = factor * weight / problem.budget_limit_s();
        self.beam.start(problem, self.beam_width, price);
        self.beams_started += 1;
    }

    /// One level of the beam search; once a beam ends, its route, polished,
    /// becomes the iterated local search's current route (a new basin,
    /// worse or not), is offered as a best, and the next beam starts.
    fn beam_step(&mut self, problem: &Problem<W>) {
        if self.beam.is_done() {
            if self.beams_started < self.settings.beam_rounds {
                self.start_beam(problem);
            }
            return;
        }
        let Some(mut route) = self.beam.step(problem).copied() else {
            return;
        };
        let Some(mut e) = problem.evaluate(&route) else {
            return;
        };
        self.ls
            .improve_deep(problem, &mut route, &mut e, self.settings.polish_passes);
        if e.feasible {
            self.cur = route;
            self.cur_eval = e;
            self.stale = 0;
            if self.offer(problem, &route, e) {
                self.ruin_cap = self.settings.ruin_min;
            }
        }
    }

    /// One generation of the swarm; its best, when it improved, is
    /// polished, offered and written back.
    fn swarm_step(&mut self, problem: &Problem<W>, rng: &mut PlannerRng) {
        self.pso.step(problem, rng);
        let (r, e) = self.pso.best();
        let (r, e) = (*r, *e);
        if problem.better(&e, &self.polished_from) {
            let (mut cand, mut ce) = (r, e);
            self.ls
                .improve(problem, &mut cand, &mut ce, self.settings.polish_passes);
            if problem.better(&ce, &e) {
                self.pso.adopt(&cand, ce);
            }
            self.polished_from = ce;
            if self.offer(problem, &cand, ce) && problem.better(&ce, &self.cur_eval) {
                self.cur = cand;
                self.cur_eval = ce;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::fixtures::random_instance;
    use crate::solver::pso::warm_vector;
    use crate::solver::{Budget, run};

    // The default capacity class unless a test names another.
    type Problem = crate::problem::Problem;
    type Route = crate::route::Route;
    type Decoder = crate::decode::Decoder;
    type Auto = crate::solver::auto::Auto;

    #[test]
    fn polished_routes_decode_back_to_themselves() {
        // The Lamarckian write-back relies on decode(encode(r)) == r.
        let mut dec = Decoder::new();
        let mut checked = 0;
        for seed in 0..12 {
            let inst = random_instance(40, 0.4, 31_000.0, seed);
            let p = Problem::from_instance(&inst).unwrap();
            let mut s = Auto::default();
            run(&mut s, &p, &mut PlannerRng::new(seed), None, Budget::iterations(5));
            let (r, e) = s.best();
            if !e.feasible {
                continue;
            }
            let mut v = [0.0f64; MAX_NODES];
            warm_vector(r, p.n(), &mut v);
            let mut out = Route::new();
            let de = dec.decode(&p, &v[..p.n()], &mut out);
            assert_eq!(out.to_vec(), r.to_vec(), "seed {seed}");
            assert_eq!(de.weight, e.weight);
            checked += 1;
        }
        assert!(checked >= 6);
    }

    #[test]
    fn the_low_risk_search_hands_its_routes_to_the_best_on_paper_cost() {
        use crate::instance::Objective;
        use crate::solver::risk_search::RiskSearch;
        // Dense networks, and sparse ones with a small φ1, where the best
        // route is a short low-risk path.
        let shapes = [(24, 0.95, 0.01), (40, 0.3, 0.001)];
        let mut found = 0;
        for (seed, (n, density, phi1)) in (0..8).zip(shapes.into_iter().cycle()) {
            let mut inst = random_instance(n, density, 31_000.0, seed);
            inst.objective = Objective::PaperCost { phi1, phi2: 1.0 };
            let p = Problem::from_instance(&inst).unwrap();
            let mut alone = RiskSearch::new();
            alone.start(&p, 8);
            let mut searched = Route::new();
            while !alone.is_done() {
                if let Some(r) = alone.run(&p, f64::INFINITY, 4096) {
                    searched = *r;
                }
            }
            let Some(searched) = p.evaluate(&searched) else {
                continue;
            };
            found += 1;
            // Enough steps for the search to finish: auto ends at least as
            // good as the search's best (polish only improves it).
            let mut s = Auto::default();
            run(&mut s, &p, &mut PlannerRng::new(seed), None, Budget::iterations(200));
            let (_, e) = s.best();
            assert!(
                !p.better(&searched, e),
                "seed {seed}: auto {} vs search {}",
                e.cost(inst.objective, p.budget_s()),
                searched.cost(inst.objective, p.budget_s())
            );
        }
        assert!(found >= 6, "the search found routes on {found} of 8 networks");
    }

    /// The route of `settings` after 30 steps on `inst`.
    fn route_of(inst: &crate::instance::Instance, settings: AutoSettings) -> Vec<usize> {
        let p = Problem::from_instance(inst).unwrap();
        let mut s = Auto::new(settings);
        run(&mut s, &p, &mut PlannerRng::new(7), None, Budget::iterations(30));
        s.best().0.to_vec()
    }

    #[test]
    fn dense_cost_shorten_acts_on_dense_paper_cost_only() {
        use crate::instance::Objective;
        // Without the low-risk search, whose routes would hide the setting.
        let off = AutoSettings {
            risk_search: 0,
            ..AutoSettings::default()
        };
        let on = AutoSettings {
            dense_cost_shorten: true,
            ..off
        };
        let cost = Objective::PaperCost { phi1: 0.01, phi2: 1.0 };
        let mut differed = 0;
        for seed in 0..4 {
            // Dense max_weight and sparse paper_cost: the same routes either way.
            let dense = random_instance(30, 0.95, 31_000.0, seed);
            assert_eq!(route_of(&dense, on), route_of(&dense, off), "seed {seed}");
            let mut sparse = random_instance(30, 0.4, 31_000.0, seed);
            sparse.objective = cost;
            assert_eq!(route_of(&sparse, on), route_of(&sparse, off), "seed {seed}");
            let mut dense_cost = dense;
            dense_cost.objective = cost;
            differed += usize::from(route_of(&dense_cost, on) != route_of(&dense_cost, off));
        }
        // Dense paper_cost: the setting is live there.
        assert!(differed > 0);
    }

    #[test]
    fn the_ruin_cap_grows_with_the_network_only_on_dense_prize_only_ones() {
        let mut rng = PlannerRng::new(1);
        let mut s = Auto::default();
        let per = AutoSettings::default().ruin_nodes_per_waypoints;
        let ruin_max = AutoSettings::default().ruin_max;
        let prizes_only = |mut inst: crate::instance::Instance| {
            for e in &mut inst.edges {
                e.priority = 0.0;
            }
            for (k, node) in inst.nodes.iter_mut().enumerate() {
                node.prize = 1.0 + (k % 7) as f64;
            }
            inst
        };
        for n in [40, 80, 120] {
            let tasks = random_instance(n, 0.95, 31_000.0, 3);
            let sparse = prizes_only(random_instance(n, 0.3, 31_000.0, 3));
            let op = prizes_only(tasks.clone());
            for (inst, top) in [(tasks, ruin_max), (sparse, ruin_max), (op, ruin_max.max(n / per))] {
                let p = Problem::from_instance(&inst).unwrap();
                s.start(&p, &mut rng, None);
                assert_eq!(s.ruin_top, top, "n {n}");
            }
        }
    }

    #[test]
    fn beams_run_under_max_weight_except_in_dense_warm_started_solves() {
        use crate::instance::Objective;
        let mut rng = PlannerRng::new(1);
        let mut s = Auto::default();
        for seed in 0..3 {
            let dense = random_instance(30, 0.95, 31_000.0, seed);
            let sparse = random_instance(30, 0.4, 31_000.0, seed);
            for (inst, is_dense) in [(dense, true), (sparse, false)] {
                let p = Problem::from_instance(&inst).unwrap();
                run(&mut s, &p, &mut rng, None, Budget::iterations(5));
                let warm = *s.best().0;
                s.start(&p, &mut rng, None);
                assert!(s.beaming, "seed {seed}, cold");
                s.start(&p, &mut rng, Some(&warm));
                assert_eq!(s.beaming, !is_dense, "seed {seed}, warm");
                let mut cost = inst;
                cost.objective = Objective::PaperCost { phi1: 0.01, phi2: 1.0 };
                let p = Problem::from_instance(&cost).unwrap();
                s.start(&p, &mut rng, None);
                assert!(!s.beaming, "seed {seed}: paper_cost values time");
            }
        }
    }
}
