//! iceoryx2 behind the transport traits.
//!
//! Generic over the iceoryx2 service flavour: `ipc::Service` (shared memory,
//! between processes) in the binaries, `local::Service` (in-process, no shared
//! memory) in unit tests, with the same code path.
//!
//! QoS, the same in every process (opening checks each value set as a
//! minimum, so all sides must agree; one function builds them all):
//! latest-value topics (history per [`Topic::history_size`], subscriber
//! buffer per [`Topic::subscriber_buffer`], safe overflow: a slow or dead subscriber never blocks a
//! publisher, notes §2 and §5), at most
//! 2 publishers per topic (a restarted publisher may overlap with its dead
//! predecessor until the dead node is cleaned), subscribers per
//! [`Topic::max_subscribers`]. Nodes are created with iceoryx2's signal
//! handling disabled: [`super::signal`] owns SIGINT/SIGTERM.
//!
//! Allocation: `loan_uninit` allocates 48 B per call in iceoryx2 0.10 (an
//! `Rc` in `ChunkMutSharedState::new`); send, receive, notify and
//! `Listener::timed_wait` do not. The planner binary serves that block from a
//! start-up pool (`service::alloc`) and reports it.

use core::marker::PhantomData;
use core::time::Duration;

use iceoryx2::node::NodeState;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::*;
use iceoryx2::service::builder::publish_subscribe::Builder as PubSubBuilder;
use iceoryx2::service::port_factory::event::PortFactory as EventFactory;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory as PubSubFactory;

use super::{Inbox, IpcOptions, OnTopic, Outbox, Role, SetupError, Topic, TransportError, WaitMode, Wake, Waker};
use auv_messages::msg::{FixedMessage, Message, SnapshotHead, WaypointSnapshot, WireEdge, zero_in_place};
use auv_platform::{clock, signal};

/// Shared-memory service flavour (between processes): what the binaries use.
pub type Shm = iceoryx2::prelude::ipc::Service;

/// In-process service flavour (no shared memory): for unit tests.
pub type InProcess = iceoryx2::prelude::local::Service;

/// Publishers per topic: one live, one dead predecessor awaiting cleanup,
/// and one outside tool (a client injecting test messages next to ours).
const MAX_PUBLISHERS: usize = 3;
/// Largest event id (topics use 1..=6).
const EVENT_ID_MAX: usize = 15;
/// Notifiers per wake service (every publisher of every topic the role
/// consumes, with room for restarts and outside publishers).
const WAKE_MAX_NOTIFIERS: usize = 16;
/// Listeners per wake service: the role's process, its restarted successor
/// overlapping with the dead one, and two outside clients (a watcher
/// blocks on the vehicle's wake service to see plans as they come).
const WAKE_MAX_LISTENERS: usize = 4;

/// The publish-subscribe QoS of one topic, identical in every process (and
/// in every outside client: a service opened with other values fails).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TopicQos {
    /// Samples a late subscriber is handed.
    pub history_size: usize,
    /// Samples a subscriber queues before the oldest is overwritten.
    pub subscriber_max_buffer_size: usize,
    /// Samples a subscriber may hold at once.
    pub subscriber_max_borrowed_samples: usize,
    /// A full subscriber queue overwrites its oldest sample (never blocks the publisher).
    pub enable_safe_overflow: bool,
    /// Publishers the service admits.
    pub max_publishers: usize,
    /// Subscribers the service admits.
    pub max_subscribers: usize,
}

/// The QoS of `topic`'s service.
pub fn topic_qos(topic: super::Topic) -> TopicQos {
    TopicQos {
        history_size: topic.history_size(),
        subscriber_max_buffer_size: topic.subscriber_buffer(),
        subscriber_max_borrowed_samples: 1,
        enable_safe_overflow: true,
        max_publishers: MAX_PUBLISHERS,
        max_subscribers: topic.max_subscribers(),
    }
}

/// The QoS of every wake event service.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WakeQos {
    /// Largest event id.
    pub event_id_max_value: usize,
    /// Notifiers the service admits.
    pub max_notifiers: usize,
    /// Listeners the service admits.
    pub max_listeners: usize,
}

/// The QoS of the wake services.
pub fn wake_qos() -> WakeQos {
    WakeQos {
        event_id_max_value: EVENT_ID_MAX,
        max_notifiers: WAKE_MAX_NOTIFIERS,
        max_listeners: WAKE_MAX_LISTENERS,
    }
}

