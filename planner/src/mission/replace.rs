//! Taking on a new mission in the middle of one (the shore's
//! `replace-mission`): the new mission file, checked against where the
//! vehicle is and the time it has left, becomes the next leg of the run.
//!
//! Contract:
//! - The new mission starts where the vehicle is: its start waypoint is
//!   moved to the vehicle's position (converted through latitude and
//!   longitude when both missions have a geographic frame; otherwise the two
//!   local frames are taken to be the same) and checked like any waypoint
//!   (over water, inside the chart, a route to the goal within the budget).
//! - Its `vehicle.time_available_s` counts from the switch and must fit in
//!   the time the vehicle has left: the battery does not recharge.
//! - While the new world is built around it, the vehicle is frozen
//!   (SIGSTOP), so the position it is given is the one it is at; a refused
//!   mission lets it go on (SIGCONT) as if nothing happened.
//! - Outside processes (`--external-*`) cannot be restarted with a new
//!   mission: the command is refused as `unsupported`.
// Without the shore link nothing can ask for a new mission.
#![cfg_attr(not(feature = "shore"), allow(dead_code))]

use std::path::PathBuf;

use auv_world::frame::LocalFrame;
use auv_world::load::{MissionWorld, ScenarioArgs};

/// A new mission the vehicle takes on: the next leg.
pub(super) struct Replacement {
    /// The shore command that brought it.
    pub(super) command_id: u64,
    /// Mission time of the leg it ends, at the switch, s.
    pub(super) t: f64,
    /// Where the vehicle was: the new start, in the new mission's frame, m.
    pub(super) start_at: [f64; 3],
    /// The flags that build the new world in every process.
    pub(super) scenario: ScenarioArgs,
    /// The new world.
    pub(super) world: MissionWorld,
    /// The mission file as received.
    pub(super) mission: PathBuf,
}

/// Why a new mission was refused: a reason name for the ack and the words.
#[derive(Debug)]
pub(super) struct Refusal {
    pub(super) reason: &'static str,
    pub(super) detail: String,
}

impl Refusal {
    fn new(reason: &'static str, detail: impl Into<String>) -> Self {
        Self {
            reason,
            detail: detail.into(),
        }
    }
}

/// The vehicle's position `p` (x, y in frame `from`) in frame `to`.
pub(super) fn carry_position(
    p: [f64; 2],
    from: Option<&LocalFrame>,
    to: Option<&LocalFrame>,
) -> Result<[f64; 2], String> {
    match (from, to) {
        (Some(f), Some(t)) => {
            let geo = f
                .to_geodetic(p[0], p[1])
                .map_err(|e| format!("the vehicle's position: {e}"))?;
            let (x, y) = t.to_local(geo).map_err(|e| format!("the vehicle's position: {e}"))?;
            Ok([x, y])
        }
        _ => Ok(p),
    }
}

/// The flags of a mission file as it stands (its own seed and budget).
pub(super) fn file_args(mission: PathBuf) -> ScenarioArgs {
    ScenarioArgs {
        mission: Some(mission),
        ..Default::default()
    }
}

#[cfg(feature = "shore")]
mod take {
    use std::time::Duration;

    use super::{Refusal, Replacement, carry_position, file_args};
    use crate::mission::child::Kid;
    use crate::mission::run::Launch;
    use crate::mission::supervise::{Monitor, Proc};
    use auv_link::replace::{Answer, Requests};
    use auv_world::load::{ScenarioArgs, load_world};

    impl Refusal {
        /// The answer to the link.
        pub(in crate::mission) fn answer(&self, t: f64) -> Answer {
            Answer {
                applied: false,
                reason: self.reason.into(),
                detail: self.detail.clone(),
                t,
            }
        }
    }

    /// The answer to the link for a mission taken on at mission time `t`.
    pub(in crate::mission) fn applied(t: f64) -> Answer {
        Answer {
            applied: true,
            reason: "none".into(),
            detail: String::new(),
            t,
        }
    }

