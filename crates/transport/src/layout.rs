//! The wire layout of every message, read from the Rust definitions in
//! [`auv_messages::msg`] (`offset_of!`, `size_of`, `align_of`), for clients in
//! other languages: `planner wire-layout` prints it as JSON, and the Python
//! client's test compares its ctypes mirrors against that output.
//!
//! Contract:
//! - [`messages`] lists every type that travels on a topic, [`structs`] the
//!   structs nested in them, each with its fields in declaration order.
//! - The tests below check that each table accounts for every byte of its
//!   type (field sizes plus explicit padding add up to `size_of`, offsets
//!   rise without gaps or overlaps). A field added to a message without its
//!   row here fails them; so does a field whose row names the wrong type.
//! - Types are named as in Rust: `u8`, `u32`, `u64`, `f64`, a nested struct
//!   by its Rust name, an array as `[T; N]`; `elem`/`len` repeat the array's
//!   parts so no reader has to parse that string.

use core::mem::{align_of, offset_of, size_of};

use iceoryx2::prelude::ZeroCopySend;
use serde_json::{Value, json};

use crate::{OnTopic, Role, Topic};
use auv_messages::msg::{
    AckStatus, AllocCounters, CommandAck, CommandKind, Header, MAX_WIRE_EDGES, MAX_WIRE_NODES, NO_NODE, ObjectiveCode,
    OperatorCommand, Outcome, Plan, PlannerPhase, PlannerStatus, REJECT_KINDS, RefuseReason, RejectKind, SnapshotHead,
    TriggerKind, VehicleEvent, VehicleMode, VehicleState, WIRE_VERSION, WaypointSnapshot, WireEdge, WireNode,
};

/// A type as it appears in a field.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum WireType {
    /// A number: `u8`, `u16`, `u32`, `u64` or `f64`.
    Scalar(&'static str),
    /// A nested struct of [`structs`], by name.
    Struct(&'static str),
    /// `[elem; len]`.
    Array(Box<WireType>, usize),
}

impl WireType {
    /// The Rust spelling: `u64`, `Header`, `[WireNode; 128]`.
    pub fn rust_name(&self) -> String {
        match self {
            Self::Scalar(n) | Self::Struct(n) => (*n).to_string(),
            Self::Array(e, n) => format!("[{}; {n}]", e.rust_name()),
        }
    }

    fn to_json(&self) -> Value {
        match self {
            Self::Array(e, n) => json!({"type": self.rust_name(), "elem": e.rust_name(), "len": n}),
            _ => json!({"type": self.rust_name()}),
        }
    }
}

/// A Rust type that may appear in a message field.
pub trait Described {
    /// How the field's type is written in the layout.
    fn wire_type() -> WireType;
}

macro_rules! scalar {
    ($($t:ty),+) => { $(impl Described for $t {
        fn wire_type() -> WireType { WireType::Scalar(stringify!($t)) }
    })+ };
}
scalar!(u8, u16, u32, u64, f64);

impl<T: Described, const N: usize> Described for [T; N] {
    fn wire_type() -> WireType {
        WireType::Array(Box::new(T::wire_type()), N)
    }
}

/// One field of a struct.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldLayout {
    /// Rust field name.
    pub name: &'static str,
    /// Byte offset from the start of the struct.
    pub offset: usize,
    /// Size, bytes.
    pub size: usize,
    /// Type.
    pub ty: WireType,
}

/// One struct: a message or a part of one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StructLayout {
    /// Rust name.
    pub name: &'static str,
    /// iceoryx2 type name (`auv.Plan.v3`) of a payload or user header; `None` for a nested struct.
    pub type_name: Option<&'static str>,
    /// `size_of`, bytes.
    pub size: usize,
    /// `align_of`, bytes.
    pub align: usize,
    /// Fields in declaration order.
    pub fields: Vec<FieldLayout>,
}

/// Field size through a projection, so the macro below never names a type.
fn field_size<S, F>(_: fn(&S) -> &F) -> usize {
    size_of::<F>()
}

fn field_type<S, F: Described>(_: fn(&S) -> &F) -> WireType {
    F::wire_type()
}

/// The table of one struct: every field named once, next to nothing else,
/// so adding a field to the struct and not here fails the size tests.
macro_rules! layout {
    ($t:ident, $type_name:expr, [$($f:ident),+ $(,)?]) => {{
        StructLayout {
            name: stringify!($t),
            type_name: $type_name,
            size: size_of::<$t>(),
            align: align_of::<$t>(),
            fields: vec![$(FieldLayout {
                name: stringify!($f),
                offset: offset_of!($t, $f),
                size: field_size(|m: &$t| &m.$f),
                ty: field_type(|m: &$t| &m.$f),
            }),+],
        }
    }};
}

