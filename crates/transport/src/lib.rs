//! The seam between the processes' loops and the message transport.
//!
//! The service loop, the simulators and the benches see only the small
//! traits here: an [`Outbox`] publishes the latest value of a topic, an
//! [`Inbox`] drains what arrived, a [`Waker`] blocks until something may have
//! arrived. [`ipc`] implements them on iceoryx2 (shared memory between
//! processes, or its in-process `local` flavour for unit tests); nothing
//! outside that module names an iceoryx2 type (house style §2).
//!
//! Topology (fixed, one place): every topic is a latest-value publish-subscribe
//! service paired with a *wake* event service per consuming role. A publisher
//! notifies the wake service of each role that consumes its topic, with the
//! topic's event id, so a process blocks on one listener whatever it consumes
//! (a WaitSet could multiplex several listeners, but allocates on every
//! wake-up in iceoryx2 0.10, see `shared/docs/iceoryx2-notes.md` §8).
//!
//! | topic | service name | from → to |
//! |---|---|---|
//! | waypoints | `auv/<vehicle>/sensor/waypoints/v2` | sensor → planner, vehicle |
//! | vehicle state | `auv/<vehicle>/vehicle/state/v3` | vehicle → planner, sensor |
//! | plan | `auv/<vehicle>/planner/plan/v3` | planner → vehicle |
//! | planner status | `auv/<vehicle>/planner/status/v4` | planner → vehicle |
//! | operator command | `auv/<vehicle>/operator/command/v1` | shore link → planner |
//! | command ack | `auv/<vehicle>/planner/ack/v1` | planner → shore link |
//!
//! Wake services: `auv/<vehicle>/<role>/wake/v1`.

#![warn(missing_docs)]

pub mod faulty;
pub mod guard;
pub mod ipc;
pub mod layout;

use core::time::Duration;

use auv_messages::msg::{
    CommandAck, Message, OperatorCommand, Plan, PlannerStatus, RawPing, RawPong, VehicleState, WaypointSnapshot,
};

/// One kind of message flow. Each message type travels on exactly one topic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Topic {
    /// [`WaypointSnapshot`].
    Waypoints,
    /// [`VehicleState`].
    VehicleState,
    /// [`Plan`].
    Plan,
    /// [`PlannerStatus`].
    Status,
    /// [`OperatorCommand`] (from the shore link).
    Command,
    /// [`CommandAck`] (to the shore link).
    Ack,
    /// Raw ping of the latency bench ([`RawPing`]).
    BenchPing,
    /// Raw pong of the latency bench ([`RawPong`]).
    BenchPong,
}

impl Topic {
    /// Service name below `auv/<vehicle>/`.
    pub fn leaf(self) -> &'static str {
        match self {
            Self::Waypoints => "sensor/waypoints/v2",
            Self::VehicleState => "vehicle/state/v3",
            Self::Plan => "planner/plan/v3",
            Self::Status => "planner/status/v4",
            Self::Command => "operator/command/v1",
            Self::Ack => "planner/ack/v1",
            Self::BenchPing => "bench/ping/v1",
            Self::BenchPong => "bench/pong/v1",
        }
    }

    /// Event id used when this topic wakes a consumer (bit in [`Wake::Woken`]).
    pub fn event_id(self) -> usize {
        match self {
            Self::Waypoints => 1,
            Self::VehicleState => 2,
            Self::Plan => 3,
            Self::Status => 4,
            Self::BenchPing => 5,
            Self::BenchPong => 6,
            Self::Command => 7,
            Self::Ack => 8,
        }
    }

    /// The roles that consume this topic (and are woken by it).
    pub fn consumers(self) -> &'static [Role] {
        match self {
            Self::Waypoints => &[Role::Planner, Role::Vehicle],
            Self::VehicleState => &[Role::Planner, Role::Sensor],
            Self::Plan => &[Role::Vehicle],
            Self::Status => &[Role::Vehicle],
            Self::Command => &[Role::Planner],
            // The shore link polls its acks: it wakes no role.
            Self::Ack => &[],
            Self::BenchPing => &[Role::Planner],
            Self::BenchPong => &[Role::Vehicle],
        }
    }

    /// Samples a subscriber that joins late is handed (iceoryx2 history).
    /// State topics keep their latest value for a restarted peer. A plan
    /// answers one vehicle state and is never replayed: a restarted vehicle
    /// reports `NoPlan` and gets a fresh plan. Without history the send path
    /// also skips the history bookkeeping (about 0.4 µs of the plan's wire
    /// time after a solve, measured with probes in iceoryx2's `send_sample`).
    pub fn history_size(self) -> usize {
        match self {
            // A command is applied once: a restarted planner must not be
            // handed the last one again (the link resends until acked).
            Self::Plan | Self::Command | Self::Ack => 0,
            _ => 1,
        }
    }

    /// Samples a subscriber queues before the oldest is overwritten. Plans
    /// come in bursts (a re-plan per sensor update at 1000× real time and
    /// more) and each one matters to an observer counting them, so their
    /// queue is deep (a plan is 1.2 KiB); the state topics keep only the
    /// freshest values.
    pub fn subscriber_buffer(self) -> usize {
        match self {
            Self::Plan => 64,
            // Commands and acks are few, and each one matters.
            Self::Command | Self::Ack => 16,
            _ => 2,
        }
    }

    /// Subscribers the topic's service admits: its consumers, the mission's
    /// monitor, [`OUTSIDE_CLIENTS`] outside clients (watchers, bridges), and
    /// a restarted consumer overlapping with its dead predecessor.
    pub fn max_subscribers(self) -> usize {
        self.consumers().len() + 1 + OUTSIDE_CLIENTS + 1
    }
}