/// Sets a topic's QoS on a publish-subscribe service builder (one place for
/// the fixed-size topics and the snapshot's slice topic).
fn with_qos<
    P: core::fmt::Debug + iceoryx2::prelude::IceoryxSend + ?Sized,
    H: core::fmt::Debug + ZeroCopySend,
    S: Service,
>(
    b: PubSubBuilder<P, H, S>,
    q: &TopicQos,
) -> PubSubBuilder<P, H, S> {
    b.history_size(q.history_size)
        .subscriber_max_buffer_size(q.subscriber_max_buffer_size)
        .subscriber_max_borrowed_samples(q.subscriber_max_borrowed_samples)
        .enable_safe_overflow(q.enable_safe_overflow)
        .max_publishers(q.max_publishers)
        .max_subscribers(q.max_subscribers)
}

fn iox(step: impl Into<String>, cause: impl core::fmt::Debug) -> SetupError {
    SetupError::Iceoryx {
        step: step.into(),
        cause: format!("{cause:?}"),
    }
}

/// The iceoryx2 configuration of one isolation domain: the default
/// configuration with our prefix (notes §6).
pub fn domain_config(prefix: &str) -> Result<Config, SetupError> {
    let mut cfg = Config::default();
    cfg.global.prefix = FileName::new(prefix.as_bytes()).map_err(|_| SetupError::BadName {
        what: "ipc prefix",
        value: prefix.to_string(),
        rule: "a valid file name",
    })?;
    Ok(cfg)
}

/// Per-sender header stamp: who we are and our next sequence number.
#[derive(Clone, Copy, Debug)]
pub struct Stamp {
    /// Scenario fingerprint written into every header.
    pub fingerprint: u64,
    /// Session id written into every header (one per process start).
    pub session: u64,
}

impl Stamp {
    /// A stamp for scenario `fingerprint` with a fresh session id (the
    /// monotonic clock at start-up mixed with the pid: distinct per start).
    pub fn new(fingerprint: u64) -> Self {
        let mut s = clock::mono_now_ns() ^ (u64::from(std::process::id()) << 40);
        Self {
            fingerprint,
            session: auv_core::rng::splitmix64(&mut s),
        }
    }
}

/// One process's connection to the domain: its node and the run options.
pub struct IpcContext<S: Service> {
    node: Node<S>,
    opts: IpcOptions,
}

impl<S: Service> IpcContext<S> {
    /// Creates the node `node_name` in the domain of `opts` (stale resources
    /// of dead nodes in the domain are removed on creation).
    pub fn new(opts: &IpcOptions, node_name: &str) -> Result<Self, SetupError> {
        let cfg = domain_config(&opts.prefix)?;
        let name = NodeName::new(node_name).map_err(|e| iox(format!("name node {node_name:?}"), e))?;
        let node = NodeBuilder::new()
            .name(&name)
            .config(&cfg)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<S>()
            .map_err(|e| iox("create node", e))?;
        Ok(Self {
            node,
            opts: opts.clone(),
        })
    }

    /// The run options.
    pub fn options(&self) -> &IpcOptions {
        &self.opts
    }

    /// The domain configuration (for [`cleanup_dead_nodes`] and listings).
    pub fn config(&self) -> &Config {
        self.node.config()
    }

    fn service_name(&self, s: &str) -> Result<ServiceName, SetupError> {
        ServiceName::new(s).map_err(|e| iox(format!("name service {s:?}"), e))
    }

    fn pubsub<T: OnTopic + FixedMessage>(&self) -> Result<PubSubFactory<S, T, ()>, SetupError> {
        let name = self.opts.service_name(T::TOPIC);
        let q = topic_qos(T::TOPIC);
        let builder = self
            .node
            .service_builder(&self.service_name(&name)?)
            .publish_subscribe::<T>();
        with_qos(builder, &q)
            .open_or_create()
            .map_err(|e| iox(format!("open service {name}"), e))
    }

