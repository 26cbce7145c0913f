//! Every message the three processes exchange, in one place.
//!
//! Contract (house style §9):
//! - Each payload is `#[repr(C)]`, fixed size, `ZeroCopySend`, and built only
//!   from integers, floats and arrays of them. Any bit pattern is therefore a
//!   valid value: a garbled or hostile sample can be *rejected*, never cause
//!   undefined behaviour (which a `bool` or Rust `enum` field would). Enums
//!   travel as `u32` codes and are decoded with `from_code`. The snapshot is
//!   the one message sized by its content: a fixed [`SnapshotHead`] (the
//!   sample's user header) and a slice of [`WireEdge`] (its payload), held
//!   in a process as a [`WaypointSnapshot`].
//! - The version is part of the iceoryx2 type name (`#[type_name]`, e.g.
//!   `auv.Plan.v3`) and of the service name (`auv/<vehicle>/planner/plan/v3`).
//!   A changed layout gets a new version in both, so stale shared memory from
//!   an older build answers `IncompatibleTypes` instead of being misread.
//! - Each message starts with a [`Header`]: sequence number, the mission time
//!   it describes, the monotonic time it was sent, the scenario fingerprint,
//!   and the sender's session (one per process start, so a restarted sender's
//!   sequence numbers are not mistaken for replays).
//! - [`Validate`] checks a payload on its own (ranges, finiteness, codes);
//!   [`SeqGuard`] checks the header against the receiver's scenario and the
//!   sender's previous message. Rejections are classified by [`RejectKind`].
//!
//! Units: m, s, m/s, ns; x east, y north, z depth (positive down).

use iceoryx2::prelude::ZeroCopySend;

use auv_core::capacity::LARGEST_NODES;

/// Most waypoints a message can name: the planner's largest capacity class.
pub const MAX_WIRE_NODES: usize = LARGEST_NODES;

/// Most edges a snapshot can carry: every pair of [`MAX_WIRE_NODES`] nodes.
/// A snapshot's edges travel as a slice sized by the mission, so this is a
/// bound, never a message size.
pub const MAX_WIRE_EDGES: usize = MAX_WIRE_NODES * (MAX_WIRE_NODES - 1) / 2;

/// A node id in a route carried by a message (every id is below [`MAX_WIRE_NODES`]).
pub type WireId = u16;

/// "No node" in node-id fields.
pub const NO_NODE: u32 = u32::MAX;

/// Oldest message format version in use. Each type carries its own version
/// in its type and service names (v2: [`VehicleState`] and [`PlannerStatus`],
/// which grew to 12 reject counters).
pub const WIRE_VERSION: u32 = 1;

/// The common start of every message.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
pub struct Header {
    /// Sequence number per sender session: 1 for the first message, +1 per message.
    pub seq: u64,
    /// Identifies the sender's process start (any value, constant while it runs).
    pub session: u64,
    /// Fingerprint of the scenario the sender was started on.
    pub fingerprint: u64,
    /// `CLOCK_MONOTONIC` when the message was handed to the transport, ns.
    pub sent_mono_ns: u64,
    /// Mission time the message describes, s since mission start.
    pub mission_time_s: f64,
}

/// A waypoint as it is reported: position and prize.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
pub struct WireNode {
    /// East, m.
    pub x: f64,
    /// North, m.
    pub y: f64,
    /// Depth, m, positive down.
    pub z: f64,
    /// Prize collected once when visited (0 in the paper's model).
    pub prize: f64,
}

/// An edge that exists right now, with its task: the element of a
/// snapshot's payload slice.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
#[type_name("auv.WireEdge.v1")]
pub struct WireEdge {
    /// One end (node id).
    pub a: u32,
    /// Other end (node id).
    pub b: u32,
    /// Task priority ρ ≥ 0.
    pub priority: f64,
    /// Task risk ξ > 0.
    pub risk: f64,
    /// Task completion time δ ≥ 0, s.
    pub task_time_s: f64,
}

/// Objective codes of [`WaypointSnapshot::objective`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum ObjectiveCode {
    /// Largest weight (the instance format's `max_weight`).
    MaxWeight = 0,
    /// The paper's cost with φ1, φ2.
    PaperCost = 1,
}

/// sensor-sim → planner, vehicle-sim: the fixed part of the network as the
/// sensor sees it now (scalars and every waypoint). On the wire it is the
/// iceoryx2 user header of a sample whose payload is the slice of edges
/// that exist now (`edge_count` of them), so a snapshot is as large as its
/// network; in a process the two travel together as a [`WaypointSnapshot`].
#[repr(C)]
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[type_name("auv.WaypointSnapshot.v2")]
pub struct SnapshotHead {
    /// Common header; `mission_time_s` is when the positions were measured.
    pub header: Header,
    /// Sensor update counter: 0 for the first snapshot, +1 per redraw.
    pub epoch: u64,
    /// Vehicle speed through water, m/s.
    pub speed_mps: f64,
    /// The mission's whole time budget T_available, s.
    pub time_available_s: f64,
    /// φ1 when `objective` is paper_cost.
    pub phi1: f64,
    /// φ2 when `objective` is paper_cost.
    pub phi2: f64,
    /// Mission time of the sensor's next update, s (a lockstep vehicle stops
    /// there and waits for it).
    pub next_update_s: f64,
    /// [`ObjectiveCode`].
    pub objective: u32,
    /// Valid entries of `nodes`.
    pub node_count: u32,
    /// Edges in the sample's payload slice.
    pub edge_count: u32,
    /// Start node id.
    pub start: u32,
    /// Goal node id.
    pub goal: u32,
    /// Explicit padding (keeps the layout free of implicit gaps).
    pub _pad: u32,
    /// Waypoints by id.
    pub nodes: [WireNode; MAX_WIRE_NODES],
}

impl Default for SnapshotHead {
    fn default() -> Self {
        Self {
            header: Header::default(),
            epoch: 0,
            speed_mps: 0.0,
            time_available_s: 0.0,
            phi1: 0.0,
            phi2: 0.0,
            next_update_s: 0.0,
            objective: 0,
            node_count: 0,
            edge_count: 0,
            start: 0,
            goal: 0,
            _pad: 0,
            nodes: [WireNode::default(); MAX_WIRE_NODES],
        }
    }
}

/// A waypoint snapshot held by a process: the [`SnapshotHead`] and a
/// preallocated edge buffer of fixed capacity, of which the first
/// `edge_count` entries are in use. Receiving one copies the used part of a
/// sample in, without allocating.
pub struct WaypointSnapshot {
    head: Box<SnapshotHead>,
    /// Edges, each pair at most once; the first `edge_count` are in use.
    pub edges: Box<[WireEdge]>,
}