macro_rules! described_struct {
    ($($t:ident),+) => { $(impl Described for $t {
        fn wire_type() -> WireType { WireType::Struct(stringify!($t)) }
    })+ };
}
described_struct!(Header, WireNode, WireEdge, AllocCounters);

fn type_name_of<T: ZeroCopySend>() -> Option<&'static str> {
    // SAFETY: `type_name` only returns the static string the derive set.
    Some(unsafe { <T as ZeroCopySend>::type_name() })
}

/// The structs nested in messages.
pub fn structs() -> Vec<StructLayout> {
    vec![
        layout!(Header, None, [seq, session, fingerprint, sent_mono_ns, mission_time_s]),
        layout!(WireNode, None, [x, y, z, prize]),
        layout!(
            AllocCounters,
            None,
            [
                sys_allocs_total,
                sys_allocs_steady,
                sys_frees_steady,
                pool_allocs_steady,
                pool_high_water,
                pool_capacity,
                pool_misses,
                steady,
            ]
        ),
    ]
}

/// What travels on the six mission topics (the latency bench's raw
/// ping/pong are internal and not listed): the snapshot's head (its user
/// header) and edge (its payload slice's element), then one payload per
/// other topic.
pub fn messages() -> Vec<StructLayout> {
    vec![
        layout!(
            SnapshotHead,
            type_name_of::<SnapshotHead>(),
            [
                header,
                epoch,
                speed_mps,
                time_available_s,
                phi1,
                phi2,
                next_update_s,
                objective,
                node_count,
                edge_count,
                start,
                goal,
                _pad,
                nodes,
            ]
        ),
        layout!(
            WireEdge,
            type_name_of::<WireEdge>(),
            [a, b, priority, risk, task_time_s]
        ),
        layout!(
            VehicleState,
            type_name_of::<VehicleState>(),
            [
                header,
                position,
                time_left_s,
                eta_free_s,
                weight,
                distance_m,
                time_scale,
                plan_seq,
                snapshot_epoch,
                mode,
                event,
                outcome,
                from_node,
                to_node,
                arrivals,
                tasks_completed,
                needs_answer,
                stale_plans,
                route_len,
                rejected,
                route,
            ]
        ),
        layout!(
            Plan,
            type_name_of::<Plan>(),
            [
                header,
                state_seq,
                snapshot_epoch,
                trigger_sent_mono_ns,
                trigger_received_mono_ns,
                compute_ns,
                solve_ns,
                time_s,
                weight,
                distance_m,
                budget_s,
                trigger,
                iterations,
                deadline_cut,
                feasible,
                fallback,
                replan,
                route_len,
                _pad,
                route,
            ]
        ),
        layout!(
            PlannerStatus,
            type_name_of::<PlannerStatus>(),
            [
                header,
                handled_state_seq,
                handled_state_session,
                handled_epoch,
                plans,
                triggers,
                sensor_updates,
                updates_without_replan,
                deadline_misses,
                deadline_cuts,
                fallbacks,
                last_latency_ns,
                max_latency_ns,
                deadline_ns,
                alloc,
                rejected,
                iterations_total,
                latency_p50_ns,
                latency_p99_ns,
                cut_iterations,
                cut_with_warm_start,
                cut_weight,
                cut_warm_start_weight,
                phase,
                last_iterations,
                rt_priority,
                _pad,
            ]
        ),
        layout!(
            OperatorCommand,
            type_name_of::<OperatorCommand>(),
            [header, command_id, value_s, kind, node]
        ),
        layout!(
            CommandAck,
            type_name_of::<CommandAck>(),
            [header, command_id, plan_seq, kind, status, reason, replan]
        ),
    ]
}

fn struct_json(s: &StructLayout) -> Value {
    let fields: Vec<Value> = s
        .fields
        .iter()
        .map(|f| {
            let mut v = f.ty.to_json();
            v["name"] = json!(f.name);
            v["offset"] = json!(f.offset);
            v["size"] = json!(f.size);
            v
        })
        .collect();
    json!({"name": s.name, "type_name": s.type_name, "size": s.size, "align": s.align, "fields": fields})
}

