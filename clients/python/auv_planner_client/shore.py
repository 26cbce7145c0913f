"""Watch and command a vehicle over its shore link (Eclipse Zenoh), from Python.

The onboard bridge (``planner link``, started by ``planner mission --shore
tcp/ADDR:PORT``) publishes the vehicle's topics as ``auv-shore/1`` JSON on
``auv/<vehicle>/<leaf>`` and takes operator commands on
``auv/<vehicle>/command``; the repository's ``docs/shore.md`` is the
contract. This module is a client of that contract on PyPI's
``eclipse-zenoh`` (``pip install ./clients/python[shore]``), with the
settings the Rust console uses: peer mode, the given endpoint only, multicast
scouting and gossip off, retrying until the vehicle listens.

    with ShoreClient("tcp/127.0.0.1:7447") as shore:
        for leaf, msg in shore.messages(timeout_s=60):
            if leaf == "plan":
                print(msg["seq"], msg["route"])

A payload of another format, or of a type the leaf does not carry, raises
:class:`BadPayload` in :func:`decode` and is counted (``refused``) and
skipped by :meth:`ShoreClient.messages`.
"""

import itertools
import json
import os
import queue
import time

import zenoh

from . import messages as m

#: The encoding's name; a receiver refuses any other.
FORMAT = "auv-shore/1"

#: The payload ``type`` each leaf below ``auv/<vehicle>/`` carries: the
#: iceoryx2 type name of the onboard message, or one of the link's own.
LEAF_TYPES = {
    "state": m.VehicleState.type_name(),
    "plan": m.Plan.type_name(),
    "status": m.PlannerStatus.type_name(),
    "snapshot": m.WaypointSnapshot.type_name(),
    "ack": m.CommandAck.type_name(),
    "event": "auv.shore.Event",
    "heartbeat/onboard": "auv.shore.Heartbeat",
}

#: The commands an operator may send, as ``planner shore --command`` names them.
COMMANDS = ("abort-to-goal", "set-time-budget", "add-task", "remove-task")

#: Outcomes of a vehicle state that end the mission.
FINAL_OUTCOMES = ("goal_reached", "timed_out", "safe_hold", "aborted")


class BadPayload(ValueError):
    """A payload that is not ``auv-shore/1`` JSON of the type its key carries."""


