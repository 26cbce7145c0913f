//! The paper's waypoint network on a chart: a seeded generator of static and
//! dynamic waypoints, their tasks and the edges the coastline allows, kept
//! up to date as the dynamic waypoints move.
//!
//! # Contract
//! - [`World::generate`] builds the world from a [`ScenarioConfig`], a `u64`
//!   seed and any [`WaterMap`]; the same three give the same world, bit for
//!   bit. Generation, cloning and snapshots allocate; the per-update calls
//!   below do not.
//! - Every waypoint is over water (`WaterMap::is_water`), inside the chart
//!   (x ∈ [0, width], y ∈ [0, height]) and inside the depth range
//!   z ∈ [0, `depth_max_m`]; a dynamic waypoint also stays inside its bound:
//!   `nominal − bound ≤ actual ≤ nominal + bound` per axis, as computed by
//!   [`bound_interval`] (validators should use that function too).
//! - Waypoints `a`, `b` are joined by an edge exactly when
//!   `map.segment_over_water` holds for the 2-D projection of the segment
//!   (always asked lower id first). The edge matrix is cached; after a move
//!   only the pairs touching a moved waypoint are rechecked.
//! - Every node *pair* carries a task drawn once from the seed, so an edge that
//!   disappears and reappears keeps its task.
//! - [`World::redraw_dynamic`], [`World::apply_positions`] and
//!   [`World::fill_problem`] do not allocate (the re-planning service calls
//!   them on every sensor update; `planner/tests/scenario_alloc.rs` counts).
//! - [`World::snapshot`] writes an `auv-route-instance/1` [`Instance`];
//!   [`World::fill_problem`] gives the same [`Problem`] as
//!   `Problem::load_instance` on that snapshot, bit for bit.
//! - [`World::fingerprint`] is a stable FNV-1a hash of the configuration, the
//!   seed and the chart (its extent and a 128 × 128 water sample).
//!
//! # Defaults (the one place they are documented)
//! [`ScenarioConfig::default`] implements this table, field for field.
//!
//! | field | default | meaning | source |
//! | --- | --- | --- | --- |
//! | `nodes` | 40 | waypoints n; node 0 the start, node n−1 the goal; 2..=512 ([`auv_core::capacity::LARGEST_NODES`]; the Monte Carlo study takes up to 128) | the paper's model (network size) |
//! | `dynamic` | 10 | dynamic waypoints d ≤ n−2 | the paper's model |
//! | which nodes are dynamic | ids 1..=d | start and goal stay static; lowest ids so that changing n keeps them | our choice: the paper is silent |
//! | static position | x ~ U(0, width), y ~ U(0, height), resampled until over water; z ~ U(0, `depth_max_m`) | also a dynamic waypoint's nominal position | the paper's model |
//! | `depth_max_m` | 1000 m | depth range [0, 1000 m] | the paper's model |
//! | `bound_sigma_m` | 300 m | σ_b: each dynamic waypoint's bound per axis is \|N(0, σ_b²)\| | the paper's model |
//! | `sigma_m` | 150 m | σ: actual = nominal + N(0, σ²) per axis, truncated to the bound ∩ area ∩ depth range, (x, y) resampled while on land | the paper's model |
//! | `priority` | U[1, 10] | task priority ρ, per node pair | the paper's model |
//! | `risk` | U[0.1, 1.0] | task risk ξ, per node pair | the paper's model |
//! | `task_time_s` | U[120, 900] s | task completion time δ, per node pair | the paper's model |
//! | `speed_mps` | 1.5 m/s | vehicle speed v; edge time T = 3-D length / v + δ | the paper's model |
//! | `time_available_s` | 31 000 s | budget T_available | the paper's model |
//! | `objective` | `max_weight` | objective written into snapshots | instance format (its default) |
//! | `chart` | `benoits-cove` | embedded chart, 5 km × 10 km, 10 m/px | the project's chart set-up (5 km × 10 km Benoit's Cove, k = 3) |
//! | `k` | 3 | k-means clusters of the chart (2..=16) | the project's chart set-up (5 km × 10 km Benoit's Cove, k = 3) |
//! | `sensor_period_s` | 60 s | mission time between two redraws of the dynamic waypoints | our choice: the paper is silent (sensor-sim's period) |
//! | `position_attempts` | 100 000 | uniform draws per waypoint before "too little water" (fails on a chart with < ~0.02 % water) | our choice: the paper is silent |
//! | `redraw_attempts` | 1 000 | truncated-normal draws per dynamic waypoint and redraw before it falls back to its nominal position (always water); counted in [`RedrawReport::fallbacks`] | our choice: the paper is silent |
//!
//! # Random streams
//! Each concern draws from its own stream, `derive_seed(seed, STREAM_*)`, so
//! that changing one setting does not reshuffle the others:
//! - [`STREAM_POSITIONS`]: node i's nominal position from sub-stream
//!   `derive_seed(derive_seed(seed, STREAM_POSITIONS), i)`;
//! - [`STREAM_BOUNDS`]: node i's bound from its own sub-stream likewise;
//! - [`STREAM_TASKS`]: one stream over the pairs in the order
//!   (0,1), (0,2), (1,2), (0,3), (1,3), (2,3), …, each drawing ρ, ξ, δ — so
//!   the tasks of n nodes are a prefix of those of n+1;
//! - [`STREAM_INITIAL`]: node i's first actual position (generation time),
//!   its own sub-stream;
//! - [`STREAM_REDRAWS`]: later redraws; [`World::redraw_rng`]`(k)` is the
//!   generator of the k-th redraw (sensor update k, or Monte Carlo run k).
//!
//! Hence: changing `dynamic` changes neither the nominal positions nor the
//! tasks nor the other dynamic waypoints' bounds; changing `nodes` keeps the
//! positions of nodes below the old goal id and the tasks among them.