impl core::fmt::Debug for WaypointSnapshot {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("WaypointSnapshot")
            .field("header", &self.head.header)
            .field("epoch", &self.head.epoch)
            .field("node_count", &self.head.node_count)
            .field("edge_count", &self.head.edge_count)
            .finish_non_exhaustive()
    }
}

impl core::ops::Deref for WaypointSnapshot {
    type Target = SnapshotHead;
    fn deref(&self) -> &SnapshotHead {
        &self.head
    }
}

impl core::ops::DerefMut for WaypointSnapshot {
    fn deref_mut(&mut self) -> &mut SnapshotHead {
        &mut self.head
    }
}

/// A copy with the same capacity, of which only the part in use is copied.
impl Clone for WaypointSnapshot {
    fn clone(&self) -> Self {
        let mut c = Self::with_capacity(self.capacity());
        *c.head = *self.head;
        let used = self.edges_in_use();
        c.edges[..used.len()].copy_from_slice(used);
        c
    }
}

impl Default for WaypointSnapshot {
    fn default() -> Self {
        Self::new()
    }
}

impl WaypointSnapshot {
    /// An all-zero snapshot with room for every edge of the largest class
    /// (zeroed pages from the allocator: only the part used is ever touched).
    pub fn new() -> Self {
        Self::with_capacity(MAX_WIRE_EDGES)
    }

    /// An all-zero snapshot with room for `max_edges` edges.
    pub fn with_capacity(max_edges: usize) -> Self {
        Self {
            head: boxed_zeroed::<SnapshotHead>(),
            edges: zeroed_slice(max_edges),
        }
    }

    /// Edges the buffer holds at most.
    pub fn capacity(&self) -> usize {
        self.edges.len()
    }

    /// The fixed part.
    pub fn head(&self) -> &SnapshotHead {
        &self.head
    }

    /// The edges in use (`edge_count`, bounded by the capacity).
    pub fn edges_in_use(&self) -> &[WireEdge] {
        &self.edges[..(self.head.edge_count as usize).min(self.edges.len())]
    }

    /// Copies a received sample in: the scalars, the used waypoints and the
    /// `edges` (whose length is the sample's; `edge_count` is set to it).
    /// Refused, changing nothing, when the edges exceed the capacity or the
    /// node count exceeds [`MAX_WIRE_NODES`].
    pub fn copy_from(&mut self, head: &SnapshotHead, edges: &[WireEdge]) -> Result<(), RejectKind> {
        let n = head.node_count as usize;
        if n > MAX_WIRE_NODES || edges.len() > self.edges.len() {
            return Err(RejectKind::Malformed);
        }
        self.copy_scalars(head);
        self.head.nodes[..n].copy_from_slice(&head.nodes[..n]);
        self.edges[..edges.len()].copy_from_slice(edges);
        self.head.edge_count = edges.len() as u32;
        Ok(())
    }

    /// Zeroes the head (nothing in use); the edge buffer keeps its bytes
    /// and its capacity.
    pub fn clear(&mut self) {
        // SAFETY: the head is a whole SnapshotHead; zero bytes are valid.
        unsafe { zero_in_place(&mut *self.head as *mut SnapshotHead) };
    }

    /// Takes a received sample in, never failing: what fits is copied; a
    /// sample whose edges do not fit, whose node count exceeds
    /// [`MAX_WIRE_NODES`] or whose head disagrees with its slice about the
    /// edge count is kept as a snapshot that fails validation as
    /// `Malformed` (so the receiver counts it rejected).
    pub fn receive(&mut self, head: &SnapshotHead, edges: &[WireEdge]) {
        let agrees = head.edge_count as usize == edges.len();
        if self.copy_from(head, edges).is_err() || !agrees {
            self.copy_scalars(head);
            self.head.edge_count = u32::MAX;
        }
    }

    /// Copies the header and scalar fields of `head` (everything before the
    /// waypoints, 112 of its 16 496 bytes).
    fn copy_scalars(&mut self, head: &SnapshotHead) {
        let scalars = core::mem::offset_of!(SnapshotHead, nodes);
        // SAFETY: both point to whole heads; the first `scalars` bytes are
        // the header and scalar fields (integers and floats), which any
        // bytes form validly; source and destination do not overlap.
        unsafe {
            core::ptr::copy_nonoverlapping(
                (head as *const SnapshotHead).cast::<u8>(),
                (&mut *self.head as *mut SnapshotHead).cast::<u8>(),
                scalars,
            );
        }
    }

    /// Copies another held snapshot in (see [`Self::copy_from`]).
    pub fn copy_snapshot(&mut self, src: &WaypointSnapshot) -> Result<(), RejectKind> {
        self.copy_from(src.head(), src.edges_in_use())
    }
}

/// A heap slice of `n` all-zero edges (zero bytes are a valid edge).
fn zeroed_slice(n: usize) -> Box<[WireEdge]> {
    if n == 0 {
        return Box::new([]);
    }
    let layout = match std::alloc::Layout::array::<WireEdge>(n) {
        Ok(l) => l,
        Err(_) => return Box::new([]),
    };
    // SAFETY: the layout is non-zero-sized; zero bytes are a valid WireEdge
    // (integers and floats); the pointer comes from the global allocator
    // with the slice's layout, as Box requires.
    unsafe {
        let p = std::alloc::alloc_zeroed(layout) as *mut WireEdge;
        if p.is_null() {
            std::alloc::handle_alloc_error(layout);
        }
        Box::from_raw(core::ptr::slice_from_raw_parts_mut(p, n))
    }
}

/// What the vehicle is doing, [`VehicleState::mode`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum VehicleMode {
    /// No plan received yet: holding position at its node.
    NoPlan = 0,
    /// Travelling along an edge towards `to_node`.
    Travelling = 1,
    /// At `to_node`, performing the edge's task.
    Working = 2,
    /// Its plan ran out (or was rejected) before the goal: holding at `to_node`.
    Holding = 3,
    /// The mission is over; see `outcome`.
    Finished = 4,
}

/// Why a state message was sent, [`VehicleState::event`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum VehicleEvent {
    /// Fixed-rate report.
    Periodic = 0,
    /// First message of the mission (at the start node, no plan yet).
    Start = 1,
    /// Reached the waypoint `to_node`; the edge's task starts now.
    Arrival = 2,
    /// Lockstep: mission time reached a sensor period boundary.
    Tick = 3,
    /// Mission over (goal reached or time out).
    Finished = 4,
}

/// How the mission ended, [`VehicleState::outcome`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Outcome {
    /// Still running.
    Running = 0,
    /// Reached the goal within the time budget.
    GoalReached = 1,
    /// Ran out of time before the goal.
    TimedOut = 2,
    /// Stopped from outside (Ctrl-C).
    Aborted = 3,
    /// Stopped in a safe state: the vehicle holds at a waypoint because a
    /// process of the mission kept failing (its restart budget ran out).
    SafeHold = 4,
}

