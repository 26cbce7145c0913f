//! Charts: a coastline image clustered into navigable water and forbidden
//! zones, and the geometric queries the world model asks of it.
//!
//! Frame: x east, y north, metres, origin at the chart's south-west corner.
//! Pixel (col, row) covers x ∈ [col·m, (col+1)·m), y ∈ [(H−1−row)·m, (H−row)·m)
//! (row 0 is the northern edge), as `shared/maps/README.md` defines.

/// What the world model needs from a chart: its extent and where water is.
/// The seam between the chart (image processing) and the scenario generator.
pub trait WaterMap {
    /// East-west extent, m.
    fn width_m(&self) -> f64;
    /// North-south extent, m.
    fn height_m(&self) -> f64;
    /// Whether the point (x east, y north) lies over navigable water. Points
    /// outside the chart are not water.
    fn is_water(&self, x: f64, y: f64) -> bool;
    /// Whether the straight segment from `a` to `b` (x, y in m) stays over
    /// water: every raster cell the segment crosses is water, not only its ends.
    fn segment_over_water(&self, a: (f64, f64), b: (f64, f64)) -> bool;
}
