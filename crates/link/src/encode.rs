//! The JSON encoding of everything on the shore link, `auv-shore/1`.
//!
//! Every payload is one JSON object with `format` (= [`FORMAT`]) and `type`:
//! the iceoryx2 type name of the onboard message it carries
//! (`auv.VehicleState.v3`, `auv.Plan.v3`, `auv.PlannerStatus.v4`,
//! `auv.WaypointSnapshot.v2`, `auv.CommandAck.v1`) or one of the link's own
//! (`auv.shore.Heartbeat`, `auv.shore.Event`, `auv.shore.Command`). Enum
//! codes travel as their snake_case names; units as on the wire (m, s, ns;
//! x east, y north, z down). A receiver refuses a payload whose format or
//! type is not the one it expects ([`decode`]); fields may be added within
//! a format version, never changed or removed (that is `auv-shore/2`).

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use auv_messages::msg::{
    AckStatus, CommandAck, CommandKind, FromCode, Outcome, Plan, PlannerPhase, PlannerStatus, RefuseReason,
    TriggerKind, VehicleEvent, VehicleMode, VehicleState, WaypointSnapshot, outcome_name, route_ids,
};

/// The encoding's name and version.
pub const FORMAT: &str = "auv-shore/1";

/// Type of [`Heartbeat`].
pub const HEARTBEAT_TYPE: &str = "auv.shore.Heartbeat";
/// Type of [`Event`].
pub const EVENT_TYPE: &str = "auv.shore.Event";
/// Type of [`Command`].
pub const COMMAND_TYPE: &str = "auv.shore.Command";
/// The command that replaces the mission: the link and the mission's
/// supervisor carry it out (it never reaches the planner), so it is no
/// onboard `CommandKind`.
pub const REPLACE_MISSION: &str = "replace-mission";

/// Why a payload was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DecodeError {
    /// Not JSON, or a field missing or of the wrong type.
    #[error("not an {FORMAT} {expected} payload: {detail}")]
    Json {
        /// The type expected.
        expected: &'static str,
        /// serde's message.
        detail: String,
    },
    /// Another format or version.
    #[error("format {found:?}, expected {FORMAT:?}")]
    Format {
        /// The format found.
        found: String,
    },
    /// Another message type.
    #[error("type {found:?}, expected {expected:?}")]
    Type {
        /// The type expected.
        expected: &'static str,
        /// The type found.
        found: String,
    },
}

/// A message type of the link.
pub trait LinkMessage: Serialize + DeserializeOwned {
    /// Its `type` field.
    fn type_name(&self) -> &str;
    /// Its `format` field.
    fn format(&self) -> &str;
}

macro_rules! link_message {
    ($($t:ty),+) => { $(impl LinkMessage for $t {
        fn type_name(&self) -> &str { &self.type_name }
        fn format(&self) -> &str { &self.format }
    })+ };
}

/// Decodes a payload of type `expected`.
pub fn decode<T: LinkMessage>(bytes: &[u8], expected: &'static str) -> Result<T, DecodeError> {
    // Format and type first, so another version is named as such rather
    // than as a missing field.
    #[derive(Deserialize)]
    struct Envelope {
        format: String,
        #[serde(rename = "type")]
        type_name: String,
    }
    let json = |e: serde_json::Error| DecodeError::Json {
        expected,
        detail: e.to_string(),
    };
    let env: Envelope = serde_json::from_slice(bytes).map_err(json)?;
    if env.format != FORMAT {
        return Err(DecodeError::Format { found: env.format });
    }
    if env.type_name != expected {
        return Err(DecodeError::Type {
            expected,
            found: env.type_name,
        });
    }
    serde_json::from_slice(bytes).map_err(json)
}

/// Encodes a message (serialising these plain structs cannot fail).
pub fn encode<T: LinkMessage>(m: &T) -> Vec<u8> {
    serde_json::to_vec(m).unwrap_or_default()
}

fn iox_type<T: auv_messages::msg::Message>() -> String {
    auv_messages::msg::type_name_of::<T>().to_string()
}

fn name_of<T: FromCode + core::fmt::Debug>(code: u32) -> String {
    // The Debug name in snake_case ("NoPlan" -> "no_plan").
    T::from_code(code).map_or_else(
        || format!("unknown_{code}"),
        |v| {
            let mut out = String::new();
            for (i, ch) in format!("{v:?}").chars().enumerate() {
                if ch.is_ascii_uppercase() && i > 0 {
                    out.push('_');
                }
                out.push(ch.to_ascii_lowercase());
            }
            out
        },
    )
}

