"""Bad messages published from Python are refused by the Rust receivers and
counted under their kind, as the Rust injectors' are (tests/wire.rs):

- states with a NaN, another scenario's fingerprint, a repeated or an
  out-of-order sequence number, sent by the Python vehicle next to its good
  ones (``--inject``), refused by the planner;
- plans through a pair of waypoints that is no edge, sent by this test as a
  second publisher on the plan topic, refused by vehicle-sim;
- snapshots whose head claims one edge more than their slice carries, sent
  as a second publisher on the waypoints topic, refused by the planner and
  vehicle-sim.

Either way the mission runs exactly as without them."""

import os
import re

from auv_planner_client import messages as m
from auv_planner_client import transport as t

from conftest import NODES, finish, prefix, python_mission, read_json, rust_mission, start_planner, sweep

STATE_KINDS = ("non_finite", "foreign_scenario", "repeated", "out_of_order")


def by_receiver(r, receiver, kind):
    return r["rejected_by_receiver"][receiver][kind]


def same_mission(r, clean):
    # A plan the vehicle refused in the clean run would change it too.
    assert not any(clean["rejected_by_receiver"]["vehicle"].values()), clean["rejected_by_receiver"]
    for key in ("outcome", "route", "time_used_s", "weight", "tasks_completed", "plans", "sensor_updates"):
        assert r[key] == clean[key], "%s changed under injection: %s vs %s" % (key, r[key], clean[key])


def test_bad_states_from_python_are_refused_by_the_planner_by_kind(tmp_path):
    clean_dir, _, _ = python_mission(tmp_path, 5, "clean")
    clean = read_json(os.path.join(clean_dir, "report.json"))
    out, v_err, _ = python_mission(tmp_path, 5, "bad", "--inject", ",".join(STATE_KINDS))
    r = read_json(os.path.join(out, "report.json"))
    injected = int(re.search(r"injected (\d+) bad state", v_err).group(1))
    refused = {k: by_receiver(r, "planner", k) for k in STATE_KINDS}
    print("python states: %d injected, planner refused %s" % (injected, refused))
    for k in STATE_KINDS:
        assert refused[k] > 0, "the planner never refused %s: %s" % (k, r["rejected_by_receiver"])
    assert sum(refused.values()) <= injected
    # Nothing good refused, nothing misfiled under another kind.
    others = {k: n for k, n in r["rejected_by_receiver"]["planner"].items() if k not in STATE_KINDS}
    assert not any(others.values()), others
    assert not any(r["rejected_by_receiver"]["vehicle"].values()), r["rejected_by_receiver"]
    same_mission(r, clean)


def non_edge_route(snapshot, state):
    """A route from where the vehicle is to the goal, through unvisited
    waypoints, whose first or second hop is no edge of ``snapshot``; or None."""
    n, goal, here = snapshot.node_count, snapshot.goal, state.to_node
    edges = {(min(e.a, e.b), max(e.a, e.b)) for e in snapshot.edges[: snapshot.edge_count]}

    def edge(a, b):
        return (min(a, b), max(a, b)) in edges

    free = [y for y in range(n) if y not in set(m.route_of(state)) and y not in (here, goal)]
    for y in free:
        if not edge(here, y):
            return [here, y, goal]
    for y in free:
        for z in free:
            if z != y and edge(here, y) and not edge(y, z):
                return [here, y, z, goal]
    return None