def decode(leaf, payload):
    """The message ``payload`` (bytes) on ``leaf``, as a dict; raises :class:`BadPayload`."""
    want = LEAF_TYPES.get(leaf)
    if want is None:
        raise BadPayload("%s: not a key the vehicle publishes" % leaf)
    try:
        msg = json.loads(bytes(payload).decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as e:
        raise BadPayload("%s: not JSON: %s" % (leaf, e)) from None
    if not isinstance(msg, dict):
        raise BadPayload("%s: not a JSON object" % leaf)
    if msg.get("format") != FORMAT:
        raise BadPayload("%s: format %r, expected %r" % (leaf, msg.get("format"), FORMAT))
    if msg.get("type") != want:
        raise BadPayload("%s: type %r, expected %r" % (leaf, msg.get("type"), want))
    return msg


def config(endpoint, credentials=None):
    """The Zenoh configuration of a shore peer on ``endpoint`` (``tcp/HOST:PORT``);
    ``credentials`` is ``(user, password)`` for a vehicle that authenticates."""
    if not endpoint.startswith("tcp/") or ":" not in endpoint[4:]:
        raise ValueError("endpoint %r: expected tcp/HOST:PORT" % endpoint)
    cfg = zenoh.Config()
    cfg.insert_json5("mode", '"peer"')
    cfg.insert_json5("listen/endpoints", "[]")
    cfg.insert_json5("connect/endpoints", json.dumps([endpoint]))
    cfg.insert_json5("scouting/multicast/enabled", "false")
    cfg.insert_json5("scouting/gossip/enabled", "false")
    # Connect in the background and keep retrying: the vehicle may not
    # listen yet, and the link comes and goes.
    cfg.insert_json5("connect/timeout_ms", "-1")
    cfg.insert_json5("connect/exit_on_failure", "false")
    cfg.insert_json5("connect/retry", "{period_init_ms: 100, period_max_ms: 1000, period_increase_factor: 2}")
    if credentials is not None:
        user, password = credentials
        cfg.insert_json5("transport/auth/usrpwd", json.dumps({"user": user, "password": password}))
    return cfg


class ShoreClient:
    """One shore peer of vehicle ``vehicle``: its messages, catch-up and commands."""

    def __init__(self, endpoint, vehicle="auv1", credentials=None):
        self.vehicle = vehicle
        self.prefix = "auv/%s/" % vehicle
        #: Payloads refused (wrong format or type), by leaf.
        self.refused = {}
        self._inbox = queue.Queue()
        self._session = zenoh.open(config(endpoint, credentials))
        self._subscriber = self._session.declare_subscriber(self.prefix + "**", self._on_sample)
        # Command ids: unique per client (time-based start, then counting), never 0.
        self._ids = itertools.count((time.time_ns() // 1000) ^ (os.getpid() << 40) | 1)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        self._subscriber.undeclare()
        self._session.close()

    def _on_sample(self, sample):
        # Zenoh's thread: only hand the sample over.
        self._inbox.put((str(sample.key_expr), sample.payload.to_bytes()))

    def _leaf(self, key):
        return key[len(self.prefix):] if key.startswith(self.prefix) else None

    def messages(self, timeout_s):
        """Yields ``(leaf, message)`` as they arrive, until ``timeout_s`` passes
        with nothing new. The client's own keys (commands, its heartbeat) are
        skipped; refused payloads are counted in ``refused``."""
        while True:
            got = self._next(timeout_s)
            if got is None:
                return
            yield got

    def _next(self, timeout_s):
        """The next message of the vehicle, or None after ``timeout_s`` without one."""
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                key, payload = self._inbox.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                return None
            leaf = self._leaf(key)
            if leaf in ("command", "heartbeat/shore"):
                continue
            try:
                return leaf, decode(leaf, payload)
            except BadPayload:
                self.refused[leaf] = self.refused.get(leaf, 0) + 1

    def catch_up(self, timeout_s=2.0):
        """The latest state, plan, status and snapshot (a dict by leaf), and
        every plan the bridge has forwarded (a list, oldest first)."""
        latest = {}
        for leaf, msg in self._query(self.prefix + "*", timeout_s):
            latest[leaf] = msg
        history = [msg for leaf, msg in self._query(self.prefix + "history/plan", timeout_s, leaf="plan")]
        history.sort(key=lambda p: p["seq"])
        return latest, history

    def _query(self, selector, timeout_s, leaf=None):
        # Every reply, not the latest per key: the history is many replies on one key.
        for reply in self._session.get(selector, consolidation=zenoh.ConsolidationMode.NONE, timeout=timeout_s):
            if reply.ok is None:
                continue
            sample = reply.ok
            name = leaf or self._leaf(str(sample.key_expr))
            try:
                yield name, decode(name, sample.payload.to_bytes())
            except BadPayload:
                self.refused[name] = self.refused.get(name, 0) + 1

    def send_command(self, command, budget_s=None, waypoint=None, command_id=None):
        """Publishes one operator command; returns its id. Send it again with
        the same id until its ack arrives: onboard, a repeat is answered
        again and never applied twice."""
        if command not in COMMANDS:
            raise ValueError("command %r: expected one of %s" % (command, ", ".join(COMMANDS)))
        if command == "set-time-budget" and budget_s is None:
            raise ValueError("set-time-budget needs budget_s")
        if command in ("add-task", "remove-task") and waypoint is None:
            raise ValueError("%s needs waypoint" % command)
        cid = command_id if command_id is not None else next(self._ids)
        if cid <= 0:
            raise ValueError("command_id %r: must be > 0" % cid)
        body = {"format": FORMAT, "type": "auv.shore.Command", "id": cid, "command": command}
        if budget_s is not None:
            body["budget_s"] = float(budget_s)
        if waypoint is not None:
            body["waypoint"] = str(waypoint)
        self._session.put(self.prefix + "command", json.dumps(body).encode("utf-8"))
        return cid

    def command(self, command, timeout_s=15.0, resend_s=0.5, **kw):
        """Sends a command, resending it every ``resend_s`` until its ack
        arrives; returns the ack (a dict) and the messages that came meanwhile,
        or raises ``TimeoutError``."""
        cid = self.send_command(command, **kw)
        seen = []
        now = time.monotonic()
        deadline, resend_at = now + timeout_s, now + resend_s
        while now < deadline:
            got = self._next(max(0.0, min(deadline, resend_at) - now))
            if got is not None:
                seen.append(got)
                leaf, msg = got
                if leaf == "ack" and msg["id"] == cid:
                    return msg, seen
            now = time.monotonic()
            if now >= resend_at:
                self.send_command(command, command_id=cid, **kw)
                resend_at = now + resend_s
        raise TimeoutError("%s (id %d): no ack within %s s" % (command, cid, timeout_s))
