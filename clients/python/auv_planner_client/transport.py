"""Open the planner's iceoryx2 services from Python, with exactly the QoS
the Rust processes use (``crates/transport/src/ipc.rs``: ``topic_qos`` and
``wake_qos``; ``tests/test_layout.py`` checks these values against
``planner wire-layout``).

Topology: every topic is a latest-value publish-subscribe service
``auv/<vehicle>/<leaf>``; a publisher also notifies the wake event service
``auv/<vehicle>/<role>/wake/v1`` of each role that consumes the topic, with
the topic's event id, so a consumer blocks on one listener whatever it reads.

Services are opened with ``open_or_create`` and the Rust QoS, so a client
may start before or after the mission's processes.

The waypoints topic is the one whose samples vary in size: a slice of
``WireEdge`` behind a ``SnapshotHead`` user header. Its inbox hands out
``messages.WaypointSnapshot`` objects; its outbox sends one.
"""

import ctypes
import os
import time

import iceoryx2 as iox2

from . import messages as m


class Topic:
    """One topic: its payload class (the slice's element when ``user_header``
    is given), service leaf, event id, consumers and QoS."""

    def __init__(self, cls, leaf, event_id, consumers, history_size, subscriber_max_buffer_size, user_header=None):
        self.cls = cls
        self.user_header = user_header
        self.leaf = leaf
        self.event_id = event_id
        self.consumers = consumers
        self.history_size = history_size
        self.subscriber_max_buffer_size = subscriber_max_buffer_size
        # Consumers, the mission's monitor, OUTSIDE_CLIENTS, one restarted consumer.
        self.max_subscribers = len(consumers) + 1 + OUTSIDE_CLIENTS + 1


OUTSIDE_CLIENTS = 2
SUBSCRIBER_MAX_BORROWED_SAMPLES = 1
ENABLE_SAFE_OVERFLOW = True
MAX_PUBLISHERS = 3
WAKE_EVENT_ID_MAX_VALUE = 15
WAKE_MAX_NOTIFIERS = 16
WAKE_MAX_LISTENERS = 4

ROLES = ("planner", "vehicle", "sensor")

WAYPOINTS = Topic(m.WireEdge, "sensor/waypoints/v2", 1, ("planner", "vehicle"), 1, 2, user_header=m.SnapshotHead)
VEHICLE_STATE = Topic(m.VehicleState, "vehicle/state/v3", 2, ("planner", "sensor"), 1, 2)
# Plans queue deep: an observer counting them must not lose one in a burst.
PLAN = Topic(m.Plan, "planner/plan/v3", 3, ("vehicle",), 0, 64)
STATUS = Topic(m.PlannerStatus, "planner/status/v4", 4, ("vehicle",), 1, 2)
# Operator commands (from the shore link) and their acks: never replayed,
# each one matters. Acks wake no role: the shore link polls them.
COMMAND = Topic(m.OperatorCommand, "operator/command/v1", 7, ("planner",), 0, 16)
ACK = Topic(m.CommandAck, "planner/ack/v1", 8, (), 0, 16)
TOPICS = [WAYPOINTS, VEHICLE_STATE, PLAN, STATUS, COMMAND, ACK]

MAX_PREFIX_LEN = 32


class ClientError(Exception):
    """A set-up step failed (bad name, iceoryx2 refused a service or port)."""


def check_name(what, value):
    ok = value and len(value) <= MAX_PREFIX_LEN and all(c.isascii() and (c.isalnum() or c == "_") for c in value)
    if not ok:
        raise ClientError("invalid %s %r: 1 to 32 characters of A-Z, a-z, 0-9 and _" % (what, value))


def domain_config(prefix):
    """The iceoryx2 configuration of one isolation domain: the default one
    with our prefix (as the Rust side builds it; ``global_config()`` would
    read config files the Rust side does not)."""
    check_name("ipc prefix", prefix)
    cfg = iox2.config.default()
    cfg.global_cfg.prefix = iox2.FileName.new(prefix)
    return cfg