mod chase;
mod config;
mod fingerprint;
mod layout;
mod map;
pub mod synthetic;

pub use chase::{APPROACH_M, CHASE_TRIALS, STREAM_CHASE};
pub use config::{ChartSource, ConfigError, MAX_K, SCENARIO_FORMAT, ScenarioConfig, UniformRange};
pub use fingerprint::{CHART_SAMPLE_GRID, Fnv1a, fnv1a64, scenario_fingerprint};
pub use layout::{GeneratedNodes, Layout, LayoutError, LayoutNode, TaskRule};
pub use map::{EMBEDDED_CHART_NAME, LoadError, STREAM_CHART, ScenarioMap, chart_spec, load_map, load_world};

use crate::chart::WaterMap;
use crate::truncnorm::TruncatedNormal;
use auv_core::capacity::LARGEST_WORDS;
use auv_core::instance::{Edge, Instance, Node};
use auv_core::problem::{NodeSet, Problem, ProblemError, edge_time_s};
use auv_core::rng::{PlannerRng, derive_seed};

/// Stream of the nominal (and static) positions.
pub const STREAM_POSITIONS: u64 = 0x5CE7_0001;
/// Stream of the dynamic waypoints' bounds.
pub const STREAM_BOUNDS: u64 = 0x5CE7_0002;
/// Stream of the per-pair tasks.
pub const STREAM_TASKS: u64 = 0x5CE7_0003;
/// Stream of the dynamic waypoints' first actual positions.
pub const STREAM_INITIAL: u64 = 0x5CE7_0004;
/// Stream of later redraws of the dynamic waypoints.
pub const STREAM_REDRAWS: u64 = 0x5CE7_0005;

/// A point or a per-axis extent in the chart frame: x east, y north, z depth
/// (positive down), all in metres.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vec3 {
    /// East, m.
    pub x: f64,
    /// North, m.
    pub y: f64,
    /// Depth, m, positive down.
    pub z: f64,
}

/// The task on one node pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Task {
    /// Priority ρ.
    pub priority: f64,
    /// Risk ξ > 0.
    pub risk: f64,
    /// Completion time δ, s.
    pub task_time_s: f64,
}

