"""ctypes mirrors of every message on the planner's wire.

Each class mirrors the Rust struct of the same name in ``crates/messages/src/msg.rs``
field by field (``#[repr(C)]``, no implicit padding). ``type_name()`` returns
the Rust ``#[type_name]``: iceoryx2 connects two sides only when the type
name, size and alignment agree. ``tests/test_layout.py`` compares every class
here with ``planner wire-layout`` and fails on any drift.

A waypoint snapshot travels as an iceoryx2 slice of ``WireEdge`` behind a
``SnapshotHead`` user header (so its size follows the network's); in Python
the two are held together by ``WaypointSnapshot``.

Units: m, s, m/s, ns; x east, y north, z depth (positive down).
"""

import ctypes
from ctypes import c_double, c_uint16, c_uint32, c_uint64

#: Most waypoints a message names (the planner's largest capacity class).
MAX_WIRE_NODES = 512
#: Most edges a snapshot carries: every pair of MAX_WIRE_NODES waypoints.
MAX_WIRE_EDGES = MAX_WIRE_NODES * (MAX_WIRE_NODES - 1) // 2
REJECT_KINDS = 12
NO_NODE = 0xFFFF_FFFF


class Header(ctypes.Structure):
    """The common start of every message."""

    _fields_ = [
        ("seq", c_uint64),
        ("session", c_uint64),
        ("fingerprint", c_uint64),
        ("sent_mono_ns", c_uint64),
        ("mission_time_s", c_double),
    ]


class WireNode(ctypes.Structure):
    """A waypoint as reported: position (m) and prize."""

    _fields_ = [("x", c_double), ("y", c_double), ("z", c_double), ("prize", c_double)]


class WireEdge(ctypes.Structure):
    """An edge that exists now, with its task: the element of a snapshot's slice."""

    _fields_ = [
        ("a", c_uint32),
        ("b", c_uint32),
        ("priority", c_double),
        ("risk", c_double),
        ("task_time_s", c_double),
    ]

    @staticmethod
    def type_name():
        return "auv.WireEdge.v1"


class AllocCounters(ctypes.Structure):
    """Allocation counters of the planner's service thread."""

    _fields_ = [
        ("sys_allocs_total", c_uint64),
        ("sys_allocs_steady", c_uint64),
        ("sys_frees_steady", c_uint64),
        ("pool_allocs_steady", c_uint64),
        ("pool_high_water", c_uint64),
        ("pool_capacity", c_uint64),
        ("pool_misses", c_uint64),
        ("steady", c_uint64),
    ]


class SnapshotHead(ctypes.Structure):
    """sensor -> planner, vehicle: the fixed part of a snapshot (the sample's
    user header); its ``edge_count`` edges are the sample's payload slice."""

    _fields_ = [
        ("header", Header),
        ("epoch", c_uint64),
        ("speed_mps", c_double),
        ("time_available_s", c_double),
        ("phi1", c_double),
        ("phi2", c_double),
        ("next_update_s", c_double),
        ("objective", c_uint32),
        ("node_count", c_uint32),
        ("edge_count", c_uint32),
        ("start", c_uint32),
        ("goal", c_uint32),
        ("_pad", c_uint32),
        ("nodes", WireNode * MAX_WIRE_NODES),
    ]

    @staticmethod
    def type_name():
        return "auv.WaypointSnapshot.v2"


class WaypointSnapshot:
    """A snapshot held in Python: its ``head`` (a ``SnapshotHead``) and its
    ``edges`` (a ctypes array of ``WireEdge``; the first ``edge_count`` are
    in use). The head's fields read and write through the snapshot itself
    (``s.epoch``, ``s.nodes[i]``), as on the Rust side."""

    __slots__ = ("head", "edges")

    def __init__(self, head=None, edges=None, max_edges=MAX_WIRE_EDGES):
        object.__setattr__(self, "head", head if head is not None else SnapshotHead())
        object.__setattr__(self, "edges", edges if edges is not None else (WireEdge * max_edges)())

    def __getattr__(self, name):
        return getattr(self.head, name)

    def __setattr__(self, name, value):
        if name in WaypointSnapshot.__slots__:
            object.__setattr__(self, name, value)
        else:
            setattr(self.head, name, value)

    @staticmethod
    def type_name():
        return SnapshotHead.type_name()

    def edges_in_use(self):
        """The first ``edge_count`` edges (as many as the array holds)."""
        return self.edges[: min(int(self.head.edge_count), len(self.edges))]


