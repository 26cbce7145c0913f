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

use crate::problem::{MAX_NODES, NodeSet, Problem};
use crate::route::{Route, RouteEval};

/// Lower end of the paper's priority range.
pub const PRIORITY_MIN: f64 = -200.0;
/// Upper end of the paper's priority range.
pub const PRIORITY_MAX: f64 = 100.0;

/// Scratch space for decoding; build once, reuse for every decode.
pub struct Decoder {
    visited: [bool; MAX_NODES],
    prefix_time_s: [f64; MAX_NODES],
    dist: [f64; MAX_NODES],
    prev: [u8; MAX_NODES],
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
            visited: [false; MAX_NODES],
            prefix_time_s: [0.0; MAX_NODES],
            dist: [0.0; MAX_NODES],
            prev: [0; MAX_NODES],
            path: [0; MAX_NODES],
        }
    }

    /// Decodes `priorities` (at least `p.n()` values) into `out` and returns
    /// the route's figures.
    pub fn decode(&mut self, p: &Problem, priorities: &[f64], out: &mut Route) -> RouteEval {
        let n = p.n();
        let prio = &priorities[..n];
        let limit = p.budget_limit_s();
        let goal = p.goal();
        let visited = &mut self.visited[..n];
        visited.fill(false);

        let mut cur = p.start();
        out.clear();
        out.push(cur);
        visited[cur] = true;
        let mut e = RouteEval {
            weight: p.prize(cur),
            ..RouteEval::default()
        };
        self.prefix_time_s[0] = 0.0;

        while cur != goal {
            let slack = limit - e.time_s;
            let row = &p.reach_row(cur)[..n];
            let mut best = usize::MAX;
            let mut best_key = f64::NEG_INFINITY;
            // Branch-free select, then a running max: the compiler keeps the
            // loop body free of unpredictable branches on the candidate test.
            for c in 0..n {
                let ok = (row[c] <= slack) & !visited[c];
                let key = if ok { prio[c] } else { f64::NEG_INFINITY };
                let take = key > best_key;
                best_key = if take { key } else { best_key };
                best = if take { c } else { best };
            }
            if best == usize::MAX {
                // No candidate has a finite priority above −∞, or none fits:
                // pick any fitting candidate before declaring a dead end.
                best = (0..n).find(|&c| row[c] <= slack && !visited[c]).unwrap_or(usize::MAX);
                if best == usize::MAX {
                    return self.repair(p, out);
                }
            }
            e.time_s += p.time_s(cur, best);
            e.distance_m += p.distance_m(cur, best);
            e.weight += p.gain(cur, best);
            e.risk_ratio_sum += p.risk_ratio(cur, best);
            e.tasks += 1;
            self.prefix_time_s[out.len()] = e.time_s;
            out.push(best);
            visited[best] = true;
            cur = best;
        }
        e.feasible = e.time_s <= limit;
        debug_assert_eq!(p.evaluate(out), Some(e));
        e
    }

    /// Cuts `out` back to the latest node with a quickest path home that
    /// fits, and appends that path.
    fn repair(&mut self, p: &Problem, out: &mut Route) -> RouteEval {
        let limit = p.budget_limit_s();
        let mut keep = None;
        // The path home from r[k] may not touch r[0..k] or excluded nodes.
        for k in (0..out.len()).rev() {
            let mut blocked = p.excluded();
            for i in 0..k {
                blocked.insert(out.get(i));
            }
            if let Some(len) = self.quickest_path(p, out.get(k), blocked, limit - self.prefix_time_s[k]) {
                keep = Some((k, len));
                break;
            }
        }
        let (k, len) = match keep {
            Some(found) => found,
            None => {
                // Nothing fits: the quickest path from the start, over budget.
                let len = self
                    .quickest_path(p, p.start(), p.excluded(), f64::INFINITY)
                    .expect("Problem::finish guarantees the goal is reachable from the start");
                (0, len)
            }
        };
        out.truncate(k + 1);
        for i in 1..len {
            out.push(self.path[i] as usize);
        }
        p.evaluate(out).expect("repair builds a valid route by construction")
    }

    /// Dijkstra from `from` to the goal avoiding `blocked`; on success the
    /// path (from `from` to the goal) is in `self.path[..len]` and `len` is
    /// returned, provided its time is at most `limit_s`.
    fn quickest_path(&mut self, p: &Problem, from: usize, blocked: NodeSet, limit_s: f64) -> Option<usize> {
        let n = p.n();
        let goal = p.goal();
        self.dist[..n].fill(f64::INFINITY);
        self.dist[from] = 0.0;
        let mut done = blocked;
        done.remove(from);
        loop {
            let mut u = usize::MAX;
            let mut best = f64::INFINITY;
            for v in 0..n {
                if !done.contains(v) && self.dist[v] < best {
                    best = self.dist[v];
                    u = v;
                }
            }
            if u == usize::MAX || best > limit_s {
                return None;
            }
            if u == goal {
                break;
            }
            done.insert(u);
            for v in p.neighbours(u).iter() {
                if done.contains(v) {
                    continue;
                }
                let cand = best + p.time_s(u, v);
                if cand < self.dist[v] {
                    self.dist[v] = cand;
                    self.prev[v] = u as u8;
                }
            }
        }
        // Walk back from the goal, then reverse into `path`.
        let mut len = 0;
        let mut v = goal;
        loop {
            self.path[len] = v as u8;
            len += 1;
            if v == from {
                break;
            }
            v = self.prev[v] as usize;
        }
        self.path[..len].reverse();
        Some(len)
    }
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
            let checked = p.evaluate(&r);
            prop_assert_eq!(checked, Some(e));
            let stats = crate::route::RouteStats::from_instance(&inst, &r.to_vec()).unwrap();
            prop_assert_eq!(stats.feasible, e.feasible);
            prop_assert_eq!(stats.time_s, e.time_s);
            let quickest_fits = p.to_goal_s(p.start()) <= p.budget_limit_s();
            prop_assert_eq!(e.feasible, quickest_fits);
        }
    }
}