/// Outside clients (in any language) that can subscribe to every topic at
/// the same time as the mission's own processes.
pub const OUTSIDE_CLIENTS: usize = 2;

/// A process's part in the system; names its wake service.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// The re-planning service.
    Planner,
    /// vehicle-sim (or the latency bench's trigger source).
    Vehicle,
    /// sensor-sim.
    Sensor,
}

impl Role {
    /// Name inside service names.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Planner => "planner",
            Self::Vehicle => "vehicle",
            Self::Sensor => "sensor",
        }
    }
}

/// Ties a message type to its topic.
pub trait OnTopic: Message {
    /// The topic this type travels on.
    const TOPIC: Topic;
}

impl OnTopic for WaypointSnapshot {
    const TOPIC: Topic = Topic::Waypoints;
}
impl OnTopic for VehicleState {
    const TOPIC: Topic = Topic::VehicleState;
}
impl OnTopic for Plan {
    const TOPIC: Topic = Topic::Plan;
}
impl OnTopic for PlannerStatus {
    const TOPIC: Topic = Topic::Status;
}
impl OnTopic for OperatorCommand {
    const TOPIC: Topic = Topic::Command;
}
impl OnTopic for CommandAck {
    const TOPIC: Topic = Topic::Ack;
}
impl OnTopic for RawPing {
    const TOPIC: Topic = Topic::BenchPing;
}
impl OnTopic for RawPong {
    const TOPIC: Topic = Topic::BenchPong;
}

/// How a process waits for input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WaitMode {
    /// Block on the wake listener (default: no CPU burnt while idle).
    #[default]
    Event,
    /// Busy-poll the inboxes; publishers skip the wake notification. For
    /// latency benchmarking only, and only when every process of the run
    /// spins: a spinning publisher does not wake event-mode consumers.
    Spin,
}

/// What ended a [`Waker::wait`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wake {
    /// Something may have arrived: a bit per topic event id (all bits in spin mode).
    Woken(u32),
    /// The timeout passed with no event.
    Timeout,
    /// SIGINT or SIGTERM was received: finish up and exit.
    Shutdown,
}

/// Failures of the transport on a hot path (small and `Copy`, house style §7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TransportError {
    /// No sample could be loaned (all in flight).
    #[error("{topic}: no sample to loan")]
    Loan {
        /// Service leaf of the topic.
        topic: &'static str,
    },
    /// A snapshot with more edges than its publisher's samples hold (they
    /// are sized for every pair of the mission's waypoints).
    #[error("{topic}: {len} edges exceed the {max} a sample of this publisher holds")]
    Oversized {
        /// Service leaf of the topic.
        topic: &'static str,
        /// Edges asked for.
        len: usize,
        /// Edges a sample holds.
        max: usize,
    },
    /// The sample could not be delivered.
    #[error("{topic}: send failed")]
    Send {
        /// Service leaf of the topic.
        topic: &'static str,
    },
    /// Receiving failed (connection broken or too many samples held).
    #[error("{topic}: receive failed")]
    Receive {
        /// Service leaf of the topic.
        topic: &'static str,
    },
    /// Waking a consumer failed.
    #[error("{topic}: wake-up notification failed")]
    Notify {
        /// Service leaf of the topic.
        topic: &'static str,
    },
    /// Waiting on the wake listener failed.
    #[error("waiting for input failed")]
    Wait,
}

