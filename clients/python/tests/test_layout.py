"""The ctypes mirrors, enum codes and QoS of the package against the Rust
definitions, as ``planner wire-layout`` prints them."""

import ctypes
import json
import subprocess

from auv_planner_client import layout, messages as m

from conftest import planner


def wire_layout():
    out = subprocess.run([planner(), "wire-layout"], check=True, capture_output=True, text=True, timeout=60)
    return json.loads(out.stdout)


def test_every_mirror_matches_the_rust_layout():
    problems = layout.check(wire_layout())
    assert problems == [], "\n".join(problems)


def test_the_sizes_are_the_ones_iceoryx2_compares():
    w = wire_layout()
    sizes = {x["type_name"]: (x["size"], x["align"]) for x in w["messages"]}
    for cls in m.MESSAGES:
        assert sizes[cls.type_name()] == (ctypes.sizeof(cls), ctypes.alignment(cls))


def _drifted_plan(fields):
    return type("Plan", (ctypes.Structure,), {"_fields_": fields, "type_name": staticmethod(m.Plan.type_name)})


def test_a_drifted_mirror_is_caught():
    w = wire_layout()
    good = list(m.Plan._fields_)
    # A field missing, two fields swapped, a field of another width, a renamed message.
    missing = _drifted_plan([f for f in good if f[0] != "fallback"])
    swapped = list(good)
    swapped[12], swapped[13] = swapped[13], swapped[12]
    narrower = [(n, ctypes.c_uint32) if n == "replan" else (n, t) for n, t in good] + [("_extra", ctypes.c_uint32)]
    for fields in (missing._fields_, swapped, narrower):
        drift = _drifted_plan(fields)
        msgs = [drift if c is m.Plan else c for c in m.MESSAGES]
        assert layout.check(w, messages=msgs), "drift in %s not caught" % [f[0] for f in fields]
    renamed = type("Plan", (ctypes.Structure,), {"_fields_": good, "type_name": staticmethod(lambda: "auv.Plan.v1")})
    msgs = [renamed if c is m.Plan else c for c in m.MESSAGES]
    assert any("type name" in p for p in layout.check(w, messages=msgs))
    # And a changed QoS or enum code on the Rust side shows too.
    w2 = json.loads(json.dumps(w))
    w2["topics"][2]["qos"]["history_size"] = 1
    w2["enums"]["RejectKind"]["non_edge"] = 99
    problems = layout.check(w2)
    assert any("history_size" in p for p in problems) and any("RejectKind" in p for p in problems)
