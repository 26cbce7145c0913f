//! Bad input on the wire: the receiver-side checks that need the scenario
//! (not just the message), and the fault injection that tests them.
//!
//! Contract:
//! - [`WireRules`] holds a copy of the scenario's world (node count, start,
//!   goal, nominal positions, bounds, water mask). [`WireRules::check_snapshot`]
//!   accepts exactly the snapshots sensor-sim can produce for that world:
//!   every waypoint over water (else [`RejectKind::OffWater`]), static ones
//!   at their fixed position and dynamic ones inside their bound on every
//!   axis (else [`RejectKind::OutsideBound`]); [`WireRules::check_state`]
//!   keeps a vehicle's node ids inside the network. Both run after
//!   [`crate::msg::Validate`] (finite numbers, counts within capacity) and
//!   allocate nothing.
//! - [`Fault`] names each kind of bad message a process can inject
//!   (`sensor-sim --inject`, `vehicle-sim --inject`, `planner … --inject-plan`),
//!   [`FaultCycle`] takes them in turn, and the `corrupt_*`/[`tamper_header`]
//!   functions turn a good message into a bad one that a receiver rejects
//!   with [`Fault::rejected_as`]. Injected messages are sent *next to* good
//!   ones, never instead of them, so a mission under injection still runs.
//!
//! Units: m; x east, y north, z depth (positive down).

use std::sync::Arc;

use crate::msg::{ContextCheck, Header, MAX_WIRE_NODES, RejectKind, VehicleState, WaypointSnapshot, WireId, route_ids};
use auv_core::capacity::{LARGEST_WORDS, NodeSet};
use auv_world::chart::WaterMap;
use auv_world::load::MissionWorld;
use auv_world::mission_file::Water;
use auv_world::scenario::{World, bound_interval};

/// The scenario-dependent checks of one receiver.
#[derive(Clone, Debug)]
pub struct WireRules {
    world: World,
    water: Water,
}

impl WireRules {
    /// Rules for the world every process of the run built.
    pub fn new(world: &MissionWorld) -> Self {
        Self {
            world: world.world().clone(),
            water: world.map().clone(),
        }
    }

    /// Waypoints in the network.
    pub fn n(&self) -> usize {
        self.world.n()
    }

    /// Whether (x, y) is navigable water, m.
    pub fn is_water(&self, x: f64, y: f64) -> bool {
        self.water.is_water(x, y)
    }

    /// Checks waypoint `i` (< n) at `(x, y, z)`: over water first (a
    /// waypoint on land is the worse fault), then inside its bound.
    fn check_node(&self, i: usize, x: f64, y: f64, z: f64) -> Result<(), RejectKind> {
        if !self.water.is_water(x, y) {
            return Err(RejectKind::OffWater);
        }
        let nom = self.world.nominal_positions()[i];
        if !self.world.is_dynamic(i) {
            // Exact comparison on purpose: static waypoints travel bit-exact.
            return if (x, y, z) == (nom.x, nom.y, nom.z) {
                Ok(())
            } else {
                Err(RejectKind::OutsideBound)
            };
        }
        let b = self.world.bounds()[i];
        let depth_max = self.world.config().depth_max_m;
        for (v, nv, bv, max) in [
            (x, nom.x, b.x, self.world.width_m()),
            (y, nom.y, b.y, self.world.height_m()),
            (z, nom.z, b.z, depth_max),
        ] {
            let (lo, hi) = bound_interval(nv, bv, max);
            if !(lo <= v && v <= hi) {
                return Err(RejectKind::OutsideBound);
            }
        }
        Ok(())
    }

    /// Checks a (well-formed) snapshot against the world.
    pub fn check_snapshot(&self, s: &WaypointSnapshot) -> Result<(), RejectKind> {
        let n = self.n();
        let count = s.node_count as usize;
        if count > n {
            return Err(RejectKind::NodeOutOfRange);
        }
        if count != n || s.start as usize != self.world.start() || s.goal as usize != self.world.goal() {
            return Err(RejectKind::Malformed);
        }
        for (i, p) in s.nodes[..n].iter().enumerate() {
            self.check_node(i, p.x, p.y, p.z)?;
        }
        Ok(())
    }