/// How a topic's samples are built: one fixed payload and no user header,
/// or (the snapshot) a slice of a payload type behind a user header.
fn topic_json<T: OnTopic>() -> Value {
    let none = json!({"type_name": "()", "size": 0, "align": 1});
    let (payload, type_name, user_header) = if T::TOPIC == Topic::Waypoints {
        let head = json!({
            "type_name": type_name_of::<SnapshotHead>(),
            "size": size_of::<SnapshotHead>(),
            "align": align_of::<SnapshotHead>(),
        });
        ("slice", type_name_of::<WireEdge>(), head)
    } else {
        ("struct", Some(T::type_name()), none)
    };
    let t = T::TOPIC;
    let q = crate::ipc::topic_qos(t);
    json!({
        "leaf": t.leaf(),
        "service": format!("auv/<vehicle>/{}", t.leaf()),
        "message": T::NAME,
        "payload": payload,
        "type_name": type_name,
        "user_header": user_header,
        "event_id": t.event_id(),
        "consumers": t.consumers().iter().map(|r| r.as_str()).collect::<Vec<_>>(),
        "qos": {
            "history_size": q.history_size,
            "subscriber_max_buffer_size": q.subscriber_max_buffer_size,
            "subscriber_max_borrowed_samples": q.subscriber_max_borrowed_samples,
            "enable_safe_overflow": q.enable_safe_overflow,
            "max_publishers": q.max_publishers,
            "max_subscribers": q.max_subscribers,
        },
    })
}

