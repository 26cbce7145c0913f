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
//! How it is fast (issue 2 §7): each priority is packed once per decode into
//! a positive `f64` *key* whose order is the priority order and whose lowest
//! 7 bits hold the node id (see [`pack_key`]). Choosing the next node is then
//! a single branch-free max over `key where reach ≤ slack else 0` across the
//! padded row — a loop the compiler vectorises — and the winner's id is read
//! back from its bits. Visited nodes get key 0. The loop is compiled three
//! times (AVX-512, AVX2, baseline) and picked at run time; all three compute
//! exactly the same max, so routes do not depend on the machine.

use crate::problem::{MAX_NODES, NodeSet, Problem};
use crate::route::{Route, RouteEval};

/// Lower end of the paper's priority range.
pub const PRIORITY_MIN: f64 = -200.0;
/// Upper end of the paper's priority range.
pub const PRIORITY_MAX: f64 = 100.0;

/// Width of one step of the candidate scan, in nodes. Rows are scanned in
/// whole blocks of this many (two AVX-512 vectors, so two independent max
/// chains hide the latency); columns ≥ n read +∞ reach and key 0.
pub const SCAN_BLOCK: usize = 16;

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
    let p = if p.is_nan() { f64::NEG_INFINITY } else { p };
    let b = p.to_bits();
    // The classic monotone map of IEEE bits onto unsigned integers.
    let mono = if (b as i64) < 0 { !b } else { b | (1 << 63) };
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
fn best_key(reach: &[f64; MAX_NODES], key: &[f64; MAX_NODES], slack: f64, len: usize) -> f64 {
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

    /// Every kernel this CPU runs (for tests that hold them equal).
    pub fn available() -> impl Iterator<Item = Self> {
        let best = Self::detect();
        [Self::Portable, Self::Avx2, Self::Avx512]
            .into_iter()
            .filter(move |k| *k as u8 <= best as u8)
    }
}

