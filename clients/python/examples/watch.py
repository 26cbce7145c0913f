#!/usr/bin/env python3
"""Watch a running mission: print each plan and planner status as it arrives.

    python3 examples/watch.py --ipc-prefix PREFIX [--vehicle NAME] [--json]

It opens (or creates, with the mission's QoS) the plan and status services
and blocks on the vehicle's wake service, which every plan and status
notifies, so it may be started before the mission and then misses no plan.
It takes one subscriber slot on each topic and one listener slot on the
wake service (the services keep two for outside clients).

It stops when the planner reports that it finished (or on Ctrl-C) and
prints a last line with what it saw. Exit status: 0, 1 on an error, 2 on
bad arguments, 130 when stopped by a signal.
"""

import argparse
import json
import os
import signal
import sys

try:
    import auv_planner_client  # noqa: F401
except ImportError:  # run from a checkout without `pip install`
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from auv_planner_client import messages as m
from auv_planner_client import transport as t

_stop = []


def plan_record(p):
    return {
        "type": "plan",
        "seq": p.header.seq,
        "t": p.header.mission_time_s,
        "replan": p.replan,
        "trigger": m.name_of("TriggerKind", p.trigger),
        "route": m.route_of(p),
        "time_s": p.time_s,
        "weight": p.weight,
        "distance_m": p.distance_m,
        "budget_s": p.budget_s,
        "feasible": bool(p.feasible),
        "fallback": bool(p.fallback),
        "iterations": p.iterations,
        "deadline_cut": bool(p.deadline_cut),
        "snapshot_epoch": p.snapshot_epoch,
        "state_seq": p.state_seq,
        "compute_us": p.compute_ns / 1000.0,
    }


def status_record(s):
    return {
        "type": "status",
        "seq": s.header.seq,
        "t": s.header.mission_time_s,
        "phase": m.name_of("PlannerPhase", s.phase),
        "plans": s.plans,
        "triggers": s.triggers,
        "sensor_updates": s.sensor_updates,
        "deadline_misses": s.deadline_misses,
        "last_latency_us": s.last_latency_ns / 1000.0,
        "max_latency_us": s.max_latency_ns / 1000.0,
        "rejected": {m.REJECT_KIND_NAMES[k]: n for k, n in enumerate(s.rejected) if n},
    }


def human(r):
    if r["type"] == "plan":
        return "t=%9.1f s  plan #%d (%s): %d waypoints, weight %.2f, %.0f s of %.0f s%s  %s" % (
            r["t"],
            r["replan"],
            r["trigger"],
            len(r["route"]),
            r["weight"],
            r["time_s"],
            r["budget_s"],
            "" if r["feasible"] else " (infeasible)",
            r["route"],
        )
    return "t=%9.1f s  status %s: %d plans, %d sensor updates, latency %.0f us (max %.0f)%s" % (
        r["t"],
        r["phase"],
        r["plans"],
        r["sensor_updates"],
        r["last_latency_us"],
        r["max_latency_us"],
        ", rejected %s" % r["rejected"] if r["rejected"] else "",
    )


def main():
    ap = argparse.ArgumentParser(prog="watch.py", description="Print each plan and planner status of a running mission")
    ap.add_argument("--ipc-prefix", required=True, help="iceoryx2 isolation prefix of the mission")
    ap.add_argument("--vehicle", default="auv1", help="vehicle namespace in service names")
    ap.add_argument("--json", action="store_true", help="one JSON object per line and message")
    args = ap.parse_args()
    try:
        t.domain_config(args.ipc_prefix)
        t.check_name("vehicle name", args.vehicle)
        client = t.Client(args.ipc_prefix, args.vehicle, "py-watch")
        plans = client.inbox(t.PLAN)
        status = client.inbox(t.STATUS)
        waker = client.waker("vehicle")
    except t.ClientError as e:
        print("watch.py: error: %s" % e, file=sys.stderr)
        return 2 if "invalid" in str(e) else 1
    signal.signal(signal.SIGINT, lambda *_: _stop.append(1))
    signal.signal(signal.SIGTERM, lambda *_: _stop.append(1))
    print("watch.py: watching auv/%s on --ipc-prefix %s" % (args.vehicle, args.ipc_prefix), file=sys.stderr, flush=True)
    try:
        return watch(args, plans, status, waker)
    except Exception as e:  # iceoryx2's own errors (a port failing mid-mission)
        print("watch.py: error: iceoryx2: %r" % e, file=sys.stderr)
        return 1


def watch(args, plans, status, waker):
    out = sys.stdout
    seen_plans, last_status = 0, None
    finished = False
    while not finished and not _stop:
        waker.wait(0.2)
        # Plans first: a plan is sent before the status that counts it.
        for p in plans.drain():
            seen_plans += 1
            r = plan_record(p)
            out.write((json.dumps(r) if args.json else human(r)) + "\n")
        for s in status.drain():
            last_status = s
            r = status_record(s)
            out.write((json.dumps(r) if args.json else human(r)) + "\n")
            finished = finished or s.phase == m.PlannerPhase.FINISHED
        out.flush()
    summary = {
        "type": "summary",
        "plans_seen": seen_plans,
        "plans_published": last_status.plans if last_status is not None else None,
        "finished": finished,
    }
    out.write((json.dumps(summary) if args.json else "watched %d plans; the planner published %s" % (seen_plans, summary["plans_published"])) + "\n")
    out.flush()
    return 0 if finished else 130


if __name__ == "__main__":
    sys.exit(main())
