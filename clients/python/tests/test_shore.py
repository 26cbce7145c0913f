"""A Python peer on the shore link (PyPI ``eclipse-zenoh``) against a real
``planner mission --shore`` on loopback: it reads every plan the planner
published, decodes the ``auv-shore/1`` payloads, commands the vehicle and
gets the acks; with the shipped authentication configuration, a peer with a
wrong password reads nothing and a viewer's commands are never applied."""

import json
import os
import socket
import time

import pytest

from conftest import example, finish, log_events, prefix, read_json, start_planner, sweep

shore = pytest.importorskip("auv_planner_client.shore", reason="eclipse-zenoh is not installed")

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))


def free_endpoint():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return "tcp/127.0.0.1:%d" % s.getsockname()[1]


def shore_mission(pfx, ep, out, scale, *extra):
    return start_planner(
        "mission", "--quiet", "--nodes", "12", "--seed", "2", "--time-scale", scale,
        "--ipc-prefix", pfx, "--shore", ep, "--out", out, *extra,
    )


def watch_until_end(client, seen, timeout_s=120):
    """Collects (leaf, message) into ``seen`` until the bridge announces the end."""
    deadline = time.monotonic() + timeout_s
    for leaf, msg in client.messages(timeout_s=30):
        seen.append((leaf, msg))
        if leaf == "event" and msg.get("event") == "mission_end":
            return msg
        if time.monotonic() > deadline:
            break
    pytest.fail("no mission_end within %d s; last messages: %r" % (timeout_s, seen[-3:]))


def test_a_python_peer_sees_every_plan_and_commands_the_vehicle(tmp_path):
    pfx, ep, out = prefix("z"), free_endpoint(), str(tmp_path / "m")
    # The example beside the library: a second peer on the same link.
    lines_path = tmp_path / "shore_watch.jsonl"
    with open(lines_path, "w", encoding="utf-8") as sink:
        watcher = example("shore_watch.py", "--connect", ep, "--json", stdout=sink)
    # Connected before the vehicle listens: the peer keeps retrying.
    with shore.ShoreClient(ep) as client:
        mission = shore_mission(pfx, ep, out, "600")
        seen = []
        for leaf, msg in client.messages(timeout_s=60):
            seen.append((leaf, msg))
            if leaf == "plan":
                break
        assert seen and seen[-1][0] == "plan", "no plan within 60 s: %r" % seen[-3:]
        # A budget beyond the battery's (the mission's own time) is refused
        # with its reason, and not applied. (A small budget is no sure refusal:
        # right after the first plan the vehicle's clock may still be near 0.)
        refused, during = client.command("set-time-budget", budget_s=1.0e9)
        seen.extend(during)
        assert (refused["status"], refused["reason"], refused["plan_seq"]) == (
            "refused", "budget_out_of_range", 0), refused
        applied, during = client.command("abort-to-goal")
        seen.extend(during)
        assert applied["status"] == "applied" and applied["plan_seq"] > 0, applied
        end = watch_until_end(client, seen)
        latest, history = client.catch_up()
        m_code, _, m_err = finish(mission, "planner mission")
    w_code, _, w_err = finish(watcher, "shore_watch.py")
    sweep(pfx)
    assert m_code == 0, m_err
    assert w_code == 0, w_err
    report = read_json(os.path.join(out, "report.json"))
    printed = [json.loads(line) for line in lines_path.read_text(encoding="utf-8").splitlines()]
    assert sorted(p["seq"] for p in printed if p["leaf"] == "plan") == list(range(1, report["plans"] + 1))
    assert printed[-1]["leaf"] == "event" and printed[-1]["event"] == "mission_end"
    plans = {msg["seq"]: msg for leaf, msg in seen if leaf == "plan"}
    live = len(plans)
    for p in history:
        plans.setdefault(p["seq"], p)
    print("python peer: %d plans live, %d with the catch-up, report %d; refused payloads %r"
          % (live, len(plans), report["plans"], client.refused))
    # Every plan published onboard reached the peer, the same routes as the planner's log.
    assert sorted(plans) == list(range(1, report["plans"] + 1))
    logged = log_events(os.path.join(out, "mission.log"), "plan")
    assert [plans[s]["route"] for s in sorted(plans)] == [p["route"] for p in logged]
    assert client.refused == {}
    # The plan the abort caused is the quickest path to the goal, made for the operator.
    caused = plans[applied["plan_seq"]]
    assert caused["trigger"] == "operator", caused
    goal = latest["snapshot"]["goal"]
    assert caused["route"][-1] == goal
    # The end the bridge announced is the vehicle's, and the report agrees.
    states = [msg for leaf, msg in seen if leaf == "state"]
    assert states and states[-1]["outcome"] == end["outcome"] == report["outcome"] == "goal_reached"
    assert report["shore_link"]["commands"]["applied"] == 1, report["shore_link"]
    commands = log_events(os.path.join(out, "mission.log"), "command")
    assert {c["id"] for c in commands} == {refused["id"], applied["id"]}


