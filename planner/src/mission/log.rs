//! `mission.log`: one JSON object per line and per event (sensor update,
//! trigger, plan, arrival, end), in the order the planner saw them.
//!
//! Contract: a line holds only mission-time and planning figures (no
//! wall-clock time, no latency), and numbers print shortest-round-trip, so a
//! lockstep mission with the same seeds writes the same bytes every time.

use serde_json::{Value, json};

use crate::msg::{Outcome, TriggerKind};
use crate::service::core::ServiceEvent;

/// snake_case name of a trigger.
pub fn trigger_name(k: TriggerKind) -> &'static str {
    match k {
        TriggerKind::Initial => "initial",
        TriggerKind::Arrival => "arrival",
        TriggerKind::EdgeLost => "edge_lost",
        TriggerKind::TimeChanged => "time_changed",
        TriggerKind::Infeasible => "infeasible",
    }
}

/// snake_case name of an outcome.
pub fn outcome_name(o: Outcome) -> &'static str {
    match o {
        Outcome::Running => "running",
        Outcome::GoalReached => "goal_reached",
        Outcome::TimedOut => "timed_out",
        Outcome::Aborted => "aborted",
    }
}

/// The log lines of one service event (a plan is two: its trigger, then the plan).
pub fn lines(e: &ServiceEvent) -> Vec<Value> {
    match *e {
        ServiceEvent::SensorUpdate {
            t,
            epoch,
            edges,
            trigger,
        } => vec![json!({
            "event": "sensor_update",
            "t": t,
            "epoch": epoch,
            "edges": edges,
            "replan": trigger.map(trigger_name),
        })],
        ServiceEvent::Arrival {
            t,
            at,
            node,
            tasks,
            weight,
            time_left_s,
        } => vec![json!({
            "event": "arrival",
            "t": t,
            "node": node,
            "x": at.0,
            "y": at.1,
            "tasks": tasks,
            "weight": weight,
            "time_left_s": time_left_s,
        })],
        ServiceEvent::Plan {
            t,
            replan,
            trigger,
            route,
            eval,
            budget_s,
            iterations,
            deadline_cut,
            at: _,
        } => vec![
            json!({
                "event": "trigger",
                "t": t,
                "kind": trigger_name(trigger),
                "from": route.iter().next(),
                "budget_s": budget_s,
            }),
            json!({
                "event": "plan",
                "t": t,
                "replan": replan,
                "route": route.to_vec(),
                "time_s": eval.time_s,
                "weight": eval.weight,
                "distance_m": eval.distance_m,
                "feasible": eval.feasible,
                "iterations": iterations,
                "deadline_cut": deadline_cut,
            }),
        ],
        ServiceEvent::Finished { t, outcome } => vec![json!({
            "event": "finished",
            "t": t,
            "outcome": outcome_name(outcome),
        })],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::route::{Route, RouteEval};

    #[test]
    fn a_plan_is_logged_as_its_trigger_then_the_plan() {
        let e = ServiceEvent::Plan {
            t: 120.5,
            replan: 3,
            trigger: TriggerKind::EdgeLost,
            route: Route::from_slice(&[4, 7, 9]).unwrap(),
            eval: RouteEval {
                time_s: 900.25,
                weight: 12.5,
                feasible: true,
                ..RouteEval::default()
            },
            budget_s: 1000.0,
            iterations: 150,
            deadline_cut: false,
            at: (1.0, 2.0),
        };
        let l = lines(&e);
        assert_eq!(l.len(), 2);
        assert_eq!(l[0]["event"], "trigger");
        assert_eq!(l[0]["kind"], "edge_lost");
        assert_eq!(l[0]["from"], 4);
        assert_eq!(l[1]["route"], json!([4, 7, 9]));
        assert_eq!(l[1]["time_s"], 900.25);
        assert_eq!(l[1].to_string(), lines(&e)[1].to_string(), "formatting is stable");
    }
}