/// The header fields every onboard message keeps.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Origin {
    /// Sequence number of the onboard sender's session.
    pub seq: u64,
    /// The onboard sender's session.
    pub session: u64,
    /// Mission time the message describes, s.
    pub t: f64,
    /// Onboard `CLOCK_MONOTONIC` when it was sent, ns (comparable with the
    /// shore's clock only when both run on one host, as in the tests).
    pub sent_mono_ns: u64,
}

fn origin(h: &auv_messages::msg::Header) -> Origin {
    Origin {
        seq: h.seq,
        session: h.session,
        t: h.mission_time_s,
        sent_mono_ns: h.sent_mono_ns,
    }
}

/// `auv.VehicleState.v3` on `…/state`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct State {
    /// [`FORMAT`].
    pub format: String,
    /// `auv.VehicleState.v3`.
    #[serde(rename = "type")]
    pub type_name: String,
    /// Its header.
    #[serde(flatten)]
    pub origin: Origin,
    /// x east, y north, z down, m.
    pub position: [f64; 3],
    /// Mission time left, s.
    pub time_left_s: f64,
    /// Weight collected.
    pub weight: f64,
    /// Distance travelled, m.
    pub distance_m: f64,
    /// `seq` of the plan followed (0: none).
    pub plan_seq: u64,
    /// `no_plan`, `travelling`, `working`, `holding`, `finished`.
    pub mode: String,
    /// `periodic`, `start`, `arrival`, `tick`, `finished`.
    pub event: String,
    /// `running`, `goal_reached`, `timed_out`, `aborted`, `safe_hold`.
    pub outcome: String,
    /// Waypoint the vehicle heads to or is at.
    pub to_node: u32,
    /// Tasks completed.
    pub tasks_completed: u32,
    /// Waypoints visited, in order.
    pub route: Vec<u16>,
}

impl State {
    /// The link's view of a vehicle state.
    pub fn of(s: &VehicleState) -> Self {
        Self {
            format: FORMAT.into(),
            type_name: iox_type::<VehicleState>(),
            origin: origin(&s.header),
            position: s.position,
            time_left_s: s.time_left_s,
            weight: s.weight,
            distance_m: s.distance_m,
            plan_seq: s.plan_seq,
            mode: name_of::<VehicleMode>(s.mode),
            event: name_of::<VehicleEvent>(s.event),
            outcome: Outcome::from_code(s.outcome).map_or("unknown", outcome_name).into(),
            to_node: s.to_node,
            tasks_completed: s.tasks_completed,
            route: route_ids(&s.route, s.route_len).to_vec(),
        }
    }

    /// Whether the mission is over.
    pub fn finished(&self) -> bool {
        self.outcome != "running"
    }
}

/// `auv.Plan.v3` on `…/plan`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlanMsg {
    /// [`FORMAT`].
    pub format: String,
    /// `auv.Plan.v3`.
    #[serde(rename = "type")]
    pub type_name: String,
    /// Its header.
    #[serde(flatten)]
    pub origin: Origin,
    /// Re-plan counter.
    pub replan: u32,
    /// Why: `initial`, `arrival`, `edge_lost`, `time_changed`, `infeasible`, `sensor_back`, `operator`.
    pub trigger: String,
    /// Waypoints from where the vehicle will be free to the goal.
    pub route: Vec<u16>,
    /// Predicted route time, s.
    pub time_s: f64,
    /// Predicted weight.
    pub weight: f64,
    /// Predicted distance, m.
    pub distance_m: f64,
    /// Budget planned for, s.
    pub budget_s: f64,
    /// The route fits the budget.
    pub feasible: bool,
    /// Snapshot epoch planned on.
    pub snapshot_epoch: u64,
    /// Solver iterations run.
    pub iterations: u32,
    /// The deadline cut the solve short.
    pub deadline_cut: bool,
    /// Trigger taken off the transport → plan filled, ns (onboard).
    pub compute_ns: u64,
}