class VehicleState(ctypes.Structure):
    """vehicle -> planner, sensor: where the vehicle is and what it has done."""

    _fields_ = [
        ("header", Header),
        ("position", c_double * 3),
        ("time_left_s", c_double),
        ("eta_free_s", c_double),
        ("weight", c_double),
        ("distance_m", c_double),
        ("time_scale", c_double),
        ("plan_seq", c_uint64),
        ("snapshot_epoch", c_uint64),
        ("mode", c_uint32),
        ("event", c_uint32),
        ("outcome", c_uint32),
        ("from_node", c_uint32),
        ("to_node", c_uint32),
        ("arrivals", c_uint32),
        ("tasks_completed", c_uint32),
        ("needs_answer", c_uint32),
        ("stale_plans", c_uint32),
        ("route_len", c_uint32),
        ("rejected", c_uint64 * REJECT_KINDS),
        ("route", c_uint16 * MAX_WIRE_NODES),
    ]

    @staticmethod
    def type_name():
        return "auv.VehicleState.v3"


class Plan(ctypes.Structure):
    """planner -> vehicle: the route from where the vehicle will be free to the goal."""

    _fields_ = [
        ("header", Header),
        ("state_seq", c_uint64),
        ("snapshot_epoch", c_uint64),
        ("trigger_sent_mono_ns", c_uint64),
        ("trigger_received_mono_ns", c_uint64),
        ("compute_ns", c_uint64),
        ("solve_ns", c_uint64),
        ("time_s", c_double),
        ("weight", c_double),
        ("distance_m", c_double),
        ("budget_s", c_double),
        ("trigger", c_uint32),
        ("iterations", c_uint32),
        ("deadline_cut", c_uint32),
        ("feasible", c_uint32),
        ("fallback", c_uint32),
        ("replan", c_uint32),
        ("route_len", c_uint32),
        ("_pad", c_uint32),
        ("route", c_uint16 * MAX_WIRE_NODES),
    ]

    @staticmethod
    def type_name():
        return "auv.Plan.v3"


class PlannerStatus(ctypes.Structure):
    """planner -> anyone: counters and latency, sent after every handled input."""

    _fields_ = [
        ("header", Header),
        ("handled_state_seq", c_uint64),
        ("handled_state_session", c_uint64),
        ("handled_epoch", c_uint64),
        ("plans", c_uint64),
        ("triggers", c_uint64),
        ("sensor_updates", c_uint64),
        ("updates_without_replan", c_uint64),
        ("deadline_misses", c_uint64),
        ("deadline_cuts", c_uint64),
        ("fallbacks", c_uint64),
        ("last_latency_ns", c_uint64),
        ("max_latency_ns", c_uint64),
        ("deadline_ns", c_uint64),
        ("alloc", AllocCounters),
        ("rejected", c_uint64 * REJECT_KINDS),
        ("iterations_total", c_uint64),
        ("latency_p50_ns", c_uint64),
        ("latency_p99_ns", c_uint64),
        ("cut_iterations", c_uint64),
        ("cut_with_warm_start", c_uint64),
        ("cut_weight", c_double),
        ("cut_warm_start_weight", c_double),
        ("phase", c_uint32),
        ("last_iterations", c_uint32),
        ("rt_priority", c_uint32),
        ("_pad", c_uint32),
    ]

    @staticmethod
    def type_name():
        return "auv.PlannerStatus.v4"


class OperatorCommand(ctypes.Structure):
    """operator (through the shore link) -> planner: one command, unique ``command_id``."""

    _fields_ = [
        ("header", Header),
        ("command_id", c_uint64),
        ("value_s", c_double),
        ("kind", c_uint32),
        ("node", c_uint32),
    ]

    @staticmethod
    def type_name():
        return "auv.OperatorCommand.v1"


