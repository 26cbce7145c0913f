//! A mission with an outside vehicle or sensor: `planner mission
//! --external-vehicle` (`--external-sensor`) starts the other processes and
//! waits for a process it did not start — a Python vehicle on iceoryx2's own
//! bindings, an autopilot bridge — to connect to the run's domain instead of
//! starting `vehicle-sim` (`sensor-sim`).
//!
//! Contract:
//! - The mission prints, on stderr, the domain and the command that starts
//!   the Python example in its place, then waits (Ctrl-C stops it) as the
//!   planner waits for any vehicle: until the first snapshot and state.
//! - The report's figures come from the vehicle's journal when the outside
//!   vehicle writes one at `<out>/journal.jsonl` (as the examples do with
//!   `--journal`), else from the last vehicle state the planner accepted.
//! - Before the domain is retired, the mission gives the outside processes
//!   a few seconds to leave it (they exit when they see the end).

use std::path::Path;
use std::time::{Duration, Instant};

use auv_messages::journal::JournalSummary;
use auv_messages::msg::{Outcome, VehicleState, route_ids};
use auv_transport::SetupError;
use auv_transport::ipc::{any_node_alive, cleanup_dead_nodes, domain_config};

/// The flags naming the processes that are not started here.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::Args)]
pub struct ExternalArgs {
    /// Do not start vehicle-sim: wait for an outside vehicle (e.g.
    /// clients/python/examples/vehicle.py) on the run's --ipc-prefix.
    #[arg(long, conflicts_with_all = ["faults", "inject_vehicle"])]
    pub external_vehicle: bool,
    /// Do not start sensor-sim: wait for an outside sensor on the run's --ipc-prefix.
    #[arg(long, conflicts_with_all = ["faults", "inject_sensor"])]
    pub external_sensor: bool,
}

impl ExternalArgs {
    /// Whether any process is left to the outside.
    pub fn any(self) -> bool {
        self.external_vehicle || self.external_sensor
    }
}

/// Tells the user what to start, on stderr (the progress bar owns stdout's line).
pub fn announce(ext: ExternalArgs, prefix: &str, vehicle: &str, fingerprint: u64, lockstep: bool, out: &Path) {
    if ext.external_vehicle {
        let pace = if lockstep {
            ""
        } else {
            " --time-scale <same as the mission>"
        };
        eprintln!(
            "planner: waiting for an outside vehicle on --ipc-prefix {prefix} --vehicle {vehicle} \
             (scenario fingerprint {fingerprint:016x}), e.g.\n  \
             python3 clients/python/examples/vehicle.py --ipc-prefix {prefix} --vehicle {vehicle}{pace} --journal {}",
            out.join("journal.jsonl").display()
        );
    }
    if ext.external_sensor {
        eprintln!(
            "planner: waiting for an outside sensor on --ipc-prefix {prefix} --vehicle {vehicle} \
             (scenario fingerprint {fingerprint:016x}): it publishes auv.WaypointSnapshot.v2 behind a slice of auv.WireEdge.v1 (see docs/wire.md)"
        );
    }
}

/// What the report states about the vehicle's mission.
#[derive(Clone, Debug, PartialEq)]
pub struct VehicleFigures {
    /// How the mission ended.
    pub outcome: Outcome,
    /// Mission time used, s.
    pub time_s: f64,
    /// Tasks completed.
    pub tasks: u32,
    /// Weight collected.
    pub weight: f64,
    /// Distance travelled, m.
    pub distance_m: f64,
    /// Waypoints visited, start first.
    pub route: Vec<usize>,
}

impl VehicleFigures {
    /// The figures of the journal (the vehicle's record), or, when it is
    /// empty (an outside vehicle that keeps none), of the last state the
    /// planner accepted. `finished`: the planner saw the mission's end.
    pub fn of(journal: &JournalSummary, last: Option<&VehicleState>, finished: bool) -> Self {
        if journal.events.is_empty()
            && let Some(s) = last
        {
            let outcome = auv_messages::msg::FromCode::from_code(s.outcome).unwrap_or(Outcome::Aborted);
            return Self {
                outcome: if finished { outcome } else { Outcome::Aborted },
                time_s: s.header.mission_time_s,
                tasks: s.tasks_completed,
                weight: s.weight,
                distance_m: s.distance_m,
                route: route_ids(&s.route, s.route_len)
                    .iter()
                    .map(|&b| usize::from(b))
                    .collect(),
            };
        }
        Self {
            outcome: match (finished, journal.outcome()) {
                (true, Some(o)) => o,
                _ => Outcome::Aborted,
            },
            time_s: journal.time_s(),
            tasks: journal.tasks(),
            weight: journal.weight(),
            distance_m: journal.distance_m(),
            route: journal.route(),
        }
    }
}

/// Waits up to `limit` for every other node of the domain `prefix` to go
/// (outside processes leave when they see the end); returns whether they did.
pub fn wait_for_outside_nodes(prefix: &str, limit: Duration) -> Result<bool, SetupError> {
    let cfg = domain_config(prefix)?;
    let t0 = Instant::now();
    loop {
        cleanup_dead_nodes(&cfg);
        if !any_node_alive(&cfg) {
            return Ok(true);
        }
        if t0.elapsed() > limit {
            return Ok(false);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_messages::journal::JournalEvent;
    use auv_messages::msg::boxed_zeroed;

    #[test]
    fn figures_come_from_the_journal_when_there_is_one_else_from_the_last_state() {
        let mut s = *boxed_zeroed::<VehicleState>();
        s.header.mission_time_s = 500.0;
        s.outcome = Outcome::GoalReached as u32;
        s.tasks_completed = 2;
        s.weight = 7.5;
        s.distance_m = 900.0;
        s.route_len = 3;
        s.route[..3].copy_from_slice(&[0, 4, 9]);
        let none = JournalSummary::default();
        let f = VehicleFigures::of(&none, Some(&s), true);
        assert_eq!(
            (f.outcome, f.tasks, f.route.clone()),
            (Outcome::GoalReached, 2, vec![0, 4, 9])
        );
        assert_eq!((f.time_s, f.weight, f.distance_m), (500.0, 7.5, 900.0));
        // The planner never saw the end: aborted, whatever the state says.
        assert_eq!(VehicleFigures::of(&none, Some(&s), false).outcome, Outcome::Aborted);
        let journal = JournalSummary {
            events: vec![
                JournalEvent::Start {
                    t: 0.0,
                    node: 0,
                    resumed: false,
                },
                JournalEvent::End {
                    t: 10.0,
                    outcome: Outcome::TimedOut,
                },
            ],
        };
        let f = VehicleFigures::of(&journal, Some(&s), true);
        assert_eq!(
            (f.outcome, f.time_s, f.tasks, f.route),
            (Outcome::TimedOut, 10.0, 0, vec![0])
        );
    }
}