impl PlanMsg {
    /// The link's view of a plan.
    pub fn of(p: &Plan) -> Self {
        Self {
            format: FORMAT.into(),
            type_name: iox_type::<Plan>(),
            origin: origin(&p.header),
            replan: p.replan,
            trigger: name_of::<TriggerKind>(p.trigger),
            route: route_ids(&p.route, p.route_len).to_vec(),
            time_s: p.time_s,
            weight: p.weight,
            distance_m: p.distance_m,
            budget_s: p.budget_s,
            feasible: p.feasible == 1,
            snapshot_epoch: p.snapshot_epoch,
            iterations: p.iterations,
            deadline_cut: p.deadline_cut == 1,
            compute_ns: p.compute_ns,
        }
    }
}

/// `auv.PlannerStatus.v4` on `…/status` (the figures an operator watches).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Status {
    /// [`FORMAT`].
    pub format: String,
    /// `auv.PlannerStatus.v4`.
    #[serde(rename = "type")]
    pub type_name: String,
    /// Its header.
    #[serde(flatten)]
    pub origin: Origin,
    /// `waiting`, `running`, `finished`.
    pub phase: String,
    /// Plans published.
    pub plans: u64,
    /// Plans later than the deadline.
    pub deadline_misses: u64,
    /// Plans that fell back to the quickest path.
    pub fallbacks: u64,
    /// Trigger → plan published latency, median, ns.
    pub latency_p50_ns: u64,
    /// The same, 99th percentile, ns.
    pub latency_p99_ns: u64,
    /// Input messages the planner rejected.
    pub rejected: u64,
}

impl Status {
    /// The link's view of a planner status.
    pub fn of(s: &PlannerStatus) -> Self {
        Self {
            format: FORMAT.into(),
            type_name: iox_type::<PlannerStatus>(),
            origin: origin(&s.header),
            phase: name_of::<PlannerPhase>(s.phase),
            plans: s.plans,
            deadline_misses: s.deadline_misses,
            fallbacks: s.fallbacks,
            latency_p50_ns: s.latency_p50_ns,
            latency_p99_ns: s.latency_p99_ns,
            rejected: s.rejected.iter().sum(),
        }
    }
}

/// `auv.WaypointSnapshot.v2` on `…/snapshot`: the network's summary (the
/// waypoints where the sensor reports them; no edges).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    /// [`FORMAT`].
    pub format: String,
    /// `auv.WaypointSnapshot.v2`.
    #[serde(rename = "type")]
    pub type_name: String,
    /// Its header.
    #[serde(flatten)]
    pub origin: Origin,
    /// Sensor update counter.
    pub epoch: u64,
    /// Edges in the network now.
    pub edge_count: u32,
    /// Start waypoint.
    pub start: u32,
    /// Goal waypoint.
    pub goal: u32,
    /// The mission's time budget, s.
    pub time_available_s: f64,
    /// Waypoint positions by id, [x east, y north], m.
    pub nodes: Vec<[f64; 2]>,
}

impl Snapshot {
    /// The link's view of a snapshot.
    pub fn of(s: &WaypointSnapshot) -> Self {
        let n = (s.node_count as usize).min(s.nodes.len());
        Self {
            format: FORMAT.into(),
            type_name: iox_type::<WaypointSnapshot>(),
            origin: origin(&s.header),
            epoch: s.epoch,
            edge_count: s.edge_count,
            start: s.start,
            goal: s.goal,
            time_available_s: s.time_available_s,
            nodes: s.nodes[..n].iter().map(|p| [p.x, p.y]).collect(),
        }
    }
}

/// `auv.CommandAck.v1` on `…/ack`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ack {
    /// [`FORMAT`].
    pub format: String,
    /// `auv.CommandAck.v1`.
    #[serde(rename = "type")]
    pub type_name: String,
    /// The command answered.
    pub id: u64,
    /// Its kind (`abort-to-goal`, …; `unknown` when malformed).
    pub command: String,
    /// `applied` or `refused`.
    pub status: String,
    /// Why it was refused (`none` when applied).
    pub reason: String,
    /// `seq` of the plan it caused (0: none).
    pub plan_seq: u64,
    /// Re-plan counter of that plan (0: none).
    pub replan: u32,
    /// Mission time of the answer, s.
    pub t: f64,
    /// The reason in words, when there is more to say than its name (a
    /// refused replace-mission: the mission file's error line).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detail: Option<String>,
}

