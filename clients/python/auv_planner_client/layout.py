"""Compare the ctypes mirrors (and the QoS and enum codes of this package)
with the wire layout the Rust side prints (``planner wire-layout``).

``check(layout)`` returns a list of one-line problems, empty when every
mirror matches: same type names, sizes, alignments, and per field the same
name, offset, size and type, in the same order.
"""

import ctypes

from . import messages as m
from . import transport as t

_SCALARS = {
    ctypes.c_uint8: "u8",
    ctypes.c_uint16: "u16",
    ctypes.c_uint32: "u32",
    ctypes.c_uint64: "u64",
    ctypes.c_double: "f64",
}


def rust_type(ct):
    """The Rust spelling of a ctypes field type (``u64``, ``Header``, ``[WireNode; 128]``)."""
    if ct in _SCALARS:
        return _SCALARS[ct]
    if issubclass(ct, ctypes.Array):
        return "[%s; %d]" % (rust_type(ct._type_), ct._length_)
    if issubclass(ct, ctypes.Structure):
        return ct.__name__
    return "unsupported(%s)" % ct.__name__


def _check_struct(cls, want, problems):
    name = want["name"]
    if cls.__name__ != name:
        problems.append("%s: mirror is named %s" % (name, cls.__name__))
    type_name = cls.type_name() if hasattr(cls, "type_name") else None
    if type_name != want["type_name"]:
        problems.append("%s: type name %r, Rust has %r" % (name, type_name, want["type_name"]))
    if ctypes.sizeof(cls) != want["size"]:
        problems.append("%s: size %d, Rust has %d" % (name, ctypes.sizeof(cls), want["size"]))
    if ctypes.alignment(cls) != want["align"]:
        problems.append("%s: alignment %d, Rust has %d" % (name, ctypes.alignment(cls), want["align"]))
    mine = [(f[0], f[1]) for f in cls._fields_]
    if [f for f, _ in mine] != [f["name"] for f in want["fields"]]:
        problems.append(
            "%s: fields %s, Rust has %s" % (name, [f for f, _ in mine], [f["name"] for f in want["fields"]])
        )
    for (fname, ftype), wf in zip(mine, want["fields"]):
        if fname != wf["name"]:
            continue
        d = getattr(cls, fname)
        got = (d.offset, d.size, rust_type(ftype))
        exp = (wf["offset"], wf["size"], wf["type"])
        if got != exp:
            problems.append("%s.%s: offset/size/type %s, Rust has %s" % (name, fname, got, exp))


def check(layout, structs=None, messages=None):
    """Problems between the mirrors and ``layout`` (the parsed JSON of ``planner wire-layout``)."""
    problems = []
    if layout.get("format") != "auv-wire-layout/1":
        return ["unknown layout format %r" % layout.get("format")]
    for key, classes in (("structs", structs or m.STRUCTS), ("messages", messages or m.MESSAGES)):
        want = layout[key]
        if len(classes) != len(want):
            problems.append(
                "%s: mirrors %s, Rust has %s" % (key, [c.__name__ for c in classes], [w["name"] for w in want])
            )
        for cls, w in zip(classes, want):
            _check_struct(cls, w, problems)
    consts = layout["constants"]
    for k in ("MAX_WIRE_NODES", "MAX_WIRE_EDGES", "REJECT_KINDS", "NO_NODE"):
        if getattr(m, k) != consts[k]:
            problems.append("constant %s = %s, Rust has %s" % (k, getattr(m, k), consts[k]))
    for enum, codes in layout["enums"].items():
        if m.ENUMS.get(enum) != codes:
            problems.append("enum %s = %s, Rust has %s" % (enum, m.ENUMS.get(enum), codes))
    if len(layout["topics"]) != len(t.TOPICS):
        problems.append("topics: %d mirrored, Rust has %d" % (len(t.TOPICS), len(layout["topics"])))
    for topic, w in zip(t.TOPICS, layout["topics"]):
        mine = {
            "leaf": topic.leaf,
            "payload": "slice" if topic.user_header is not None else "struct",
            "type_name": topic.cls.type_name(),
            "event_id": topic.event_id,
            "consumers": list(topic.consumers),
            "qos": {
                "history_size": topic.history_size,
                "subscriber_max_buffer_size": topic.subscriber_max_buffer_size,
                "subscriber_max_borrowed_samples": t.SUBSCRIBER_MAX_BORROWED_SAMPLES,
                "enable_safe_overflow": t.ENABLE_SAFE_OVERFLOW,
                "max_publishers": t.MAX_PUBLISHERS,
                "max_subscribers": topic.max_subscribers,
            },
        }
        head = topic.user_header
        mine["user_header"] = {
            "type_name": head.type_name() if head is not None else "()",
            "size": ctypes.sizeof(head) if head is not None else 0,
            "align": ctypes.alignment(head) if head is not None else 1,
        }
        for k, v in mine.items():
            if w.get(k) != v:
                problems.append("topic %s: %s = %s, Rust has %s" % (topic.leaf, k, v, w.get(k)))
    wake = layout["wake"]
    mine = {
        "roles": list(t.ROLES),
        "event_id_max_value": t.WAKE_EVENT_ID_MAX_VALUE,
        "max_notifiers": t.WAKE_MAX_NOTIFIERS,
        "max_listeners": t.WAKE_MAX_LISTENERS,
    }
    for k, v in mine.items():
        if wake[k] != v:
            problems.append("wake services: %s = %s, Rust has %s" % (k, v, wake[k]))
    return problems