class Stamp:
    """Header stamp of one sender: scenario fingerprint, session (one per
    process start), and the next sequence number."""

    def __init__(self, fingerprint, session=None):
        self.fingerprint = fingerprint
        self.session = session if session is not None else int.from_bytes(os.urandom(8), "little") or 1
        self.seq = 0

    def stamp(self, header):
        """Writes seq (+1), session, fingerprint and the send time into ``header``; returns the seq."""
        self.seq += 1
        header.seq = self.seq
        header.session = self.session
        header.fingerprint = self.fingerprint
        header.sent_mono_ns = time.monotonic_ns()
        return self.seq


class Outbox:
    """Publishes one topic and wakes its consumers. On the waypoints topic
    the samples hold the edges of a network of up to ``max_nodes`` waypoints."""

    def __init__(self, client, topic, max_nodes=128):
        self.topic = topic
        self._service = client._pubsub(topic)
        self._max_edges = max(1, max_nodes * (max_nodes - 1) // 2)
        try:
            builder = self._service.publisher_builder().max_loaned_samples(1)
            if topic.user_header is not None:
                builder = builder.initial_max_slice_len(self._max_edges)
            self._publisher = builder.create()
        except Exception as e:  # iceoryx2 raises its own exception classes
            raise ClientError("create publisher on %s: %r" % (topic.leaf, e)) from e
        self._notifiers = [client._notifier(role) for role in topic.consumers]
        self._event = iox2.EventId.new(topic.event_id)

    def send(self, msg):
        """Sends ``msg`` as it is and wakes the consumers: a ctypes instance of
        the topic's class, or on the waypoints topic a ``WaypointSnapshot``
        (its head, and its first ``edge_count`` edges as the slice)."""
        if self.topic.user_header is not None:
            edges = msg.edges_in_use()
            if len(edges) > self._max_edges:
                raise ClientError(
                    "%s: %d edges exceed the %d a sample of this outbox holds (open it with a larger max_nodes)"
                    % (self.topic.leaf, len(edges), self._max_edges)
                )
            sample = self._publisher.loan_slice_uninit(len(edges))
            ctypes.memmove(sample.user_header_ptr, ctypes.byref(msg.head), ctypes.sizeof(msg.head))
            if edges:
                array = (m.WireEdge * len(edges))(*edges)
                ctypes.memmove(sample.payload_ptr, array, ctypes.sizeof(array))
            sample = sample.assume_init()
        else:
            sample = self._publisher.loan_uninit()
            sample = sample.write_payload(msg)
        sample.send()
        for n in self._notifiers:
            n.notify_with_custom_event_id(self._event)

    def publish(self, msg, stamp):
        """Stamps ``msg``'s header with ``stamp``, sends it; returns its seq."""
        seq = stamp.stamp(msg.header)
        self.send(msg)
        return seq

    def refresh(self):
        """Hands the latest value to subscribers that joined since the last send."""
        self._publisher.update_connections()


class Inbox:
    """Drains one topic, copying each sample out (a subscriber may hold only
    one sample at a time)."""

    def __init__(self, client, topic):
        self.topic = topic
        self._service = client._pubsub(topic)
        try:
            self._subscriber = self._service.subscriber_builder().create()
        except Exception as e:
            raise ClientError("create subscriber on %s: %r" % (topic.leaf, e)) from e

    def drain(self):
        """Every message that arrived since the last call, oldest first (copies)."""
        out = []
        while True:
            sample = self._subscriber.receive()
            if sample is None:
                return out
            if self.topic.user_header is not None:
                head = m.copy_of(self.topic.user_header, sample.user_header_ptr)
                # The sample header's element count: iceoryx2 0.10's Python
                # `payload()` Slice of a sample from a Rust publisher has its
                # length in bytes, which would read far past the sample.
                n = sample.header.number_of_elements
                data = ctypes.string_at(sample.payload_ptr, n * ctypes.sizeof(m.WireEdge))
                out.append(m.WaypointSnapshot(head, (m.WireEdge * n).from_buffer_copy(data)))
            else:
                out.append(m.copy_of(self.topic.cls, sample.payload_ptr))
            sample.delete()


class Waker:
    """Blocks on a role's wake listener."""

    def __init__(self, client, role):
        self._service = client._wake(role)
        try:
            self._listener = self._service.listener_builder().create()
        except Exception as e:
            raise ClientError("create listener for %s: %r" % (role, e)) from e

    def wait(self, timeout_s):
        """Waits at most ``timeout_s``; returns the set of event ids seen (empty on timeout)."""
        d = iox2.Duration.from_secs_f64(max(timeout_s, 0.0))
        return {a.id.as_value for a in self._listener.timed_wait(d)}


class Client:
    """One node in the planner's domain ``prefix``, for vehicle ``vehicle``."""

    def __init__(self, prefix, vehicle="auv1", node_name="py-client"):
        check_name("vehicle name", vehicle)
        self.prefix = prefix
        self.vehicle = vehicle
        cfg = domain_config(prefix)
        try:
            self.node = (
                iox2.NodeBuilder.new()
                .name(iox2.NodeName.new(node_name))
                .config(cfg)
                .signal_handling_mode(iox2.SignalHandlingMode.Disabled)
                .create(iox2.ServiceType.Ipc)
            )
        except Exception as e:
            raise ClientError("create node: %r" % e) from e
        self._pubsubs = {}
        self._wakes = {}

    def service_name(self, topic):
        return "auv/%s/%s" % (self.vehicle, topic.leaf)

    def wake_name(self, role):
        return "auv/%s/%s/wake/v1" % (self.vehicle, role)

    def _pubsub(self, topic):
        if topic.leaf not in self._pubsubs:
            name = self.service_name(topic)
            try:
                builder = self.node.service_builder(iox2.ServiceName.new(name))
                if topic.user_header is not None:
                    builder = builder.publish_subscribe(iox2.Slice[topic.cls]).user_header(topic.user_header)
                else:
                    builder = builder.publish_subscribe(topic.cls)
                svc = (
                    builder.history_size(topic.history_size)
                    .subscriber_max_buffer_size(topic.subscriber_max_buffer_size)
                    .subscriber_max_borrowed_samples(SUBSCRIBER_MAX_BORROWED_SAMPLES)
                    .enable_safe_overflow(ENABLE_SAFE_OVERFLOW)
                    .max_publishers(MAX_PUBLISHERS)
                    .max_subscribers(topic.max_subscribers)
                    .open_or_create()
                )
            except Exception as e:
                raise ClientError("open service %s: %r" % (name, e)) from e
            self._pubsubs[topic.leaf] = svc
        return self._pubsubs[topic.leaf]

    def _wake(self, role):
        if role not in self._wakes:
            name = self.wake_name(role)
            try:
                svc = (
                    self.node.service_builder(iox2.ServiceName.new(name))
                    .event()
                    .event_id_max_value(WAKE_EVENT_ID_MAX_VALUE)
                    .max_notifiers(WAKE_MAX_NOTIFIERS)
                    .max_listeners(WAKE_MAX_LISTENERS)
                    .open_or_create()
                )
            except Exception as e:
                raise ClientError("open event service %s: %r" % (name, e)) from e
            self._wakes[role] = svc
        return self._wakes[role]

    def _notifier(self, role):
        try:
            return self._wake(role).notifier_builder().create()
        except ClientError:
            raise
        except Exception as e:
            raise ClientError("create notifier for %s: %r" % (role, e)) from e

    def outbox(self, topic, max_nodes=128):
        return Outbox(self, topic, max_nodes)

    def inbox(self, topic):
        return Inbox(self, topic)

    def waker(self, role):
        return Waker(self, role)

