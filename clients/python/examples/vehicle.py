#!/usr/bin/env python3
"""A complete AUV in Python on the planner's wire, in place of vehicle-sim.

It follows each plan edge by edge at the mission's speed (constant speed in
3-D, straight towards the latest reported position of the next waypoint;
the edge's task time is spent on arrival), publishes its state the way
vehicle-sim does, and ends at the goal (or when its time runs out):

- lockstep (default): stops at every arrival and at every sensor update
  (the ``next_update_s`` each snapshot announces) and waits until the
  planner's status says it handled that state (and that epoch), so the same
  seeds give the same mission; states carry ``time_scale`` 0, which makes
  sensor-sim follow this vehicle's clock.
- ``--time-scale S``: mission seconds per real second, a state at
  ``--state-rate-hz`` and one at every arrival.

Inputs are checked as vehicle-sim checks them (fingerprint, ranges,
sequence; plans against the network and the route so far) and refusals are
counted by kind in every state's ``rejected``. What it does not check: the
chart (waypoints over water and inside their bounds), which needs the
scenario's world.

    python3 examples/vehicle.py --ipc-prefix PREFIX [--vehicle NAME] [--journal FILE]

Exit status: 0 when the mission ended (goal or time out), 1 on an error, 2
on bad arguments, 130 when stopped by a signal.
"""

import argparse
import json
import math
import os
import signal
import sys
import time

try:
    import auv_planner_client  # noqa: F401
except ImportError:  # run from a checkout without `pip install`
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from auv_planner_client import messages as m
from auv_planner_client import transport as t
from auv_planner_client.validate import Guard

_stop = []


def _on_signal(signum, _frame):
    _stop.append(signum)


def dist(p, q):
    dx, dy, dz = p[0] - q[0], p[1] - q[1], p[2] - q[2]
    return math.sqrt(dx * dx + dy * dy + dz * dz)


FREE, TRAVEL, TASK = "free", "travel", "task"

#: Faults ``--inject`` can put into states (each refused by the planner under this name).
STATE_FAULTS = ("non_finite", "foreign_scenario", "repeated", "out_of_order")
#: Mixed into a fingerprint to forge another scenario's.
FOREIGN_XOR = 0x5EED_F00D_0BAD_CAFE


class Network:
    """What the vehicle needs of a snapshot."""

    def __init__(self, s):
        n = s.node_count
        self.epoch = s.epoch
        self.next_update_s = s.next_update_s
        self.speed = s.speed_mps
        self.budget = s.time_available_s
        self.start = s.start
        self.goal = s.goal
        self.n = n
        self.pos = [(p.x, p.y, p.z) for p in s.nodes[:n]]
        self.prize = [p.prize for p in s.nodes[:n]]
        self.edges = {}
        for e in s.edges[: s.edge_count]:
            # Each pair at most once per snapshot; the first one wins, as in a scan.
            self.edges.setdefault((min(e.a, e.b), max(e.a, e.b)), (e.priority, e.risk, e.task_time_s))

    def edge(self, a, b):
        return self.edges.get((min(a, b), max(a, b)))