/// Why a world could not be generated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ScenarioError {
    /// The configuration is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The chart's extent is not a positive finite size.
    #[error("chart extent {width_m} m × {height_m} m must be finite and > 0")]
    BadChartExtent {
        /// Width, m.
        width_m: f64,
        /// Height, m.
        height_m: f64,
    },
    /// No water found for a waypoint within the allowed attempts.
    #[error(
        "chart has too little water: no water found for waypoint {node} in {attempts} random draws \
         (position_attempts)"
    )]
    NotEnoughWater {
        /// The waypoint.
        node: usize,
        /// Draws made.
        attempts: u32,
    },
}

/// Why a set of reported positions was refused by [`World::apply_positions`]
/// (small and `Copy`: it sits on the service's hot path).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum PositionError {
    /// Not one position per node.
    #[error("expected {expected} positions, got {got}")]
    WrongCount {
        /// Node count.
        expected: usize,
        /// Positions given.
        got: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("waypoint {node}: non-finite coordinate")]
    NonFinite {
        /// The waypoint.
        node: usize,
    },
    /// A static waypoint is not at its fixed position.
    #[error("waypoint {node} is static but was reported away from its position")]
    StaticMoved {
        /// The waypoint.
        node: usize,
    },
    /// A dynamic waypoint outside its bound, the chart or the depth range.
    #[error("waypoint {node} is outside its bound on axis {axis}")]
    OutsideBound {
        /// The waypoint.
        node: usize,
        /// `'x'`, `'y'` or `'z'`.
        axis: char,
    },
    /// A dynamic waypoint over land.
    #[error("waypoint {node} is on land")]
    OnLand {
        /// The waypoint.
        node: usize,
    },
}

/// A set of the world's waypoints. A world holds up to
/// [`auv_core::capacity::LARGEST_NODES`] of them, so its sets are those of the
/// largest class; a planner fills a problem of its own class from it.
pub type WorldSet = NodeSet<LARGEST_WORDS>;

/// What a move of the dynamic waypoints changed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RedrawReport {
    /// Waypoints whose position changed.
    pub moved: WorldSet,
    /// Edges that appeared.
    pub edges_added: u32,
    /// Edges that disappeared.
    pub edges_removed: u32,
    /// Dynamic waypoints that found no water within `redraw_attempts` and
    /// were put at their nominal position.
    pub fallbacks: u32,
}

/// The interval a coordinate with nominal value `nominal` and bound `bound`
/// may take inside [0, `max`]: [max(nominal − bound, 0), min(nominal + bound, max)].
/// The one place this is computed, for the sampler and for validators alike.
#[inline]
pub fn bound_interval(nominal: f64, bound: f64, max: f64) -> (f64, f64) {
    ((nominal - bound).max(0.0), (nominal + bound).min(max))
}

/// Index of pair (a, b), a < b, in the task table (the draw order).
#[inline]
fn pair_index(a: usize, b: usize) -> usize {
    debug_assert!(a < b);
    b * (b - 1) / 2 + a
}

/// Generator of sub-stream `index` of `stream` under `seed`.
fn sub_stream(seed: u64, stream: u64, index: u64) -> PlannerRng {
    PlannerRng::new(derive_seed(derive_seed(seed, stream), index))
}

/// The live waypoint network.
#[derive(Clone, Debug)]
pub struct World {
    config: ScenarioConfig,
    seed: u64,
    fingerprint: u64,
    width_m: f64,
    height_m: f64,
    dynamic: WorldSet,
    nominal: Vec<Vec3>,
    bound: Vec<Vec3>,
    /// σ of each dynamic waypoint's drift per axis, m (the configuration's
    /// `sigma_m` unless a layout set its own).
    sigma: Vec<f64>,
    /// Prize collected on a visit, by node id (0 in the paper's model).
    prize: Vec<f64>,
    position: Vec<Vec3>,
    /// One task per pair, indexed by [`pair_index`].
    tasks: Vec<Task>,
    /// The edge cache: bit b of row a ⇔ edge a–b, one row per node.
    adjacency: Vec<WorldSet>,
}

