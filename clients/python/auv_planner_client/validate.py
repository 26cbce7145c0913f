"""Receiver-side checks, as the Rust receivers apply them
(``crates/messages/src/msg.rs``: ``Validate`` and ``SeqGuard``; order: scenario
fingerprint, payload, sequence). Each check returns ``None`` for a good
message or the snake_case name of the reject kind."""

import math

from . import messages as m


class Reject(Exception):
    """A message refused, with its kind (one of ``messages.REJECT_KIND_NAMES``)."""

    def __init__(self, kind):
        super().__init__(kind)
        self.kind = kind


def _finite(v):
    if not math.isfinite(v):
        raise Reject("non_finite")


def _at_least(v, lo):
    _finite(v)
    if not v >= lo:
        raise Reject("out_of_range")


def _positive(v):
    _finite(v)
    if not v > 0.0:
        raise Reject("out_of_range")


def _code(enum, c):
    if c not in m.ENUMS[enum].values():
        raise Reject("malformed")


def _count(c, cap):
    if c > cap:
        raise Reject("malformed")
    return c


def _node(i, n):
    if i >= n:
        raise Reject("node_out_of_range")
    return i


def _header(h):
    _at_least(h.mission_time_s, 0.0)
    if h.seq == 0:
        raise Reject("out_of_range")


def _ids_in_range(ids):
    if any(i >= m.MAX_WIRE_NODES for i in ids):
        raise Reject("node_out_of_range")


def _snapshot(s):
    _header(s.header)
    _positive(s.speed_mps)
    _positive(s.time_available_s)
    _at_least(s.next_update_s, s.header.mission_time_s)
    _code("ObjectiveCode", s.objective)
    if s.objective == m.ObjectiveCode.PAPER_COST:
        _at_least(s.phi1, 0.0)
        _at_least(s.phi2, 0.0)
    n = _count(s.node_count, m.MAX_WIRE_NODES)
    k = _count(s.edge_count, min(m.MAX_WIRE_EDGES, len(s.edges)))
    if n < 2:
        raise Reject("malformed")
    start, goal = _node(s.start, n), _node(s.goal, n)
    if start == goal:
        raise Reject("malformed")
    for p in s.nodes[:n]:
        _finite(p.x)
        _finite(p.y)
        _finite(p.z)
        _at_least(p.prize, 0.0)
    for e in s.edges[:k]:
        a, b = _node(e.a, n), _node(e.b, n)
        if a == b:
            raise Reject("malformed")
        _at_least(e.priority, 0.0)
        _positive(e.risk)
        _at_least(e.task_time_s, 0.0)


def _plan(p):
    _header(p.header)
    for v in (p.time_s, p.weight, p.distance_m, p.budget_s):
        _finite(v)
    _code("TriggerKind", p.trigger)
    for flag in (p.deadline_cut, p.feasible, p.fallback):
        if flag > 1:
            raise Reject("malformed")
    n = _count(p.route_len, m.MAX_WIRE_NODES)
    if n < 1:
        raise Reject("malformed")
    _ids_in_range(p.route[:n])


def _status(s):
    _header(s.header)
    _code("PlannerPhase", s.phase)


def _state(s):
    _header(s.header)
    for v in s.position:
        _finite(v)
    _finite(s.time_left_s)
    _at_least(s.eta_free_s, 0.0)
    _at_least(s.weight, 0.0)
    _at_least(s.distance_m, 0.0)
    _code("VehicleMode", s.mode)
    _code("VehicleEvent", s.event)
    _code("Outcome", s.outcome)
    _node(s.from_node, m.MAX_WIRE_NODES)
    _node(s.to_node, m.MAX_WIRE_NODES)
    n = _count(s.route_len, m.MAX_WIRE_NODES)
    if n == 0:
        raise Reject("malformed")
    _ids_in_range(s.route[:n])
    _finite(s.time_scale)
    if s.needs_answer > 1:
        raise Reject("malformed")


_CHECKS = {
    m.WaypointSnapshot: _snapshot,
    m.Plan: _plan,
    m.PlannerStatus: _status,
    m.VehicleState: _state,
}


def validate(msg):
    """``None`` when every field of ``msg`` is in range, else the first problem's kind."""
    try:
        _CHECKS[type(msg)](msg)
    except Reject as r:
        return r.kind
    return None


class Guard:
    """Per-topic receiver: the scenario check, the payload check and the
    per-session sequence check, with rejections counted by kind. A rejected
    message never advances the sequence check."""

    def __init__(self, fingerprint=None):
        #: The scenario accepted; ``None`` adopts the first well-formed message's.
        self.fingerprint = fingerprint
        self.session = 0
        self.last_seq = 0
        self.rejected = [0] * m.REJECT_KINDS

    def reject(self, kind):
        self.rejected[m.ENUMS["RejectKind"][kind]] += 1

    def check(self, msg):
        """``None`` when ``msg`` is accepted (and remembered), else its reject kind (counted)."""
        h = msg.header
        kind = None
        if self.fingerprint is not None and h.fingerprint != self.fingerprint:
            kind = "foreign_scenario"
        else:
            kind = validate(msg)
        if kind is None and h.session == self.session and self.last_seq != 0:
            if h.seq == self.last_seq:
                kind = "repeated"
            elif h.seq < self.last_seq:
                kind = "out_of_order"
        if kind is not None:
            self.reject(kind)
            return kind
        if self.fingerprint is None:
            self.fingerprint = h.fingerprint
        self.session = h.session
        self.last_seq = h.seq
        return None