    /// The snapshot topic: a slice of edges behind a [`SnapshotHead`] user header.
    fn snapshot_pubsub(&self) -> Result<SnapshotFactory<S>, SetupError> {
        let name = self.opts.service_name(Topic::Waypoints);
        let q = topic_qos(Topic::Waypoints);
        let builder = self
            .node
            .service_builder(&self.service_name(&name)?)
            .publish_subscribe::<[WireEdge]>()
            .user_header::<SnapshotHead>();
        with_qos(builder, &q)
            .open_or_create()
            .map_err(|e| iox(format!("open service {name}"), e))
    }

    fn wake_service(&self, role: Role) -> Result<EventFactory<S>, SetupError> {
        let name = self.opts.wake_name(role);
        let w = wake_qos();
        self.node
            .service_builder(&self.service_name(&name)?)
            .event()
            .event_id_max_value(w.event_id_max_value)
            .max_notifiers(w.max_notifiers)
            .max_listeners(w.max_listeners)
            .open_or_create()
            .map_err(|e| iox(format!("open event service {name}"), e))
    }

    /// The notifiers that wake `topic`'s consumers (none in spin mode).
    fn wake_ups(&self, topic: Topic) -> Result<WakeUps<S>, SetupError> {
        let mut notifiers = Vec::new();
        let mut services = Vec::new();
        if self.opts.mode == WaitMode::Event {
            for &role in topic.consumers() {
                let ev = self.wake_service(role)?;
                notifiers.push(
                    ev.notifier_builder()
                        .create()
                        .map_err(|e| iox(format!("create notifier for {}", role.as_str()), e))?,
                );
                services.push(ev);
            }
        }
        Ok(WakeUps {
            notifiers,
            _services: services,
            id: EventId::new(topic.event_id()),
            topic: topic.leaf(),
        })
    }

    /// A publisher of `T`'s topic that wakes the topic's consumers.
    pub fn outbox<T: OnTopic + FixedMessage>(&self, stamp: Stamp) -> Result<IpcOutbox<S, T>, SetupError> {
        let service = self.pubsub::<T>()?;
        let publisher = service
            .publisher_builder()
            .max_loaned_samples(1)
            .create()
            .map_err(|e| iox(format!("create publisher on {}", T::TOPIC.leaf()), e))?;
        Ok(IpcOutbox {
            publisher,
            wake: self.wake_ups(T::TOPIC)?,
            _service: service,
            stamp,
            seq: 0,
        })
    }

    /// A publisher of snapshots of networks of up to `max_nodes` waypoints:
    /// its samples hold every pair's edge of such a network and no more, so
    /// a snapshot's shared memory grows with the mission, not with the
    /// largest network the build supports.
    pub fn snapshot_outbox(&self, stamp: Stamp, max_nodes: usize) -> Result<IpcSnapshotOutbox<S>, SetupError> {
        let max_edges = auv_messages::network::max_edges_of(max_nodes.min(auv_messages::msg::MAX_WIRE_NODES)).max(1);
        let service = self.snapshot_pubsub()?;
        let publisher = service
            .publisher_builder()
            .max_loaned_samples(1)
            .initial_max_slice_len(max_edges)
            .create()
            .map_err(|e| iox(format!("create publisher on {}", Topic::Waypoints.leaf()), e))?;
        Ok(IpcSnapshotOutbox {
            publisher,
            wake: self.wake_ups(Topic::Waypoints)?,
            _service: service,
            staging: WaypointSnapshot::with_capacity(max_edges),
            stamp,
            seq: 0,
        })
    }

    /// A subscriber of the snapshot topic; it copies each sample into a
    /// buffer that holds the largest network the build supports.
    pub fn snapshot_inbox(&self) -> Result<IpcSnapshotInbox<S>, SetupError> {
        let service = self.snapshot_pubsub()?;
        let subscriber = service
            .subscriber_builder()
            .create()
            .map_err(|e| iox(format!("create subscriber on {}", Topic::Waypoints.leaf()), e))?;
        Ok(IpcSnapshotInbox {
            subscriber,
            _service: service,
            staging: WaypointSnapshot::new(),
        })
    }

    /// A subscriber of `T`'s topic. It receives the latest sample already
    /// published, if any and if the topic keeps history.
    pub fn inbox<T: OnTopic + FixedMessage>(&self) -> Result<IpcInbox<S, T>, SetupError> {
        let service = self.pubsub::<T>()?;
        let subscriber = service
            .subscriber_builder()
            .create()
            .map_err(|e| iox(format!("create subscriber on {}", T::TOPIC.leaf()), e))?;
        Ok(IpcInbox {
            subscriber,
            _service: service,
            _t: PhantomData,
        })
    }