/// vehicle-sim → planner, sensor-sim: where the vehicle is and what it has done.
#[repr(C)]
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[type_name("auv.VehicleState.v3")]
pub struct VehicleState {
    /// Common header; `mission_time_s` is the elapsed mission time.
    pub header: Header,
    /// Position (x east, y north, z depth), m.
    pub position: [f64; 3],
    /// Mission time left, s (T_available − elapsed).
    pub time_left_s: f64,
    /// Time until the vehicle is free at `to_node` (rest of the travel plus
    /// the rest of the task), s; 0 when it is there and free.
    pub eta_free_s: f64,
    /// Weight collected (Σ ρ/ξ of completed tasks + prizes).
    pub weight: f64,
    /// Distance travelled, m.
    pub distance_m: f64,
    /// Mission seconds per real second (0: lockstep). Lets sensor-sim follow
    /// the vehicle's clock instead of keeping its own.
    pub time_scale: f64,
    /// `seq` of the plan being followed (0: none).
    pub plan_seq: u64,
    /// Latest waypoint snapshot epoch the vehicle has applied.
    pub snapshot_epoch: u64,
    /// [`VehicleMode`].
    pub mode: u32,
    /// [`VehicleEvent`].
    pub event: u32,
    /// [`Outcome`].
    pub outcome: u32,
    /// Node the current edge starts at (== `to_node` when at a node).
    pub from_node: u32,
    /// Node the vehicle is heading to, or is at.
    pub to_node: u32,
    /// Arrivals so far (each is one completed task).
    pub arrivals: u32,
    /// Tasks completed.
    pub tasks_completed: u32,
    /// Lockstep: 1 when the vehicle waits for the planner's answer to this message.
    pub needs_answer: u32,
    /// Plans the vehicle set aside as stale (they answered a position it
    /// had already left, or came after the mission ended); refused plans
    /// are counted in `rejected`, by kind.
    pub stale_plans: u32,
    /// Valid entries of `route`.
    pub route_len: u32,
    /// Input messages the vehicle rejected so far, by [`RejectKind`]
    /// (snapshots, plans and planner status together).
    pub rejected: [u64; REJECT_KINDS],
    /// Nodes visited so far, in order, start first.
    pub route: [WireId; MAX_WIRE_NODES],
}

/// Why the planner re-planned, [`Plan::trigger`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum TriggerKind {
    /// First plan of the mission (or after a planner restart).
    Initial = 0,
    /// The vehicle arrived at a waypoint.
    Arrival = 1,
    /// A sensor update removed an edge of the plan.
    EdgeLost = 2,
    /// A sensor update changed the plan's remaining time beyond the threshold.
    TimeChanged = 3,
    /// A sensor update made the plan infeasible.
    Infeasible = 4,
    /// The first snapshot of a restarted sensor (a new sender session):
    /// the network may have moved on while it was away.
    SensorBack = 5,
    /// An operator's command changed what to plan for (budget, abort,
    /// tasks), [`OperatorCommand`].
    Operator = 6,
}

/// planner → vehicle-sim: the route to follow from the node the vehicle is
/// heading to (or is at) to the goal.
#[repr(C)]
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[type_name("auv.Plan.v3")]
pub struct Plan {
    /// Common header; `mission_time_s` is the vehicle's time when the trigger happened.
    pub header: Header,
    /// `seq` of the vehicle state this plan was computed from.
    pub state_seq: u64,
    /// Snapshot epoch this plan was computed on.
    pub snapshot_epoch: u64,
    /// `sent_mono_ns` of the triggering message, ns (for end-to-end latency).
    pub trigger_sent_mono_ns: u64,
    /// When the planner took the trigger off the transport, ns (monotonic).
    pub trigger_received_mono_ns: u64,
    /// Time from the trigger's arrival at the planner to this plan being
    /// filled (just before it is stamped and sent), ns.
    pub compute_ns: u64,
    /// Solver wall time, ns.
    pub solve_ns: u64,
    /// Predicted route time from `route[0]`, s.
    pub time_s: f64,
    /// Predicted route weight.
    pub weight: f64,
    /// Predicted route distance, m.
    pub distance_m: f64,
    /// Budget the route was planned for (time left minus `eta_free_s`), s.
    pub budget_s: f64,
    /// [`TriggerKind`].
    pub trigger: u32,
    /// Solver iterations run.
    pub iterations: u32,
    /// 1 when the deadline stopped the solver before its iteration budget.
    pub deadline_cut: u32,
    /// 1 when the route fits the budget.
    pub feasible: u32,
    /// 1 when no feasible route exists and this is the quickest path to the goal.
    pub fallback: u32,
    /// Re-plan counter of the planner (1 for its first plan).
    pub replan: u32,
    /// Valid entries of `route`.
    pub route_len: u32,
    /// Explicit padding.
    pub _pad: u32,
    /// Node ids, `route[0]` = where the vehicle will be free, last = goal.
    pub route: [WireId; MAX_WIRE_NODES],
}

/// Kinds of rejected input, the index into the reject counters. Stable
/// numbering: it is part of the status message layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum RejectKind {
    /// Sent by a process started on another scenario (fingerprint differs).
    ForeignScenario = 0,
    /// A sequence number not above the previous one from the same session.
    OutOfOrder = 1,
    /// The same sequence number again.
    Repeated = 2,
    /// NaN or infinite number.
    NonFinite = 3,
    /// A node id outside the network.
    NodeOutOfRange = 4,
    /// A count above its capacity or an unknown enum code.
    Malformed = 5,
    /// A plan that does not fit the vehicle (wrong start, not ending at
    /// the goal, or sent when no plan can be taken).
    BadPlan = 6,
    /// A waypoint on land or outside the chart.
    OffWater = 7,
    /// A dynamic waypoint outside its bound.
    OutsideBound = 8,
    /// A number outside its documented range (negative time, speed ≤ 0, …).
    OutOfRange = 9,
    /// A plan whose route uses a pair of waypoints that is not an edge now.
    NonEdge = 10,
    /// A plan whose route returns to a waypoint already visited (or lists
    /// one twice).
    VisitedNode = 11,
}

/// Number of [`RejectKind`] counters carried in messages.
pub const REJECT_KINDS: usize = 12;

impl RejectKind {
    /// All kinds, in counter order.
    pub const ALL: [RejectKind; REJECT_KINDS] = [
        Self::ForeignScenario,
        Self::OutOfOrder,
        Self::Repeated,
        Self::NonFinite,
        Self::NodeOutOfRange,
        Self::Malformed,
        Self::BadPlan,
        Self::OffWater,
        Self::OutsideBound,
        Self::OutOfRange,
        Self::NonEdge,
        Self::VisitedNode,
    ];