    /// Checks request `id` and builds its world around the vehicle.
    pub(in crate::mission) fn take_on(
        id: u64,
        requests: &Requests,
        l: &Launch,
        outside_processes: bool,
        over: bool,
        vehicle: &mut Kid,
        monitor: &mut Monitor,
    ) -> Result<Replacement, Refusal> {
        if over {
            return Err(Refusal::new("mission_over", "the mission has ended"));
        }
        if outside_processes {
            return Err(Refusal::new(
                "unsupported",
                "outside processes (--external-*) cannot be restarted with a new mission",
            ));
        }
        let mission = requests.mission_path(id);
        let plain = file_args(mission.clone());
        // The file on its own first, while the vehicle goes on.
        let as_written = load_world(&plain).map_err(|e| Refusal::new("bad_mission", e.to_string()))?;
        vehicle.signal(libc::SIGSTOP);
        let r = around_the_vehicle(id, plain, &as_written, l, monitor);
        if r.is_err() {
            vehicle.signal(libc::SIGCONT);
            monitor.forget(Proc::Vehicle);
        }
        r
    }

    fn around_the_vehicle(
        id: u64,
        plain: ScenarioArgs,
        as_written: &auv_world::load::MissionWorld,
        l: &Launch,
        monitor: &mut Monitor,
    ) -> Result<Replacement, Refusal> {
        // The last state it sent before it stopped.
        std::thread::sleep(Duration::from_millis(20));
        let mut events = Vec::new();
        monitor.poll([false; 3], &mut events);
        let s = *monitor
            .last_state()
            .ok_or_else(|| Refusal::new("no_state", "no vehicle state yet: where the vehicle is is not known"))?;
        let [x, y] = carry_position([s.position[0], s.position[1]], l.frame, as_written.frame())
            .map_err(|e| Refusal::new("bad_mission", e))?;
        let start_at = [x, y, s.position[2]];
        let scenario = ScenarioArgs {
            start_at: Some(start_at),
            ..plain.clone()
        };
        let world = load_world(&scenario).map_err(|e| {
            Refusal::new(
                "bad_mission",
                format!("starting where the vehicle is, ({x:.0}, {y:.0}) m: {e}"),
            )
        })?;
        let need = world.snapshot().time_available_s;
        if need > s.time_left_s {
            return Err(Refusal::new(
                "budget_out_of_range",
                format!(
                    "the new mission's time_available_s = {need} s exceeds the {:.0} s the vehicle has left",
                    s.time_left_s
                ),
            ));
        }
        Ok(Replacement {
            command_id: id,
            t: s.header.mission_time_s,
            start_at,
            scenario,
            world,
            mission: plain.mission.unwrap_or_default(),
        })
    }
}

#[cfg(feature = "shore")]
pub(super) use take::{applied, take_on};

#[cfg(test)]
mod tests {
    use super::*;
    use auv_world::frame::LatLon;

    #[test]
    fn positions_cross_between_frames_through_latitude_and_longitude() {
        let a = LocalFrame::new(LatLon {
            lat: 48.99,
            lon: -58.17,
        })
        .unwrap();
        let b = LocalFrame::new(LatLon {
            lat: 48.995,
            lon: -58.16,
        })
        .unwrap();
        let p = [1200.0, 800.0];
        let q = carry_position(p, Some(&a), Some(&b)).unwrap();
        // b's origin is north-east of a's: the same spot is south-west of it.
        assert!(q[0] < p[0] && q[1] < p[1], "{q:?}");
        let back = carry_position(q, Some(&b), Some(&a)).unwrap();
        assert!(
            (back[0] - p[0]).abs() < 1e-6 && (back[1] - p[1]).abs() < 1e-6,
            "{back:?}"
        );
        // Without a frame on either side the local frames are the same.
        assert_eq!(carry_position(p, None, Some(&b)).unwrap(), p);
        assert_eq!(carry_position(p, Some(&a), None).unwrap(), p);
    }
}