/// Scratch space for decoding; build once, reuse for every decode.
pub struct Decoder {
    key: [f64; MAX_NODES],
    prefix_time_s: [f64; MAX_NODES],
    /// Repair's reverse search (see [`Decoder::repair`]).
    open: [f64; MAX_NODES],
    done: [f64; MAX_NODES],
    succ: [u64; MAX_NODES],
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
            prefix_time_s: [0.0; MAX_NODES],
            open: [0.0; MAX_NODES],
            done: [0.0; MAX_NODES],
            succ: [0; MAX_NODES],
        }
    }

    /// Decodes `priorities` (at least `p.n()` values) into `out` and returns
    /// the route's figures.
    #[inline]
    pub fn decode(&mut self, p: &Problem, priorities: &[f64], out: &mut Route) -> RouteEval {
        self.decode_with(Kernel::detect(), p, priorities, out)
    }

    /// [`Decoder::decode`] on a chosen kernel; a kernel this CPU lacks falls
    /// back to the portable one. Every kernel gives the same route.
    pub fn decode_with(&mut self, kernel: Kernel, p: &Problem, priorities: &[f64], out: &mut Route) -> RouteEval {
        let n = p.n();
        for (c, (k, &pr)) in self.key[..n].iter_mut().zip(&priorities[..n]).enumerate() {
            *k = pack_key(pr, c);
        }
        self.key[n..padded_len(n)].fill(0.0);
        #[cfg(target_arch = "x86_64")]
        {
            let best = Kernel::detect();
            if kernel == Kernel::Avx512 && best == Kernel::Avx512 {
                // SAFETY: the CPU has AVX-512F (checked just above).
                return unsafe { self.walk_avx512(p, out) };
            }
            if kernel != Kernel::Portable && best as u8 >= Kernel::Avx2 as u8 {
                // SAFETY: the CPU has AVX2 (checked just above).
                return unsafe { self.walk_avx2(p, out) };
            }
        }
        let _ = kernel;
        self.walk(p, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn walk_avx512(&mut self, p: &Problem, out: &mut Route) -> RouteEval {
        self.walk(p, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn walk_avx2(&mut self, p: &Problem, out: &mut Route) -> RouteEval {
        self.walk(p, out)
    }

    /// The greedy walk over the keys in `self.key`.
    #[inline(always)]
    fn walk(&mut self, p: &Problem, out: &mut Route) -> RouteEval {
        let len = padded_len(p.n());
        let limit = p.budget_limit_s();
        let goal = p.goal();

        let mut cur = p.start();
        out.clear();
        out.push(cur);
        self.key[cur] = 0.0;
        let mut e = RouteEval {
            weight: p.prize(cur),
            ..RouteEval::default()
        };
        self.prefix_time_s[0] = 0.0;

        while cur != goal {
            let best = best_key(p.reach_row(cur), &self.key, limit - e.time_s, len);
            if best == 0.0 {
                return self.repair(p, out);
            }
            let next = key_id(best);
            let step = p.edge(cur, next);
            e.time_s += step.time_s;
            e.distance_m += step.distance_m;
            e.weight += step.gain;
            e.risk_ratio_sum += step.risk_ratio;
            e.tasks += 1;
            self.prefix_time_s[out.len()] = e.time_s;
            out.push(next);
            self.key[next] = 0.0;
            cur = next;
        }
        e.feasible = e.time_s <= limit;
        debug_assert_eq!(p.evaluate(out), Some(e));
        e
    }

    /// Cuts `out` back to the latest node r_k with a quickest path home
    /// (avoiding r_0..r_{k−1} and excluded nodes) that fits in the time
    /// left at r_k, and appends that path; if there is none, returns the
    /// quickest path from the start (over budget).
    ///
    /// One reverse Dijkstra from the goal serves every k: it runs on the
    /// graph without the route's nodes, settles only what the current
    /// slack can use, and, as k steps back, unblocks r_k and carries on
    /// with the larger slack. Unblocking r_k is consistent with the
    /// settled region whenever r_k's distance exceeds everything settled so
    /// far; otherwise the search restarts for the new graph (rare). Cost is
    /// about one bounded Dijkstra however far back the cut goes.
    #[inline(always)]
    fn repair(&mut self, p: &Problem, out: &mut Route) -> RouteEval {
        let limit = p.budget_limit_s();
        let len = padded_len(p.n());
        let mut blocked = p.excluded();
        for node in out.iter() {
            blocked.insert(node);
        }
        self.home_reset(p, blocked, len);
        let mut settled_to = f64::NEG_INFINITY;
        let mut cut = None;
        for k in (0..out.len()).rev() {
            let r = out.get(k);
            blocked.remove(r);
            if !self.home_unblock(p, r, settled_to, len) {
                self.home_reset(p, blocked, len);
            }
            let slack = limit - self.prefix_time_s[k];
            self.home_advance(p, slack, len);
            settled_to = slack;
            if self.done[r] <= slack {
                cut = Some(k);
                break;
            }
        }
        let k = match cut {
            Some(k) => k,
            None => {
                // Nothing fits: every node is unblocked now; finish the
                // search and take the quickest path from the start.
                self.home_advance(p, f64::INFINITY, len);
                0
            }
        };
        out.truncate(k + 1);
        let mut v = out.get(k);
        while v != p.goal() {
            v = self.succ[v] as usize;
            out.push(v);
        }
        p.evaluate(out).expect("repair builds a valid route by construction")
    }

    /// Fresh reverse search from the goal on the graph without `blocked`.
    /// `open[v]`: tentative time to the goal of an unsettled, unblocked node
    /// (+∞ until reached), NaN for settled or blocked nodes so every
    /// comparison skips them; `done[v]`: final time of settled nodes, +∞
    /// otherwise.
    #[inline(always)]
    fn home_reset(&mut self, p: &Problem, blocked: NodeSet, len: usize) {
        let n = p.n();
        for v in 0..len {
            self.open[v] = if v < n && !blocked.contains(v) {
                f64::INFINITY
            } else {
                f64::NAN
            };
        }
        self.done[..len].fill(f64::INFINITY);
        self.open[p.goal()] = 0.0;
    }

    /// Makes `r` available again. Returns `false` when its time home is
    /// within the settled region (`≤ settled_to`), where it could shorten
    /// settled times; the caller then restarts the search.
    #[inline(always)]
    fn home_unblock(&mut self, p: &Problem, r: usize, settled_to: f64, len: usize) -> bool {
        let row = &p.time_row(r)[..len];
        let done = &self.done[..len];
        let t = min_of(len, |v| row[v] + done[v]);
        if t <= settled_to {
            return false;
        }
        self.open[r] = t;
        if t < f64::INFINITY {
            self.succ[r] = first_where(len, |v| row[v] + done[v] == t) as u64;
        }
        true
    }

    /// Settles every node whose time home is at most `bound`.
    #[inline(always)]
    fn home_advance(&mut self, p: &Problem, bound: f64, len: usize) {
        loop {
            let open = &self.open;
            let m = min_of(len, |v| open[v]);
            // +∞: nothing left that can reach the goal.
            if !(m <= bound && m < f64::INFINITY) {
                return;
            }
            let u = first_where(len, |v| open[v] == m);
            self.done[u] = m;
            self.open[u] = f64::NAN;
            let row = &p.time_row(u)[..len];
            let (open, succ) = (&mut self.open[..len], &mut self.succ[..len]);
            for v in 0..len {
                let cand = m + row[v];
                let better = cand < open[v];
                open[v] = if better { cand } else { open[v] };
                succ[v] = if better { u as u64 } else { succ[v] };
            }
        }
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

/// First index in `0..len` where `pred` holds (the caller knows one does).
#[inline(always)]
fn first_where(len: usize, pred: impl Fn(usize) -> bool) -> usize {
    (0..len).find(|&v| pred(v)).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{line_instance, random_instance};
    use crate::instance::{Edge, Instance, Node, Objective};
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