    /// snake_case name for reports and logs.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::ForeignScenario => "foreign_scenario",
            Self::OutOfOrder => "out_of_order",
            Self::Repeated => "repeated",
            Self::NonFinite => "non_finite",
            Self::NodeOutOfRange => "node_out_of_range",
            Self::Malformed => "malformed",
            Self::BadPlan => "bad_plan",
            Self::OffWater => "off_water",
            Self::OutsideBound => "outside_bound",
            Self::OutOfRange => "out_of_range",
            Self::NonEdge => "non_edge",
            Self::VisitedNode => "visited_node",
        }
    }

    /// The kind named `name` (as [`RejectKind::as_str`] writes it).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.as_str() == name)
    }
}

/// Allocation counters of the planner's service thread (see
/// `service::alloc`). "Steady" counts start once the service declares its
/// warm-up over.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
pub struct AllocCounters {
    /// Calls into the system allocator (alloc, realloc) by the service thread since start.
    pub sys_allocs_total: u64,
    /// Calls into the system allocator (alloc, realloc) by the service thread in steady state.
    pub sys_allocs_steady: u64,
    /// Frees into the system allocator by the service thread in steady state.
    pub sys_frees_steady: u64,
    /// Blocks served from the start-up pool in steady state, without the
    /// system allocator (iceoryx2 0.10 allocates 48 B per `loan`, and
    /// 65–512 B blocks when it connects a restarted peer).
    pub pool_allocs_steady: u64,
    /// Most pool blocks in use at once.
    pub pool_high_water: u64,
    /// Pool blocks reserved at start-up.
    pub pool_capacity: u64,
    /// Steady-state requests of the service thread that the pool could not
    /// serve (too big or pool exhausted) and that went to the system allocator.
    pub pool_misses: u64,
    /// 1 once the steady state began (it stays 1 after it ended).
    pub steady: u64,
}

/// What the planner service is doing, [`PlannerStatus::phase`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum PlannerPhase {
    /// Waiting for the first snapshot or vehicle state.
    Waiting = 0,
    /// Planning.
    Running = 1,
    /// The vehicle finished; the service is stopping.
    Finished = 2,
}

/// planner → anyone: counters and latency, sent after every handled input.
#[repr(C)]
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[type_name("auv.PlannerStatus.v4")]
pub struct PlannerStatus {
    /// Common header; `mission_time_s` is the latest vehicle time seen.
    pub header: Header,
    /// `seq` of the latest vehicle state handled (lockstep answer).
    pub handled_state_seq: u64,
    /// `session` of that vehicle state.
    pub handled_state_session: u64,
    /// Latest snapshot epoch handled (lockstep answer).
    pub handled_epoch: u64,
    /// Plans published.
    pub plans: u64,
    /// Triggers seen (each led to a plan).
    pub triggers: u64,
    /// Sensor updates applied.
    pub sensor_updates: u64,
    /// Sensor updates that did not change the plan enough to re-plan.
    pub updates_without_replan: u64,
    /// Plans published later than the deadline after their trigger arrived.
    pub deadline_misses: u64,
    /// Plans whose solve the deadline cut short.
    pub deadline_cuts: u64,
    /// Plans that fell back to the quickest path (no feasible route).
    pub fallbacks: u64,
    /// Latest trigger arrival → plan published latency, ns.
    pub last_latency_ns: u64,
    /// Largest trigger arrival → plan published latency, ns.
    pub max_latency_ns: u64,
    /// The latency deadline, ns.
    pub deadline_ns: u64,
    /// Allocation counters of the service thread.
    pub alloc: AllocCounters,
    /// Rejected input messages by [`RejectKind`].
    pub rejected: [u64; REJECT_KINDS],
    /// Solver iterations summed over all plans.
    pub iterations_total: u64,
    /// Median trigger arrival → plan published latency of this process's
    /// plans, from its own histogram, ns (0 before the first plan).
    pub latency_p50_ns: u64,
    /// 99th percentile of the same, ns.
    pub latency_p99_ns: u64,
    /// Solver iterations of the plans the deadline cut.
    pub cut_iterations: u64,
    /// Cut plans that had a warm start.
    pub cut_with_warm_start: u64,
    /// Weight of those cut plans.
    pub cut_weight: f64,
    /// Weight of their warm starts on the same problem.
    pub cut_warm_start_weight: f64,
    /// [`PlannerPhase`].
    pub phase: u32,
    /// Solver iterations of the latest plan.
    pub last_iterations: u32,
    /// SCHED_FIFO priority of the service thread (0: normal scheduling).
    pub rt_priority: u32,
    /// Explicit padding.
    pub _pad: u32,
}

/// What an operator asks for, [`OperatorCommand::kind`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum CommandKind {
    /// Plan the quickest feasible route to the goal now, and keep doing so
    /// at every later trigger (tasks no longer count).
    AbortToGoal = 1,
    /// Plan within the mission time `value_s` (a total, in mission time,
    /// like `time_available_s`): at most the vehicle's own budget, more
    /// than the mission time already used.
    SetTimeBudget = 2,
    /// Plan through waypoint `node` again (undo a [`CommandKind::RemoveTask`]).
    AddTask = 3,
    /// Never plan through waypoint `node` (its tasks are dropped).
    RemoveTask = 4,
}

/// operator (through the shore link) → planner: one command, identified by
/// `command_id` so that a command sent again after a reconnect is
/// acknowledged again but never applied twice.
#[repr(C)]
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[type_name("auv.OperatorCommand.v1")]
pub struct OperatorCommand {
    /// Common header; `mission_time_s` is the link's latest vehicle time.
    pub header: Header,
    /// Chosen by the operator's console, unique per command, never 0.
    pub command_id: u64,
    /// [`CommandKind::SetTimeBudget`]: the new mission time budget, s.
    pub value_s: f64,
    /// [`CommandKind`].
    pub kind: u32,
    /// [`CommandKind::AddTask`], [`CommandKind::RemoveTask`]: the waypoint
    /// ([`NO_NODE`] otherwise).
    pub node: u32,
}

/// How a command ended, [`CommandAck::status`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum AckStatus {
    /// Applied; `plan_seq` names the plan it caused (0: none could be made).
    Applied = 1,
    /// Refused; `reason` says why. Nothing changed.
    Refused = 2,
}

/// Why a command was refused, [`CommandAck::reason`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum RefuseReason {
    /// Not refused.
    None = 0,
    /// The message failed validation (unknown kind, zero id, bad number).
    Malformed = 1,
    /// No mission to command: the planner has no vehicle state and snapshot
    /// yet, or the mission is over.
    NotRunning = 2,
    /// The budget is not above the mission time used, or above the vehicle's own budget.
    BudgetOutOfRange = 3,
    /// The waypoint is not in the network, or is the start or the goal.
    BadWaypoint = 4,
    /// The waypoint was already visited (nothing left to add or remove).
    AlreadyVisited = 5,
    /// Removing a waypoint that is already removed, or adding one that was not.
    NoChange = 6,
}

