//! The navigable-water raster and the geometric queries on it.
//!
//! Contract: a [`WaterMask`] is a byte raster (one `bool` per chart pixel,
//! row 0 north, as the image) plus the pixel size in metres, and implements
//! [`WaterMap`] in the frame `chart/mod.rs` fixes: pixel (col, row) covers
//! x ∈ [col·m, (col+1)·m), y ∈ [(H−1−row)·m, (H−row)·m).
//!
//! - [`WaterMap::is_water`] uses those half-open cells: every point of the
//!   chart lies in exactly one cell; points outside the chart (or NaN) are
//!   not water.
//! - [`WaterMap::segment_over_water`] is deliberately *conservative*: both
//!   ends must lie inside the chart, and every cell whose **closed** square
//!   the segment touches must be water. So a segment may not slip between two
//!   land cells that meet only at a corner, nor run along an edge of a land
//!   cell; a segment that ends exactly on a cell border also tests the cell
//!   beyond it. (Consequence: `segment_over_water(p, p)` equals `is_water(p)`
//!   except for a point exactly on a border with land, where it is false.)
//!   Cells are found by a closed supercover traversal, column by column: for
//!   each raster column the segment's x-range reaches, clip the segment to
//!   that column and visit every row its y-range there reaches. Every touched
//!   cell is visited once, in O(cells touched); borders are widened by
//!   [`TOUCH_EPS`] cells so an exact corner or border contact counts as a
//!   touch whatever the floating-point rounding of the crossing point.
//!   Chosen over Amanatides–Woo stepping because the column form has no
//!   special cases for corner crossings or segments along grid lines.

use super::image::decode_png;
use super::{ChartError, WaterMap, validate_scale};

/// Tolerance, in cells, within which a segment counts as touching a cell
/// border (1e-9 cell = 10 nm at 10 m/px: far below any chart's accuracy,
/// far above f64 rounding on rasters up to millions of cells).
pub const TOUCH_EPS: f64 = 1e-9;

/// Where a chart is navigable: one flag per pixel plus the pixel size.
#[derive(Clone, Debug, PartialEq)]
pub struct WaterMask {
    width: usize,
    height: usize,
    metres_per_pixel: f64,
    water: Vec<bool>,
}

impl WaterMask {
    /// A mask from its flags (row-major, row 0 north, `width * height` of them)
    /// and its pixel size in m.
    pub fn new(width: usize, height: usize, metres_per_pixel: f64, water: Vec<bool>) -> Result<Self, ChartError> {
        validate_scale(metres_per_pixel)?;
        if width == 0 || height == 0 || width.checked_mul(height) != Some(water.len()) {
            return Err(ChartError::MaskSize {
                width,
                height,
                cells: water.len(),
            });
        }
        Ok(Self {
            width,
            height,
            metres_per_pixel,
            water,
        })
    }

    /// A mask whose flag at (col, row) is `f(col, row)`.
    pub fn from_fn(
        width: usize,
        height: usize,
        metres_per_pixel: f64,
        mut f: impl FnMut(usize, usize) -> bool,
    ) -> Result<Self, ChartError> {
        let water = (0..height.saturating_mul(width))
            .map(|i| f(i % width, i / width))
            .collect();
        Self::new(width, height, metres_per_pixel, water)
    }

    /// Reads a truth mask PNG: white (luma ≥ 128) is water, black is land.
    /// `what` names the source in errors. A mask with no water is an error.
    pub fn from_mask_png(bytes: &[u8], metres_per_pixel: f64, what: &str) -> Result<Self, ChartError> {
        validate_scale(metres_per_pixel)?;
        let img = decode_png(bytes).map_err(|source| ChartError::Image {
            what: what.to_owned(),
            source,
        })?;
        let water = img
            .pixels()
            .iter()
            .map(|&[r, g, b]| 299 * u32::from(r) + 587 * u32::from(g) + 114 * u32::from(b) >= 128_000)
            .collect();
        let mask = Self::new(img.width(), img.height(), metres_per_pixel, water)?;
        if mask.water_cells() == 0 {
            return Err(ChartError::NoWater { what: what.to_owned() });
        }
        Ok(mask)
    }