class CommandAck(ctypes.Structure):
    """planner -> shore link: the answer to one OperatorCommand."""

    _fields_ = [
        ("header", Header),
        ("command_id", c_uint64),
        ("plan_seq", c_uint64),
        ("kind", c_uint32),
        ("status", c_uint32),
        ("reason", c_uint32),
        ("replan", c_uint32),
    ]

    @staticmethod
    def type_name():
        return "auv.CommandAck.v1"


#: Nested structs, as ``planner wire-layout`` lists them under "structs".
STRUCTS = [Header, WireNode, AllocCounters]
#: Messages, as ``planner wire-layout`` lists them under "messages".
MESSAGES = [SnapshotHead, WireEdge, VehicleState, Plan, PlannerStatus, OperatorCommand, CommandAck]


class ObjectiveCode:
    MAX_WEIGHT = 0
    PAPER_COST = 1


class VehicleMode:
    NO_PLAN = 0
    TRAVELLING = 1
    WORKING = 2
    HOLDING = 3
    FINISHED = 4


class VehicleEvent:
    PERIODIC = 0
    START = 1
    ARRIVAL = 2
    TICK = 3
    FINISHED = 4


class Outcome:
    RUNNING = 0
    GOAL_REACHED = 1
    TIMED_OUT = 2
    ABORTED = 3


class TriggerKind:
    INITIAL = 0
    ARRIVAL = 1
    EDGE_LOST = 2
    TIME_CHANGED = 3
    INFEASIBLE = 4
    SENSOR_BACK = 5
    OPERATOR = 6


class CommandKind:
    ABORT_TO_GOAL = 1
    SET_TIME_BUDGET = 2
    ADD_TASK = 3
    REMOVE_TASK = 4


class AckStatus:
    APPLIED = 1
    REFUSED = 2


class PlannerPhase:
    WAITING = 0
    RUNNING = 1
    FINISHED = 2


#: Reject kinds in counter order (the index into every ``rejected`` array).
REJECT_KIND_NAMES = [
    "foreign_scenario",
    "out_of_order",
    "repeated",
    "non_finite",
    "node_out_of_range",
    "malformed",
    "bad_plan",
    "off_water",
    "outside_bound",
    "out_of_range",
    "non_edge",
    "visited_node",
]

#: The enums as ``planner wire-layout`` names them: {enum: {snake_name: code}}.
ENUMS = {
    "ObjectiveCode": {"max_weight": 0, "paper_cost": 1},
    "VehicleMode": {"no_plan": 0, "travelling": 1, "working": 2, "holding": 3, "finished": 4},
    "VehicleEvent": {"periodic": 0, "start": 1, "arrival": 2, "tick": 3, "finished": 4},
    "Outcome": {"running": 0, "goal_reached": 1, "timed_out": 2, "aborted": 3},
    "TriggerKind": {
        "initial": 0,
        "arrival": 1,
        "edge_lost": 2,
        "time_changed": 3,
        "infeasible": 4,
        "sensor_back": 5,
        "operator": 6,
    },
    "CommandKind": {"abort_to_goal": 1, "set_time_budget": 2, "add_task": 3, "remove_task": 4},
    "AckStatus": {"applied": 1, "refused": 2},
    "RefuseReason": {
        "none": 0,
        "malformed": 1,
        "not_running": 2,
        "budget_out_of_range": 3,
        "bad_waypoint": 4,
        "already_visited": 5,
        "no_change": 6,
    },
    "PlannerPhase": {"waiting": 0, "running": 1, "finished": 2},
    "RejectKind": {name: k for k, name in enumerate(REJECT_KIND_NAMES)},
}


def name_of(enum, code):
    """The snake_case name of ``code`` in ``enum`` (one of ``ENUMS``), or ``"unknown(<code>)"``."""
    for name, c in ENUMS[enum].items():
        if c == code:
            return name
    return "unknown(%d)" % code


def copy_of(cls, address):
    """A copy of the ``cls`` message at ``address`` (a sample's payload pointer)."""
    return cls.from_buffer_copy(ctypes.string_at(address, ctypes.sizeof(cls)))


def route_of(msg):
    """The route of a plan or vehicle state as a list of node ids (length checked against capacity)."""
    n = min(int(msg.route_len), MAX_WIRE_NODES)
    return list(msg.route[:n])