impl RefuseReason {
    /// All reasons, in code order.
    pub const ALL: [RefuseReason; 7] = [
        Self::None,
        Self::Malformed,
        Self::NotRunning,
        Self::BudgetOutOfRange,
        Self::BadWaypoint,
        Self::AlreadyVisited,
        Self::NoChange,
    ];

    /// snake_case name for acks, reports and logs.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Malformed => "malformed",
            Self::NotRunning => "not_running",
            Self::BudgetOutOfRange => "budget_out_of_range",
            Self::BadWaypoint => "bad_waypoint",
            Self::AlreadyVisited => "already_visited",
            Self::NoChange => "no_change",
        }
    }
}

impl CommandKind {
    /// All kinds, in code order.
    pub const ALL: [CommandKind; 4] = [Self::AbortToGoal, Self::SetTimeBudget, Self::AddTask, Self::RemoveTask];

    /// The kebab-case name the shore console takes (`abort-to-goal`).
    pub fn as_str(self) -> &'static str {
        match self {
            Self::AbortToGoal => "abort-to-goal",
            Self::SetTimeBudget => "set-time-budget",
            Self::AddTask => "add-task",
            Self::RemoveTask => "remove-task",
        }
    }

    /// The kind named `name` (as [`CommandKind::as_str`] writes it).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.as_str() == name)
    }
}

/// planner → shore link: the answer to one [`OperatorCommand`].
#[repr(C)]
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[type_name("auv.CommandAck.v1")]
pub struct CommandAck {
    /// Common header; `mission_time_s` is the planner's vehicle time.
    pub header: Header,
    /// The command answered.
    pub command_id: u64,
    /// `seq` of the plan the command caused (0: refused, or no plan).
    pub plan_seq: u64,
    /// [`CommandKind`] of the command answered (0 when it was malformed).
    pub kind: u32,
    /// [`AckStatus`].
    pub status: u32,
    /// [`RefuseReason`].
    pub reason: u32,
    /// Re-plan counter of that plan (0: none).
    pub replan: u32,
}

/// Latency bench only: a raw ping of the same size as a [`VehicleState`],
/// answered by a [`RawPong`] the size of a [`Plan`], so the raw iceoryx2
/// round trip carries exactly the bytes a trigger and its plan carry.
#[repr(C)]
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[type_name("auv.bench.RawPing.v2")]
pub struct RawPing {
    /// Common header.
    pub header: Header,
    /// Filler up to the size of a vehicle state.
    pub body: [u8; core::mem::size_of::<VehicleState>() - core::mem::size_of::<Header>()],
}

/// Latency bench only: the answer to a [`RawPing`], the size of a [`Plan`].
#[repr(C)]
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[type_name("auv.bench.RawPong.v2")]
pub struct RawPong {
    /// Common header.
    pub header: Header,
    /// `seq` of the ping answered.
    pub ping_seq: u64,
    /// `sent_mono_ns` of the ping answered.
    pub ping_sent_mono_ns: u64,
    /// Filler up to the size of a plan.
    pub body: [u8; core::mem::size_of::<Plan>() - core::mem::size_of::<Header>() - 16],
}

/// snake_case name of an outcome.
pub fn outcome_name(o: Outcome) -> &'static str {
    match o {
        Outcome::Running => "running",
        Outcome::GoalReached => "goal_reached",
        Outcome::TimedOut => "timed_out",
        Outcome::Aborted => "aborted",
        Outcome::SafeHold => "safe_hold",
    }
}

/// A receiver-side check that needs more than the message itself (the
/// scenario's chart, bounds, node count). Runs after [`Validate`], so it sees
/// only well-formed messages; it must not allocate.
pub type ContextCheck<T> = Box<dyn Fn(&T) -> Result<(), RejectKind>>;

/// A receiver-side check of one payload on its own.
pub trait Validate {
    /// `Ok` when every field is in range; otherwise the first problem found.
    fn validate(&self) -> Result<(), RejectKind>;
}

/// Gives generic code the header of any message.
pub trait Message: core::fmt::Debug + Validate + 'static {
    /// Short name for logs ("plan", "vehicle state", …).
    const NAME: &'static str;
    /// The versioned iceoryx2 type name (`auv.Plan.v3`; for a snapshot,
    /// its head's).
    fn type_name() -> &'static str;
    /// The header.
    fn header(&self) -> &Header;
    /// The header, mutable (the transport stamps it when sending).
    fn header_mut(&mut self) -> &mut Header;
}

/// A message that travels as one fixed-size `repr(C)` sample (every message
/// but the snapshot, whose edges are a slice).
pub trait FixedMessage: Message + Copy + ZeroCopySend {}

macro_rules! impl_message {
    ($t:ty, $name:literal) => {
        impl Message for $t {
            const NAME: &'static str = $name;
            fn type_name() -> &'static str {
                // SAFETY: `type_name` only returns the static string the derive set.
                unsafe { <$t as ZeroCopySend>::type_name() }
            }
            #[inline]
            fn header(&self) -> &Header {
                &self.header
            }
            #[inline]
            fn header_mut(&mut self) -> &mut Header {
                &mut self.header
            }
        }
        impl FixedMessage for $t {}
    };
}

impl Message for WaypointSnapshot {
    const NAME: &'static str = "waypoint snapshot";
    fn type_name() -> &'static str {
        // SAFETY: `type_name` only returns the static string the derive set.
        unsafe { <SnapshotHead as ZeroCopySend>::type_name() }
    }
    #[inline]
    fn header(&self) -> &Header {
        &self.head.header
    }
    #[inline]
    fn header_mut(&mut self) -> &mut Header {
        &mut self.head.header
    }
}
impl_message!(VehicleState, "vehicle state");
impl_message!(Plan, "plan");
impl_message!(PlannerStatus, "planner status");
impl_message!(OperatorCommand, "operator command");
impl_message!(CommandAck, "command ack");
impl_message!(RawPing, "bench ping");
impl_message!(RawPong, "bench pong");

/// The versioned type name of message `T` (`auv.Plan.v3`).
pub fn type_name_of<T: Message>() -> &'static str {
    T::type_name()
}

/// Decodes a `u32` enum code.
pub trait FromCode: Sized {
    /// The variant with code `c`, if any.
    fn from_code(c: u32) -> Option<Self>;
}

macro_rules! codes {
    ($t:ty: $($v:ident),+) => {
        impl FromCode for $t {
            fn from_code(c: u32) -> Option<Self> {
                $( if c == <$t>::$v as u32 { return Some(<$t>::$v); } )+
                None
            }
        }
    };
}