    /// Width, px (columns, west to east).
    pub fn width_px(&self) -> usize {
        self.width
    }

    /// Height, px (rows, north to south).
    pub fn height_px(&self) -> usize {
        self.height
    }

    /// Pixel size, m.
    pub fn metres_per_pixel(&self) -> f64 {
        self.metres_per_pixel
    }

    /// The flags, row-major from the north-west corner.
    pub fn cells(&self) -> &[bool] {
        &self.water
    }

    /// Whether pixel (col, row) is water; false outside the raster.
    #[inline]
    pub fn is_water_cell(&self, col: usize, row: usize) -> bool {
        col < self.width && row < self.height && self.water[row * self.width + col]
    }

    /// The pixel (col, row) holding point (x east, y north) in m, or `None`
    /// outside the chart.
    pub fn cell_at(&self, x: f64, y: f64) -> Option<(usize, usize)> {
        // Written so NaN fails every comparison and falls out as None.
        if !(x >= 0.0 && y >= 0.0 && x < self.width_m() && y < self.height_m()) {
            return None;
        }
        // `min` guards the last cell against x/m rounding up to W.
        let col = ((x / self.metres_per_pixel) as usize).min(self.width - 1);
        let j = ((y / self.metres_per_pixel) as usize).min(self.height - 1);
        Some((col, self.height - 1 - j))
    }

    /// Number of water pixels.
    pub fn water_cells(&self) -> usize {
        self.water.iter().filter(|&&w| w).count()
    }

    /// Share of the chart that is water, in [0, 1].
    pub fn water_fraction(&self) -> f64 {
        self.water_cells() as f64 / self.water.len() as f64
    }

    /// Intersection over union of the water of `self` and `other`, in [0, 1]
    /// (1 when neither has water). The two must have the same raster size.
    pub fn iou(&self, other: &WaterMask) -> Result<f64, ChartError> {
        if (self.width, self.height) != (other.width, other.height) {
            return Err(ChartError::SizeMismatch {
                left: (self.width, self.height),
                right: (other.width, other.height),
            });
        }
        let (mut inter, mut union) = (0usize, 0usize);
        for (&a, &b) in self.water.iter().zip(&other.water) {
            inter += usize::from(a && b);
            union += usize::from(a || b);
        }
        Ok(if union == 0 { 1.0 } else { inter as f64 / union as f64 })
    }

    /// Calls `visit(col, row)` for every cell whose closed square the segment
    /// a–b touches (see the module contract), stopping early when `visit`
    /// returns false. Returns false if it stopped early or an end lies
    /// outside the chart, true otherwise.
    pub fn for_each_touched_cell(
        &self,
        a: (f64, f64),
        b: (f64, f64),
        mut visit: impl FnMut(usize, usize) -> bool,
    ) -> bool {
        if self.cell_at(a.0, a.1).is_none() || self.cell_at(b.0, b.1).is_none() {
            return false;
        }
        let m = self.metres_per_pixel;
        // Grid units: u east, v north, one unit per cell; row j counts from
        // the south (raster row = H − 1 − j).
        let (mut p0, mut p1) = ((a.0 / m, a.1 / m), (b.0 / m, b.1 / m));
        if p1.0 < p0.0 {
            std::mem::swap(&mut p0, &mut p1);
        }
        let ((u0, v0), (u1, v1)) = (p0, p1);
        let last_col = (self.width - 1) as f64;
        let last_row = (self.height - 1) as f64;
        // Closed cell [i, i+1] meets [lo, hi] iff ceil(lo) − 1 ≤ i ≤ floor(hi).
        let range = |lo: f64, hi: f64, last: f64| {
            let first = ((lo - TOUCH_EPS).ceil() - 1.0).max(0.0);
            let end = (hi + TOUCH_EPS).floor().min(last);
            (first as usize, end as usize)
        };
        let (i_first, i_last) = range(u0, u1, last_col);
        let du = u1 - u0;
        for i in i_first..=i_last {
            // The part of the segment within column i (or, for a column only
            // within TOUCH_EPS, its nearest point).
            let ul = (i as f64).clamp(u0, u1);
            let ur = (i as f64 + 1.0).clamp(u0, u1);
            let (va, vb) = if du > 0.0 {
                // Interpolate by the fraction t ∈ [0, 1], never by a slope,
                // which overflows for near-vertical segments.
                let dv = v1 - v0;
                (v0 + dv * ((ul - u0) / du), v0 + dv * ((ur - u0) / du))
            } else {
                (v0, v1)
            };
            let (j_first, j_last) = range(va.min(vb), va.max(vb), last_row);
            for j in j_first..=j_last {
                if !visit(i, self.height - 1 - j) {
                    return false;
                }
            }
        }
        true
    }
}

