//! `mission.log`: one JSON object per line and per event (sensor update,
//! trigger, plan, arrival, end), in the order the planner saw them.
//!
//! Contract: a line holds only mission-time and planning figures (no
//! wall-clock time, no latency), and numbers print shortest-round-trip, so a
//! lockstep mission with the same seeds writes the same bytes every time.

use serde_json::{Value, json};

use auv_messages::msg::{AckStatus, TriggerKind, outcome_name};
use auv_service::core::ServiceEvent;

/// snake_case name of a trigger.
pub fn trigger_name(k: TriggerKind) -> &'static str {
    match k {
        TriggerKind::Initial => "initial",
        TriggerKind::Arrival => "arrival",
        TriggerKind::EdgeLost => "edge_lost",
        TriggerKind::TimeChanged => "time_changed",
        TriggerKind::Infeasible => "infeasible",
        TriggerKind::SensorBack => "sensor_back",
        TriggerKind::Operator => "operator",
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
        ServiceEvent::Command {
            t,
            id,
            kind,
            status,
            reason,
            value,
            repeat,
        } => vec![json!({
            "event": "command",
            "t": t,
            "id": id,
            "command": kind.as_str(),
            "status": if status == AckStatus::Applied { "applied" } else { "refused" },
            "reason": reason.as_str(),
            "value": value,
            "repeat": repeat,
        })],
        ServiceEvent::Finished { t, outcome } => vec![json!({
            "event": "finished",
            "t": t,
            "outcome": outcome_name(outcome),
        })],
    }
}

/// Events a log writer queues before the service waits for room.
const LOG_QUEUE_LEN: usize = 1024;

/// Runs `body` with an event sink that appends each event's lines to
/// `path` (created if missing) from a writer thread of its own, so the
/// calling (service) thread neither formats nor allocates: it only moves
/// the event into a fixed-size lock-free queue. The lines are flushed after
/// every batch. Without a path the sink discards events.
pub fn with_log_writer<R>(
    path: Option<&std::path::Path>,
    body: impl FnOnce(&mut dyn FnMut(&ServiceEvent)) -> R,
) -> std::io::Result<R> {
    use std::io::Write;
    use std::sync::atomic::{AtomicBool, Ordering};
    let Some(path) = path else {
        return Ok(body(&mut |_| {}));
    };
    let file = std::fs::OpenOptions::new().create(true).append(true).open(path)?;
    let mut queue: Box<heapless::spsc::Queue<ServiceEvent, LOG_QUEUE_LEN>> = Box::new(heapless::spsc::Queue::new());
    let (mut producer, mut consumer) = queue.split();
    let done = AtomicBool::new(false);
    std::thread::scope(|scope| {
        let done = &done;
        let writer = scope.spawn(move || -> std::io::Result<()> {
            let mut out = std::io::BufWriter::new(file);
            loop {
                let finished = done.load(Ordering::Acquire);
                let mut wrote = false;
                while let Some(e) = consumer.dequeue() {
                    for line in lines(&e) {
                        writeln!(out, "{line}")?;
                    }
                    wrote = true;
                }
                if wrote {
                    out.flush()?;
                }
                if finished {
                    return out.flush();
                }
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
        });
        let r = body(&mut |e: &ServiceEvent| {
            // Never drop an event: wait for room.
            while producer.enqueue(*e).is_err() {
                if writer.is_finished() {
                    return;
                }
                std::thread::yield_now();
            }
        });
        done.store(true, Ordering::Release);
        match writer.join() {
            Ok(Ok(())) => Ok(r),
            Ok(Err(e)) => Err(e),
            Err(_) => Err(std::io::Error::other("the log writer panicked")),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_core::route::{Route, RouteEval};

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

    #[test]
    fn the_log_writer_appends_every_event_in_order() {
        let p = std::env::temp_dir().join(format!("log-writer-{}.log", std::process::id()));
        let _ = std::fs::remove_file(&p);
        for round in 0..2 {
            with_log_writer(Some(&p), |sink| {
                for k in 0..2000 {
                    sink(&ServiceEvent::Finished {
                        t: f64::from(k + round * 2000),
                        outcome: auv_messages::msg::Outcome::GoalReached,
                    });
                }
            })
            .unwrap();
        }
        let text = std::fs::read_to_string(&p).unwrap();
        let ts: Vec<f64> = text
            .lines()
            .map(|l| serde_json::from_str::<Value>(l).unwrap()["t"].as_f64().unwrap())
            .collect();
        assert_eq!(ts, (0..4000).map(f64::from).collect::<Vec<_>>());
        let _ = std::fs::remove_file(&p);
    }
}