    /// Checks a (well-formed) vehicle state against the network size.
    pub fn check_state(&self, s: &VehicleState) -> Result<(), RejectKind> {
        let n = self.n();
        let in_net = |id: u32| (id as usize) < n;
        if !in_net(s.from_node) || !in_net(s.to_node) {
            return Err(RejectKind::NodeOutOfRange);
        }
        if route_ids(&s.route, s.route_len)
            .iter()
            .any(|&id| !in_net(u32::from(id)))
        {
            return Err(RejectKind::NodeOutOfRange);
        }
        Ok(())
    }

    /// A point on land inside the chart, if the chart has any (scanned on a
    /// 128 × 128 grid): where an `off_water` injection puts a waypoint.
    pub fn land_point(&self) -> Option<(f64, f64)> {
        const GRID: usize = 128;
        let (w, h) = (self.world.width_m(), self.world.height_m());
        (0..GRID * GRID)
            .map(|k| {
                let (c, r) = (k % GRID, k / GRID);
                ((c as f64 + 0.5) * w / GRID as f64, (r as f64 + 0.5) * h / GRID as f64)
            })
            .find(|&(x, y)| !self.water.is_water(x, y))
    }

    /// `check_snapshot` as a [`ContextCheck`] for a guarded inbox.
    pub fn snapshot_check(self: &Arc<Self>) -> ContextCheck<WaypointSnapshot> {
        let r = Arc::clone(self);
        Box::new(move |s| r.check_snapshot(s))
    }

    /// `check_state` as a [`ContextCheck`] for a guarded inbox.
    pub fn state_check(self: &Arc<Self>) -> ContextCheck<VehicleState> {
        let r = Arc::clone(self);
        Box::new(move |s| r.check_state(s))
    }

    /// The world's nominal position and bound of waypoint `i` (for injection).
    fn nominal_and_bound(&self, i: usize) -> ([f64; 3], [f64; 3]) {
        let (p, b) = (self.world.nominal_positions()[i], self.world.bounds()[i]);
        let b = if self.world.is_dynamic(i) {
            [b.x, b.y, b.z]
        } else {
            [0.0; 3]
        };
        ([p.x, p.y, p.z], b)
    }
}

/// A kind of bad message that can be injected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// A NaN coordinate.
    NonFinite,
    /// A node id outside the network.
    NodeOutOfRange,
    /// A waypoint moved onto land.
    OffWater,
    /// A waypoint moved outside its bound (in depth, so it stays over water).
    OutsideBound,
    /// A sequence number below the last one sent.
    OutOfOrder,
    /// The last message again, same sequence number.
    Repeated,
    /// Another scenario's fingerprint.
    ForeignScenario,
    /// A plan through a pair of waypoints that is no edge.
    NonEdge,
    /// A plan back through a waypoint the vehicle already visited.
    VisitedNode,
    /// An unknown enum code (objective, vehicle mode).
    Malformed,
    /// A number outside its range (speed ≤ 0, negative time to be free).
    OutOfRange,
    /// A plan that does not start where the vehicle will be free.
    BadPlan,
}

impl Fault {
    /// Every fault, in the order of [`Fault::as_str`]'s documentation.
    pub const ALL: [Fault; 12] = [
        Self::NonFinite,
        Self::NodeOutOfRange,
        Self::OffWater,
        Self::OutsideBound,
        Self::OutOfOrder,
        Self::Repeated,
        Self::ForeignScenario,
        Self::NonEdge,
        Self::VisitedNode,
        Self::Malformed,
        Self::OutOfRange,
        Self::BadPlan,
    ];

