"""A lockstep mission with the Python vehicle in place of vehicle-sim
(``planner mission --external-vehicle``): it reaches the goal, the run is
the same every time with the same seed, and it is the very mission
vehicle-sim flies (same mission.log and journal, byte for byte)."""

import argparse
import importlib.util
import os

import pytest

from auv_planner_client import messages as m
from auv_planner_client import transport as t

from conftest import EXAMPLES, NODES, example, finish, prefix, python_mission, read_json, rust_mission, sweep


def read(path):
    with open(path, "rb") as f:
        return f.read()


@pytest.mark.parametrize("seed", [1, 4])
def test_the_python_vehicle_reaches_the_goal_deterministically_as_vehicle_sim_does(tmp_path, seed):
    a, err, _ = python_mission(tmp_path, seed, "a")
    r = read_json(os.path.join(a, "report.json"))
    assert r["outcome"] == "goal_reached", r
    assert r["rejected_messages"] == 0, r
    assert r["stale_plans"] == 0, r
    assert r["shm_files_left"] == 0, r
    assert r["plans"] > 0 and r["route"][-1] == int(NODES) - 1
    assert "goal_reached" in err
    b, _, _ = python_mission(tmp_path, seed, "b")
    for f in ("mission.log", "journal.jsonl"):
        assert read(os.path.join(a, f)) == read(os.path.join(b, f)), "%s differs between two runs, seed %d" % (f, seed)
    rust = rust_mission(tmp_path, seed, "rust")
    for f in ("mission.log", "journal.jsonl"):
        assert read(os.path.join(a, f)) == read(os.path.join(rust, f)), "%s differs from vehicle-sim's, seed %d" % (f, seed)
    assert read_json(os.path.join(rust, "report.json"))["route"] == r["route"]


def test_beyond_128_waypoints_the_python_vehicle_flies_the_mission_vehicle_sim_flies(tmp_path):
    # 200 waypoints: snapshots of ~18 000 edges as slices, u16 route ids.
    a, _, _ = python_mission(tmp_path, 2, "py200", nodes="200")
    r = read_json(os.path.join(a, "report.json"))
    assert r["outcome"] == "goal_reached", r
    assert r["rejected_messages"] == 0, r
    assert r["route"][-1] == 199
    rust = rust_mission(tmp_path, 2, "rust200", nodes="200")
    for f in ("mission.log", "journal.jsonl"):
        assert read(os.path.join(a, f)) == read(os.path.join(rust, f)), "%s differs from vehicle-sim's" % f


def test_bad_arguments_are_one_line_errors(tmp_path):
    for args, needle in (
        (["--ipc-prefix", "has space"], "invalid ipc prefix"),
        (["--ipc-prefix", "ok_", "--vehicle", "a/b"], "invalid vehicle name"),
        (["--ipc-prefix", "ok_", "--time-scale", "-1"], "must be > 0"),
        (["--ipc-prefix", "ok_", "--inject", "nope"], "unknown kind"),
    ):
        code, out, err = finish(example("vehicle.py", *args), "vehicle.py")
        assert code == 2, (args, err)
        assert needle in err and "Traceback" not in err, (args, err)


def line_snapshot(epoch, with_middle_edge):
    """0 - 1 - 2 - 3 on a line 100 m apart, 1 m/s; the edge 1 - 2 only when asked."""
    s = m.WaypointSnapshot()
    s.epoch, s.speed_mps, s.time_available_s, s.next_update_s = epoch, 1.0, 1000.0, 60.0 * (epoch + 1)
    s.header.mission_time_s = 60.0 * epoch
    s.objective = m.ENUMS["ObjectiveCode"]["max_weight"]
    s.node_count, s.start, s.goal = 4, 0, 3
    for i in range(4):
        s.nodes[i].x = 100.0 * i
    pairs = [(0, 1), (2, 3), (0, 3)] + ([(1, 2)] if with_middle_edge else [])
    for k, (a, b) in enumerate(pairs):
        e = s.edges[k]
        e.a, e.b, e.priority, e.risk, e.task_time_s = a, b, 2.0, 0.5, 10.0
    s.edge_count = len(pairs)
    return s


def test_a_plan_on_a_snapshot_still_queued_is_checked_against_that_snapshot():
    # The sensor's update and a plan computed on it can both arrive after the
    # vehicle drained its snapshots; the plan must not be judged on the
    # snapshot before (where its edge 1 - 2 does not exist).
    spec = importlib.util.spec_from_file_location("vehicle_example", os.path.join(EXAMPLES, "vehicle.py"))
    vehicle = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(vehicle)
    pfx = prefix("q")
    args = argparse.Namespace(
        ipc_prefix=pfx, vehicle="auv1", fingerprint=None, time_scale=None, state_rate_hz=20.0,
        answer_timeout_s=5.0, journal=None, inject=[],
    )
    try:
        v = vehicle.Vehicle(args)
        peer = t.Client(pfx, "auv1", "py-peer")
        sensor, planner = peer.outbox(t.WAYPOINTS), peer.outbox(t.PLAN)
        sensor_stamp, planner_stamp = t.Stamp(0xABC), t.Stamp(0xABC)
        sensor.publish(line_snapshot(0, False), sensor_stamp)
        v.drain()
        assert v.sim.net.epoch == 0
        sensor.publish(line_snapshot(1, True), sensor_stamp)
        p = m.Plan()
        p.snapshot_epoch, p.route_len = 1, 4
        for k, node in enumerate((0, 1, 2, 3)):
            p.route[k] = node
        planner.publish(p, planner_stamp)
        v.drain_plans()
        assert v.sim.net.epoch == 1
        assert v.sim.plan == [0, 1, 2, 3]
        assert not any(v.rejected()), v.rejected()
    finally:
        sweep(pfx)
