//! `sensor-sim`: the sensor. Loads the same scenario as the other processes
//! and, every sensor period of mission time (default 60 s), redraws the
//! dynamic waypoints inside their bounds and publishes the network as a
//! waypoint snapshot over iceoryx2.
//!
//! Clock: sensor-sim keeps no clock of its own; it follows the vehicle's
//! mission time from its state messages (exactly in lockstep, extrapolated
//! with the vehicle's time scale otherwise), so a lockstep vehicle that stops
//! at an update time gets exactly one update there. It publishes epoch 0 at
//! start and exits when the vehicle reports the end of the mission.
//!
//! Tests: `--inject KIND[,KIND…]` also sends, from epoch 1 on, one bad
//! snapshot per update next to the good one (kinds in turn; see
//! [`auv_messages::wire`]): payload faults just before it, sequence faults just
//! after it, so receivers still get every good update.
//!
//! Input: vehicle states, validated and checked against the network size;
//! rejections are logged rate-limited and summed up on exit.
//!
//! Exit status: 0 at the end of the mission, 1 on an error, 2 on bad
//! arguments, 130 when stopped by a signal.

use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use auv_messages::msg::{Outcome, VehicleState, WaypointSnapshot};
use auv_messages::network::write_snapshot;
use auv_messages::wire::{Fault, FaultCycle, FaultListError, SENSOR_FAULTS, WireRules, corrupt_snapshot};
use auv_platform::clock::mono_now_ns;
use auv_platform::signal;
use auv_transport::faulty::{Corrupt, FaultyOutbox};
use auv_transport::guard::Guarded;
use auv_transport::ipc::{IpcContext, IpcInbox, IpcSnapshotOutbox, IpcWaker, Shm, Stamp};
use auv_transport::{IpcArgs, Outbox, Role, Wake, Waker};
use auv_world::load::{MissionWorld, ScenarioArgs, load_world};
use clap::Parser;

#[derive(Parser, Debug)]
#[command(
    name = "sensor-sim",
    about = "Simulated sensor: redraws the dynamic waypoints and publishes snapshots"
)]
struct Args {
    #[command(flatten)]
    ipc: IpcArgs,
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// Mission time between sensor updates, s (default: the scenario's).
    #[arg(long)]
    sensor_period_s: Option<f64>,
    /// Restart after a crash: wait up to this many real seconds for the
    /// vehicle's latest state and publish the snapshot of its mission time
    /// (not epoch 0) first.
    #[arg(long, value_name = "S")]
    resume_wait_s: Option<f64>,
    /// Tests: send a bad snapshot next to each good one from epoch 1 on,
    /// these kinds in turn: non_finite, node_out_of_range, off_water,
    /// outside_bound, out_of_order, repeated, foreign_scenario, malformed,
    /// out_of_range, or all.
    #[arg(long, value_name = "KIND[,KIND…]")]
    inject: Option<String>,
}