class Sim:
    """The vehicle's motion and task model, advanced exactly to a mission time."""

    def __init__(self):
        self.net = None
        self.t = 0.0
        self.pos = [0.0, 0.0, 0.0]
        self.frm = self.to = 0
        self.phase, self.task_left = FREE, 0.0
        self.edge_weight = self.edge_task_s = 0.0
        self.plan, self.cursor, self.has_plan, self.ever_planned, self.plan_seq = [], 0, False, False, 0
        self.route, self.visited = [], set()
        self.arrivals = self.tasks = 0
        self.weight = self.distance_m = 0.0
        self.outcome = m.Outcome.RUNNING
        self.stale_plans = 0

    def apply_snapshot(self, s):
        first = self.net is None
        self.net = Network(s)
        if first:
            self.frm = self.to = s.start
            self.pos = list(self.net.pos[s.start])
            self.route = [s.start]
            self.visited = {s.start}

    def offer_plan(self, p):
        """'taken', 'stale', or the reject kind."""
        ids = m.route_of(p)
        verdict = self._check_plan(ids)
        if verdict == "taken":
            self.plan, self.cursor, self.has_plan, self.ever_planned = ids, 0, True, True
            self.plan_seq = p.header.seq
        elif verdict == "stale":
            self.stale_plans += 1
        return verdict

    def _check_plan(self, ids):
        if self.net is None:
            return "bad_plan"
        if any(i >= self.net.n for i in ids):
            return "node_out_of_range"
        if self.outcome != m.Outcome.RUNNING:
            return "stale"
        if not ids or ids[0] != self.to:
            return "stale" if ids and ids[0] in self.visited else "bad_plan"
        if ids[-1] != self.net.goal:
            return "bad_plan"
        seen = set()
        for k, i in enumerate(ids):
            if i in seen or (k > 0 and i in self.visited):
                return "visited_node"
            seen.add(i)
            if k > 0 and self.net.edge(ids[k - 1], i) is None:
                return "non_edge"
        return "taken"

    def _next_edge(self):
        if not self.has_plan or self.cursor + 1 >= len(self.plan):
            return None
        w = self.plan[self.cursor + 1]
        e = self.net.edge(self.to, w)
        if e is None:
            return None
        priority, risk, task_s = e
        return w, task_s, priority / risk + self.net.prize[w]

    def next_event_time(self):
        if self.outcome != m.Outcome.RUNNING or self.net is None:
            return math.inf
        if self.phase == FREE:
            t = self.t if (self.to == self.net.goal or self._next_edge() is not None) else math.inf
        elif self.phase == TRAVEL:
            t = self.t + dist(self.pos, self.net.pos[self.to]) / self.net.speed
        else:
            t = self.t + self.task_left
        return min(t, self.net.budget)

    def step_until(self, t_target):
        """Advances to ``t_target`` or the next event; returns the event or None.
        Events: ('arrival', node), ('task', node), ('finished', outcome)."""
        if self.outcome != m.Outcome.RUNNING or self.net is None:
            return None
        end = min(t_target, self.net.budget)
        while True:
            if self.phase == FREE:
                if self.to == self.net.goal:
                    self.outcome = m.Outcome.GOAL_REACHED
                    return ("finished", self.outcome)
                nxt = self._next_edge()
                if nxt is not None:
                    w, task_s, weight = nxt
                    self.frm, self.to = self.to, w
                    self.cursor += 1
                    self.edge_weight, self.edge_task_s = weight, task_s
                    self.phase = TRAVEL
                    continue
                self.has_plan = False
                return self._wait_until(end)
            if self.phase == TRAVEL:
                target = self.net.pos[self.to]
                d = dist(self.pos, target)
                t_arrive = self.t + d / self.net.speed
                if t_arrive <= end:
                    self.t = t_arrive
                    self.pos = list(target)
                    self.distance_m += d
                    self.arrivals += 1
                    self.route.append(self.to)
                    self.visited.add(self.to)
                    self.phase, self.task_left = TASK, self.edge_task_s
                    return ("arrival", self.to)
                frac = (end - self.t) * self.net.speed / d
                for k in range(3):
                    self.pos[k] += (target[k] - self.pos[k]) * frac
                self.distance_m += (end - self.t) * self.net.speed
                return self._wait_until(end)
            # TASK
            if self.t + self.task_left <= end:
                self.t += self.task_left
                self.tasks += 1
                self.weight += self.edge_weight
                self.phase = FREE
                return ("task", self.to)
            self.task_left = self.task_left - (end - self.t)
            return self._wait_until(end)

    def _wait_until(self, end):
        self.t = max(self.t, end)
        if self.t >= self.net.budget:
            self.outcome = m.Outcome.TIMED_OUT
            return ("finished", self.outcome)
        return None

    def mode(self):
        if self.outcome != m.Outcome.RUNNING:
            return m.VehicleMode.FINISHED
        if self.phase == TRAVEL:
            return m.VehicleMode.TRAVELLING
        if self.phase == TASK:
            return m.VehicleMode.WORKING
        return m.VehicleMode.HOLDING if self.ever_planned else m.VehicleMode.NO_PLAN

    def fill_state(self, event, time_scale, needs_answer, s):
        s.header.mission_time_s = self.t
        for k in range(3):
            s.position[k] = self.pos[k]
        s.time_left_s = max(self.net.budget - self.t, 0.0)
        if self.phase == FREE:
            s.eta_free_s = 0.0
        elif self.phase == TRAVEL:
            s.eta_free_s = dist(self.pos, self.net.pos[self.to]) / self.net.speed + self.edge_task_s
        else:
            s.eta_free_s = self.task_left
        s.weight = self.weight
        s.distance_m = self.distance_m
        s.time_scale = time_scale
        s.plan_seq = self.plan_seq if self.has_plan else 0
        s.snapshot_epoch = self.net.epoch
        s.mode = self.mode()
        s.event = event
        s.outcome = self.outcome
        s.from_node = self.frm
        s.to_node = self.to
        s.arrivals = self.arrivals
        s.tasks_completed = self.tasks
        s.needs_answer = 1 if needs_answer else 0
        s.stale_plans = self.stale_plans
        s.route_len = len(self.route)
        for k, i in enumerate(self.route):
            s.route[k] = i