    /// The flag value naming this fault (the name of the rejection it causes).
    pub fn as_str(self) -> &'static str {
        self.rejected_as().as_str()
    }

    /// How a receiver classifies the injected message.
    pub fn rejected_as(self) -> RejectKind {
        match self {
            Self::NonFinite => RejectKind::NonFinite,
            Self::NodeOutOfRange => RejectKind::NodeOutOfRange,
            Self::OffWater => RejectKind::OffWater,
            Self::OutsideBound => RejectKind::OutsideBound,
            Self::OutOfOrder => RejectKind::OutOfOrder,
            Self::Repeated => RejectKind::Repeated,
            Self::ForeignScenario => RejectKind::ForeignScenario,
            Self::NonEdge => RejectKind::NonEdge,
            Self::VisitedNode => RejectKind::VisitedNode,
            Self::Malformed => RejectKind::Malformed,
            Self::OutOfRange => RejectKind::OutOfRange,
            Self::BadPlan => RejectKind::BadPlan,
        }
    }

    /// Whether the fault is in the header (sequence number, fingerprint)
    /// rather than the payload. Sequence faults are sent *after* the good
    /// message they copy; the others before it, so the latest value a late
    /// subscriber gets is a good one.
    pub fn in_header(self) -> bool {
        matches!(self, Self::OutOfOrder | Self::Repeated | Self::ForeignScenario)
    }

    /// Whether the fault is sent after the good message.
    pub fn after_good(self) -> bool {
        matches!(self, Self::OutOfOrder | Self::Repeated)
    }
}

/// Faults sensor-sim can inject into waypoint snapshots.
pub const SENSOR_FAULTS: [Fault; 9] = [
    Fault::NonFinite,
    Fault::NodeOutOfRange,
    Fault::OffWater,
    Fault::OutsideBound,
    Fault::OutOfOrder,
    Fault::Repeated,
    Fault::ForeignScenario,
    Fault::Malformed,
    Fault::OutOfRange,
];

/// Faults vehicle-sim can inject into its state messages.
pub const VEHICLE_FAULTS: [Fault; 7] = [
    Fault::NonFinite,
    Fault::NodeOutOfRange,
    Fault::OutOfOrder,
    Fault::Repeated,
    Fault::ForeignScenario,
    Fault::Malformed,
    Fault::OutOfRange,
];

/// Faults the planner can inject into its plans.
pub const PLAN_FAULTS: [Fault; 3] = [Fault::NonEdge, Fault::VisitedNode, Fault::BadPlan];

/// A bad `--inject` list.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{flag} {value:?}: unknown kind {kind:?}; expected a comma-separated list of {expected}, or all")]
pub struct FaultListError {
    /// The flag.
    pub flag: &'static str,
    /// Its whole value.
    pub value: String,
    /// The item not understood.
    pub kind: String,
    /// The kinds this flag accepts.
    pub expected: String,
}

/// The faults to inject, taken in turn. Fixed size and `Copy`: no allocation
/// where it is used (the planner's service loop).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultCycle {
    faults: [Option<Fault>; 12],
    len: usize,
    next: usize,
}

impl FaultCycle {
    /// No faults.
    pub const NONE: FaultCycle = FaultCycle {
        faults: [None; 12],
        len: 0,
        next: 0,
    };

    /// Parses `value` ("kind,kind,…" or "all") for `flag`, accepting only
    /// `allowed`. Duplicates are kept once.
    pub fn parse(flag: &'static str, value: &str, allowed: &[Fault]) -> Result<Self, FaultListError> {
        let mut c = Self::NONE;
        let err = |kind: &str| FaultListError {
            flag,
            value: value.to_string(),
            kind: kind.to_string(),
            expected: allowed.iter().map(|f| f.as_str()).collect::<Vec<_>>().join(", "),
        };
        for item in value.split(',').map(str::trim) {
            if item == "all" {
                for &f in allowed {
                    c.push(f);
                }
                continue;
            }
            match allowed.iter().find(|f| f.as_str() == item) {
                Some(&f) => c.push(f),
                None => return Err(err(item)),
            }
        }
        Ok(c)
    }

