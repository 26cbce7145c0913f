//! Small synthetic charts for tests, benches and examples, so that code above
//! the chart layer can be exercised without decoding a PNG.
//!
//! - [`IslandMap`]: a rectangle of water with rectangular islands, answered
//!   analytically (exact segment–rectangle clipping).
//! - [`GridMap`]: a raster in the chart frame of `chart/mod.rs` (row 0 the
//!   northern edge), whose segment test walks every cell the segment crosses,
//!   the way the real chart does; [`GridMap::cove`] is a Benoit's-Cove-sized
//!   stand-in (5 km × 10 km at 10 m per cell) with a wavy coast and islands.

use crate::chart::WaterMap;

/// A closed axis-aligned rectangle [x0, x1] × [y0, y1] of land, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    /// West edge, m.
    pub x0: f64,
    /// South edge, m.
    pub y0: f64,
    /// East edge, m.
    pub x1: f64,
    /// North edge, m.
    pub y1: f64,
}

impl Rect {
    fn contains(&self, x: f64, y: f64) -> bool {
        self.x0 <= x && x <= self.x1 && self.y0 <= y && y <= self.y1
    }

    /// Whether the segment a→b meets the closed rectangle (Liang–Barsky).
    fn meets_segment(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (p, d, lo, hi) in [(a.0, b.0 - a.0, self.x0, self.x1), (a.1, b.1 - a.1, self.y0, self.y1)] {
            if d == 0.0 {
                if p < lo || p > hi {
                    return false;
                }
            } else {
                let (u, v) = ((lo - p) / d, (hi - p) / d);
                t0 = t0.max(u.min(v));
                t1 = t1.min(u.max(v));
                if t0 > t1 {
                    return false;
                }
            }
        }
        true
    }
}

/// Water over [0, width) × [0, height) except on the islands.
#[derive(Clone, Debug, PartialEq)]
pub struct IslandMap {
    width_m: f64,
    height_m: f64,
    islands: Vec<Rect>,
}

impl IslandMap {
    /// A `width_m` × `height_m` area of water with `islands` of land.
    pub fn new(width_m: f64, height_m: f64, islands: Vec<Rect>) -> Self {
        Self {
            width_m,
            height_m,
            islands,
        }
    }
}

impl WaterMap for IslandMap {
    fn width_m(&self) -> f64 {
        self.width_m
    }
    fn height_m(&self) -> f64 {
        self.height_m
    }
    fn is_water(&self, x: f64, y: f64) -> bool {
        (0.0..self.width_m).contains(&x)
            && (0.0..self.height_m).contains(&y)
            && !self.islands.iter().any(|r| r.contains(x, y))
    }
    fn segment_over_water(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        // The area is convex: two ends inside keep the whole segment inside.
        self.is_water(a.0, a.1) && self.is_water(b.0, b.1) && !self.islands.iter().any(|r| r.meets_segment(a, b))
    }
}

/// A raster chart: `cols` × `rows` cells of `cell_m` metres, row 0 north.
#[derive(Clone, Debug, PartialEq)]
pub struct GridMap {
    cols: usize,
    rows: usize,
    cell_m: f64,
    /// Row-major, row 0 the northern edge.
    water: Vec<bool>,
}

impl GridMap {
    /// Cell (col, row) is water when `water(x, y)` holds at its centre.
    pub fn from_fn(cols: usize, rows: usize, cell_m: f64, water: impl Fn(f64, f64) -> bool) -> Self {
        let mut cells = Vec::with_capacity(cols * rows);
        for row in 0..rows {
            for col in 0..cols {
                let x = (col as f64 + 0.5) * cell_m;
                let y = ((rows - 1 - row) as f64 + 0.5) * cell_m;
                cells.push(water(x, y));
            }
        }
        Self {
            cols,
            rows,
            cell_m,
            water: cells,
        }
    }

    /// A 5 km × 10 km stand-in for Benoit's Cove at 10 m per cell: land to
    /// the east behind a wavy coast, two round islands; about 55 % water.
    pub fn cove() -> Self {
        Self::from_fn(500, 1000, 10.0, |x, y| {
            let coast = 3000.0 + 900.0 * (y / 1700.0).sin() + 300.0 * (y / 430.0).cos();
            let island = |cx: f64, cy: f64, r: f64| (x - cx).powi(2) + (y - cy).powi(2) < r * r;
            x < coast && !island(1500.0, 3000.0, 450.0) && !island(1000.0, 7200.0, 300.0)
        })
    }

    /// Whether cell (col, row) is water; cells outside the grid are not.
    fn cell(&self, col: i64, row_from_south: i64) -> bool {
        if col < 0 || row_from_south < 0 || col >= self.cols as i64 || row_from_south >= self.rows as i64 {
            return false;
        }
        let row = self.rows - 1 - row_from_south as usize;
        self.water[row * self.cols + col as usize]
    }
}