class NoAnswer(Exception):
    pass


class Journal:
    """The vehicle's journal, in vehicle-sim's format (one JSON object per line)."""

    def __init__(self, path):
        self.path = path
        self.f = open(path, "a", encoding="utf-8") if path else None

    def write(self, **event):
        if self.f:
            self.f.write(json.dumps(event, sort_keys=True, separators=(",", ":")) + "\n")
            self.f.flush()


class Vehicle:
    def __init__(self, args):
        self.args = args
        self.client = t.Client(args.ipc_prefix, args.vehicle, "py-vehicle")
        self.waker = self.client.waker("vehicle")
        self.state_out = self.client.outbox(t.VEHICLE_STATE)
        self.snapshots = self.client.inbox(t.WAYPOINTS)
        self.plans = self.client.inbox(t.PLAN)
        self.status = self.client.inbox(t.STATUS)
        fp = int(args.fingerprint, 16) if args.fingerprint else None
        self.g_snap, self.g_plan, self.g_status = Guard(fp), Guard(fp), Guard(fp)
        self.stamp = None
        self.sim = Sim()
        self.answered = (0, 0, 0)  # session, state seq, epoch
        self.time_scale = 0.0 if args.time_scale is None else args.time_scale
        self.journal = Journal(args.journal)
        self.faults = args.inject
        self.injected = 0

    def rejected(self):
        return [a + b + c for a, b, c in zip(self.g_snap.rejected, self.g_plan.rejected, self.g_status.rejected)]

    def drain_snapshots(self):
        for s in self.snapshots.drain():
            if self.g_snap.check(s) is None:
                self.sim.apply_snapshot(s)

    def drain(self):
        self.drain_snapshots()
        if self.g_snap.fingerprint is None:
            return  # the scenario is known from the first snapshot on
        if self.stamp is None:
            self.stamp = t.Stamp(self.g_snap.fingerprint)
            self.g_plan.fingerprint = self.g_status.fingerprint = self.g_snap.fingerprint
        self.drain_plans()
        answered = False
        for st in self.status.drain():
            if self.g_status.check(st) is None:
                self.answered = (st.handled_state_session, st.handled_state_seq, st.handled_epoch)
                answered = True
        if answered:
            # A plan is sent before the status that answers its trigger, so
            # it is queued by now even when it came after the drain above:
            # take it before moving on (lockstep stays deterministic).
            self.drain_plans()

    def drain_plans(self):
        for p in self.plans.drain():
            if self.g_plan.check(p) is not None:
                continue
            if p.snapshot_epoch > self.sim.net.epoch:
                # Planned on a snapshot still queued here (the sensor sent it
                # before the planner read it): check the plan against it.
                self.drain_snapshots()
            verdict = self.sim.offer_plan(p)
            if verdict == "taken":
                self.journal.write(event="plan", t=self.sim.t, seq=p.header.seq, route=list(self.sim.plan))
            elif verdict != "stale":
                self.g_plan.reject(verdict)

    def good_state(self, event, needs_answer):
        s = m.VehicleState()
        self.sim.fill_state(event, self.time_scale, needs_answer, s)
        for k, n in enumerate(self.rejected()):
            s.rejected[k] = n
        return s

    def publish(self, event, needs_answer):
        """Publishes the state for ``event``; returns the good message's seq.
        With ``--inject``, a bad copy goes out next to it (never next to the
        first or the last state), as vehicle-sim's ``--inject`` does."""
        fault = None
        if self.faults and event not in (m.VehicleEvent.START, m.VehicleEvent.FINISHED):
            fault = self.faults[self.injected % len(self.faults)]
            self.injected += 1
        if fault is None:
            return self.state_out.publish(self.good_state(event, needs_answer), self.stamp)
        if fault in ("repeated", "out_of_order"):
            # After the good one: the same seq again, or one below it.
            seq = self.state_out.publish(self.good_state(event, needs_answer), self.stamp)
            bad = self.good_state(event, needs_answer)
            self.stamp.stamp(bad.header)
            bad.header.seq = seq if fault == "repeated" else max(seq - 1, 1)
            self.state_out.send(bad)
            return seq
        bad = self.good_state(event, needs_answer)
        self.stamp.stamp(bad.header)
        if fault == "foreign_scenario":
            bad.header.fingerprint ^= FOREIGN_XOR
        else:  # non_finite
            bad.position[0] = math.nan
        self.state_out.send(bad)
        return self.state_out.publish(self.good_state(event, needs_answer), self.stamp)

    def record(self, ev):
        kind, what = ev
        sim = self.sim
        if kind == "arrival":
            self.journal.write(
                event="arrival",
                t=sim.t,
                node=what,
                x=sim.pos[0],
                y=sim.pos[1],
                z=sim.pos[2],
                distance_m=sim.distance_m,
                task_s=sim.edge_task_s,
                task_weight=sim.edge_weight,
            )
        elif kind == "task":
            self.journal.write(event="task", t=sim.t, node=what, weight=sim.edge_weight)
        else:
            self.journal.write(event="end", t=sim.t, outcome=m.name_of("Outcome", what))

    def wait_for(self, what, done):
        t0 = time.monotonic()
        while True:
            self.drain()
            if done():
                return True
            if _stop:
                return False
            if time.monotonic() - t0 > self.args.answer_timeout_s:
                raise NoAnswer(
                    "no answer within %g s while waiting for %s (mission time %.1f s, planner answered state %d): "
                    "are the planner and sensor-sim running with the same --ipc-prefix?"
                    % (self.args.answer_timeout_s, what, self.sim.t, self.answered[1])
                )
            if not self.waker.wait(0.05):
                self.state_out.refresh()

    def answered_seq(self, seq):
        return self.answered[0] == self.stamp.session and self.answered[1] >= seq

    def lockstep(self):
        seq = self.publish(m.VehicleEvent.START, True)
        if not self.wait_for("the first plan", lambda: self.answered_seq(seq)):
            return m.Outcome.ABORTED
        while True:
            ev = self.sim.step_until(self.sim.net.next_update_s)
            if ev is not None:
                self.record(ev)
            if ev is None:
                epoch = self.sim.net.epoch + 1
                seq = self.publish(m.VehicleEvent.TICK, True)
                ok = self.wait_for(
                    "the sensor update",
                    lambda: self.sim.net.epoch >= epoch and self.answered_seq(seq) and self.answered[2] >= epoch,
                )
                if not ok:
                    return m.Outcome.ABORTED
            elif ev[0] == "arrival":
                seq = self.publish(m.VehicleEvent.ARRIVAL, True)
                if not self.wait_for("the planner's answer", lambda: self.answered_seq(seq)):
                    return m.Outcome.ABORTED
            elif ev[0] == "finished":
                self.publish(m.VehicleEvent.FINISHED, False)
                return ev[1]

    def scaled(self):
        scale = self.time_scale
        period_ns = int(1e9 / self.args.state_rate_hz)
        t0 = time.monotonic_ns()
        t_start = self.sim.t
        next_periodic = t0
        self.publish(m.VehicleEvent.START, False)
        while True:
            now = time.monotonic_ns()
            tm = t_start + (now - t0) * 1e-9 * scale
            while True:
                ev = self.sim.step_until(tm)
                if ev is None:
                    break
                self.record(ev)
                if ev[0] == "arrival":
                    self.publish(m.VehicleEvent.ARRIVAL, False)
                elif ev[0] == "finished":
                    self.publish(m.VehicleEvent.FINISHED, False)
                    return ev[1]
            if now >= next_periodic:
                self.publish(m.VehicleEvent.PERIODIC, False)
                next_periodic = now + period_ns
            if _stop:
                return m.Outcome.ABORTED
            to_event_s = max((self.sim.next_event_time() - tm) / scale, 0.0)
            wait_s = min(max(next_periodic - now, 0) * 1e-9, to_event_s, 0.05)
            if not self.waker.wait(wait_s):
                self.state_out.refresh()
            self.drain()

    def run(self):
        if not self.wait_for("the first waypoint snapshot", lambda: self.sim.net is not None and self.stamp is not None):
            return m.Outcome.ABORTED
        self.journal.write(event="start", t=self.sim.t, node=self.sim.route[-1], resumed=False)
        outcome = self.lockstep() if self.args.time_scale is None else self.scaled()
        if outcome == m.Outcome.ABORTED:
            if self.sim.outcome == m.Outcome.RUNNING:
                self.sim.outcome = m.Outcome.ABORTED
            self.journal.write(event="end", t=self.sim.t, outcome="aborted")
            self.publish(m.VehicleEvent.FINISHED, False)
        sim = self.sim
        print(
            "vehicle.py: %s at mission time %.1f s: %d tasks, weight %.2f, %.0f m, route %s"
            % (m.name_of("Outcome", outcome), sim.t, sim.tasks, sim.weight, sim.distance_m, sim.route),
            file=sys.stderr,
        )
        if self.faults:
            print("vehicle.py: injected %d bad state(s): %s" % (self.injected, ",".join(self.faults)), file=sys.stderr)
        r = self.rejected()
        if sum(r):
            kinds = ", ".join("%s %d" % (m.REJECT_KIND_NAMES[k], n) for k, n in enumerate(r) if n)
            print("vehicle.py: rejected %d input message(s) in all: %s" % (sum(r), kinds), file=sys.stderr)
        return outcome