/// Failures while setting the transport up (start-up only, so they may carry text).
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// A name or prefix iceoryx2 cannot use.
    #[error("invalid {what} {value:?}: {rule}")]
    BadName {
        /// Which name.
        what: &'static str,
        /// The value given.
        value: String,
        /// What a valid one looks like.
        rule: &'static str,
    },
    /// iceoryx2 refused a step of the set-up.
    #[error("iceoryx2: cannot {step}: {cause}")]
    Iceoryx {
        /// What was being done.
        step: String,
        /// iceoryx2's error.
        cause: String,
    },
}

/// Publishes the latest value of one topic.
pub trait Outbox<T: Message> {
    /// Loans a zeroed sample, lets `fill` write the payload (the header's
    /// `mission_time_s` included), stamps the rest of the header (sequence
    /// number, session, fingerprint, send time), sends it and wakes the
    /// topic's consumers. Returns the sequence number used.
    fn publish(&mut self, fill: &mut dyn FnMut(&mut T)) -> Result<u64, TransportError>;

    /// Hands the latest value to subscribers that joined since the last
    /// send (history reaches a late joiner only when its publisher acts,
    /// notes §2). Cheap when nobody joined; call it when idle.
    fn refresh(&mut self);
}

/// Drains one topic.
pub trait Inbox<T: Message> {
    /// Calls `each` for every sample that arrived since the last call, oldest
    /// first, and returns how many there were. Nothing is validated here
    /// (see [`guard::Guarded`]).
    fn drain(&mut self, each: &mut dyn FnMut(&T)) -> Result<usize, TransportError>;
}

/// Blocks until input may have arrived.
pub trait Waker {
    /// Waits at most `timeout`; returns early on input or shutdown.
    fn wait(&mut self, timeout: Duration) -> Result<Wake, TransportError>;
}

/// Options shared by every process of one run: the isolation domain, the
/// vehicle namespace and the wait mode.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IpcOptions {
    /// iceoryx2 domain prefix: every shared-memory object and file of the run
    /// carries it, so runs with different prefixes never see each other.
    pub prefix: String,
    /// Vehicle namespace in service names (`auv/<vehicle>/…`).
    pub vehicle: String,
    /// How to wait for input.
    pub mode: WaitMode,
}

/// Environment variable that sets the isolation prefix when no flag does.
pub const PREFIX_ENV: &str = "AUV_IPC_PREFIX";

/// Default isolation prefix (our choice: short, so socket paths stay far
/// below the 108-byte limit, and distinct from iceoryx2's own `iox2_`).
pub const DEFAULT_PREFIX: &str = "auv_";

/// Longest prefix accepted. A listener's socket path is
/// `/tmp/iceoryx2/<prefix><39-digit id>.event`, which must stay under 108
/// bytes; 32 leaves a wide margin (notes §6: 50 worked, 60 failed).
pub const MAX_PREFIX_LEN: usize = 32;

impl IpcOptions {
    /// Options with `prefix` (or the `AUV_IPC_PREFIX` environment variable, or
    /// the default) and `vehicle`, validated.
    pub fn new(prefix: Option<&str>, vehicle: &str, mode: WaitMode) -> Result<Self, SetupError> {
        let env = std::env::var(PREFIX_ENV).ok();
        let prefix = prefix.or(env.as_deref()).unwrap_or(DEFAULT_PREFIX).to_string();
        let ok_char = |c: char| c.is_ascii_alphanumeric() || c == '_';
        if prefix.is_empty() || prefix.len() > MAX_PREFIX_LEN || !prefix.chars().all(ok_char) {
            return Err(SetupError::BadName {
                what: "ipc prefix",
                value: prefix,
                rule: "1 to 32 characters of A-Z, a-z, 0-9 and _",
            });
        }
        if vehicle.is_empty() || vehicle.len() > 32 || !vehicle.chars().all(ok_char) {
            return Err(SetupError::BadName {
                what: "vehicle name",
                value: vehicle.to_string(),
                rule: "1 to 32 characters of A-Z, a-z, 0-9 and _",
            });
        }
        Ok(Self {
            prefix,
            vehicle: vehicle.to_string(),
            mode,
        })
    }

    /// Full service name of `topic`.
    pub fn service_name(&self, topic: Topic) -> String {
        format!("auv/{}/{}", self.vehicle, topic.leaf())
    }