impl World {
    /// Generates the world of `config` and `seed` on `map` (see the module
    /// doc for the model and the random streams).
    pub fn generate(config: &ScenarioConfig, seed: u64, map: &impl WaterMap) -> Result<Self, ScenarioError> {
        config.validate()?;
        let (width_m, height_m) = (map.width_m(), map.height_m());
        if !(width_m.is_finite() && width_m > 0.0 && height_m.is_finite() && height_m > 0.0) {
            return Err(ScenarioError::BadChartExtent { width_m, height_m });
        }
        let n = config.nodes;
        let mut nominal = Vec::with_capacity(n);
        for i in 0..n {
            let mut rng = sub_stream(seed, STREAM_POSITIONS, i as u64);
            nominal.push(
                draw_over_water(&mut rng, map, config).ok_or(ScenarioError::NotEnoughWater {
                    node: i,
                    attempts: config.position_attempts,
                })?,
            );
        }
        let mut dynamic = WorldSet::EMPTY;
        for i in 1..=config.dynamic {
            dynamic.insert(i);
        }
        let bound = (0..n)
            .map(|i| {
                if dynamic.contains(i) {
                    let mut rng = sub_stream(seed, STREAM_BOUNDS, i as u64);
                    let s = config.bound_sigma_m;
                    Vec3 {
                        x: rng.normal(0.0, s).abs(),
                        y: rng.normal(0.0, s).abs(),
                        z: rng.normal(0.0, s).abs(),
                    }
                } else {
                    Vec3::default()
                }
            })
            .collect();
        let mut rng = PlannerRng::new(derive_seed(seed, STREAM_TASKS));
        let mut tasks = Vec::with_capacity(n * (n - 1) / 2);
        for _b in 1..n {
            for _a in 0.._b {
                tasks.push(Task {
                    priority: rng.uniform(config.priority.lo, config.priority.hi),
                    risk: rng.uniform(config.risk.lo, config.risk.hi),
                    task_time_s: rng.uniform(config.task_time_s.lo, config.task_time_s.hi),
                });
            }
        }
        let mut world = Self {
            config: config.clone(),
            seed,
            fingerprint: scenario_fingerprint(config, seed, map),
            width_m,
            height_m,
            dynamic,
            position: nominal.clone(),
            nominal,
            bound,
            sigma: vec![config.sigma_m; n],
            prize: vec![0.0; n],
            tasks,
            adjacency: vec![WorldSet::EMPTY; n],
        };
        world.place_initially(map);
        Ok(world)
    }

    /// Draws every dynamic waypoint's initial position (epoch 0, from its
    /// own stream of the seed) and computes every edge: the last step of
    /// building a world, whoever laid it out.
    fn place_initially(&mut self, map: &impl WaterMap) {
        for i in self.dynamic.iter() {
            let mut rng = sub_stream(self.seed, STREAM_INITIAL, i as u64);
            // A fallback here is legal (nominal is water); nothing to report.
            self.position[i] = self.draw_dynamic(i, &mut rng, map).0;
        }
        self.update_edges(WorldSet::first(self.n()), map);
    }

    /// Redraws every dynamic waypoint around its nominal position (the
    /// truncated-normal model) and updates the edge cache for the pairs that
    /// touch one. Static waypoints never move. Does not allocate.
    pub fn redraw_dynamic(&mut self, rng: &mut PlannerRng, map: &impl WaterMap) -> RedrawReport {
        let mut report = RedrawReport::default();
        for i in self.dynamic.iter() {
            let (p, fell_back) = self.draw_dynamic(i, rng, map);
            report.fallbacks += u32::from(fell_back);
            if p != self.position[i] {
                self.position[i] = p;
                report.moved.insert(i);
            }
        }
        let (added, removed) = self.update_edges(report.moved, map);
        report.edges_added = added;
        report.edges_removed = removed;
        report
    }

    /// The generator of the `k`-th redraw of this world's dynamic waypoints
    /// (stream [`STREAM_REDRAWS`], sub-stream `k`).
    pub fn redraw_rng(&self, k: u64) -> PlannerRng {
        sub_stream(self.seed, STREAM_REDRAWS, k)
    }