    /// The waker of `role`: blocks on the role's wake listener (event mode)
    /// or returns at once (spin mode).
    pub fn waker(&self, role: Role) -> Result<IpcWaker<S>, SetupError> {
        let listener = match self.opts.mode {
            WaitMode::Event => {
                let ev = self.wake_service(role)?;
                let l = ev
                    .listener_builder()
                    .create()
                    .map_err(|e| iox(format!("create listener for {}", role.as_str()), e))?;
                Some((l, ev))
            }
            WaitMode::Spin => None,
        };
        Ok(IpcWaker { listener, polls: 0 })
    }
}

/// The snapshot topic's service: edges as the payload slice, the rest in the user header.
type SnapshotFactory<S> = PubSubFactory<S, [WireEdge], SnapshotHead>;

/// The notifiers of one topic's consumers.
struct WakeUps<S: Service> {
    notifiers: Vec<Notifier<S>>,
    _services: Vec<EventFactory<S>>,
    id: EventId,
    topic: &'static str,
}

impl<S: Service> WakeUps<S> {
    fn notify(&self) -> Result<(), TransportError> {
        for n in &self.notifiers {
            n.notify_with_custom_event_id(self.id)
                .map_err(|_| TransportError::Notify { topic: self.topic })?;
        }
        Ok(())
    }
}

/// Stamps the rest of a filled message's header: sequence number, session,
/// fingerprint, send time.
fn stamp_header<T: Message>(m: &mut T, stamp: &Stamp, seq: &mut u64) {
    *seq += 1;
    let h = m.header_mut();
    h.seq = *seq;
    h.session = stamp.session;
    h.fingerprint = stamp.fingerprint;
    h.sent_mono_ns = clock::mono_now_ns();
}

/// iceoryx2 publisher of one topic plus the notifiers of its consumers.
pub struct IpcOutbox<S: Service, T: OnTopic + FixedMessage> {
    publisher: Publisher<S, T, ()>,
    wake: WakeUps<S>,
    _service: PubSubFactory<S, T, ()>,
    stamp: Stamp,
    seq: u64,
}

impl<S: Service, T: OnTopic + FixedMessage> crate::faulty::TamperOutbox<T> for IpcOutbox<S, T> {
    fn publish_tampered(
        &mut self,
        fill: &mut dyn FnMut(&mut T),
        tamper: &mut dyn FnMut(&mut T),
    ) -> Result<u64, TransportError> {
        self.send_one(fill, Some(tamper))
    }
}

impl<S: Service, T: OnTopic + FixedMessage> IpcOutbox<S, T> {
    fn send_one(
        &mut self,
        fill: &mut dyn FnMut(&mut T),
        tamper: Option<&mut dyn FnMut(&mut T)>,
    ) -> Result<u64, TransportError> {
        let topic = T::TOPIC.leaf();
        let mut sample = self
            .publisher
            .loan_uninit()
            .map_err(|_| TransportError::Loan { topic })?;
        // SAFETY: the loaned payload is valid for writes of one T and aligned
        // for T; T is a message type, for which all-zero bytes are valid.
        let mut sample = unsafe {
            zero_in_place(sample.payload_mut().as_mut_ptr());
            sample.assume_init()
        };
        let m = sample.payload_mut();
        fill(m);
        stamp_header(m, &self.stamp, &mut self.seq);
        if let Some(t) = tamper {
            t(m);
        }
        sample.send().map_err(|_| TransportError::Send { topic })?;
        self.wake.notify()?;
        Ok(self.seq)
    }
}

impl<S: Service, T: OnTopic + FixedMessage> Outbox<T> for IpcOutbox<S, T> {
    fn publish(&mut self, fill: &mut dyn FnMut(&mut T)) -> Result<u64, TransportError> {
        self.send_one(fill, None)
    }

    fn refresh(&mut self) {
        // A failed connection is retried on the next call or send.
        let _ = self.publisher.update_connections();
    }
}

/// iceoryx2 publisher of snapshots: the process fills a held snapshot,
/// which is then copied into a sample of exactly its edges.
pub struct IpcSnapshotOutbox<S: Service> {
    publisher: Publisher<S, [WireEdge], SnapshotHead>,
    wake: WakeUps<S>,
    _service: SnapshotFactory<S>,
    staging: WaypointSnapshot,
    stamp: Stamp,
    seq: u64,
}