    /// Full name of `role`'s wake service.
    pub fn wake_name(&self, role: Role) -> String {
        format!("auv/{}/{}/wake/v1", self.vehicle, role.as_str())
    }
}

/// The transport flags every process takes.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct IpcArgs {
    /// iceoryx2 isolation prefix of the run (default: $AUV_IPC_PREFIX, else `auv_`).
    #[arg(long, value_name = "PREFIX")]
    pub ipc_prefix: Option<String>,
    /// Vehicle namespace in service names.
    #[arg(long, default_value = "auv1")]
    pub vehicle: String,
    /// Busy-poll instead of blocking on events (latency benchmarking; every
    /// process of the run must spin).
    #[arg(long)]
    pub spin: bool,
}

impl IpcArgs {
    /// The validated options.
    pub fn options(&self) -> Result<IpcOptions, SetupError> {
        let mode = if self.spin { WaitMode::Spin } else { WaitMode::Event };
        IpcOptions::new(self.ipc_prefix.as_deref(), &self.vehicle, mode)
    }

    /// The flags that give these settings (to start a child process with them).
    pub fn to_flags(&self) -> Vec<String> {
        let mut f = Vec::new();
        if let Some(p) = &self.ipc_prefix {
            f.extend(["--ipc-prefix".to_string(), p.clone()]);
        }
        f.extend(["--vehicle".to_string(), self.vehicle.clone()]);
        if self.spin {
            f.push("--spin".into());
        }
        f
    }

    /// The flags of `opts` (a run's domain, its vehicle and how it waits).
    pub fn of(opts: &IpcOptions) -> Self {
        Self {
            ipc_prefix: Some(opts.prefix.clone()),
            vehicle: opts.vehicle.clone(),
            spin: opts.mode == WaitMode::Spin,
        }
    }
}

/// A fresh isolation prefix for one run: `<tag><pid base36><counter>_`,
/// short and unique among concurrently running tests and missions.
pub fn unique_prefix(tag: &str) -> String {
    use std::sync::atomic::{AtomicU32, Ordering};
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let nanos = auv_platform::clock::mono_now_ns() % 1_000_000;
    format!(
        "{tag}{}{}{}_",
        base36(u64::from(std::process::id())),
        base36(u64::from(n)),
        base36(nanos)
    )
}

fn base36(mut v: u64) -> String {
    const DIGITS: &[u8; 36] = b"0123456789abcdefghijklmnopqrstuvwxyz";
    let mut out = Vec::new();
    loop {
        out.push(DIGITS[(v % 36) as usize]);
        v /= 36;
        if v == 0 {
            break;
        }
    }
    out.reverse();
    String::from_utf8(out).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn service_names_are_versioned_and_namespaced() {
        let o = IpcOptions::new(Some("t_"), "auv1", WaitMode::Event).unwrap();
        assert_eq!(o.service_name(Topic::Waypoints), "auv/auv1/sensor/waypoints/v2");
        assert_eq!(o.service_name(Topic::Plan), "auv/auv1/planner/plan/v3");
        assert_eq!(o.wake_name(Role::Planner), "auv/auv1/planner/wake/v1");
    }

    #[test]
    fn bad_prefixes_and_names_are_clear_errors() {
        for p in ["", "has space", "a/b", &"x".repeat(33)] {
            let e = IpcOptions::new(Some(p), "auv1", WaitMode::Event).unwrap_err();
            assert!(e.to_string().contains("ipc prefix"), "{e}");
        }
        let e = IpcOptions::new(Some("ok_"), "a/b", WaitMode::Event).unwrap_err();
        assert!(e.to_string().contains("vehicle name"), "{e}");
    }

    #[test]
    fn unique_prefixes_differ_and_stay_short() {
        let a = unique_prefix("t");
        let b = unique_prefix("t");
        assert_ne!(a, b);
        assert!(a.len() <= MAX_PREFIX_LEN, "{a}");
        assert!(IpcOptions::new(Some(&a), "v", WaitMode::Event).is_ok());
    }

    #[test]
    fn every_topic_has_a_distinct_event_id_below_32() {
        let all = [
            Topic::Waypoints,
            Topic::VehicleState,
            Topic::Plan,
            Topic::Status,
            Topic::BenchPing,
            Topic::BenchPong,
        ];
        let mut seen = 0u32;
        for t in all {
            assert!(t.event_id() < 32);
            assert_eq!(seen & (1 << t.event_id()), 0);
            seen |= 1 << t.event_id();
        }
    }
}
