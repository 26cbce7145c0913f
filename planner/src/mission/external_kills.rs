//! Kills from outside the supervisor, the way an operator or the OOM killer
//! would: SIGKILL to a mission's child at a chosen wall time, by the pid the
//! supervisor publishes in `<out>/pids.json`. The supervisor is not told;
//! it must notice and recover on its own.
//!
//! Contract: the kills are drawn from a seed ([`plan_external_kills`]); a
//! kill is sent only to a process whose parent is the supervisor named in
//! `pids.json` (a pid the supervisor no longer owns, or a child that is
//! down at that moment, is a *miss*, counted, never a stray signal).

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use super::child::parent_of;
use super::supervise::Proc;
use auv_core::rng::PlannerRng;

/// One kill: when (real time after the mission started) and whom.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExternalKill {
    /// Real time after the start of the mission.
    pub after: Duration,
    /// The target.
    pub target: Proc,
}

/// `n` kills at random times in [10 %, 60 %] of `expected_wall` (the
/// mission's budget at its time scale; missions often end earlier), in time
/// order, targets uniform over the three processes.
pub fn plan_external_kills(seed: u64, n: usize, expected_wall: Duration) -> Vec<ExternalKill> {
    let mut rng = PlannerRng::new(seed ^ 0x0E47_E41A_0E47_E41A);
    let mut v: Vec<ExternalKill> = (0..n)
        .map(|_| ExternalKill {
            after: expected_wall.mul_f64(0.10 + 0.50 * rng.next_f64()),
            target: Proc::ALL[rng.below(3) as usize],
        })
        .collect();
    v.sort_by_key(|k| k.after);
    v
}

/// Kills sent and missed, by process ([`Proc`] order).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KillTally {
    /// SIGKILLs delivered.
    pub sent: [u64; 3],
    /// Kills whose target was not running as the supervisor's child then.
    pub missed: [u64; 3],
}

/// The pid of `target` in `<out>/pids.json` if it is a live child of the
/// supervisor the file names.
fn child_pid(out: &Path, target: Proc) -> Option<u32> {
    let text = std::fs::read_to_string(out.join("pids.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    let supervisor = u32::try_from(v["supervisor"].as_u64()?).ok()?;
    let pid = u32::try_from(v[target.name()].as_u64()?).ok()?;
    (parent_of(pid) == Some(supervisor)).then_some(pid)
}

/// Sends `kills` to the mission writing into `out`, timed from now, until
/// done or `stop` is set.
pub fn run_kills(out: &Path, kills: &[ExternalKill], stop: &AtomicBool) -> KillTally {
    let t0 = Instant::now();
    let mut tally = KillTally::default();
    for k in kills {
        while t0.elapsed() < k.after {
            if stop.load(Ordering::Relaxed) {
                return tally;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        match child_pid(out, k.target) {
            Some(pid) => {
                // SAFETY: a signal to a pid just checked to be the mission
                // supervisor's child.
                unsafe { libc::kill(pid as libc::pid_t, libc::SIGKILL) };
                tally.sent[k.target as usize] += 1;
            }
            None => tally.missed[k.target as usize] += 1,
        }
    }
    tally
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kills_are_drawn_from_the_seed_in_time_order_within_the_window() {
        let wall = Duration::from_secs(10);
        let a = plan_external_kills(4, 30, wall);
        assert_eq!(a, plan_external_kills(4, 30, wall));
        assert_ne!(a, plan_external_kills(5, 30, wall));
        assert!(a.windows(2).all(|w| w[0].after <= w[1].after));
        assert!(a.iter().all(|k| (1.0..=6.0).contains(&k.after.as_secs_f64())));
        for p in Proc::ALL {
            assert!(a.iter().any(|k| k.target == p), "{p:?} never drawn");
        }
    }

    #[test]
    fn a_pid_that_is_not_the_supervisors_child_is_a_miss() {
        let dir = std::env::temp_dir().join(auv_transport::unique_prefix("ek"));
        std::fs::create_dir_all(&dir).unwrap();
        // pid 1 (init) is no child of this process.
        std::fs::write(
            dir.join("pids.json"),
            format!(
                r#"{{"supervisor": {}, "planner": 1, "sensor-sim": null}}"#,
                std::process::id()
            ),
        )
        .unwrap();
        let kills = [
            ExternalKill {
                after: Duration::ZERO,
                target: Proc::Planner,
            },
            ExternalKill {
                after: Duration::ZERO,
                target: Proc::Sensor,
            },
        ];
        let t = run_kills(&dir, &kills, &AtomicBool::new(false));
        assert_eq!(t.sent, [0; 3]);
        assert_eq!(t.missed, [1, 1, 0]);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