impl<S: Service> IpcSnapshotOutbox<S> {
    fn send_one(
        &mut self,
        fill: &mut dyn FnMut(&mut WaypointSnapshot),
        tamper: Option<&mut dyn FnMut(&mut WaypointSnapshot)>,
    ) -> Result<u64, TransportError> {
        let topic = Topic::Waypoints.leaf();
        self.staging.clear();
        fill(&mut self.staging);
        stamp_header(&mut self.staging, &self.stamp, &mut self.seq);
        if let Some(t) = tamper {
            t(&mut self.staging);
        }
        let (len, max) = (self.staging.edge_count as usize, self.staging.capacity());
        if len > max {
            return Err(TransportError::Oversized { topic, len, max });
        }
        let edges = self.staging.edges_in_use();
        let mut sample = self
            .publisher
            .loan_slice_uninit(edges.len())
            .map_err(|_| TransportError::Loan { topic })?;
        *sample.user_header_mut() = *self.staging.head();
        let sample = sample.write_from_slice(edges);
        sample.send().map_err(|_| TransportError::Send { topic })?;
        self.wake.notify()?;
        Ok(self.seq)
    }
}

impl<S: Service> crate::faulty::TamperOutbox<WaypointSnapshot> for IpcSnapshotOutbox<S> {
    fn publish_tampered(
        &mut self,
        fill: &mut dyn FnMut(&mut WaypointSnapshot),
        tamper: &mut dyn FnMut(&mut WaypointSnapshot),
    ) -> Result<u64, TransportError> {
        self.send_one(fill, Some(tamper))
    }
}

impl<S: Service> Outbox<WaypointSnapshot> for IpcSnapshotOutbox<S> {
    fn publish(&mut self, fill: &mut dyn FnMut(&mut WaypointSnapshot)) -> Result<u64, TransportError> {
        self.send_one(fill, None)
    }

    fn refresh(&mut self) {
        let _ = self.publisher.update_connections();
    }
}

/// iceoryx2 subscriber of snapshots.
pub struct IpcSnapshotInbox<S: Service> {
    subscriber: Subscriber<S, [WireEdge], SnapshotHead>,
    _service: SnapshotFactory<S>,
    staging: WaypointSnapshot,
}

impl<S: Service> Inbox<WaypointSnapshot> for IpcSnapshotInbox<S> {
    fn drain(&mut self, each: &mut dyn FnMut(&WaypointSnapshot)) -> Result<usize, TransportError> {
        let mut n = 0;
        loop {
            match self.subscriber.receive() {
                Ok(Some(sample)) => {
                    self.staging.receive(sample.user_header(), sample.payload());
                    each(&self.staging);
                    n += 1;
                }
                Ok(None) => return Ok(n),
                Err(_) => {
                    return Err(TransportError::Receive {
                        topic: Topic::Waypoints.leaf(),
                    });
                }
            }
        }
    }
}

/// iceoryx2 subscriber of one topic.
pub struct IpcInbox<S: Service, T: OnTopic + FixedMessage> {
    subscriber: Subscriber<S, T, ()>,
    _service: PubSubFactory<S, T, ()>,
    _t: PhantomData<T>,
}

impl<S: Service, T: OnTopic + FixedMessage> Inbox<T> for IpcInbox<S, T> {
    fn drain(&mut self, each: &mut dyn FnMut(&T)) -> Result<usize, TransportError> {
        let mut n = 0;
        loop {
            match self.subscriber.receive() {
                Ok(Some(sample)) => {
                    each(sample.payload());
                    n += 1;
                }
                Ok(None) => return Ok(n),
                Err(_) => {
                    return Err(TransportError::Receive { topic: T::TOPIC.leaf() });
                }
            }
        }
    }
}

/// Spin-mode polls between two `sched_yield`s (our choice: about 0.8 ms of
/// polling at ~0.2 µs per poll, so a spinner still gives way to a starved
/// peer on a small machine). Measured on the quiet 2-core VM
/// (`planner bench-latency --spin`): every 256 polls, a yield that lands on
/// another runnable task put the plan's wire time at p99 6.9 µs and the raw
/// round trip at p99 52 µs; every 4096 polls, 4.0–5.8 µs and 0.9–1.0 µs.
const SPIN_YIELD_EVERY: u32 = 4096;

