//! The time a vehicle loses chasing a drifting waypoint.
//!
//! A dynamic waypoint is redrawn around its nominal position every sensor
//! period (independent truncated-normal draws, σ = 150 m per axis by
//! default), and the vehicle heads for its *latest reported* position. At
//! 1.5 m/s it covers 90 m per 60 s period while the target jumps ~200 m, so
//! it often arrives only when a draw lands within reach: measured on 30
//! lockstep missions, an arrival at a dynamic waypoint took a median 495 s
//! (mean 742 s) longer than the straight line, against 23 s for a static one.
//! A planner that ignores this commits to routes it cannot finish.
//!
//! [`World::arrival_allowance_s`] estimates that expected excess per dynamic
//! waypoint by simulating the chase itself (same draws as the sensor, same
//! speed and period), seeded from the scenario so it is deterministic.

use super::{World, sub_stream};
use crate::chart::WaterMap;
use auv_core::instance::distance_3d_m as dist;

/// Stream of the chase simulations (one sub-stream per waypoint).
pub const STREAM_CHASE: u64 = 0x5CE7_0007;

/// Simulated approaches per waypoint (our choice: the mean's standard error
/// is then about 6 % of the mean).
pub const CHASE_TRIALS: u32 = 256;

/// Distance from which a simulated approach starts, m (our choice: about
/// one edge of the default 40-node network).
pub const APPROACH_M: f64 = 1_500.0;

/// Periods after which a simulated chase is cut (its time is then counted
/// as is: the estimate stays finite on pathological charts).
const MAX_PERIODS: u32 = 10_000;

impl World {
    /// Expected extra time, s, to reach waypoint `i` over the straight-line
    /// time to where it was when the approach began: 0 for a static waypoint.
    pub fn arrival_allowance_s(&self, i: usize, map: &impl WaterMap) -> f64 {
        let (v, period) = (self.config.speed_mps, self.config.sensor_period_s);
        if !(self.is_dynamic(i) && v > 0.0 && period > 0.0) {
            return 0.0;
        }
        let mut rng = sub_stream(self.seed, STREAM_CHASE, i as u64);
        let mut total = 0.0;
        for _ in 0..CHASE_TRIALS {
            let heading = rng.uniform(0.0, core::f64::consts::TAU);
            let nom = self.nominal[i];
            let mut pos = [
                nom.x + APPROACH_M * heading.cos(),
                nom.y + APPROACH_M * heading.sin(),
                nom.z,
            ];
            let first = self.draw_dynamic(i, &mut rng, map).0;
            let mut target = [first.x, first.y, first.z];
            let direct_s = dist(pos, target) / v;
            // The sensor's phase when the approach begins is uniform.
            let mut window = rng.uniform(0.0, period);
            let mut t = 0.0;
            for _ in 0..MAX_PERIODS {
                let d = dist(pos, target);
                if d <= v * window {
                    t += d / v;
                    break;
                }
                let f = v * window / d;
                for (p, q) in pos.iter_mut().zip(target) {
                    *p += (q - *p) * f;
                }
                t += window;
                window = period;
                let p = self.draw_dynamic(i, &mut rng, map).0;
                target = [p.x, p.y, p.z];
            }
            total += (t - direct_s).max(0.0);
        }
        total / f64::from(CHASE_TRIALS)
    }

    /// [`Self::arrival_allowance_s`] of every waypoint, indexed by node id
    /// (n entries).
    pub fn arrival_allowances_s(&self, map: &impl WaterMap) -> Vec<f64> {
        let mut out = vec![0.0; self.n()];
        for i in self.dynamic.iter() {
            out[i] = self.arrival_allowance_s(i, map);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use crate::scenario::ScenarioConfig;
    use crate::scenario::World;
    use crate::scenario::synthetic::IslandMap;

    fn open_water() -> IslandMap {
        IslandMap::new(5_000.0, 10_000.0, Vec::new())
    }

    fn world(sigma_m: f64) -> World {
        let cfg = ScenarioConfig {
            sigma_m,
            ..ScenarioConfig::default()
        };
        World::generate(&cfg, 7, &open_water()).unwrap()
    }

    #[test]
    fn static_waypoints_cost_nothing_and_drifting_ones_cost_time() {
        let w = world(150.0);
        let map = open_water();
        let a = w.arrival_allowances_s(&map);
        for (i, &ai) in a.iter().enumerate().take(w.n()) {
            if w.is_dynamic(i) {
                assert!(ai > 30.0, "node {i}: {ai}");
            } else {
                assert_eq!(ai, 0.0);
            }
        }
        // Deterministic per scenario.
        assert_eq!(a, w.arrival_allowances_s(&map));
    }

    #[test]
    fn more_drift_costs_more_time() {
        let map = open_water();
        let mean = |w: &World| {
            let a = w.arrival_allowances_s(&map);
            w.dynamic_nodes().iter().map(|i| a[i]).sum::<f64>() / f64::from(w.dynamic_nodes().len())
        };
        assert!(mean(&world(300.0)) > mean(&world(50.0)) + 50.0);
    }
}
