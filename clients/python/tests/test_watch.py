"""The watcher attached to a scaled-time mission sees every plan the
planner published: as many plan lines as mission.log has plans (and the
report and the planner's last status count), the same routes in the same
order."""

import json
import os

from conftest import example, finish, log_events, prefix, read_json, start_planner, sweep, wait_line


def test_the_watcher_sees_every_plan_of_a_scaled_time_mission(tmp_path):
    pfx = prefix("w")
    out = str(tmp_path / "m")
    # Started first: it opens the plan and status services with the
    # mission's QoS, so it is subscribed before the first plan exists.
    lines_path = tmp_path / "watch.jsonl"
    with open(lines_path, "w", encoding="utf-8") as sink:
        watch = example("watch.py", "--ipc-prefix", pfx, "--json", stdout=sink)
    wait_line(watch, "watching")
    mission = start_planner(
        "mission", "--quiet", "--seed", "2", "--nodes", "12", "--time-scale", "10000",
        "--ipc-prefix", pfx, "--out", out,
    )
    m_code, _, m_err = finish(mission, "planner mission")
    w_code, _, w_err = finish(watch, "watch.py")
    sweep(pfx)
    assert m_code == 0, m_err
    assert w_code == 0, w_err
    lines = [json.loads(line) for line in lines_path.read_text(encoding="utf-8").splitlines()]
    plans = [r for r in lines if r["type"] == "plan"]
    statuses = [r for r in lines if r["type"] == "status"]
    summary = lines[-1]
    logged = log_events(os.path.join(out, "mission.log"), "plan")
    report = read_json(os.path.join(out, "report.json"))
    print("watcher: %d plans seen, mission.log %d, report %d" % (len(plans), len(logged), report["plans"]))
    assert len(logged) == report["plans"] > 0
    assert len(plans) == len(logged)
    assert [p["route"] for p in plans] == [p["route"] for p in logged]
    assert [p["replan"] for p in plans] == list(range(1, len(logged) + 1))
    assert summary == {"type": "summary", "plans_seen": len(logged), "plans_published": len(logged), "finished": True}
    assert statuses[-1]["phase"] == "finished"


def test_the_human_format_prints_one_line_per_message(tmp_path):
    pfx = prefix("h")
    watch = example("watch.py", "--ipc-prefix", pfx)
    wait_line(watch, "watching")
    mission = start_planner(
        "mission", "--quiet", "--lockstep", "--seed", "1", "--nodes", "8", "--ipc-prefix", pfx,
        "--out", str(tmp_path / "m"),
    )
    assert finish(mission, "planner mission")[0] == 0
    code, out, err = finish(watch, "watch.py")
    sweep(pfx)
    assert code == 0, err
    text = out.splitlines()
    assert any(" plan #1 (initial)" in line for line in text), out
    assert "status finished" in out and text[-1].startswith("watched ")