/// Blocks on a role's wake listener, or spins.
pub struct IpcWaker<S: Service> {
    listener: Option<(Listener<S>, EventFactory<S>)>,
    polls: u32,
}

impl<S: Service> Waker for IpcWaker<S> {
    fn wait(&mut self, timeout: Duration) -> Result<Wake, TransportError> {
        if signal::shutdown_requested() {
            return Ok(Wake::Shutdown);
        }
        let Some((listener, _)) = &self.listener else {
            // Busy-poll; every SPIN_YIELD_EVERY polls give the core away if
            // something else is runnable (sched_yield returns at once on an
            // idle core), so a spinner does not starve the process it waits
            // for on a small machine.
            self.polls = self.polls.wrapping_add(1);
            if self.polls.is_multiple_of(SPIN_YIELD_EVERY) {
                std::thread::yield_now();
            } else {
                core::hint::spin_loop();
            }
            return Ok(Wake::Woken(u32::MAX));
        };
        let mut mask = 0u32;
        match listener.timed_wait(|e| mask |= 1 << (e.id.as_value() & 31), timeout) {
            Ok(_) if mask != 0 => Ok(Wake::Woken(mask)),
            Ok(_) => Ok(Wake::Timeout),
            Err(ListenerWaitError::InterruptSignal) if signal::shutdown_requested() => Ok(Wake::Shutdown),
            // Another signal (e.g. SIGCHLD of a child process): a spurious wake-up.
            Err(ListenerWaitError::InterruptSignal) => Ok(Wake::Woken(u32::MAX)),
            Err(_) => Err(TransportError::Wait),
        }
    }
}

/// Removes the resources of dead nodes in the domain of `cfg`; returns how
/// many dead nodes were cleaned (a start-up step: a crashed earlier run may
/// have left them, notes §5).
pub fn cleanup_dead_nodes(cfg: &Config) -> usize {
    let mut cleaned = 0;
    let _ = Node::<ipc::Service>::list(cfg, |state| {
        if let NodeState::Dead(view) = state
            && view.try_remove_stale_resources().is_ok()
        {
            cleaned += 1;
        }
        CallbackProgression::Continue
    });
    cleaned
}

/// Whether any node of the domain of `cfg` is alive.
pub fn any_node_alive(cfg: &Config) -> bool {
    let mut alive = false;
    let _ = Node::<ipc::Service>::list(cfg, |state| {
        if let NodeState::Alive(_) = state {
            alive = true;
            return CallbackProgression::Stop;
        }
        CallbackProgression::Continue
    });
    alive
}

/// Removes what iceoryx2 keeps per domain by design (the 16-byte global
/// management segment, notes §6) once no node of the domain is alive; dead
/// nodes are cleaned first. Returns whether the domain is now empty. Call it
/// from the process that owns the run (the mission or the bench), after its
/// children have exited and its own node is dropped.
pub fn retire_domain(prefix: &str) -> Result<bool, SetupError> {
    let cfg = domain_config(prefix)?;
    cleanup_dead_nodes(&cfg);
    if any_node_alive(&cfg) {
        return Ok(false);
    }
    // SAFETY: no process of this domain is alive (checked just above; the
    // caller owns the run, so none is starting).
    let _ = unsafe { iceoryx2::testing::remove_global_mgmt_segment::<ipc::Service>(&cfg) };
    remove_orphaned_node_files(prefix);
    Ok(true)
}

/// Removes what a node killed while it was being created leaves: iceoryx2
/// 0.10 cleans a dead node whose details were never written with the
/// global configuration, i.e. in another domain, so its monitor files and
/// port tags stay. Only called once no node of the domain is alive, so
/// every file still named after the domain belongs to a dead process.
fn remove_orphaned_node_files(prefix: &str) {
    for f in leftover_files(prefix) {
        if f.is_file()
            && std::fs::remove_file(&f).is_ok()
            && let Some(dir) = f.parent()
            && dir
                .parent()
                .is_some_and(|d| d.file_name().is_some_and(|n| n == "nodes"))
        {
            // The dead node's own folder of port tags, once empty.
            let _ = std::fs::remove_dir(dir);
        }
    }
}