def test_with_authentication_a_wrong_password_reads_nothing_and_a_viewer_cannot_command(tmp_path):
    pfx, ep, out = prefix("za"), free_endpoint(), str(tmp_path / "m")
    users = tmp_path / "users.txt"
    users.write_text("operator:op-secret\nviewer:view-secret\n", encoding="utf-8")
    with open(os.path.join(ROOT, "config", "zenoh", "onboard-auth.json5"), encoding="utf-8") as f:
        onboard = f.read().replace("/etc/auv/shore-users.txt", str(users))
    assert str(users) in onboard, "the shipped configuration no longer names its dictionary file"
    onboard_path = tmp_path / "onboard.json5"
    onboard_path.write_text(onboard, encoding="utf-8")
    mission = shore_mission(pfx, ep, out, "1500", "--zenoh-config", str(onboard_path))
    try:
        with shore.ShoreClient(ep, credentials=("operator", "guess")) as intruder:
            heard = list(intruder.messages(timeout_s=4))
        with shore.ShoreClient(ep, credentials=("viewer", "view-secret")) as viewer:
            first = next(viewer.messages(timeout_s=30), None)
            assert first is not None, "the viewer, who may watch, heard nothing"
            with pytest.raises(TimeoutError):
                viewer.command("abort-to-goal", timeout_s=3)
        with shore.ShoreClient(ep, credentials=("operator", "op-secret")) as operator:
            seen = []
            end = watch_until_end(operator, seen)
    finally:
        m_code, _, m_err = finish(mission, "planner mission")
        sweep(pfx)
    assert m_code == 0, m_err
    assert heard == [], "a peer with a wrong password read %d messages" % len(heard)
    report = read_json(os.path.join(out, "report.json"))
    assert end["outcome"] == report["outcome"] == "goal_reached"
    # The viewer's command never reached the planner.
    assert report["shore_link"]["commands"]["applied"] == 0, report["shore_link"]
    assert log_events(os.path.join(out, "mission.log"), "command") == []


def test_payloads_of_another_format_or_type_are_refused_by_name():
    plan = {"format": "auv-shore/1", "type": shore.LEAF_TYPES["plan"], "seq": 1}
    assert shore.decode("plan", json.dumps(plan).encode())["seq"] == 1
    for leaf, body, needle in [
        ("plan", dict(plan, format="auv-shore/2"), "format"),
        ("plan", dict(plan, type=shore.LEAF_TYPES["state"]), "type"),
        ("plan", [1, 2], "object"),
        ("nowhere", plan, "not a key"),
    ]:
        with pytest.raises(shore.BadPayload, match=needle):
            shore.decode(leaf, json.dumps(body).encode())
    with pytest.raises(shore.BadPayload, match="not JSON"):
        shore.decode("plan", b"\xff{")
    with pytest.raises(ValueError, match="tcp/HOST:PORT"):
        shore.config("udp/1.2.3.4:5")