impl Ack {
    /// The link's view of an ack.
    pub fn of(a: &CommandAck) -> Self {
        Self::new(
            a.command_id,
            CommandKind::from_code(a.kind).map_or("unknown", CommandKind::as_str),
            AckStatus::from_code(a.status) == Some(AckStatus::Applied),
            RefuseReason::from_code(a.reason).map_or("unknown", RefuseReason::as_str),
            (a.plan_seq, a.replan),
            a.header.mission_time_s,
        )
    }

    /// An ack built by the bridge itself (a command it could not forward).
    pub fn new(id: u64, command: &str, applied: bool, reason: &str, plan: (u64, u32), t: f64) -> Self {
        Self {
            format: FORMAT.into(),
            type_name: iox_type::<CommandAck>(),
            id,
            command: command.into(),
            status: if applied { "applied" } else { "refused" }.into(),
            reason: reason.into(),
            plan_seq: plan.0,
            replan: plan.1,
            t,
            detail: None,
        }
    }

    /// Whether the command was applied.
    pub fn applied(&self) -> bool {
        self.status == "applied"
    }
}

/// `auv.shore.Command` on `…/command`: what the operator asks for, with
/// waypoints by name (or id).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Command {
    /// [`FORMAT`].
    pub format: String,
    /// [`COMMAND_TYPE`].
    #[serde(rename = "type")]
    pub type_name: String,
    /// Unique per command, never 0; a command sent again keeps its id.
    pub id: u64,
    /// `abort-to-goal`, `set-time-budget`, `add-task`, `remove-task`.
    pub command: String,
    /// set-time-budget: the new mission time budget, s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub budget_s: Option<f64>,
    /// add-task, remove-task: the waypoint's name in the mission file (or its id).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub waypoint: Option<String>,
    /// replace-mission: the new mission file (`auv-mission/1` TOML), whole.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mission: Option<String>,
}

impl Command {
    /// A command of kind `command`.
    pub fn new(id: u64, command: CommandKind, budget_s: Option<f64>, waypoint: Option<String>) -> Self {
        Self {
            format: FORMAT.into(),
            type_name: COMMAND_TYPE.into(),
            id,
            command: command.as_str().into(),
            budget_s,
            waypoint,
            mission: None,
        }
    }

    /// A [`REPLACE_MISSION`] command carrying the mission file `text`.
    pub fn replace_mission(id: u64, text: String) -> Self {
        Self {
            format: FORMAT.into(),
            type_name: COMMAND_TYPE.into(),
            id,
            command: REPLACE_MISSION.into(),
            budget_s: None,
            waypoint: None,
            mission: Some(text),
        }
    }
}

/// `auv.shore.Heartbeat` on `…/heartbeat/onboard` and `…/heartbeat/shore`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Heartbeat {
    /// [`FORMAT`].
    pub format: String,
    /// [`HEARTBEAT_TYPE`].
    #[serde(rename = "type")]
    pub type_name: String,
    /// `onboard` or `shore`.
    pub side: String,
    /// Counter per sender start.
    pub seq: u64,
    /// The sender's start (any value, constant while it runs).
    pub session: u64,
    /// Latest mission time the sender knows, s.
    pub t: f64,
    /// The link state as the sender sees it (`waiting`, `up`, `lost`).
    pub link: String,
}

impl Heartbeat {
    /// A heartbeat of `side`.
    pub fn new(side: &str, seq: u64, session: u64, t: f64, link: &str) -> Self {
        Self {
            format: FORMAT.into(),
            type_name: HEARTBEAT_TYPE.into(),
            side: side.into(),
            seq,
            session,
            t,
            link: link.into(),
        }
    }
}

/// `auv.shore.Event` on `…/event`: the link's and the mission's events.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// [`FORMAT`].
    pub format: String,
    /// [`EVENT_TYPE`].
    #[serde(rename = "type")]
    pub type_name: String,
    /// `link_restored`, `mission_end`.
    pub event: String,
    /// Mission time, s.
    pub t: f64,
    /// mission_end: the outcome (`goal_reached`, …).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outcome: Option<String>,
    /// link_restored: how long the link was down, ms.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub down_ms: Option<f64>,
}

impl Event {
    /// An event named `event` at mission time `t`.
    pub fn new(event: &str, t: f64) -> Self {
        Self {
            format: FORMAT.into(),
            type_name: EVENT_TYPE.into(),
            event: event.into(),
            t,
            outcome: None,
            down_ms: None,
        }
    }
}