    /// Parses an optional flag value (absent: no faults).
    pub fn parse_opt(flag: &'static str, value: Option<&str>, allowed: &[Fault]) -> Result<Self, FaultListError> {
        value.map_or(Ok(Self::NONE), |v| Self::parse(flag, v, allowed))
    }

    fn push(&mut self, f: Fault) {
        if !self.iter().any(|g| g == f) && self.len < self.faults.len() {
            self.faults[self.len] = Some(f);
            self.len += 1;
        }
    }

    /// Whether there is nothing to inject.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The faults, in order.
    pub fn iter(&self) -> impl Iterator<Item = Fault> + '_ {
        self.faults[..self.len].iter().flatten().copied()
    }

    /// The next fault to inject (without taking it).
    pub fn peek(&self) -> Option<Fault> {
        (self.len > 0).then(|| self.faults[self.next % self.len]).flatten()
    }

    /// Takes the next fault, cycling.
    pub fn advance(&mut self) -> Option<Fault> {
        let f = self.peek()?;
        self.next = (self.next + 1) % self.len;
        Some(f)
    }

    /// Comma-separated names (for the flag a child process gets).
    pub fn to_flag_value(&self) -> String {
        self.iter().map(|f| f.as_str()).collect::<Vec<_>>().join(",")
    }
}

/// Mixed into a fingerprint to forge another scenario's.
const FOREIGN_XOR: u64 = 0x5EED_F00D_0BAD_CAFE;

/// Rewrites a stamped header for a header fault; `last_good_seq` is the
/// sequence number of the good message just sent (≥ 1). Payload faults
/// leave it alone.
pub fn tamper_header(f: Fault, h: &mut Header, last_good_seq: u64) {
    match f {
        Fault::Repeated => h.seq = last_good_seq,
        // Below the last accepted one, never 0 (0 is malformed, not out of order).
        Fault::OutOfOrder => h.seq = last_good_seq.saturating_sub(1).max(1),
        Fault::ForeignScenario => h.fingerprint ^= FOREIGN_XOR,
        _ => {}
    }
}

/// Corrupts the payload of a good snapshot for a payload fault; `k` picks
/// the waypoint (any value). Returns false when the fault cannot be built
/// here (a header fault, or no land on the chart for `off_water`).
pub fn corrupt_snapshot(f: Fault, s: &mut WaypointSnapshot, rules: &WireRules, k: u64) -> bool {
    let n = (s.node_count as usize).clamp(1, MAX_WIRE_NODES);
    let i = (k % n as u64) as usize;
    match f {
        Fault::NonFinite => {
            s.nodes[i].x = f64::NAN;
            true
        }
        Fault::NodeOutOfRange => {
            let m = s.edges_in_use().len();
            if m > 0 {
                let e = (k % m as u64) as usize;
                s.edges[e].b = s.node_count;
            } else {
                s.goal = s.node_count;
            }
            true
        }
        Fault::OffWater => match rules.land_point() {
            Some((x, y)) => {
                s.nodes[i].x = x;
                s.nodes[i].y = y;
                true
            }
            None => false,
        },
        Fault::OutsideBound => {
            // Deeper than the bound allows: still over water, so the bound
            // check (not the water check) rejects it.
            let (nom, b) = rules.nominal_and_bound(i.min(rules.n() - 1));
            s.nodes[i].z = nom[2] + b[2] + 1.0;
            true
        }
        Fault::Malformed => {
            s.objective = u32::MAX;
            true
        }
        Fault::OutOfRange => {
            s.speed_mps = -s.speed_mps;
            true
        }
        _ => false,
    }
}

