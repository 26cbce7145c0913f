//! A world from an explicit layout: waypoints whose positions, drift and
//! prizes someone wrote down (a mission file), optionally with more
//! waypoints and tasks drawn as in the paper's model.
//!
//! Contract: [`World::from_layout`] gives node ids in the mission format's
//! order: the layout's `head` (the start first, id 0), then the generated
//! waypoints (the dynamic ones first, then the static ones), then the goal
//! (id n − 1). Every random draw uses the same streams and sub-streams, by
//! node id and pair, as [`World::generate`]: a layout whose start and goal sit
//! where `generate` put them, with the paper's generated waypoints and drawn
//! tasks, is the same world bit for bit (tested below). The fingerprint
//! covers the configuration, the seed, the chart and every explicit position,
//! bound, σ, prize and task, so two different layouts never share one.

use super::{
    ConfigError, STREAM_BOUNDS, STREAM_POSITIONS, STREAM_TASKS, ScenarioConfig, Task, UniformRange, Vec3, World,
    WorldSet, draw_over_water, pair_index, scenario_fingerprint, sub_stream,
};
use crate::chart::WaterMap;
use auv_core::capacity::LARGEST_NODES;
use auv_core::rng::{PlannerRng, derive_seed};

use super::fingerprint::Fnv1a;

/// One waypoint written down explicitly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayoutNode {
    /// Its (nominal) position, m: x east, y north, z depth down.
    pub nominal: Vec3,
    /// Collected once on a visit, ≥ 0.
    pub prize: f64,
    /// A drifting waypoint: its per-axis bound (m) and drift σ (m).
    pub drift: Option<(Vec3, f64)>,
}

/// Waypoints drawn as in the paper's model.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GeneratedNodes {
    /// Dynamic ones (ids right after the head).
    pub dynamic: usize,
    /// Static ones (after the generated dynamic ones).
    pub fixed: usize,
    /// σ_b of a generated dynamic waypoint's bound |N(0, σ_b²)| per axis, m.
    pub bound_sigma_m: f64,
}

/// Tasks of the pairs no explicit task names.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TaskRule {
    /// Drawn uniformly per pair from these ranges (stream `STREAM_TASKS`).
    Draw {
        /// Priority ρ.
        priority: UniformRange,
        /// Risk ξ.
        risk: UniformRange,
        /// Task time δ, s.
        task_time_s: UniformRange,
    },
    /// Transit legs: priority 0, risk 1, task time 0.
    Transit,
}

/// Everything a mission file says about the network.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// Explicit waypoints before the generated ones; the start is `head[0]`.
    pub head: Vec<LayoutNode>,
    /// Generated waypoints.
    pub generated: GeneratedNodes,
    /// The goal (id n − 1).
    pub goal: LayoutNode,
    /// Tasks of the pairs not in `explicit_tasks`.
    pub tasks: TaskRule,
    /// Explicit tasks by node ids (a ≠ b, both < n).
    pub explicit_tasks: Vec<(usize, usize, Task)>,
}

impl Layout {
    /// Node count n.
    pub fn n(&self) -> usize {
        self.head.len() + self.generated.dynamic + self.generated.fixed + 1
    }
}

/// Why a layout could not become a world.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LayoutError {
    /// The configuration is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Not 2..=[`LARGEST_NODES`] waypoints, or no start.
    #[error("{0} waypoints: a mission needs a start and a goal and at most {LARGEST_NODES} waypoints")]
    NodeCount(usize),
    /// The chart's extent is not a positive finite size.
    #[error("chart extent {0} m × {1} m must be finite and > 0")]
    BadChartExtent(f64, f64),
    /// No water found for a generated waypoint.
    #[error("chart has too little water: no water found for generated waypoint {node} in {attempts} random draws")]
    NotEnoughWater {
        /// Its id.
        node: usize,
        /// Draws made.
        attempts: u32,
    },
    /// An explicit task on a pair that is not two distinct nodes of the network.
    #[error("explicit task on pair ({0}, {1}): not two distinct waypoints of the network")]
    BadPair(usize, usize),
}

