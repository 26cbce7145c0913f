#!/usr/bin/env python3
"""Watch a vehicle from shore over Zenoh, from another machine: print each
plan, vehicle arrival and link event as it arrives; optionally send one
operator command first.

    python3 examples/shore_watch.py --connect tcp/VEHICLE:7447 [--vehicle NAME]
        [--user U --password P] [--command abort-to-goal|set-time-budget|add-task|remove-task
        [--budget-s S] [--waypoint NAME]] [--json]

The vehicle runs ``planner mission --shore tcp/0.0.0.0:7447``. This is a
peer with scouting off that keeps retrying until the vehicle listens; it
catches up with the plans it missed once it is connected, and stops when
the mission ends. Exit status: 0, 1 when the command was refused or nothing
was heard for --give-up-s, 2 on bad arguments.
"""

import argparse
import json
import os
import sys

try:
    import auv_planner_client  # noqa: F401
except ImportError:  # run from a checkout without `pip install`
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from auv_planner_client import shore


def key(plan):
    """A plan's identity: its planner session and number (a restarted
    planner, or the next leg of a replaced mission, counts from 1 again)."""
    return plan.get("session"), plan["seq"]


def show(leaf, msg, as_json):
    if as_json:
        print(json.dumps({"leaf": leaf, **msg}), flush=True)
    elif leaf == "plan":
        print("plan %d (re-plan %d, %s) at t %.0f s: %s, %.0f of %.0f s, weight %.1f"
              % (msg["seq"], msg["replan"], msg["trigger"], msg["t"], msg["route"], msg["time_s"],
                 msg["budget_s"], msg["weight"]), flush=True)
    elif leaf == "event":
        print("event %s at t %.0f s%s" % (msg["event"], msg["t"],
                                          " (%s)" % msg["outcome"] if msg.get("outcome") else ""), flush=True)
    elif leaf == "ack":
        print("ack %d %s: %s %s" % (msg["id"], msg["command"], msg["status"], msg["reason"]), flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--connect", required=True, help="the vehicle's endpoint, tcp/HOST:PORT")
    ap.add_argument("--vehicle", default="auv1")
    ap.add_argument("--user")
    ap.add_argument("--password")
    ap.add_argument("--command", choices=shore.COMMANDS)
    ap.add_argument("--budget-s", type=float)
    ap.add_argument("--waypoint")
    ap.add_argument("--give-up-s", type=float, default=60.0)
    ap.add_argument("--json", action="store_true", help="one JSON line per message")
    a = ap.parse_args()
    if (a.user is None) != (a.password is None):
        ap.error("--user and --password go together")
    try:
        client = shore.ShoreClient(a.connect, a.vehicle, (a.user, a.password) if a.user else None)
    except ValueError as e:
        ap.error(str(e))
    seen = set()
    with client:
        if a.command:
            try:
                ack, _ = client.command(a.command, timeout_s=a.give_up_s, budget_s=a.budget_s, waypoint=a.waypoint)
            except (ValueError, TimeoutError) as e:
                print("shore_watch.py: %s" % e, file=sys.stderr)
                return 1
            show("ack", ack, a.json)
            if ack["status"] != "applied":
                return 1
        caught_up = False
        for leaf, msg in client.messages(timeout_s=a.give_up_s):
            if not caught_up:
                caught_up = True
                for p in client.catch_up()[1]:
                    if key(p) not in seen:
                        seen.add(key(p))
                        show("plan", p, a.json)
            if leaf == "plan":
                if key(msg) in seen:
                    continue
                seen.add(key(msg))
            if leaf in ("plan", "event", "ack"):
                show(leaf, msg, a.json)
            if leaf == "event" and msg["event"] == "mission_end":
                print("watched %d plans; refused payloads %r" % (len(seen), client.refused), file=sys.stderr)
                return 0
    print("shore_watch.py: nothing from the vehicle for %.0f s" % a.give_up_s, file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