def test_non_edge_plans_from_python_are_refused_by_vehicle_sim(tmp_path):
    # The default 40 waypoints: a network with non-edges to send plans through.
    clean = read_json(os.path.join(rust_mission(tmp_path, 6, "clean", nodes=None), "report.json"))
    pfx = prefix("b")
    out = str(tmp_path / "bad")
    # Attached before the mission starts (open_or_create with its QoS), so
    # it sees the first snapshot and every state.
    c = t.Client(pfx, "auv1", "py-injector")
    snapshots, states = c.inbox(t.WAYPOINTS), c.inbox(t.VEHICLE_STATE)
    plans = c.outbox(t.PLAN)
    waker = c.waker("planner")  # every state wakes the planner's role
    mission = start_planner(
        "mission", "--quiet", "--lockstep", "--seed", "6", "--ipc-prefix", pfx, "--out", out,
    )
    snapshot, stamp, sent, done = None, None, 0, False
    # While the vehicle waits for the planner's answer at an arrival, send
    # it a plan from where it is through a non-edge. One that arrives after
    # the vehicle moved on starts at a visited waypoint: stale, not refused.
    while not done and mission.poll() is None:
        waker.wait(0.05)
        for s in snapshots.drain():
            snapshot = s
            stamp = stamp or t.Stamp(s.header.fingerprint)
        for st in states.drain():
            done = done or st.outcome != m.Outcome.RUNNING
            if snapshot is None or done or st.event != m.VehicleEvent.ARRIVAL or st.to_node == snapshot.goal:
                continue
            route = non_edge_route(snapshot, st)
            if route is None:
                continue
            p = m.Plan()
            p.header.mission_time_s = st.header.mission_time_s
            p.state_seq = st.header.seq
            p.snapshot_epoch = st.snapshot_epoch
            p.trigger = m.TriggerKind.ARRIVAL
            p.feasible = 1
            p.route_len = len(route)
            for k, i in enumerate(route):
                p.route[k] = i
            plans.publish(p, stamp)
            sent += 1
    code, _, err = finish(mission, "planner mission")
    del plans, states, snapshots, waker, c
    sweep(pfx)
    assert code == 0, err
    r = read_json(os.path.join(out, "report.json"))
    non_edge = by_receiver(r, "vehicle", "non_edge")
    print("python plans: %d sent, vehicle-sim refused %d as non_edge, %d stale" % (sent, non_edge, r["stale_plans"]))
    assert sent > 0
    assert 1 <= non_edge <= sent
    assert non_edge + r["stale_plans"] <= sent
    others = {k: n for k, n in r["rejected_by_receiver"]["vehicle"].items() if k != "non_edge"}
    assert not any(others.values()), others
    assert not any(r["rejected_by_receiver"]["planner"].values()), r["rejected_by_receiver"]
    same_mission(r, clean)


def test_snapshots_whose_head_and_slice_disagree_are_refused_by_both_receivers(tmp_path):
    # A second publisher on the waypoints topic sends, after each good
    # snapshot, its twin whose head claims one edge more than its slice
    # carries: the planner and vehicle-sim each refuse it as malformed, and
    # the mission runs as without it.
    clean = read_json(os.path.join(rust_mission(tmp_path, 7, "clean", nodes=None), "report.json"))
    pfx = prefix("s")
    out = str(tmp_path / "bad")
    c = t.Client(pfx, "auv1", "py-injector")
    snapshots = c.inbox(t.WAYPOINTS)
    forged = c.outbox(t.WAYPOINTS, max_nodes=40)
    waker = c.waker("vehicle")  # every snapshot wakes the vehicle's role
    mission = start_planner(
        "mission", "--quiet", "--lockstep", "--seed", "7", "--ipc-prefix", pfx, "--out", out,
    )
    stamp, sent = None, 0
    while mission.poll() is None:
        waker.wait(0.05)
        for s in snapshots.drain():
            if stamp is None:
                stamp = t.Stamp(s.header.fingerprint)
            elif s.header.session == stamp.session:
                continue  # our own
            # A good snapshot arrives with exactly its edges.
            assert len(s.edges) == s.edge_count, (len(s.edges), s.edge_count)
            if sent >= 5:
                continue
            twin = m.WaypointSnapshot(s.head, s.edges)
            twin.edge_count = len(s.edges) + 1
            forged.publish(twin, stamp)
            sent += 1
    code, _, err = finish(mission, "planner mission")
    del forged, snapshots, waker, c
    sweep(pfx)
    assert code == 0, err
    r = read_json(os.path.join(out, "report.json"))
    refused = {who: by_receiver(r, who, "malformed") for who in ("planner", "vehicle")}
    print("python snapshots: %d sent, refused as malformed %s" % (sent, refused))
    assert sent > 0
    for who, n in refused.items():
        assert 1 <= n <= sent, (who, n, sent)
        others = {k: v for k, v in r["rejected_by_receiver"][who].items() if k != "malformed"}
        assert not any(others.values()), (who, others)
    same_mission(r, clean)