/// Corrupts the payload of a good vehicle state for a payload fault; `n` is
/// the network's waypoint count. Returns false for a header fault.
pub fn corrupt_state(f: Fault, s: &mut VehicleState, n: usize) -> bool {
    match f {
        Fault::NonFinite => {
            s.position[0] = f64::INFINITY;
            true
        }
        Fault::NodeOutOfRange => {
            s.to_node = n as u32;
            true
        }
        Fault::Malformed => {
            s.mode = u32::MAX;
            true
        }
        Fault::OutOfRange => {
            s.eta_free_s = -1.0;
            true
        }
        _ => false,
    }
}

/// A bad route for a plan fault, written to `out`: from the good route's
/// first node (where the vehicle will be free) to the goal, through a node
/// that is no neighbour (`non_edge`) or already visited (`visited_node`);
/// or the goal alone, which is not where the vehicle will be free
/// (`bad_plan`).
/// `visited` is the vehicle's route so far. Returns the length, or `None`
/// when the fault cannot be built now (e.g. nothing visited yet).
pub fn bad_route(
    f: Fault,
    good: &[u16],
    snap: &WaypointSnapshot,
    visited: &[WireId],
    out: &mut [WireId; MAX_WIRE_NODES],
) -> Option<usize> {
    let (first, goal) = (*good.first()?, *good.last()?);
    if first == goal {
        return None;
    }
    let n = (snap.node_count as usize).min(MAX_WIRE_NODES);
    let mut seen: NodeSet<LARGEST_WORDS> = NodeSet::EMPTY;
    for &v in visited {
        seen.insert(v as usize);
    }
    if f == Fault::BadPlan {
        out[0] = goal;
        return Some(1);
    }
    let via = match f {
        Fault::NonEdge => (0..n).find(|&x| {
            x != first as usize && !seen.contains(x) && crate::network::find_edge(snap, first as usize, x).is_none()
        })?,
        Fault::VisitedNode => visited
            .iter()
            .map(|&v| v as usize)
            .find(|&v| v != first as usize && v != goal as usize)?,
        _ => return None,
    };
    out[0] = first;
    out[1] = via as WireId;
    if via == goal as usize {
        return Some(2);
    }
    out[2] = goal;
    Some(3)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Validate, boxed_zeroed};
    use crate::network::write_snapshot;
    use auv_world::load::{ScenarioArgs, load_world};

    fn world(seed: u64) -> MissionWorld {
        load_world(&ScenarioArgs {
            seed: Some(seed),
            nodes: Some(16),
            ..Default::default()
        })
        .unwrap()
    }

    fn snapshot(w: &MissionWorld, epoch: u64) -> WaypointSnapshot {
        let mut s = WaypointSnapshot::new();
        write_snapshot(&w.snapshot(), epoch, &mut s).unwrap();
        s.header.seq = 1;
        s
    }

    #[test]
    fn every_snapshot_the_sensor_can_send_passes() {
        let mut w = world(3);
        let rules = WireRules::new(&w);
        for epoch in 0..40 {
            if epoch > 0 {
                w.redraw(epoch);
            }
            let s = snapshot(&w, epoch);
            assert_eq!(s.validate(), Ok(()));
            assert_eq!(rules.check_snapshot(&s), Ok(()), "epoch {epoch}");
        }
    }

    #[test]
    fn each_injected_snapshot_fault_is_rejected_as_its_kind() {
        let w = world(4);
        let rules = WireRules::new(&w);
        for f in SENSOR_FAULTS.into_iter().filter(|f| !f.in_header()) {
            for k in 0..16 {
                let mut s = snapshot(&w, 0);
                assert!(corrupt_snapshot(f, &mut s, &rules, k), "{f:?}");
                let verdict = s.validate().and_then(|()| rules.check_snapshot(&s));
                assert_eq!(verdict, Err(f.rejected_as()), "{f:?} k={k}");
            }
        }
    }

    #[test]
    fn a_snapshot_of_another_world_fails_the_rules() {
        let rules = WireRules::new(&world(5));
        let other = snapshot(&world(6), 0);
        assert!(rules.check_snapshot(&other).is_err());
    }

    #[test]
    fn injected_state_faults_are_rejected_as_their_kind() {
        let rules = WireRules::new(&world(4));
        let mut s = *boxed_zeroed::<VehicleState>();
        s.header.seq = 2;
        s.route_len = 1;
        assert_eq!(s.validate().and_then(|()| rules.check_state(&s)), Ok(()));
        for f in VEHICLE_FAULTS.into_iter().filter(|f| !f.in_header()) {
            let mut bad = s;
            assert!(corrupt_state(f, &mut bad, rules.n()));
            assert_eq!(
                bad.validate().and_then(|()| rules.check_state(&bad)),
                Err(f.rejected_as())
            );
        }
        let mut g = crate::msg::SeqGuard::new(9);
        let mut h = Header {
            seq: 5,
            fingerprint: 9,
            ..Header::default()
        };
        g.accept(&h).unwrap();
        for f in [Fault::Repeated, Fault::OutOfOrder, Fault::ForeignScenario] {
            let mut bad = h;
            tamper_header(f, &mut bad, 5);
            assert_eq!(g.accept(&bad), Err(f.rejected_as()), "{f:?}");
        }
        h.seq = 6;
        assert_eq!(g.accept(&h), Ok(()), "the good flow goes on");
    }

    #[test]
    fn bad_routes_use_a_non_edge_or_a_visited_node() {
        let w = world(7);
        let s = snapshot(&w, 0);
        let (start, goal) = (s.start as WireId, s.goal as WireId);
        let mut out = [0; MAX_WIRE_NODES];
        let len = bad_route(Fault::NonEdge, &[start, goal], &s, &[start], &mut out).unwrap();
        let r = &out[..len];
        assert_eq!((r[0], r[len - 1]), (start, goal));
        assert!(crate::network::find_edge(&s, r[0] as usize, r[1] as usize).is_none());
        // Nothing visited but the start: no visited-node plan can be built yet.
        assert_eq!(
            bad_route(Fault::VisitedNode, &[start, goal], &s, &[start], &mut out),
            None
        );
        let len = bad_route(Fault::VisitedNode, &[3, goal], &s, &[start, 3], &mut out).unwrap();
        assert_eq!(&out[..len], &[3, start, goal]);
        let len = bad_route(Fault::BadPlan, &[3, goal], &s, &[start, 3], &mut out).unwrap();
        assert_eq!(&out[..len], &[goal]);
        assert_eq!(bad_route(Fault::OffWater, &[3, goal], &s, &[start, 3], &mut out), None);
    }

    #[test]
    fn fault_lists_parse_and_unknown_kinds_are_one_line_errors() {
        let c = FaultCycle::parse("--inject", "repeated,non_finite,repeated", &SENSOR_FAULTS).unwrap();
        assert_eq!(c.iter().collect::<Vec<_>>(), vec![Fault::Repeated, Fault::NonFinite]);
        assert_eq!(c.to_flag_value(), "repeated,non_finite");
        let mut c = c;
        assert_eq!(c.advance(), Some(Fault::Repeated));
        assert_eq!(c.advance(), Some(Fault::NonFinite));
        assert_eq!(c.advance(), Some(Fault::Repeated));
        let all = FaultCycle::parse("--inject", "all", &VEHICLE_FAULTS).unwrap();
        assert_eq!(all.iter().count(), VEHICLE_FAULTS.len());
        let e = FaultCycle::parse("--inject", "non_finite,bogus", &SENSOR_FAULTS).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("\"bogus\"") && msg.contains("off_water") && !msg.contains('\n'),
            "{msg}"
        );
        assert!(FaultCycle::parse("--inject-plan", "off_water", &PLAN_FAULTS).is_err());
        assert!(FaultCycle::parse("--inject", "", &SENSOR_FAULTS).is_err());
        assert!(
            FaultCycle::parse_opt("--inject", None, &SENSOR_FAULTS)
                .unwrap()
                .is_empty()
        );
    }
}