    /// Moves the waypoints to reported `positions` (one per node, e.g. from a
    /// sensor snapshot) after checking every one of them: finite; a static
    /// waypoint exactly at its position; a dynamic one inside
    /// [`bound_interval`] on each axis and over water. Either all positions
    /// are applied or, on the first violation, none. Does not allocate.
    pub fn apply_positions(&mut self, positions: &[Vec3], map: &impl WaterMap) -> Result<RedrawReport, PositionError> {
        let n = self.n();
        if positions.len() != n {
            return Err(PositionError::WrongCount {
                expected: n,
                got: positions.len(),
            });
        }
        for (i, p) in positions.iter().enumerate() {
            self.check_position(i, *p, map)?;
        }
        let mut report = RedrawReport::default();
        for (i, p) in positions.iter().enumerate() {
            if *p != self.position[i] {
                self.position[i] = *p;
                report.moved.insert(i);
            }
        }
        let (added, removed) = self.update_edges(report.moved, map);
        report.edges_added = added;
        report.edges_removed = removed;
        Ok(report)
    }

    /// Whether `p` is a legal position of waypoint `i` (see
    /// [`World::apply_positions`]). `i` must be < n.
    pub fn check_position(&self, i: usize, p: Vec3, map: &impl WaterMap) -> Result<(), PositionError> {
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            return Err(PositionError::NonFinite { node: i });
        }
        if !self.dynamic.contains(i) {
            return if p == self.nominal[i] {
                Ok(())
            } else {
                Err(PositionError::StaticMoved { node: i })
            };
        }
        let (nom, b) = (self.nominal[i], self.bound[i]);
        for (axis, v, nv, bv, max) in [
            ('x', p.x, nom.x, b.x, self.width_m),
            ('y', p.y, nom.y, b.y, self.height_m),
            ('z', p.z, nom.z, b.z, self.config.depth_max_m),
        ] {
            let (lo, hi) = bound_interval(nv, bv, max);
            if !(lo <= v && v <= hi) {
                return Err(PositionError::OutsideBound { node: i, axis });
            }
        }
        if !map.is_water(p.x, p.y) {
            return Err(PositionError::OnLand { node: i });
        }
        Ok(())
    }

    /// One draw of dynamic waypoint `i`: per axis N(nominal, σ²) truncated to
    /// [`bound_interval`], (x, y) redrawn while over land; after
    /// `redraw_attempts` land draws, the nominal (x, y). Returns the position
    /// and whether it fell back.
    fn draw_dynamic(&self, i: usize, rng: &mut PlannerRng, map: &impl WaterMap) -> (Vec3, bool) {
        let (nom, b, sigma) = (self.nominal[i], self.bound[i], self.sigma[i]);
        // A degenerate interval (zero bound) pins the axis at its nominal
        // value; `new` cannot fail otherwise (σ > 0 and finite, validated).
        let law = |nv: f64, bv: f64, max: f64| {
            let (lo, hi) = bound_interval(nv, bv, max);
            TruncatedNormal::new(nv, sigma, lo, hi).ok()
        };
        let draw = |law: &Option<TruncatedNormal>, nv: f64, rng: &mut PlannerRng| law.map_or(nv, |t| t.sample(rng));
        let (lx, ly) = (law(nom.x, b.x, self.width_m), law(nom.y, b.y, self.height_m));
        let lz = law(nom.z, b.z, self.config.depth_max_m);
        let mut found = None;
        for _ in 0..self.config.redraw_attempts {
            let x = draw(&lx, nom.x, rng);
            let y = draw(&ly, nom.y, rng);
            if map.is_water(x, y) {
                found = Some((x, y));
                break;
            }
        }
        let fell_back = found.is_none();
        let (x, y) = found.unwrap_or((nom.x, nom.y));
        let z = draw(&lz, nom.z, rng);
        (Vec3 { x, y, z }, fell_back)
    }

    /// Rechecks every pair touching a node of `moved`; returns (added, removed).
    fn update_edges(&mut self, moved: WorldSet, map: &impl WaterMap) -> (u32, u32) {
        let n = self.n();
        let (mut added, mut removed) = (0, 0);
        for i in moved.iter() {
            for j in 0..n {
                // Pairs of two moved nodes are done once, from the lower id.
                if j == i || (moved.contains(j) && j < i) {
                    continue;
                }
                let (a, b) = (i.min(j), i.max(j));
                let (p, q) = (self.position[a], self.position[b]);
                let now = map.segment_over_water((p.x, p.y), (q.x, q.y));
                let before = self.adjacency[a].contains(b);
                if now != before {
                    if now {
                        self.adjacency[a].insert(b);
                        self.adjacency[b].insert(a);
                        added += 1;
                    } else {
                        self.adjacency[a].remove(b);
                        self.adjacency[b].remove(a);
                        removed += 1;
                    }
                }
            }
        }
        (added, removed)
    }

    /// The current network as an `auv-route-instance/1` snapshot named `name`.
    pub fn snapshot(&self, name: &str) -> Instance {
        let n = self.n();
        let mut edges = Vec::with_capacity(self.edge_count());
        for a in 0..n {
            for b in self.adjacency[a].iter().filter(|&b| b > a) {
                let t = self.tasks[pair_index(a, b)];
                edges.push(Edge {
                    a,
                    b,
                    priority: t.priority,
                    risk: t.risk,
                    task_time_s: t.task_time_s,
                });
            }
        }
        Instance {
            name: name.to_string(),
            speed_mps: self.config.speed_mps,
            time_available_s: self.config.time_available_s,
            start: self.start(),
            goal: self.goal(),
            nodes: self
                .position
                .iter()
                .zip(&self.prize)
                .map(|(p, &prize)| Node {
                    x: p.x,
                    y: p.y,
                    z: p.z,
                    prize,
                })
                .collect(),
            edges,
            objective: self.config.objective,
        }
    }

    /// Refills `problem` straight from the current network, as
    /// `problem.load_instance(&self.snapshot(..), start, excluded, budget_s)`
    /// would, without building the snapshot, in the problem's own capacity
    /// class (too small a class is [`ProblemError::TooManyNodes`]). Does not
    /// allocate.
    pub fn fill_problem<const W: usize>(
        &self,
        problem: &mut Problem<W>,
        start: usize,
        excluded: NodeSet<W>,
        budget_s: f64,
    ) -> Result<(), ProblemError> {
        self.fill_problem_with(problem, start, excluded, budget_s, |_, _| true)
    }

    /// [`World::fill_problem`] keeping only the edges (a, b), a < b, for
    /// which `keep(a, b)` holds: a thinner network of the same waypoints
    /// (e.g. for studies of network density). Does not allocate.
    pub fn fill_problem_with<const W: usize>(
        &self,
        problem: &mut Problem<W>,
        start: usize,
        excluded: NodeSet<W>,
        budget_s: f64,
        keep: impl Fn(usize, usize) -> bool,
    ) -> Result<(), ProblemError> {
        let n = self.n();
        problem.begin(n, start, self.goal(), budget_s, self.config.objective, excluded)?;
        for (i, &prize) in self.prize.iter().enumerate() {
            problem.set_prize(i, prize);
        }
        for a in 0..n {
            for b in self.adjacency[a].iter().filter(|&b| b > a && keep(a, b)) {
                let d = self.distance_m(a, b);
                let t = self.tasks[pair_index(a, b)];
                problem.set_edge(
                    a,
                    b,
                    d,
                    edge_time_s(d, self.config.speed_mps, t.task_time_s),
                    t.priority,
                    t.risk,
                );
            }
        }
        problem.finish()
    }

    /// 3-D distance between the current positions of `a` and `b`, m, computed
    /// exactly as [`Instance::distance`] does.
    #[inline]
    pub fn distance_m(&self, a: usize, b: usize) -> f64 {
        let (p, q) = (&self.position[a], &self.position[b]);
        auv_core::instance::distance_3d_m([p.x, p.y, p.z], [q.x, q.y, q.z])
    }

    /// Node count n.
    #[inline]
    pub fn n(&self) -> usize {
        self.position.len()
    }
    /// Start node (0).
    #[inline]
    pub fn start(&self) -> usize {
        0
    }
    /// Goal node (n − 1).
    #[inline]
    pub fn goal(&self) -> usize {
        self.n() - 1
    }
    /// The dynamic waypoints (ids 1..=d).
    #[inline]
    pub fn dynamic_nodes(&self) -> WorldSet {
        self.dynamic
    }
    /// Whether waypoint `i` is dynamic.
    #[inline]
    pub fn is_dynamic(&self, i: usize) -> bool {
        self.dynamic.contains(i)
    }
    /// Current positions, by node id.
    #[inline]
    pub fn positions(&self) -> &[Vec3] {
        &self.position
    }
    /// Nominal positions, by node id (a static waypoint's nominal position is
    /// its position).
    #[inline]
    pub fn nominal_positions(&self) -> &[Vec3] {
        &self.nominal
    }
    /// Per-axis bounds, m, by node id (zero for static waypoints). Plots draw
    /// the horizontal bound as an ellipse around the nominal position with
    /// semi-axes (x, y) (`plot::BoundMarker`).
    #[inline]
    pub fn bounds(&self) -> &[Vec3] {
        &self.bound
    }
    /// Prizes collected on a visit, by node id.
    #[inline]
    pub fn prizes(&self) -> &[f64] {
        &self.prize
    }
    /// σ of each dynamic waypoint's drift per axis, m, by node id.
    #[inline]
    pub fn drift_sigmas_m(&self) -> &[f64] {
        &self.sigma
    }
    /// The task of pair {a, b} (whether or not the edge exists now), or
    /// `None` when a = b or an id is out of range.
    pub fn task(&self, a: usize, b: usize) -> Option<Task> {
        let (lo, hi) = (a.min(b), a.max(b));
        (lo != hi && hi < self.n()).then(|| self.tasks[pair_index(lo, hi)])
    }
    /// Whether edge a–b exists now (false for ids out of range).
    #[inline]
    pub fn has_edge(&self, a: usize, b: usize) -> bool {
        a < self.n() && b < self.n() && self.adjacency[a].contains(b)
    }
    /// Current neighbours of `i` (empty for ids out of range).
    #[inline]
    pub fn neighbours(&self, i: usize) -> WorldSet {
        self.adjacency.get(i).copied().unwrap_or(WorldSet::EMPTY)
    }
    /// Number of edges now.
    pub fn edge_count(&self) -> usize {
        self.adjacency.iter().map(|s| s.len() as usize).sum::<usize>() / 2
    }
    /// The configuration this world was generated from.
    #[inline]
    pub fn config(&self) -> &ScenarioConfig {
        &self.config
    }
    /// The seed this world was generated from.
    #[inline]
    pub fn seed(&self) -> u64 {
        self.seed
    }
    /// Stable fingerprint of (config, seed, chart).
    #[inline]
    pub fn fingerprint(&self) -> u64 {
        self.fingerprint
    }
    /// Chart width, m.
    #[inline]
    pub fn width_m(&self) -> f64 {
        self.width_m
    }
    /// Chart height, m.
    #[inline]
    pub fn height_m(&self) -> f64 {
        self.height_m
    }
}

/// A static position: (x, y) uniform over the chart until over water, then
/// z uniform over the depth range. `None` after `position_attempts` misses.
fn draw_over_water(rng: &mut PlannerRng, map: &impl WaterMap, config: &ScenarioConfig) -> Option<Vec3> {
    let (w, h) = (map.width_m(), map.height_m());
    for _ in 0..config.position_attempts {
        let x = rng.uniform(0.0, w);
        let y = rng.uniform(0.0, h);
        if map.is_water(x, y) {
            let z = rng.uniform(0.0, config.depth_max_m);
            return Some(Vec3 { x, y, z });
        }
    }
    None
}

#[cfg(test)]
mod tests;
