//! A stable 64-bit fingerprint of a scenario: FNV-1a over a canonical byte
//! encoding of the configuration, the seed and the chart's identity.
//!
//! Contract: the same inputs give the same value on every platform, build and
//! run (no random keys, no `usize`, no `std::hash::Hash` impls whose byte
//! layout is unspecified); any change of a field, the seed or the chart gives
//! a different value except with probability ~2⁻⁶⁴. It identifies, it does
//! not authenticate. Processes started on different scenarios compare it to
//! refuse each other's messages.
//!
//! Reference: G. Fowler, L. C. Noll, K.-P. Vo, D. Eastlake, "The FNV
//! Non-Cryptographic Hash Algorithm", IETF draft-eastlake-fnv.

use super::config::{ChartSource, ScenarioConfig, UniformRange};
use crate::chart::WaterMap;
use auv_core::instance::Objective;

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

/// Side of the grid of points at which the chart's water is sampled for its
/// identity (our choice: 128² = 16 384 queries, well under a millisecond, and
/// enough to tell any two real charts apart).
pub const CHART_SAMPLE_GRID: usize = 128;

/// Versions the encoding below: bump it when the encoding changes.
const TAG: &[u8] = b"auv-scenario-fingerprint/1";

/// Incremental FNV-1a (64-bit).
#[derive(Clone, Copy, Debug)]
pub struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Self::new()
    }
}

impl Fnv1a {
    /// The FNV offset basis.
    pub const fn new() -> Self {
        Self(FNV_OFFSET)
    }

    /// Mixes in raw bytes.
    pub fn bytes(&mut self, bytes: &[u8]) -> &mut Self {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(FNV_PRIME);
        }
        self
    }

    /// Mixes in a `u64`, little-endian.
    pub fn u64(&mut self, v: u64) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }

    /// Mixes in an `f64` by its bit pattern.
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.u64(v.to_bits())
    }

    /// Mixes in a string, length first so that concatenations differ.
    pub fn str(&mut self, s: &str) -> &mut Self {
        self.u64(s.len() as u64).bytes(s.as_bytes())
    }

    /// The hash so far.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// FNV-1a of a byte string.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    Fnv1a::new().bytes(bytes).finish()
}

/// Fingerprint of (`config`, `seed`, `map`). Each field is preceded by its
/// name so that a value moving between fields changes the hash.
pub fn scenario_fingerprint(config: &ScenarioConfig, seed: u64, map: &impl WaterMap) -> u64 {
    let mut h = Fnv1a::new();
    h.bytes(TAG);
    h.str("seed").u64(seed);
    let range = |h: &mut Fnv1a, name: &str, r: UniformRange| {
        h.str(name).f64(r.lo).f64(r.hi);
    };
    h.str("nodes").u64(config.nodes as u64);
    h.str("dynamic").u64(config.dynamic as u64);
    h.str("sigma_m").f64(config.sigma_m);
    h.str("bound_sigma_m").f64(config.bound_sigma_m);
    h.str("depth_max_m").f64(config.depth_max_m);
    h.str("speed_mps").f64(config.speed_mps);
    h.str("time_available_s").f64(config.time_available_s);
    range(&mut h, "priority", config.priority);
    range(&mut h, "risk", config.risk);
    range(&mut h, "task_time_s", config.task_time_s);
    match config.objective {
        Objective::MaxWeight => h.str("objective").str("max_weight"),
        Objective::PaperCost { phi1, phi2 } => h.str("objective").str("paper_cost").f64(phi1).f64(phi2),
    };
    match &config.chart {
        ChartSource::Embedded(name) => h.str("chart").str("embedded").str(name),
        ChartSource::Png { path, metres_per_pixel } => h
            .str("chart")
            .str("png")
            .str(&path.to_string_lossy())
            .f64(*metres_per_pixel),
        ChartSource::LandGeojson { path, extent_m } => h
            .str("chart")
            .str("land_geojson")
            .str(&path.to_string_lossy())
            .f64(extent_m[0])
            .f64(extent_m[1]),
    };
    h.str("k").u64(config.k as u64);
    h.str("sensor_period_s").f64(config.sensor_period_s);
    h.str("position_attempts").u64(u64::from(config.position_attempts));
    h.str("redraw_attempts").u64(u64::from(config.redraw_attempts));
    // The chart itself: its extent and where its water is, so that a chart
    // file edited under the same path still changes the fingerprint.
    let (w, ht) = (map.width_m(), map.height_m());
    h.str("extent").f64(w).f64(ht);
    h.str("water");
    let g = CHART_SAMPLE_GRID;
    for row in 0..g {
        let mut bits = [0u8; CHART_SAMPLE_GRID / 8];
        for col in 0..g {
            let x = (col as f64 + 0.5) / g as f64 * w;
            let y = (row as f64 + 0.5) / g as f64 * ht;
            if map.is_water(x, y) {
                bits[col / 8] |= 1 << (col % 8);
            }
        }
        h.bytes(&bits);
    }
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_published_fnv1a_test_vectors() {
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn strings_are_length_prefixed() {
        let ab_c = Fnv1a::new().str("ab").str("c").finish();
        let a_bc = Fnv1a::new().str("a").str("bc").finish();
        assert_ne!(ab_c, a_bc);
    }
}
