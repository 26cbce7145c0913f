//! Small instances for tests, benches and examples: a hand-checkable line
//! and seeded random networks (not the paper's scenario model, which lives in
//! the scenario generator).

use crate::instance::{Edge, Instance, Node, Objective};
use crate::rng::PlannerRng;

/// 0 - 1 - 2 - 3 in a line 100 m apart plus a shortcut 0 - 3; speed 1 m/s,
/// task time 10 s, risk 0.5, budget 1000 s.
pub fn line_instance() -> Instance {
    // 0 - 1 - 2 - 3 in a line 100 m apart, plus a shortcut 0 - 3.
    let nodes = (0..4)
        .map(|i| Node {
            x: 100.0 * i as f64,
            y: 0.0,
            z: 0.0,
            prize: 0.0,
        })
        .collect();
    let e = |a, b, p| Edge {
        a,
        b,
        priority: p,
        risk: 0.5,
        task_time_s: 10.0,
    };
    Instance {
        name: "line".into(),
        speed_mps: 1.0,
        time_available_s: 1000.0,
        start: 0,
        goal: 3,
        nodes,
        edges: vec![e(0, 1, 2.0), e(1, 2, 3.0), e(2, 3, 4.0), e(0, 3, 1.0)],
        objective: Objective::MaxWeight,
    }
}

/// A random instance: `n` nodes in a 10 km square, each pair an edge with
/// probability `density`.
pub fn random_instance(n: usize, density: f64, budget: f64, seed: u64) -> Instance {
    let mut rng = PlannerRng::new(seed);
    let nodes = (0..n)
        .map(|_| Node {
            x: rng.uniform(0.0, 10_000.0),
            y: rng.uniform(0.0, 10_000.0),
            z: rng.uniform(0.0, 1000.0),
            prize: 0.0,
        })
        .collect();
    let mut edges = Vec::new();
    for a in 0..n {
        for b in a + 1..n {
            if rng.next_f64() < density {
                edges.push(Edge {
                    a,
                    b,
                    priority: rng.uniform(1.0, 10.0),
                    risk: rng.uniform(0.1, 1.0),
                    task_time_s: rng.uniform(120.0, 900.0),
                });
            }
        }
    }
    Instance {
        name: format!("random-{seed}"),
        speed_mps: 1.5,
        time_available_s: budget,
        start: 0,
        goal: n - 1,
        nodes,
        edges,
        objective: Objective::MaxWeight,
    }
}