impl World {
    /// Builds the world of `layout` with `config`'s vehicle, objective, depth
    /// range, drift σ default and attempt counts, drawing generated waypoints,
    /// drawn tasks and first positions from `seed` (see the module doc).
    /// `config.nodes` and `config.dynamic` are set from the layout.
    pub fn from_layout(
        config: &ScenarioConfig,
        seed: u64,
        layout: &Layout,
        map: &impl WaterMap,
    ) -> Result<Self, LayoutError> {
        let n = layout.n();
        if layout.head.is_empty() || !(2..=LARGEST_NODES).contains(&n) {
            return Err(LayoutError::NodeCount(n));
        }
        let (width_m, height_m) = (map.width_m(), map.height_m());
        if !(width_m.is_finite() && width_m > 0.0 && height_m.is_finite() && height_m > 0.0) {
            return Err(LayoutError::BadChartExtent(width_m, height_m));
        }
        let g = layout.generated;
        let first_generated = layout.head.len();
        let mut config = config.clone();
        config.nodes = n;
        let mut nominal = vec![Vec3::default(); n];
        let mut bound = vec![Vec3::default(); n];
        let mut sigma = vec![config.sigma_m; n];
        let mut prize = vec![0.0; n];
        let mut dynamic = WorldSet::EMPTY;
        for (i, node) in layout
            .head
            .iter()
            .enumerate()
            .chain(std::iter::once((n - 1, &layout.goal)))
        {
            nominal[i] = node.nominal;
            prize[i] = node.prize;
            if let Some((b, s)) = node.drift {
                dynamic.insert(i);
                bound[i] = b;
                sigma[i] = s;
            }
        }
        for k in 0..g.dynamic + g.fixed {
            let i = first_generated + k;
            let mut rng = sub_stream(seed, STREAM_POSITIONS, i as u64);
            nominal[i] = draw_over_water(&mut rng, map, &config).ok_or(LayoutError::NotEnoughWater {
                node: i,
                attempts: config.position_attempts,
            })?;
            if k < g.dynamic {
                dynamic.insert(i);
                let mut rng = sub_stream(seed, STREAM_BOUNDS, i as u64);
                let s = g.bound_sigma_m;
                bound[i] = Vec3 {
                    x: rng.normal(0.0, s).abs(),
                    y: rng.normal(0.0, s).abs(),
                    z: rng.normal(0.0, s).abs(),
                };
            }
        }
        config.dynamic = dynamic.len() as usize;
        if g.dynamic > 0 {
            config.bound_sigma_m = g.bound_sigma_m;
        }
        if let TaskRule::Draw {
            priority,
            risk,
            task_time_s,
        } = layout.tasks
        {
            config.priority = priority;
            config.risk = risk;
            config.task_time_s = task_time_s;
        }
        config.validate()?;

        let mut tasks = Vec::with_capacity(n * (n - 1) / 2);
        match layout.tasks {
            TaskRule::Draw {
                priority,
                risk,
                task_time_s,
            } => {
                let mut rng = PlannerRng::new(derive_seed(seed, STREAM_TASKS));
                for _ in 0..n * (n - 1) / 2 {
                    tasks.push(Task {
                        priority: rng.uniform(priority.lo, priority.hi),
                        risk: rng.uniform(risk.lo, risk.hi),
                        task_time_s: rng.uniform(task_time_s.lo, task_time_s.hi),
                    });
                }
            }
            TaskRule::Transit => tasks.resize(
                n * (n - 1) / 2,
                Task {
                    priority: 0.0,
                    risk: 1.0,
                    task_time_s: 0.0,
                },
            ),
        }
        for &(a, b, t) in &layout.explicit_tasks {
            if a == b || a >= n || b >= n {
                return Err(LayoutError::BadPair(a, b));
            }
            tasks[pair_index(a.min(b), a.max(b))] = t;
        }

        let mut h = Fnv1a::new();
        h.bytes(b"auv-layout-fingerprint/1")
            .u64(scenario_fingerprint(&config, seed, map));
        for i in 0..n {
            let (p, b) = (nominal[i], bound[i]);
            h.u64(u64::from(dynamic.contains(i)));
            h.f64(p.x)
                .f64(p.y)
                .f64(p.z)
                .f64(b.x)
                .f64(b.y)
                .f64(b.z)
                .f64(sigma[i])
                .f64(prize[i]);
        }
        for t in &tasks {
            h.f64(t.priority).f64(t.risk).f64(t.task_time_s);
        }

        let mut world = Self {
            fingerprint: h.finish(),
            config,
            seed,
            width_m,
            height_m,
            dynamic,
            position: nominal.clone(),
            nominal,
            bound,
            sigma,
            prize,
            tasks,
            adjacency: vec![WorldSet::EMPTY; n],
        };
        world.place_initially(map);
        Ok(world)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::synthetic::GridMap;

    /// The paper's generated world, rewritten as a layout with its start and
    /// goal copied: the same world, bit for bit.
    #[test]
    fn a_layout_of_the_generators_draws_is_the_generated_world() {
        let map = GridMap::cove();
        let config = ScenarioConfig {
            nodes: 20,
            dynamic: 5,
            ..ScenarioConfig::default()
        };
        let generated = World::generate(&config, 7, &map).unwrap();
        let endpoint = |i: usize| LayoutNode {
            nominal: generated.nominal_positions()[i],
            prize: 0.0,
            drift: None,
        };
        let layout = Layout {
            head: vec![endpoint(0)],
            generated: GeneratedNodes {
                dynamic: 5,
                fixed: 13,
                bound_sigma_m: config.bound_sigma_m,
            },
            goal: endpoint(19),
            tasks: TaskRule::Draw {
                priority: config.priority,
                risk: config.risk,
                task_time_s: config.task_time_s,
            },
            explicit_tasks: vec![],
        };
        let mut from_layout = World::from_layout(&config, 7, &layout, &map).unwrap();
        assert_eq!(from_layout.snapshot("x"), generated.snapshot("x"));
        assert_eq!(from_layout.bounds(), generated.bounds());
        assert_eq!(from_layout.dynamic_nodes(), generated.dynamic_nodes());
        // Redraws too.
        let mut g = generated.clone();
        g.redraw_dynamic(&mut g.redraw_rng(3), &map);
        from_layout.redraw_dynamic(&mut from_layout.redraw_rng(3), &map);
        assert_eq!(from_layout.snapshot("x"), g.snapshot("x"));
    }

    #[test]
    fn explicit_nodes_prizes_drift_and_tasks_are_kept() {
        let map = GridMap::cove();
        let node = |x: f64, y: f64| LayoutNode {
            nominal: Vec3 { x, y, z: 10.0 },
            prize: 0.0,
            drift: None,
        };
        let mut buoy = node(1000.0, 5000.0);
        buoy.prize = 4.5;
        buoy.drift = Some((
            Vec3 {
                x: 200.0,
                y: 100.0,
                z: 5.0,
            },
            40.0,
        ));
        let task = Task {
            priority: 7.0,
            risk: 0.5,
            task_time_s: 60.0,
        };
        let layout = Layout {
            head: vec![node(500.0, 500.0), buoy],
            generated: GeneratedNodes::default(),
            goal: node(800.0, 9000.0),
            tasks: TaskRule::Transit,
            explicit_tasks: vec![(1, 0, task)],
        };
        let config = ScenarioConfig::default();
        let world = World::from_layout(&config, 1, &layout, &map).unwrap();
        assert_eq!(world.n(), 3);
        assert!(world.is_dynamic(1) && !world.is_dynamic(0) && !world.is_dynamic(2));
        assert_eq!(world.prizes(), &[0.0, 4.5, 0.0]);
        assert_eq!(world.drift_sigmas_m()[1], 40.0);
        assert_eq!(world.task(0, 1), Some(task));
        let transit = world.task(1, 2).unwrap();
        assert_eq!((transit.priority, transit.risk, transit.task_time_s), (0.0, 1.0, 0.0));
        let p = world.positions()[1];
        assert!((p.x - 1000.0).abs() <= 200.0 && (p.y - 5000.0).abs() <= 100.0 && (p.z - 10.0).abs() <= 5.0);
        assert_eq!(world.snapshot("s").nodes[1].prize, 4.5);
        // Another prize is another world.
        let mut other = layout.clone();
        other.head[1].prize = 4.0;
        assert_ne!(
            World::from_layout(&config, 1, &other, &map).unwrap().fingerprint(),
            world.fingerprint()
        );
        let mut bad = layout;
        bad.explicit_tasks.push((2, 2, task));
        assert_eq!(
            World::from_layout(&config, 1, &bad, &map).unwrap_err(),
            LayoutError::BadPair(2, 2)
        );
    }
}