impl WaterMap for GridMap {
    fn width_m(&self) -> f64 {
        self.cols as f64 * self.cell_m
    }
    fn height_m(&self) -> f64 {
        self.rows as f64 * self.cell_m
    }
    fn is_water(&self, x: f64, y: f64) -> bool {
        if !(0.0..self.width_m()).contains(&x) || !(0.0..self.height_m()).contains(&y) {
            return false;
        }
        self.cell((x / self.cell_m) as i64, (y / self.cell_m) as i64)
    }
    fn segment_over_water(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        if !self.is_water(a.0, a.1) || !self.is_water(b.0, b.1) {
            return false;
        }
        // Amanatides–Woo walk over the cells the segment crosses, in cell
        // units, v measured from the southern edge.
        let (u0, v0) = (a.0 / self.cell_m, a.1 / self.cell_m);
        let (u1, v1) = (b.0 / self.cell_m, b.1 / self.cell_m);
        let (mut i, mut j) = (u0.floor() as i64, v0.floor() as i64);
        let (ie, je) = (u1.floor() as i64, v1.floor() as i64);
        let (du, dv) = (u1 - u0, v1 - v0);
        let axis = |p0: f64, d: f64, cell: i64| -> (i64, f64, f64) {
            if d > 0.0 {
                (1, (cell as f64 + 1.0 - p0) / d, 1.0 / d)
            } else if d < 0.0 {
                (-1, (p0 - cell as f64) / -d, -1.0 / d)
            } else {
                (0, f64::INFINITY, f64::INFINITY)
            }
        };
        let (si, mut tu, dtu) = axis(u0, du, i);
        let (sj, mut tv, dtv) = axis(v0, dv, j);
        let steps = (ie - i).abs() + (je - j).abs();
        for _ in 0..steps {
            if tu < tv {
                i += si;
                tu += dtu;
            } else {
                j += sj;
                tv += dtv;
            }
            if !self.cell(i, j) {
                return false;
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_core::rng::PlannerRng;

    /// Dense sampling along the segment: a brute-force reference.
    fn sampled(map: &impl WaterMap, a: (f64, f64), b: (f64, f64), samples: usize) -> bool {
        (0..=samples).all(|k| {
            let t = k as f64 / samples as f64;
            map.is_water(a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))
        })
    }

    #[test]
    fn island_map_segments_agree_with_dense_sampling() {
        let map = IslandMap::new(
            4000.0,
            3000.0,
            vec![Rect {
                x0: 1500.0,
                y0: 1000.0,
                x1: 2500.0,
                y1: 2000.0,
            }],
        );
        assert!(!map.is_water(2000.0, 1500.0) && map.is_water(100.0, 100.0) && !map.is_water(4000.0, 1.0));
        assert!(!map.segment_over_water((1000.0, 1500.0), (3000.0, 1500.0)));
        assert!(map.segment_over_water((1000.0, 500.0), (3000.0, 500.0)));
        let mut rng = PlannerRng::new(1);
        let (mut hit, mut miss) = (0, 0);
        for _ in 0..2000 {
            let a = (rng.uniform(0.0, 4000.0), rng.uniform(0.0, 3000.0));
            let b = (rng.uniform(0.0, 4000.0), rng.uniform(0.0, 3000.0));
            let exact = map.segment_over_water(a, b);
            assert_eq!(exact, sampled(&map, a, b, 20_000), "{a:?} → {b:?}");
            if exact { hit += 1 } else { miss += 1 }
        }
        assert!(hit > 200 && miss > 200, "both outcomes exercised: {hit} / {miss}");
    }

    #[test]
    fn grid_map_walk_agrees_with_dense_sampling() {
        let map = GridMap::cove();
        assert_eq!((map.width_m(), map.height_m()), (5000.0, 10_000.0));
        let mut rng = PlannerRng::new(2);
        let (mut hit, mut miss, mut corner_only) = (0, 0, 0);
        for _ in 0..1000 {
            let a = (rng.uniform(0.0, 5000.0), rng.uniform(0.0, 10_000.0));
            let b = (rng.uniform(0.0, 5000.0), rng.uniform(0.0, 10_000.0));
            let walk = map.segment_over_water(a, b);
            // Sampling finer than a cell can only miss a corner the walk
            // catches, so: walk says water ⇒ sampling says water.
            let dense = sampled(&map, a, b, 50_000);
            if walk {
                assert!(dense, "{a:?} → {b:?}");
                hit += 1;
            } else {
                miss += 1;
                // The converse fails only where the segment clips a land
                // cell's corner for less than the sampling step: rare.
                corner_only += usize::from(dense);
            }
        }
        assert!(hit > 100 && miss > 100, "{hit} / {miss}");
        assert!(
            corner_only <= 5,
            "{corner_only} segments blocked by the walk but not by sampling"
        );
        // A horizontal segment across the first island's centre is blocked;
        // one along the western edge is open.
        assert!(!map.segment_over_water((500.0, 3000.0), (2500.0, 3000.0)));
        assert!(map.segment_over_water((50.0, 100.0), (50.0, 9900.0)));
    }
}