/// Files of the domain `prefix` that exist now in `/dev/shm` and in
/// iceoryx2's root directory (leak check for tests and soak runs).
pub fn leftover_files(prefix: &str) -> Vec<std::path::PathBuf> {
    fn walk(dir: &std::path::Path, prefix: &str, depth: u32, out: &mut Vec<std::path::PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else { return };
        for e in entries.flatten() {
            let p = e.path();
            if e.file_name().to_string_lossy().starts_with(prefix) {
                out.push(p.clone());
            }
            if depth > 0 && p.is_dir() {
                walk(&p, prefix, depth - 1, out);
            }
        }
    }
    let mut out = Vec::new();
    walk(std::path::Path::new("/dev/shm"), prefix, 0, &mut out);
    let root = Config::default().global.root_path().to_string();
    walk(std::path::Path::new(&root), prefix, 3, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Topic, unique_prefix};
    use auv_messages::msg::{Plan, VehicleState};

    fn ctx(prefix: &str, vehicle: &str) -> IpcContext<local::Service> {
        let o = IpcOptions::new(Some(prefix), vehicle, WaitMode::Event).unwrap();
        IpcContext::<local::Service>::new(&o, "test").unwrap()
    }

    #[test]
    fn publish_stamps_headers_and_wakes_the_consumer() {
        let prefix = unique_prefix("u");
        let c = ctx(&prefix, "v1");
        let mut waker = c.waker(Role::Vehicle).unwrap();
        let mut inbox = c.inbox::<Plan>().unwrap();
        let mut out = c
            .outbox::<Plan>(Stamp {
                fingerprint: 9,
                session: 5,
            })
            .unwrap();
        for k in 0..3u32 {
            out.publish(&mut |p: &mut Plan| {
                p.route_len = 2;
                p.iterations = k;
            })
            .unwrap();
        }
        match waker.wait(Duration::from_secs(5)).unwrap() {
            Wake::Woken(mask) => assert_ne!(mask & (1 << Topic::Plan.event_id()), 0),
            other => panic!("expected a wake-up, got {other:?}"),
        }
        let mut seen = Vec::new();
        inbox
            .drain(&mut |p: &Plan| seen.push((p.header.seq, p.header.session, p.header.fingerprint, p.iterations)))
            .unwrap();
        // Plans queue deep: none was lost.
        assert_eq!(seen, vec![(1, 5, 9, 0), (2, 5, 9, 1), (3, 5, 9, 2)]);
    }

    #[test]
    fn a_full_state_queue_overwrites_its_oldest_sample() {
        let prefix = unique_prefix("u");
        let c = ctx(&prefix, "v4");
        let mut inbox = c.inbox::<VehicleState>().unwrap();
        let mut out = c.outbox::<VehicleState>(Stamp::new(1)).unwrap();
        for k in 1..=3u32 {
            out.publish(&mut |s: &mut VehicleState| s.arrivals = k).unwrap();
        }
        let mut got = Vec::new();
        inbox.drain(&mut |s: &VehicleState| got.push(s.arrivals)).unwrap();
        // Buffer 2 with safe overflow: the oldest was overwritten.
        assert_eq!(got, vec![2, 3]);
    }

    #[test]
    fn a_late_subscriber_gets_the_latest_value() {
        let prefix = unique_prefix("u");
        let c = ctx(&prefix, "v2");
        let mut out = c.outbox::<VehicleState>(Stamp::new(1)).unwrap();
        out.publish(&mut |s: &mut VehicleState| s.arrivals = 1).unwrap();
        out.publish(&mut |s: &mut VehicleState| s.arrivals = 2).unwrap();
        let mut inbox = c.inbox::<VehicleState>().unwrap();
        // History reaches a late joiner when the publisher acts next.
        out.publish(&mut |s: &mut VehicleState| s.arrivals = 3).unwrap();
        let mut got = Vec::new();
        inbox.drain(&mut |s: &VehicleState| got.push(s.arrivals)).unwrap();
        assert_eq!(got.last(), Some(&3));
    }

    #[test]
    fn a_timeout_without_input_is_reported() {
        let prefix = unique_prefix("u");
        let c = ctx(&prefix, "v3");
        let mut waker = c.waker(Role::Planner).unwrap();
        assert_eq!(waker.wait(Duration::from_millis(1)).unwrap(), Wake::Timeout);
    }
}