def positive(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("%r: not a number" % text)
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError("%r: must be > 0" % text)
    return v


def fault_list(text):
    kinds = [k.strip() for k in text.split(",")]
    out = []
    for k in kinds:
        if k == "all":
            out.extend(f for f in STATE_FAULTS if f not in out)
        elif k in STATE_FAULTS:
            if k not in out:
                out.append(k)
        else:
            raise argparse.ArgumentTypeError("unknown kind %r; expected a comma-separated list of %s, or all" % (k, ", ".join(STATE_FAULTS)))
    return out


def main():
    ap = argparse.ArgumentParser(prog="vehicle.py", description="A Python AUV following the planner's plans over iceoryx2")
    ap.add_argument("--ipc-prefix", required=True, help="iceoryx2 isolation prefix of the mission")
    ap.add_argument("--vehicle", default="auv1", help="vehicle namespace in service names")
    ap.add_argument("--time-scale", type=positive, default=None, help="mission s per real s (default: lockstep)")
    ap.add_argument("--state-rate-hz", type=positive, default=20.0, help="states per real s in scaled time")
    ap.add_argument("--answer-timeout-s", type=positive, default=60.0, help="lockstep: give up after this long, real s")
    ap.add_argument("--journal", default=None, help="append the events acted on to this file (JSON lines)")
    ap.add_argument(
        "--inject",
        type=fault_list,
        default=[],
        metavar="KIND[,KIND...]",
        help="tests: send a bad state next to each good one after the first, these kinds in turn: %s, or all"
        % ", ".join(STATE_FAULTS),
    )
    ap.add_argument("--fingerprint", default=None, help="scenario fingerprint, hex (default: the first snapshot's)")
    args = ap.parse_args()
    try:
        if args.fingerprint:
            int(args.fingerprint, 16)
        t.domain_config(args.ipc_prefix)
        t.check_name("vehicle name", args.vehicle)
    except (ValueError, t.ClientError) as e:
        print("vehicle.py: error: %s" % (e if isinstance(e, t.ClientError) else "--fingerprint %r: not hex" % args.fingerprint), file=sys.stderr)
        return 2
    if args.journal and os.path.exists(args.journal) and os.path.getsize(args.journal) > 0:
        print("vehicle.py: error: journal %s already holds a mission (this vehicle does not resume; use a fresh file)" % args.journal, file=sys.stderr)
        return 2
    signal.signal(signal.SIGINT, _on_signal)
    signal.signal(signal.SIGTERM, _on_signal)
    try:
        outcome = Vehicle(args).run()
    except (t.ClientError, NoAnswer, OSError) as e:
        print("vehicle.py: error: %s" % e, file=sys.stderr)
        return 1
    except Exception as e:  # iceoryx2's own errors (a port failing mid-mission)
        print("vehicle.py: error: iceoryx2: %r" % e, file=sys.stderr)
        return 1
    return 130 if outcome == m.Outcome.ABORTED else 0


if __name__ == "__main__":
    sys.exit(main())