codes!(ObjectiveCode: MaxWeight, PaperCost);
codes!(VehicleMode: NoPlan, Travelling, Working, Holding, Finished);
codes!(VehicleEvent: Periodic, Start, Arrival, Tick, Finished);
codes!(Outcome: Running, GoalReached, TimedOut, Aborted, SafeHold);
codes!(TriggerKind: Initial, Arrival, EdgeLost, TimeChanged, Infeasible, SensorBack, Operator);
codes!(CommandKind: AbortToGoal, SetTimeBudget, AddTask, RemoveTask);
codes!(AckStatus: Applied, Refused);
codes!(RefuseReason: None, Malformed, NotRunning, BudgetOutOfRange, BadWaypoint, AlreadyVisited, NoChange);
codes!(PlannerPhase: Waiting, Running, Finished);

fn finite(v: f64) -> Result<(), RejectKind> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(RejectKind::NonFinite)
    }
}

fn at_least(v: f64, min: f64) -> Result<(), RejectKind> {
    finite(v)?;
    if v >= min { Ok(()) } else { Err(RejectKind::OutOfRange) }
}

fn positive(v: f64) -> Result<(), RejectKind> {
    finite(v)?;
    if v > 0.0 { Ok(()) } else { Err(RejectKind::OutOfRange) }
}

fn code<T: FromCode>(c: u32) -> Result<T, RejectKind> {
    T::from_code(c).ok_or(RejectKind::Malformed)
}

fn count(c: u32, max: usize) -> Result<usize, RejectKind> {
    let c = c as usize;
    if c <= max { Ok(c) } else { Err(RejectKind::Malformed) }
}

fn node(id: u32, n: usize) -> Result<usize, RejectKind> {
    let id = id as usize;
    if id < n {
        Ok(id)
    } else {
        Err(RejectKind::NodeOutOfRange)
    }
}

fn ids_in_range(ids: &[WireId]) -> Result<(), RejectKind> {
    if ids.iter().all(|&id| (id as usize) < MAX_WIRE_NODES) {
        Ok(())
    } else {
        Err(RejectKind::NodeOutOfRange)
    }
}

fn header_ok(h: &Header) -> Result<(), RejectKind> {
    at_least(h.mission_time_s, 0.0)?;
    if h.seq == 0 {
        return Err(RejectKind::OutOfRange);
    }
    Ok(())
}

impl Validate for WaypointSnapshot {
    fn validate(&self) -> Result<(), RejectKind> {
        validate_snapshot(&self.head, self.edges_in_use(), self.capacity())
    }
}

/// Checks a snapshot's head and its `edges` (a received sample's slice, or
/// the used part of a held buffer of `capacity` edges).
pub fn validate_snapshot(head: &SnapshotHead, edges: &[WireEdge], capacity: usize) -> Result<(), RejectKind> {
    header_ok(&head.header)?;
    positive(head.speed_mps)?;
    positive(head.time_available_s)?;
    at_least(head.next_update_s, head.header.mission_time_s)?;
    let objective = code::<ObjectiveCode>(head.objective)?;
    if objective == ObjectiveCode::PaperCost {
        at_least(head.phi1, 0.0)?;
        at_least(head.phi2, 0.0)?;
    }
    let n = count(head.node_count, MAX_WIRE_NODES)?;
    let m = count(head.edge_count, MAX_WIRE_EDGES.min(capacity))?;
    if m != edges.len() || n < 2 {
        return Err(RejectKind::Malformed);
    }
    let (s, g) = (node(head.start, n)?, node(head.goal, n)?);
    if s == g {
        return Err(RejectKind::Malformed);
    }
    for p in &head.nodes[..n] {
        finite(p.x)?;
        finite(p.y)?;
        finite(p.z)?;
        at_least(p.prize, 0.0)?;
    }
    for e in edges {
        let (a, b) = (node(e.a, n)?, node(e.b, n)?);
        if a == b {
            return Err(RejectKind::Malformed);
        }
        at_least(e.priority, 0.0)?;
        positive(e.risk)?;
        at_least(e.task_time_s, 0.0)?;
    }
    Ok(())
}

impl Validate for VehicleState {
    fn validate(&self) -> Result<(), RejectKind> {
        header_ok(&self.header)?;
        for v in self.position {
            finite(v)?;
        }
        finite(self.time_left_s)?;
        at_least(self.eta_free_s, 0.0)?;
        at_least(self.weight, 0.0)?;
        at_least(self.distance_m, 0.0)?;
        code::<VehicleMode>(self.mode)?;
        code::<VehicleEvent>(self.event)?;
        code::<Outcome>(self.outcome)?;
        node(self.from_node, MAX_WIRE_NODES)?;
        node(self.to_node, MAX_WIRE_NODES)?;
        let len = count(self.route_len, MAX_WIRE_NODES)?;
        if len == 0 {
            return Err(RejectKind::Malformed);
        }
        ids_in_range(&self.route[..len])?;
        finite(self.time_scale)?;
        if self.needs_answer > 1 {
            return Err(RejectKind::Malformed);
        }
        Ok(())
    }
}

impl Validate for Plan {
    fn validate(&self) -> Result<(), RejectKind> {
        header_ok(&self.header)?;
        for v in [self.time_s, self.weight, self.distance_m, self.budget_s] {
            finite(v)?;
        }
        code::<TriggerKind>(self.trigger)?;
        for flag in [self.deadline_cut, self.feasible, self.fallback] {
            if flag > 1 {
                return Err(RejectKind::Malformed);
            }
        }
        let len = count(self.route_len, MAX_WIRE_NODES)?;
        if len < 1 {
            return Err(RejectKind::Malformed);
        }
        ids_in_range(&self.route[..len])
    }
}

impl Validate for RawPing {
    fn validate(&self) -> Result<(), RejectKind> {
        header_ok(&self.header)
    }
}

impl Validate for RawPong {
    fn validate(&self) -> Result<(), RejectKind> {
        header_ok(&self.header)
    }
}

impl Validate for PlannerStatus {
    fn validate(&self) -> Result<(), RejectKind> {
        header_ok(&self.header)?;
        code::<PlannerPhase>(self.phase)?;
        if !(self.cut_weight.is_finite() && self.cut_warm_start_weight.is_finite()) {
            return Err(RejectKind::NonFinite);
        }
        Ok(())
    }
}

impl Validate for OperatorCommand {
    fn validate(&self) -> Result<(), RejectKind> {
        header_ok(&self.header)?;
        if self.command_id == 0 {
            return Err(RejectKind::Malformed);
        }
        match code::<CommandKind>(self.kind)? {
            CommandKind::SetTimeBudget => positive(self.value_s),
            CommandKind::AddTask | CommandKind::RemoveTask => node(self.node, MAX_WIRE_NODES).map(|_| ()),
            CommandKind::AbortToGoal => Ok(()),
        }
    }
}