impl WaterMap for WaterMask {
    fn width_m(&self) -> f64 {
        self.width as f64 * self.metres_per_pixel
    }

    fn height_m(&self) -> f64 {
        self.height as f64 * self.metres_per_pixel
    }

    fn is_water(&self, x: f64, y: f64) -> bool {
        self.cell_at(x, y)
            .is_some_and(|(col, row)| self.water[row * self.width + col])
    }

    fn segment_over_water(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        self.for_each_touched_cell(a, b, |col, row| self.water[row * self.width + col])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_core::rng::PlannerRng;
    use std::collections::BTreeSet;

    /// A mask drawn as text, north row first: `.` water, `#` land; 10 m/px.
    fn mask(rows: &[&str]) -> WaterMask {
        let h = rows.len();
        let w = rows[0].len();
        WaterMask::from_fn(w, h, 10.0, |c, r| rows[r].as_bytes()[c] == b'.').unwrap()
    }

    /// Centre (m) of the cell (col, j) with j counted from the south.
    fn centre(col: usize, j: usize) -> (f64, f64) {
        (col as f64 * 10.0 + 5.0, j as f64 * 10.0 + 5.0)
    }

    #[test]
    fn pixel_frame_follows_the_chart_convention() {
        // Row 0 is north: the land pixel at raster (col 1, row 0) holds the
        // points with x in [10, 20), y in [(3−1−0)·10, 3·10) = [20, 30).
        let m = mask(&[".#..", "....", "...."]);
        assert_eq!((m.width_m(), m.height_m()), (40.0, 30.0));
        assert!(!m.is_water(10.0, 20.0));
        assert!(!m.is_water(19.999, 29.999));
        assert!(m.is_water(20.0, 25.0), "x = 20 is the next column");
        assert!(m.is_water(15.0, 19.999), "y < 20 is the next row south");
        assert_eq!(m.cell_at(10.0, 20.0), Some((1, 0)));
        assert_eq!(m.cell_at(0.0, 0.0), Some((0, 2)));
    }

    #[test]
    fn outside_and_nan_are_not_water() {
        let m = mask(&["..", ".."]);
        for (x, y) in [
            (-0.001, 5.0),
            (5.0, -0.001),
            (20.0, 5.0),
            (5.0, 20.0),
            (f64::NAN, 5.0),
            (5.0, f64::INFINITY),
        ] {
            assert!(!m.is_water(x, y), "({x}, {y})");
        }
        assert!(m.is_water(0.0, 0.0));
        assert!(m.is_water(19.999_999, 19.999_999));
    }

    #[test]
    fn diagonal_through_a_land_corner_is_blocked() {
        // Land at the NE and SW of the shared corner (10, 10); water at NW
        // and SE. Both diagonals through the corner touch a land cell.
        let m = mask(&[".#", "#."]);
        assert!(
            !m.segment_over_water(centre(0, 1), centre(1, 0)),
            "NW to SE through the corner"
        );
        // Mirror image: water at SW and NE, land at NW and SE.
        let m = mask(&["#.", ".#"]);
        assert!(
            !m.segment_over_water(centre(0, 0), centre(1, 1)),
            "SW to NE through the corner"
        );
        // With one land cell at the corner, the diagonal through the corner
        // touches it; a parallel one passing 1 m south-east of it does not.
        let m = mask(&["#.", ".."]);
        assert!(
            !m.segment_over_water((5.0, 5.0), (15.0, 15.0)),
            "touches the land corner"
        );
        assert!(m.segment_over_water((6.0, 5.0), (15.0, 14.0)), "misses it");
        assert!(
            !m.segment_over_water((5.0, 5.0), (9.0, 19.0)),
            "enters the NW land cell"
        );
    }

    #[test]
    fn segment_along_a_border_tests_both_sides() {
        // North row land, south row water; the border is y = 10.
        let m = mask(&["####", "...."]);
        assert!(!m.segment_over_water((5.0, 10.0), (35.0, 10.0)), "runs along land");
        assert!(m.segment_over_water((5.0, 9.9), (35.0, 9.9)), "just south of it");
        // Vertical border x = 20 between a water and a land column.
        let m = mask(&["..##", "..##", "..##"]);
        assert!(!m.segment_over_water((20.0, 1.0), (20.0, 29.0)));
        assert!(m.segment_over_water((19.99, 1.0), (19.99, 29.0)));
        // A border between two water cells is no obstacle.
        let m = mask(&["....", "...."]);
        assert!(m.segment_over_water((0.0, 10.0), (39.9, 10.0)));
    }

    #[test]
    fn zero_length_segment_is_its_point() {
        let m = mask(&[".#", ".."]);
        assert!(m.segment_over_water((5.0, 5.0), (5.0, 5.0)));
        assert!(!m.segment_over_water((15.0, 15.0), (15.0, 15.0)));
        // On the border with the land cell: conservative.
        assert!(m.is_water(10.0 - 1e-6, 15.0));
        assert!(!m.segment_over_water((10.0, 15.0), (10.0, 15.0)));
    }

    #[test]
    fn segment_leaving_the_chart_is_rejected() {
        let m = mask(&["...", "..."]);
        assert!(!m.segment_over_water((5.0, 5.0), (35.0, 5.0)), "east end outside");
        assert!(!m.segment_over_water((-1.0, 5.0), (5.0, 5.0)), "west end outside");
        assert!(!m.segment_over_water((5.0, 5.0), (5.0, 20.0)), "north edge is outside");
        assert!(!m.segment_over_water((5.0, 5.0), (f64::NAN, 5.0)));
        assert!(
            m.segment_over_water((0.0, 0.0), (29.999, 19.999)),
            "corner to corner inside"
        );
    }

    #[test]
    fn a_single_land_cell_on_a_long_diagonal_is_found() {
        // 200 x 100 water with one land pixel right on the line between two
        // far corners: checking only the ends would miss it.
        let (w, h) = (200, 100);
        let land_col = 100;
        let land_row = h - 1 - 50;
        let m = WaterMask::from_fn(w, h, 10.0, |c, r| !(c == land_col && r == land_row)).unwrap();
        assert!(m.is_water(5.0, 5.0) && m.is_water(1995.0, 995.0));
        assert!(!m.segment_over_water((5.0, 5.0), (1995.0, 1005.0 - 10.0)));
        assert!(m.segment_over_water((5.0, 5.0), (1995.0, 5.0)));
    }

    /// Reference: cells whose closed square, widened by TOUCH_EPS, the
    /// segment meets (Liang–Barsky clipping against every cell).
    fn brute_force(m: &WaterMask, a: (f64, f64), b: (f64, f64)) -> BTreeSet<(usize, usize)> {
        let s = m.metres_per_pixel();
        let (ua, va, ub, vb) = (a.0 / s, a.1 / s, b.0 / s, b.1 / s);
        let mut out = BTreeSet::new();
        for i in 0..m.width_px() {
            for j in 0..m.height_px() {
                let e = TOUCH_EPS * 0.5;
                let (xl, xh, yl, yh) = (i as f64 - e, i as f64 + 1.0 + e, j as f64 - e, j as f64 + 1.0 + e);
                let (mut t0, mut t1) = (0.0f64, 1.0f64);
                let mut ok = true;
                for (p, q) in [
                    (-(ub - ua), ua - xl),
                    (ub - ua, xh - ua),
                    (-(vb - va), va - yl),
                    (vb - va, yh - va),
                ] {
                    if p == 0.0 {
                        if q < 0.0 {
                            ok = false;
                        }
                    } else {
                        let r = q / p;
                        if p < 0.0 {
                            t0 = t0.max(r);
                        } else {
                            t1 = t1.min(r);
                        }
                    }
                }
                if ok && t0 <= t1 {
                    out.insert((i, m.height_px() - 1 - j));
                }
            }
        }
        out
    }

    #[test]
    fn traversal_matches_brute_force_on_random_and_grid_aligned_segments() {
        let m = WaterMask::from_fn(13, 9, 10.0, |_, _| true).unwrap();
        let mut rng = PlannerRng::new(77);
        for trial in 0..3000 {
            // Half the trials on a half-cell lattice: corners, borders,
            // axis-parallel and exact diagonals.
            let mut coord = |extent: f64| {
                if trial % 2 == 0 {
                    rng.uniform(0.0, extent)
                } else {
                    (rng.below((extent / 5.0) as u32) as f64) * 5.0
                }
            };
            let a = (coord(130.0), coord(90.0));
            let b = (coord(130.0), coord(90.0));
            let mut seen = BTreeSet::new();
            let mut dup = false;
            assert!(m.for_each_touched_cell(a, b, |c, r| {
                dup |= !seen.insert((c, r));
                true
            }));
            assert!(!dup, "{a:?} {b:?} visited a cell twice");
            assert_eq!(seen, brute_force(&m, a, b), "{a:?} -> {b:?}");
            // Direction does not matter.
            let mut back = BTreeSet::new();
            m.for_each_touched_cell(b, a, |c, r| {
                back.insert((c, r));
                true
            });
            assert_eq!(seen, back);
        }
    }

    #[test]
    fn truth_mask_png_loads_and_iou_counts() {
        use crate::chart::image::tests::encode;
        // 4 x 2, 1-bit: row 0 = 1100, row 1 = 1111 (white = water).
        let png = encode(
            4,
            2,
            png::ColorType::Grayscale,
            png::BitDepth::One,
            None,
            None,
            &[0b1100_0000, 0b1111_0000],
        );
        let a = WaterMask::from_mask_png(&png, 5.0, "test mask").unwrap();
        assert_eq!(a.cells(), &[true, true, false, false, true, true, true, true]);
        assert_eq!(a.water_cells(), 6);
        assert!((a.water_fraction() - 0.75).abs() < 1e-12);
        let b = WaterMask::from_fn(4, 2, 5.0, |c, _| c < 2).unwrap();
        // Intersection 4, union 6.
        assert!((a.iou(&b).unwrap() - 4.0 / 6.0).abs() < 1e-12);
        assert_eq!(a.iou(&a).unwrap(), 1.0);
        let other = WaterMask::from_fn(2, 4, 5.0, |_, _| true).unwrap();
        assert!(matches!(a.iou(&other), Err(ChartError::SizeMismatch { .. })));
        let dry = WaterMask::from_fn(4, 2, 5.0, |_, _| false).unwrap();
        assert_eq!(dry.iou(&dry).unwrap(), 1.0);
        assert_eq!(dry.iou(&a).unwrap(), 0.0);
    }

    #[test]
    fn all_black_mask_png_is_a_no_water_error() {
        use crate::chart::image::tests::encode;
        let png = encode(
            2,
            2,
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            None,
            None,
            &[0, 0, 0, 0],
        );
        let err = WaterMask::from_mask_png(&png, 5.0, "mask `dry.png`").unwrap_err();
        assert!(matches!(err, ChartError::NoWater { .. }));
        assert!(err.to_string().contains("dry.png"), "{err}");
    }

    #[test]
    fn bad_construction_is_an_error() {
        assert!(matches!(
            WaterMask::new(2, 2, 10.0, vec![true; 3]),
            Err(ChartError::MaskSize { .. })
        ));
        assert!(matches!(
            WaterMask::new(0, 0, 10.0, vec![]),
            Err(ChartError::MaskSize { .. })
        ));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                WaterMask::new(1, 1, bad, vec![true]),
                Err(ChartError::BadScale { .. })
            ));
        }
    }
}