fn codes<T: Copy>(all: &[(T, &'static str)], code: fn(T) -> u32) -> Value {
    Value::Object(all.iter().map(|&(v, n)| (n.to_string(), json!(code(v)))).collect())
}

/// Everything a client in another language needs to mirror the wire: the
/// layouts, the capacities, the enum codes, and each topic's service name,
/// event id and QoS.
pub fn wire_layout_json() -> Value {
    let w = crate::ipc::wake_qos();
    let roles: Vec<&str> = [Role::Planner, Role::Vehicle, Role::Sensor]
        .iter()
        .map(|r| r.as_str())
        .collect();
    json!({
        "format": "auv-wire-layout/1",
        "wire_version": WIRE_VERSION,
        "constants": {
            "MAX_WIRE_NODES": MAX_WIRE_NODES,
            "MAX_WIRE_EDGES": MAX_WIRE_EDGES,
            "REJECT_KINDS": REJECT_KINDS,
            "NO_NODE": NO_NODE,
        },
        "structs": structs().iter().map(struct_json).collect::<Vec<_>>(),
        "messages": messages().iter().map(struct_json).collect::<Vec<_>>(),
        "enums": {
            "ObjectiveCode": codes(&[(ObjectiveCode::MaxWeight, "max_weight"), (ObjectiveCode::PaperCost, "paper_cost")], |v| v as u32),
            "VehicleMode": codes(&[
                (VehicleMode::NoPlan, "no_plan"), (VehicleMode::Travelling, "travelling"),
                (VehicleMode::Working, "working"), (VehicleMode::Holding, "holding"),
                (VehicleMode::Finished, "finished"),
            ], |v| v as u32),
            "VehicleEvent": codes(&[
                (VehicleEvent::Periodic, "periodic"), (VehicleEvent::Start, "start"),
                (VehicleEvent::Arrival, "arrival"), (VehicleEvent::Tick, "tick"),
                (VehicleEvent::Finished, "finished"),
            ], |v| v as u32),
            "Outcome": codes(&[
                (Outcome::Running, "running"), (Outcome::GoalReached, "goal_reached"),
                (Outcome::TimedOut, "timed_out"), (Outcome::Aborted, "aborted"),
            ], |v| v as u32),
            "TriggerKind": codes(&[
                (TriggerKind::Initial, "initial"), (TriggerKind::Arrival, "arrival"),
                (TriggerKind::EdgeLost, "edge_lost"), (TriggerKind::TimeChanged, "time_changed"),
                (TriggerKind::Infeasible, "infeasible"), (TriggerKind::SensorBack, "sensor_back"),
                (TriggerKind::Operator, "operator"),
            ], |v| v as u32),
            "CommandKind": Value::Object(CommandKind::ALL.iter().map(|&k| (k.as_str().replace('-', "_"), json!(k as u32))).collect()),
            "AckStatus": codes(&[(AckStatus::Applied, "applied"), (AckStatus::Refused, "refused")], |v| v as u32),
            "RefuseReason": Value::Object(RefuseReason::ALL.iter().map(|&k| (k.as_str().to_string(), json!(k as u32))).collect()),
            "PlannerPhase": codes(&[
                (PlannerPhase::Waiting, "waiting"), (PlannerPhase::Running, "running"),
                (PlannerPhase::Finished, "finished"),
            ], |v| v as u32),
            "RejectKind": Value::Object(RejectKind::ALL.iter().map(|&k| (k.as_str().to_string(), json!(k as u32))).collect()),
        },
        "topics": [
            topic_json::<WaypointSnapshot>(),
            topic_json::<VehicleState>(),
            topic_json::<Plan>(),
            topic_json::<PlannerStatus>(),
            topic_json::<OperatorCommand>(),
            topic_json::<CommandAck>(),
        ],
        "wake": {
            "service": "auv/<vehicle>/<role>/wake/v1",
            "roles": roles,
            "event_id_max_value": w.event_id_max_value,
            "max_notifiers": w.max_notifiers,
            "max_listeners": w.max_listeners,
        },
    })
}

/// The topics a layout is printed for, in the JSON's order.
pub const TOPICS: [Topic; 6] = [
    Topic::Waypoints,
    Topic::VehicleState,
    Topic::Plan,
    Topic::Status,
    Topic::Command,
    Topic::Ack,
];

#[cfg(test)]
mod tests {
    use super::*;

    fn check_tiles(s: &StructLayout) {
        // Offsets rise and each field starts where the previous one ended:
        // no implicit padding, no overlap, nothing left over at the end.
        let mut end = 0;
        for f in &s.fields {
            assert_eq!(
                f.offset, end,
                "{}.{} starts at {} after a field ending at {end}",
                s.name, f.name, f.offset
            );
            end = f.offset + f.size;
        }
        assert_eq!(
            end, s.size,
            "{}: the listed fields cover {end} of its {} bytes: a field is missing from the table",
            s.name, s.size
        );
    }

    fn element_size(ty: &WireType, all: &[StructLayout]) -> usize {
        match ty {
            WireType::Scalar("u8") => 1,
            WireType::Scalar("u16") => 2,
            WireType::Scalar("u32") => 4,
            WireType::Scalar("u64" | "f64") => 8,
            WireType::Scalar(other) => panic!("unknown scalar {other}"),
            WireType::Struct(n) => all
                .iter()
                .find(|s| s.name == *n)
                .map(|s| s.size)
                .expect("a listed struct"),
            WireType::Array(e, n) => element_size(e, all) * n,
        }
    }

    #[test]
    fn every_table_covers_its_type_exactly() {
        let nested = structs();
        for s in nested.iter().chain(messages().iter()) {
            check_tiles(s);
            for f in &s.fields {
                assert_eq!(
                    element_size(&f.ty, &nested),
                    f.size,
                    "{}.{}: {}",
                    s.name,
                    f.name,
                    f.ty.rust_name()
                );
            }
        }
    }

    #[test]
    fn messages_carry_their_versioned_type_names() {
        let names: Vec<_> = messages().iter().map(|m| m.type_name.unwrap_or("")).collect();
        assert_eq!(
            names,
            [
                "auv.WaypointSnapshot.v2",
                "auv.WireEdge.v1",
                "auv.VehicleState.v3",
                "auv.Plan.v3",
                "auv.PlannerStatus.v4",
                "auv.OperatorCommand.v1",
                "auv.CommandAck.v1"
            ]
        );
        assert!(structs().iter().all(|s| s.type_name.is_none()));
    }

    #[test]
    fn the_json_names_every_topic_with_its_qos() {
        let v = wire_layout_json();
        let topics = v["topics"].as_array().expect("topics");
        assert_eq!(topics.len(), TOPICS.len());
        for (t, j) in TOPICS.iter().zip(topics) {
            assert_eq!(j["leaf"], t.leaf());
            assert!(j["qos"]["max_subscribers"].as_u64().unwrap_or(0) as usize >= t.consumers().len() + 2);
        }
        let plan = &v["messages"][3];
        assert_eq!(plan["name"], "Plan");
        assert_eq!(plan["fields"][19]["type"], format!("[u16; {MAX_WIRE_NODES}]"));
        assert_eq!(plan["fields"][19]["len"], MAX_WIRE_NODES);
        let waypoints = &topics[0];
        assert_eq!(waypoints["payload"], "slice");
        assert_eq!(waypoints["type_name"], "auv.WireEdge.v1");
        assert_eq!(waypoints["user_header"]["type_name"], "auv.WaypointSnapshot.v2");
        assert_eq!(topics[2]["user_header"]["type_name"], "()");
        assert_eq!(v["enums"]["RejectKind"]["visited_node"], 11);
    }
}