impl Validate for CommandAck {
    fn validate(&self) -> Result<(), RejectKind> {
        header_ok(&self.header)?;
        code::<AckStatus>(self.status)?;
        code::<RefuseReason>(self.reason)?;
        if self.kind != 0 {
            code::<CommandKind>(self.kind)?;
        }
        Ok(())
    }
}

/// Zero-initialises a message in place. Every message type consists only of
/// integers, floats and arrays of them, so all-zero bytes are a valid value;
/// building in place avoids moving a 16 KiB snapshot head through the stack.
///
/// # Safety
/// `ptr` must be valid for writes of one `T` and properly aligned; `T` must be
/// one of the message types of this module.
pub unsafe fn zero_in_place<T: ZeroCopySend>(ptr: *mut T) {
    // SAFETY: guaranteed by the caller; zero bytes are a valid T (see above).
    unsafe { core::ptr::write_bytes(ptr, 0, 1) };
}

/// A heap-allocated all-zero message (set-up code and tests; not hot paths).
/// `T` is one of this module's `repr(C)` types, all integers and floats.
pub fn boxed_zeroed<T: ZeroCopySend>() -> Box<T> {
    let layout = std::alloc::Layout::new::<T>();
    // SAFETY: T is not zero-sized (it has a Header); zero bytes are a valid T
    // (see `zero_in_place`), and the pointer comes from the global allocator
    // with T's layout, as Box requires.
    unsafe {
        let p = std::alloc::alloc_zeroed(layout) as *mut T;
        if p.is_null() {
            std::alloc::handle_alloc_error(layout);
        }
        Box::from_raw(p)
    }
}

/// Per-sender sequence tracking and the scenario check for one topic.
///
/// A message is accepted when its fingerprint equals ours and its sequence
/// number is above the previous one *of the same session*; a new session (a
/// restarted sender) starts over. Messages from another scenario are refused
/// whatever their sequence number.
#[derive(Clone, Copy, Debug, Default)]
pub struct SeqGuard {
    fingerprint: u64,
    session: u64,
    last_seq: u64,
}

impl SeqGuard {
    /// A guard for receivers of scenario `fingerprint`.
    pub fn new(fingerprint: u64) -> Self {
        Self {
            fingerprint,
            session: 0,
            last_seq: 0,
        }
    }

    /// Checks only that `h` comes from our scenario.
    pub fn same_scenario(&self, h: &Header) -> Result<(), RejectKind> {
        if h.fingerprint == self.fingerprint {
            Ok(())
        } else {
            Err(RejectKind::ForeignScenario)
        }
    }

    /// Checks `h`, and remembers it when accepted.
    pub fn accept(&mut self, h: &Header) -> Result<(), RejectKind> {
        self.same_scenario(h)?;
        if h.session == self.session && self.last_seq != 0 {
            if h.seq == self.last_seq {
                return Err(RejectKind::Repeated);
            }
            if h.seq < self.last_seq {
                return Err(RejectKind::OutOfOrder);
            }
        }
        self.session = h.session;
        self.last_seq = h.seq;
        Ok(())
    }

    /// The scenario fingerprint this guard accepts.
    pub fn fingerprint(&self) -> u64 {
        self.fingerprint
    }

    /// Session and sequence number of the last accepted message (0, 0 before any).
    pub fn last(&self) -> (u64, u64) {
        (self.session, self.last_seq)
    }
}

/// Counters of rejected messages by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RejectCounters(pub [u64; REJECT_KINDS]);

impl RejectCounters {
    /// Counts one rejection.
    #[inline]
    pub fn add(&mut self, kind: RejectKind) {
        self.0[kind as usize] += 1;
    }

    /// Total over all kinds.
    pub fn total(&self) -> u64 {
        self.0.iter().sum()
    }

    /// Adds another set of counters.
    pub fn merge(&mut self, other: &RejectCounters) {
        for (a, b) in self.0.iter_mut().zip(other.0) {
            *a += b;
        }
    }
}

/// "kind count, kind count, …" for the non-zero kinds (log lines).
impl core::fmt::Display for RejectCounters {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let mut first = true;
        for (k, n) in RejectKind::ALL.iter().zip(self.0) {
            if n > 0 {
                write!(f, "{}{} {n}", if first { "" } else { ", " }, k.as_str())?;
                first = false;
            }
        }
        Ok(())
    }
}

/// A route carried in a message, as node ids (`len` checked against capacity).
pub fn route_ids(route: &[WireId; MAX_WIRE_NODES], len: u32) -> &[WireId] {
    &route[..(len as usize).min(MAX_WIRE_NODES)]
}

