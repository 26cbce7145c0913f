"""A lockstep mission with the Python vehicle in place of vehicle-sim
(``planner mission --external-vehicle``): it reaches the goal, the run is
the same every time with the same seed, and it is the very mission
vehicle-sim flies (same mission.log and journal, byte for byte)."""

import os

import pytest

from conftest import NODES, example, finish, python_mission, read_json, rust_mission


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
