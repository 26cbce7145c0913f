"""Shared helpers: the real binaries (``AUV_BIN_DIR``, set by
``run-tests.sh``), isolated iceoryx2 prefixes, processes under a watchdog
(a hung process must not hang the suite; no timing is asserted)."""

import glob
import itertools
import json
import os
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
EXAMPLES = os.path.join(HERE, "..", "examples")
#: Longest a single process may run before the watchdog kills it, real s.
WATCHDOG_S = 300

_counter = itertools.count()
#: Waypoints of the test missions (small: quick lockstep runs).
NODES = "12"


def bin_dir():
    d = os.environ.get("AUV_BIN_DIR")
    if not d:
        pytest.fail("AUV_BIN_DIR is not set: run clients/python/run-tests.sh (or cargo test --test python)")
    return d


def planner():
    return os.path.join(bin_dir(), "planner")


def prefix(tag):
    """A fresh, short isolation prefix (socket paths are limited to 108 bytes)."""
    return "p%s%x%d_" % (tag, os.getpid(), next(_counter))


def example(name, *args, stdout=subprocess.PIPE):
    """Starts ``examples/<name>`` with this interpreter. Give a file as
    ``stdout`` when it prints a lot while others run: a full pipe nobody
    reads would stall it."""
    return subprocess.Popen(
        [sys.executable, "-u", os.path.join(EXAMPLES, name), *args],
        stdout=stdout,
        stderr=subprocess.PIPE,
        text=True,
    )


def start_planner(*args):
    return subprocess.Popen([planner(), *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_line(proc, needle):
    """Reads ``proc``'s stderr until a line containing ``needle``; returns the lines read."""
    lines = []
    for line in proc.stderr:
        lines.append(line)
        if needle in line:
            return lines
    pytest.fail("%r never appeared; stderr:\n%s" % (needle, "".join(lines)))


def finish(proc, name):
    """Waits for ``proc`` (watchdog); returns (code, stdout, stderr)."""
    try:
        out, err = proc.communicate(timeout=WATCHDOG_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        pytest.fail("watchdog: %s killed after %d s\nstdout:\n%s\nstderr:\n%s" % (name, WATCHDOG_S, out, err))
    return proc.returncode, out, err


def read_json(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def log_events(path, event):
    with open(path, encoding="utf-8") as f:
        return [json.loads(line) for line in f if json.loads(line).get("event") == event]


def sweep(pfx):
    """Removes what is left of domain ``pfx`` once every process of it has
    exited (a late outside client keeps the mission from retiring it)."""
    for p in glob.glob("/dev/shm/%s*" % pfx) + glob.glob("/tmp/iceoryx2/**/%s*" % pfx, recursive=True):
        try:
            os.remove(p)
        except OSError:
            pass


def python_mission(tmp_path, seed, name, *vehicle_args, nodes=NODES):
    """A lockstep mission with examples/vehicle.py as its vehicle; returns (out dir, vehicle stderr, mission stderr)."""
    out = str(tmp_path / name)
    pfx = prefix("v")
    mission = start_planner(
        "mission", "--quiet", "--lockstep", "--seed", str(seed), "--nodes", nodes,
        "--external-vehicle", "--ipc-prefix", pfx, "--out", out,
    )
    # The mission names the journal's path once it has cleared the old one.
    head = wait_line(mission, "waiting for an outside vehicle")
    assert pfx in "".join(head)
    journal = os.path.join(out, "journal.jsonl")
    vehicle = example("vehicle.py", "--ipc-prefix", pfx, "--journal", journal, *vehicle_args)
    v_code, _, v_err = finish(vehicle, "vehicle.py")
    if v_code != 0:
        # The mission would wait for its vehicle until the watchdog: stop it
        # and report the vehicle's own error.
        mission.kill()
        mission.communicate()
        sweep(pfx)
        pytest.fail("vehicle.py exited %s:\n%s" % (v_code, v_err))
    m_code, _, m_err = finish(mission, "planner mission")
    sweep(pfx)
    assert m_code == 0, m_err
    return out, v_err, m_err


def rust_mission(tmp_path, seed, name, nodes=NODES):
    """The same mission with vehicle-sim (``nodes`` None: the default
    scenario's); returns its out dir."""
    out = str(tmp_path / name)
    size = ["--nodes", nodes] if nodes else []
    mission = start_planner(
        "mission", "--quiet", "--lockstep", "--seed", str(seed), *size,
        "--ipc-prefix", prefix("r"), "--out", out,
    )
    code, _, err = finish(mission, "planner mission")
    assert code == 0, err
    return out