#[derive(Debug, thiserror::Error)]
enum Error {
    #[error(transparent)]
    Setup(#[from] auv_transport::SetupError),
    #[error(transparent)]
    World(#[from] auv_world::load::WorldError),
    #[error("transport: {0}")]
    Transport(#[from] auv_transport::TransportError),
    #[error(transparent)]
    Snapshot(#[from] auv_messages::network::SnapshotError),
    #[error("--sensor-period-s {0}: must be > 0")]
    BadPeriod(f64),
    #[error("--resume-wait-s {0}: must be between 0 and 3600")]
    BadResumeWait(f64),
    #[error(transparent)]
    BadFaults(#[from] FaultListError),
    #[error("--inject off_water: the chart has no land to put a waypoint on")]
    NoLand,
}

/// The vehicle's clock as last reported.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct VehicleClock {
    mission_time_s: f64,
    sent_mono_ns: u64,
    /// 0: lockstep.
    time_scale: f64,
}

impl VehicleClock {
    /// The vehicle's mission time at `now_ns`.
    fn at(&self, now_ns: u64) -> f64 {
        if self.time_scale > 0.0 {
            self.mission_time_s + now_ns.saturating_sub(self.sent_mono_ns) as f64 * 1e-9 * self.time_scale
        } else {
            self.mission_time_s
        }
    }
}

/// The outbox of snapshots: bad ones next to the good under `--inject`.
type SnapshotOut = FaultyOutbox<IpcSnapshotOutbox<Shm>, BadSnapshot>;

/// Makes an injected snapshot bad (see [`corrupt_snapshot`]).
struct BadSnapshot {
    rules: Arc<WireRules>,
    period_s: f64,
}

impl Corrupt<WaypointSnapshot> for BadSnapshot {
    fn corrupt(&mut self, fault: Fault, m: &mut WaypointSnapshot) {
        // The good snapshot's epoch, from its mission time (epoch × period).
        let epoch = (m.header.mission_time_s / self.period_s).round().max(0.0) as u64;
        corrupt_snapshot(fault, m, &self.rules, epoch);
    }
}

/// Publishes the snapshot of `epoch`; `alone`: without a bad twin.
fn publish(out: &mut SnapshotOut, world: &MissionWorld, epoch: u64, period_s: f64, alone: bool) -> Result<(), Error> {
    let inst = world.snapshot();
    let mut res = Ok(());
    let mut good = |m: &mut WaypointSnapshot| {
        if let Err(e) = write_snapshot(&inst, epoch, m) {
            res = Err(e);
        }
        m.header.mission_time_s = epoch as f64 * period_s;
        m.next_update_s = (epoch + 1) as f64 * period_s;
    };
    if alone {
        out.publish_alone(&mut good)?;
    } else {
        out.publish(&mut good)?;
    }
    Ok(res?)
}

fn run(args: &Args) -> Result<Outcome, Error> {
    let faults = FaultCycle::parse_opt("--inject", args.inject.as_deref(), &SENSOR_FAULTS)?;
    signal::install();
    let mut world = load_world(&args.scenario)?;
    let period = args.sensor_period_s.unwrap_or(world.sensor_period_s());
    if !(period.is_finite() && period > 0.0) {
        return Err(Error::BadPeriod(period));
    }
    let fingerprint = world.fingerprint();
    let rules = Arc::new(WireRules::new(&world));
    if faults.iter().any(|f| f == Fault::OffWater) && rules.land_point().is_none() {
        return Err(Error::NoLand);
    }
    let opts = args.ipc.options()?;
    let ctx = IpcContext::<Shm>::new(&opts, "sensor-sim")?;
    let bad = BadSnapshot {
        rules: rules.clone(),
        period_s: period,
    };
    let out_box = ctx.snapshot_outbox(Stamp::new(fingerprint), world.world().n())?;
    let mut out = FaultyOutbox::new(out_box, faults, bad);
    let mut states =
        Guarded::new(ctx.inbox::<VehicleState>()?, fingerprint, "sensor-sim").with_check(rules.state_check());
    let mut waker = ctx.waker(Role::Sensor)?;
    if let Some(wait_s) = args.resume_wait_s
        && !(wait_s.is_finite() && (0.0..=3600.0).contains(&wait_s))
    {
        return Err(Error::BadResumeWait(wait_s));
    }
    let outcome = serve(
        &mut world,
        &mut out,
        &mut states,
        &mut waker,
        period,
        args.resume_wait_s,
    );
    let r = states.rejected();
    if r.total() > 0 {
        eprintln!(
            "sensor-sim: rejected {} vehicle state message(s) in all: {r}",
            r.total()
        );
    }
    outcome
}

#[allow(clippy::too_many_arguments)]
fn serve(
    world: &mut MissionWorld,
    out: &mut SnapshotOut,
    states: &mut Guarded<VehicleState, IpcInbox<Shm, VehicleState>>,
    waker: &mut IpcWaker<Shm>,
    period: f64,
    resume_wait_s: Option<f64>,
) -> Result<Outcome, Error> {
    let mut epoch = 0u64;
    let mut clock: Option<VehicleClock> = None;
    let mut outcome = Outcome::Running;
    if let Some(wait_s) = resume_wait_s {
        // Restarted: the vehicle's state history reaches us when it next publishes.
        let t0 = mono_now_ns();
        while clock.is_none() && (mono_now_ns() - t0) as f64 * 1e-9 < wait_s {
            states.drain(&mut |s| {
                clock = Some(VehicleClock {
                    mission_time_s: s.header.mission_time_s,
                    sent_mono_ns: s.header.sent_mono_ns,
                    time_scale: s.time_scale,
                });
            })?;
            if clock.is_none() && waker.wait(Duration::from_millis(20))? == Wake::Shutdown {
                return Ok(Outcome::Aborted);
            }
        }
        if let Some(c) = clock {
            epoch = (c.at(mono_now_ns()) / period).floor().max(0.0) as u64;
            if epoch > 0 {
                world.redraw(epoch);
            }
            eprintln!("sensor-sim: resumed at epoch {epoch}");
        }
    }
    // The first snapshot always goes out clean: a receiver that joins late
    // gets only the latest sample, and it must be a good one to start on.
    publish(out, world, epoch, period, true)?;
    loop {
        states.drain(&mut |s| {
            clock = Some(VehicleClock {
                mission_time_s: s.header.mission_time_s,
                sent_mono_ns: s.header.sent_mono_ns,
                time_scale: s.time_scale,
            });
            if let Some(o) = auv_messages::msg::FromCode::from_code(s.outcome) {
                outcome = o;
            }
        })?;
        if outcome != Outcome::Running {
            return Ok(outcome);
        }
        let now = mono_now_ns();
        let t = clock.map_or(0.0, |c| c.at(now));
        while t >= (epoch + 1) as f64 * period {
            epoch += 1;
            world.redraw(epoch);
            publish(out, world, epoch, period, false)?;
        }
        let wait = match clock {
            Some(c) if c.time_scale > 0.0 => {
                let to_next = ((epoch + 1) as f64 * period - t) / c.time_scale;
                Duration::from_secs_f64(to_next.clamp(0.0, 0.05))
            }
            _ => Duration::from_millis(50),
        };
        match waker.wait(wait)? {
            Wake::Shutdown => return Ok(Outcome::Aborted),
            Wake::Timeout => out.refresh(),
            Wake::Woken(_) => {}
        }
    }
}

fn main() -> ExitCode {
    let args = match Args::try_parse() {
        Ok(a) => a,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    match run(&args) {
        Ok(Outcome::Aborted) => ExitCode::from(130),
        Ok(_) => ExitCode::SUCCESS,
        Err(e @ (Error::BadPeriod(_) | Error::BadResumeWait(_) | Error::BadFaults(_) | Error::NoLand)) => {
            eprintln!("sensor-sim: error: {e}");
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("sensor-sim: error: {e}");
            ExitCode::from(1)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clock_follows_the_vehicle_exactly_in_lockstep_and_extrapolates_otherwise() {
        let lock = VehicleClock {
            mission_time_s: 120.0,
            sent_mono_ns: 1_000,
            time_scale: 0.0,
        };
        assert_eq!(lock.at(9_000_000_000), 120.0);
        let scaled = VehicleClock {
            mission_time_s: 120.0,
            sent_mono_ns: 1_000_000_000,
            time_scale: 1000.0,
        };
        assert_eq!(scaled.at(1_010_000_000), 130.0);
        assert_eq!(scaled.at(0), 120.0, "a clock never runs backwards");
    }
}