/// A plan message through `ids` with sequence number `seq`, every other
/// field zero (for tests of a plan's receiver).
pub fn plan_through(ids: &[WireId], seq: u64) -> Plan {
    let mut p = *boxed_zeroed::<Plan>();
    p.header = Header {
        seq,
        ..Header::default()
    };
    p.route_len = ids.len() as u32;
    p.route[..ids.len()].copy_from_slice(ids);
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use iceoryx2::prelude::ZeroCopySend;
    use proptest::prelude::*;

    fn header(seq: u64) -> Header {
        Header {
            seq,
            session: 7,
            fingerprint: 42,
            sent_mono_ns: 1,
            mission_time_s: 0.0,
        }
    }

    fn small_snapshot() -> WaypointSnapshot {
        let mut s = WaypointSnapshot::with_capacity(4);
        s.header = header(1);
        s.speed_mps = 1.5;
        s.time_available_s = 100.0;
        s.node_count = 3;
        s.edge_count = 2;
        s.start = 0;
        s.goal = 2;
        s.edges[0] = WireEdge {
            a: 0,
            b: 1,
            priority: 1.0,
            risk: 0.5,
            task_time_s: 3.0,
        };
        s.edges[1] = WireEdge {
            a: 1,
            b: 2,
            priority: 1.0,
            risk: 0.5,
            task_time_s: 3.0,
        };
        s
    }

    #[test]
    fn type_names_carry_the_version() {
        // SAFETY: type_name only returns the static string set by the derive.
        unsafe {
            assert_eq!(<SnapshotHead as ZeroCopySend>::type_name(), "auv.WaypointSnapshot.v2");
            assert_eq!(<WireEdge as ZeroCopySend>::type_name(), "auv.WireEdge.v1");
            assert_eq!(<VehicleState as ZeroCopySend>::type_name(), "auv.VehicleState.v3");
            assert_eq!(<Plan as ZeroCopySend>::type_name(), "auv.Plan.v3");
            assert_eq!(<PlannerStatus as ZeroCopySend>::type_name(), "auv.PlannerStatus.v4");
            assert_eq!(<OperatorCommand as ZeroCopySend>::type_name(), "auv.OperatorCommand.v1");
            assert_eq!(<CommandAck as ZeroCopySend>::type_name(), "auv.CommandAck.v1");
        }
    }

    #[test]
    fn layouts_have_no_implicit_padding() {
        // Sum of field sizes == struct size: nothing uninitialised travels.
        assert_eq!(core::mem::size_of::<Header>(), 40);
        assert_eq!(core::mem::size_of::<WireEdge>(), 32);
        assert_eq!(
            core::mem::size_of::<SnapshotHead>(),
            40 + 8 * 6 + 4 * 6 + 32 * MAX_WIRE_NODES
        );
        assert_eq!(core::mem::size_of::<Plan>(), 40 + 8 * 10 + 4 * 8 + 2 * MAX_WIRE_NODES);
        assert_eq!(core::mem::size_of::<OperatorCommand>(), 40 + 8 * 2 + 4 * 2);
        assert_eq!(core::mem::size_of::<CommandAck>(), 40 + 8 * 2 + 4 * 4);
        assert_eq!(core::mem::size_of::<RawPing>(), core::mem::size_of::<VehicleState>());
        assert_eq!(core::mem::size_of::<RawPong>(), core::mem::size_of::<Plan>());
        assert_eq!(
            core::mem::size_of::<VehicleState>(),
            40 + 8 * 3 + 8 * 5 + 8 * 2 + 4 * 10 + 8 * REJECT_KINDS + 2 * MAX_WIRE_NODES
        );
    }

    #[test]
    fn snapshot_validation_catches_each_fault() {
        assert_eq!(small_snapshot().validate(), Ok(()));
        let mut s = small_snapshot();
        s.nodes[1].x = f64::NAN;
        assert_eq!(s.validate(), Err(RejectKind::NonFinite));
        let mut s = small_snapshot();
        s.edges[1].b = 3;
        assert_eq!(s.validate(), Err(RejectKind::NodeOutOfRange));
        let mut s = small_snapshot();
        s.edge_count = 5;
        assert_eq!(
            s.validate(),
            Err(RejectKind::Malformed),
            "more edges than the buffer holds"
        );
        let s = small_snapshot();
        assert_eq!(
            validate_snapshot(s.head(), &s.edges[..1], 4),
            Err(RejectKind::Malformed),
            "a slice shorter than edge_count"
        );
        let mut big = WaypointSnapshot::with_capacity(1);
        assert_eq!(big.copy_snapshot(&small_snapshot()), Err(RejectKind::Malformed));
        let mut s = small_snapshot();
        s.node_count = MAX_WIRE_NODES as u32 + 1;
        assert_eq!(s.validate(), Err(RejectKind::Malformed));
        let mut s = small_snapshot();
        s.edges[0].risk = 0.0;
        assert_eq!(s.validate(), Err(RejectKind::OutOfRange));
        let mut s = small_snapshot();
        s.goal = 0;
        assert_eq!(s.validate(), Err(RejectKind::Malformed));
        let mut s = small_snapshot();
        s.objective = 9;
        assert_eq!(s.validate(), Err(RejectKind::Malformed));
    }

    #[test]
    fn seq_guard_rejects_replays_and_other_scenarios_and_accepts_restarts() {
        let mut g = SeqGuard::new(42);
        assert_eq!(g.accept(&header(1)), Ok(()));
        assert_eq!(g.accept(&header(2)), Ok(()));
        assert_eq!(g.accept(&header(2)), Err(RejectKind::Repeated));
        assert_eq!(g.accept(&header(1)), Err(RejectKind::OutOfOrder));
        let mut foreign = header(3);
        foreign.fingerprint = 43;
        assert_eq!(g.accept(&foreign), Err(RejectKind::ForeignScenario));
        // A restarted sender (new session) starts again at 1.
        let mut restarted = header(1);
        restarted.session = 8;
        assert_eq!(g.accept(&restarted), Ok(()));
        assert_eq!(g.last(), (8, 1));
    }

    #[test]
    fn reject_counters_print_the_non_zero_kinds() {
        let mut r = RejectCounters::default();
        assert_eq!(r.to_string(), "");
        r.add(RejectKind::Repeated);
        r.add(RejectKind::Repeated);
        r.add(RejectKind::VisitedNode);
        assert_eq!(r.to_string(), "repeated 2, visited_node 1");
        assert_eq!(RejectKind::from_name("non_edge"), Some(RejectKind::NonEdge));
        assert_eq!(RejectKind::from_name("nope"), None);
    }

    #[test]
    fn codes_round_trip() {
        for k in RejectKind::ALL {
            assert_eq!(RejectKind::ALL[k as usize], k);
        }
        assert_eq!(TriggerKind::from_code(4), Some(TriggerKind::Infeasible));
        assert_eq!(TriggerKind::from_code(5), Some(TriggerKind::SensorBack));
        assert_eq!(TriggerKind::from_code(6), Some(TriggerKind::Operator));
        assert_eq!(TriggerKind::from_code(7), None);
        for k in CommandKind::ALL {
            assert_eq!(CommandKind::from_name(k.as_str()), Some(k));
            assert_eq!(CommandKind::from_code(k as u32), Some(k));
        }
        for r in RefuseReason::ALL {
            assert_eq!(RefuseReason::from_code(r as u32), Some(r));
        }
        assert_eq!(
            VehicleMode::from_code(VehicleMode::Holding as u32),
            Some(VehicleMode::Holding)
        );
    }

    fn bytes_to<T: ZeroCopySend>(bytes: &[u8]) -> Box<T> {
        let mut m = boxed_zeroed::<T>();
        let n = core::mem::size_of::<T>().min(bytes.len());
        // SAFETY: any bytes are a valid T (integers and floats only).
        unsafe { core::ptr::copy_nonoverlapping(bytes.as_ptr(), (&mut *m as *mut T).cast::<u8>(), n) };
        m
    }

    proptest! {
        // Garbage on the wire is rejected or accepted, never a panic.
        #[test]
        fn validators_never_panic_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..1024)) {
            let _ = bytes_to::<VehicleState>(&bytes).validate();
            let _ = bytes_to::<Plan>(&bytes).validate();
            let _ = bytes_to::<PlannerStatus>(&bytes).validate();
            let head = bytes_to::<SnapshotHead>(&bytes);
            let edges: Vec<WireEdge> = bytes.chunks_exact(32).map(|c| *bytes_to::<WireEdge>(c)).collect();
            let _ = validate_snapshot(&head, &edges, MAX_WIRE_EDGES);
            let _ = bytes_to::<OperatorCommand>(&bytes).validate();
            let _ = bytes_to::<CommandAck>(&bytes).validate();
        }

        #[test]
        fn accepted_vehicle_states_have_in_range_fields(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
            let s = bytes_to::<VehicleState>(&bytes);
            if s.validate().is_ok() {
                prop_assert!(s.time_left_s.is_finite());
                prop_assert!((s.to_node as usize) < MAX_WIRE_NODES);
                prop_assert!((1..=MAX_WIRE_NODES).contains(&(s.route_len as usize)));
            }
        }
    }
}