link_message!(State, PlanMsg, Status, Snapshot, Ack, Command, Heartbeat, Event);

/// The `type` of each onboard message kind, for decoding.
pub mod types {
    /// [`super::State`].
    pub const STATE: &str = "auv.VehicleState.v3";
    /// [`super::PlanMsg`].
    pub const PLAN: &str = "auv.Plan.v3";
    /// [`super::Status`].
    pub const STATUS: &str = "auv.PlannerStatus.v4";
    /// [`super::Snapshot`].
    pub const SNAPSHOT: &str = "auv.WaypointSnapshot.v2";
    /// [`super::Ack`].
    pub const ACK: &str = "auv.CommandAck.v1";
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_messages::msg::boxed_zeroed;

    #[test]
    fn type_names_are_the_onboard_ones() {
        let p = boxed_zeroed::<Plan>();
        assert_eq!(PlanMsg::of(&p).type_name, types::PLAN);
        assert_eq!(State::of(&boxed_zeroed::<VehicleState>()).type_name, types::STATE);
        assert_eq!(Status::of(&boxed_zeroed::<PlannerStatus>()).type_name, types::STATUS);
        assert_eq!(
            Snapshot::of(&WaypointSnapshot::with_capacity(0)).type_name,
            types::SNAPSHOT
        );
        assert_eq!(Ack::of(&boxed_zeroed::<CommandAck>()).type_name, types::ACK);
    }

    #[test]
    fn a_plan_round_trips_and_other_formats_or_types_are_named() {
        let mut p = *boxed_zeroed::<Plan>();
        p.header.seq = 7;
        p.replan = 3;
        p.trigger = TriggerKind::EdgeLost as u32;
        p.route_len = 3;
        p.route[..3].copy_from_slice(&[4, 9, 2]);
        p.feasible = 1;
        let m = PlanMsg::of(&p);
        assert_eq!(m.trigger, "edge_lost");
        let bytes = encode(&m);
        let back: PlanMsg = decode(&bytes, types::PLAN).unwrap();
        assert_eq!(back, m);
        assert_eq!(back.route, vec![4, 9, 2]);
        let e = decode::<PlanMsg>(&bytes, types::STATE).unwrap_err();
        assert!(matches!(e, DecodeError::Type { .. }), "{e}");
        let v2 = String::from_utf8(bytes).unwrap().replace(FORMAT, "auv-shore/2");
        assert!(matches!(
            decode::<PlanMsg>(v2.as_bytes(), types::PLAN),
            Err(DecodeError::Format { .. })
        ));
        assert!(matches!(
            decode::<PlanMsg>(b"{]", types::PLAN),
            Err(DecodeError::Json { .. })
        ));
    }

    #[test]
    fn enum_codes_travel_as_names() {
        let mut s = *boxed_zeroed::<VehicleState>();
        s.mode = VehicleMode::NoPlan as u32;
        s.outcome = Outcome::GoalReached as u32;
        s.route_len = 1;
        let m = State::of(&s);
        assert_eq!((m.mode.as_str(), m.outcome.as_str()), ("no_plan", "goal_reached"));
        assert!(m.finished());
        s.mode = 99;
        assert_eq!(State::of(&s).mode, "unknown_99");
    }

    #[test]
    fn a_command_without_optional_fields_decodes() {
        let c = Command::new(5, CommandKind::AbortToGoal, None, None);
        let text = String::from_utf8(encode(&c)).unwrap();
        assert!(!text.contains("budget_s") && !text.contains("mission"), "{text}");
        assert_eq!(decode::<Command>(text.as_bytes(), COMMAND_TYPE).unwrap(), c);
        // A new mission travels as its text, whole; an ack may carry its reason in words.
        let m = Command::replace_mission(6, "format = \"auv-mission/1\"\n[chart]\n".into());
        let back: Command = decode(&encode(&m), COMMAND_TYPE).unwrap();
        assert_eq!(
            (back.command.as_str(), back.mission.as_deref()),
            (REPLACE_MISSION, m.mission.as_deref())
        );
        let mut a = Ack::new(6, REPLACE_MISSION, false, "bad_mission", (0, 0), 1.0);
        assert!(!String::from_utf8(encode(&a)).unwrap().contains("detail"));
        a.detail = Some("waypoint \"start\": on land".into());
        assert_eq!(decode::<Ack>(&encode(&a), types::ACK).unwrap(), a);
    }
}
