//! Vector charts: land areas given as GeoJSON polygons (RFC 7946, lon/lat on
//! WGS 84), next to the raster charts.
//!
//! Contract: [`LandChart::from_geojson`] accepts a GeoJSON document whose
//! every geometry is a `Polygon` or a `MultiPolygon` (in a
//! FeatureCollection, a Feature, a bare geometry or a GeometryCollection),
//! each ring closed with at least four positions, every position a finite
//! lon/lat; anything else is a [`LandError`] naming the feature. The polygons
//! are converted vertex by vertex into the local frame of a
//! [`LocalFrame`] and kept there. As a [`WaterMap`], the operating area is the
//! rectangle [0, width) × [0, height) m from the frame origin; a point is
//! water when it is inside that area and touches no land polygon (a point on
//! a coastline is land), and a segment is over water when both its ends are
//! and it meets no land polygon. The geometry (point in polygon, segment
//! against polygon) is the `geo` crate's; the queries do not allocate.

use geo::{BoundingRect, Coord, Intersects, Line, LineString, Point, Polygon, Rect};
use geojson::{GeoJson, Geometry, GeometryValue, PolygonType};

use super::WaterMap;
use crate::frame::{FrameError, LatLon, LocalFrame};

/// Sample grid, per side, of the "has water" check. Our choice: the same
/// resolution as the scenario fingerprint's chart sample.
pub const WATER_CHECK_GRID: usize = 128;

/// Why a GeoJSON land chart was refused. Messages are one line.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LandError {
    /// Not a GeoJSON document.
    #[error("not GeoJSON: {0}")]
    NotGeoJson(String),
    /// A geometry that is not a polygon (or a feature without one).
    #[error("{place}: a {found} is not a land polygon (only Polygon and MultiPolygon are)")]
    NotPolygon {
        /// Which feature or geometry.
        place: String,
        /// Its type.
        found: String,
    },
    /// A ring that breaks RFC 7946 (too short, not closed).
    #[error("{place}: {problem}")]
    BadRing {
        /// Which ring.
        place: String,
        /// What is wrong.
        problem: String,
    },
    /// A position that is not a valid lon/lat.
    #[error("{place}: {source}")]
    BadPosition {
        /// Which ring and position.
        place: String,
        /// What is wrong.
        source: FrameError,
    },
    /// The operating area is not a positive finite size.
    #[error("extent {0} m × {1} m must be finite and > 0")]
    BadExtent(f64, f64),
    /// No water anywhere in the area.
    #[error("no water: the land polygons cover the whole operating area")]
    NoWater,
}

/// One land polygon in the local frame, with its bounding box for a quick
/// reject.
#[derive(Clone, Debug, PartialEq)]
struct Land {
    polygon: Polygon<f64>,
    bbox: Rect<f64>,
}

/// Land polygons in the local frame over a rectangular operating area.
#[derive(Clone, Debug, PartialEq)]
pub struct LandChart {
    width_m: f64,
    height_m: f64,
    land: Vec<Land>,
}

impl LandChart {
    /// Reads the land polygons of a GeoJSON document, converting lon/lat to
    /// the local frame of `frame`; the operating area is `width_m` × `height_m`
    /// east and north of the frame origin.
    pub fn from_geojson(text: &str, frame: &LocalFrame, width_m: f64, height_m: f64) -> Result<Self, LandError> {
        if !(width_m.is_finite() && width_m > 0.0 && height_m.is_finite() && height_m > 0.0) {
            return Err(LandError::BadExtent(width_m, height_m));
        }
        let doc: GeoJson = text
            .parse()
            .map_err(|e: geojson::Error| LandError::NotGeoJson(e.to_string()))?;
        let mut polygons = Vec::new();
        match &doc {
            GeoJson::FeatureCollection(fc) => {
                for (k, f) in fc.features.iter().enumerate() {
                    let place = format!("features[{k}]");
                    let g = f.geometry.as_ref().ok_or_else(|| LandError::NotPolygon {
                        place: place.clone(),
                        found: "feature without geometry".into(),
                    })?;
                    collect(g, &place, frame, &mut polygons)?;
                }
            }
            GeoJson::Feature(f) => {
                let g = f.geometry.as_ref().ok_or_else(|| LandError::NotPolygon {
                    place: "feature".into(),
                    found: "feature without geometry".into(),
                })?;
                collect(g, "feature", frame, &mut polygons)?;
            }
            GeoJson::Geometry(g) => collect(g, "geometry", frame, &mut polygons)?,
        }
        let land = polygons
            .into_iter()
            .filter_map(|polygon| polygon.bounding_rect().map(|bbox| Land { polygon, bbox }))
            .collect();
        let chart = Self {
            width_m,
            height_m,
            land,
        };
        if !chart.has_water() {
            return Err(LandError::NoWater);
        }
        Ok(chart)
    }

    /// The land polygons, in the local frame (m), for plots.
    pub fn polygons(&self) -> impl Iterator<Item = &Polygon<f64>> {
        self.land.iter().map(|l| &l.polygon)
    }

    /// Each land polygon's rings (the exterior, then its holes) as (x, y)
    /// in the local frame, m: for writers that know nothing of `geo`.
    pub fn rings(&self) -> impl Iterator<Item = Vec<Vec<(f64, f64)>>> + '_ {
        self.polygons().map(|p| {
            std::iter::once(p.exterior())
                .chain(p.interiors())
                .map(|r| r.coords().map(|c| (c.x, c.y)).collect())
                .collect()
        })
    }

    fn has_water(&self) -> bool {
        let g = WATER_CHECK_GRID;
        (0..g * g).any(|k| {
            let (c, r) = ((k % g) as f64 + 0.5, (k / g) as f64 + 0.5);
            self.is_water(c * self.width_m / g as f64, r * self.height_m / g as f64)
        })
    }

    fn inside_area(&self, x: f64, y: f64) -> bool {
        (0.0..self.width_m).contains(&x) && (0.0..self.height_m).contains(&y)
    }
}

/// Converts one GeoJSON polygon (rings of lon/lat positions) to the local frame.
fn polygon(rings: &PolygonType, place: &str, frame: &LocalFrame) -> Result<Polygon<f64>, LandError> {
    let mut local = Vec::with_capacity(rings.len());
    if rings.is_empty() {
        return Err(LandError::BadRing {
            place: place.to_string(),
            problem: "a polygon needs an exterior ring".into(),
        });
    }
    for (r, ring) in rings.iter().enumerate() {
        let rp = format!("{place} ring {r}");
        if ring.len() < 4 {
            return Err(LandError::BadRing {
                place: rp,
                problem: format!("{} positions; a linear ring needs at least 4", ring.len()),
            });
        }
        if ring.first().map(|p| p.as_slice()) != ring.last().map(|p| p.as_slice()) {
            return Err(LandError::BadRing {
                place: rp,
                problem: "not closed (the first and last positions differ)".into(),
            });
        }
        let mut coords = Vec::with_capacity(ring.len());
        for (i, p) in ring.iter().enumerate() {
            let s = p.as_slice();
            let bad = |source| LandError::BadPosition {
                place: format!("{rp} position {i}"),
                source,
            };
            if s.len() < 2 {
                return Err(LandError::BadRing {
                    place: format!("{rp} position {i}"),
                    problem: "a position needs longitude and latitude".into(),
                });
            }
            let (x, y) = frame.to_local(LatLon { lat: s[1], lon: s[0] }).map_err(bad)?;
            coords.push(Coord { x, y });
        }
        local.push(LineString::new(coords));
    }
    let exterior = local.remove(0);
    Ok(Polygon::new(exterior, local))
}

fn collect(g: &Geometry, place: &str, frame: &LocalFrame, out: &mut Vec<Polygon<f64>>) -> Result<(), LandError> {
    match &g.value {
        GeometryValue::Polygon { coordinates } => out.push(polygon(coordinates, place, frame)?),
        GeometryValue::MultiPolygon { coordinates } => {
            for (k, p) in coordinates.iter().enumerate() {
                out.push(polygon(p, &format!("{place} polygon {k}"), frame)?);
            }
        }
        GeometryValue::GeometryCollection { geometries } => {
            for (k, inner) in geometries.iter().enumerate() {
                collect(inner, &format!("{place} geometry {k}"), frame, out)?;
            }
        }
        other => {
            return Err(LandError::NotPolygon {
                place: place.to_string(),
                found: other.type_name().to_string(),
            });
        }
    }
    Ok(())
}

impl WaterMap for LandChart {
    fn width_m(&self) -> f64 {
        self.width_m
    }
    fn height_m(&self) -> f64 {
        self.height_m
    }
    fn is_water(&self, x: f64, y: f64) -> bool {
        if !self.inside_area(x, y) {
            return false;
        }
        let p = Point::new(x, y);
        !self
            .land
            .iter()
            .any(|l| l.bbox.intersects(&p) && l.polygon.intersects(&p))
    }
    fn segment_over_water(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        // The area is a rectangle (convex): two ends inside keep the segment inside.
        if !self.is_water(a.0, a.1) || !self.is_water(b.0, b.1) {
            return false;
        }
        let line = Line::new(Coord { x: a.0, y: a.1 }, Coord { x: b.0, y: b.1 });
        !self
            .land
            .iter()
            .any(|l| l.bbox.intersects(&line) && l.polygon.intersects(&line))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame() -> LocalFrame {
        LocalFrame::new(LatLon {
            lat: 48.99,
            lon: -58.17,
        })
        .unwrap()
    }

    /// A square island of about 1 km a side whose south-west corner is
    /// about 1 km east and 1 km north of the origin, as lon/lat.
    /// The ring through `pts` (local m) as GeoJSON positions [lon, lat].
    fn lon_lat_ring(f: &LocalFrame, pts: &[(f64, f64)]) -> Vec<[f64; 2]> {
        pts.iter()
            .map(|&(x, y)| {
                let p = f.to_geodetic(x, y).unwrap();
                [p.lon, p.lat]
            })
            .collect()
    }

    fn island_ring(f: &LocalFrame) -> Vec<[f64; 2]> {
        lon_lat_ring(
            f,
            &[
                (1000.0, 1000.0),
                (2000.0, 1000.0),
                (2000.0, 2000.0),
                (1000.0, 2000.0),
                (1000.0, 1000.0),
            ],
        )
    }

    fn island_doc(f: &LocalFrame) -> String {
        let ring = serde_json::to_string(&island_ring(f)).unwrap();
        format!(
            r#"{{"type": "FeatureCollection", "features": [{{"type": "Feature", "properties": {{"name": "isle"}},
               "geometry": {{"type": "Polygon", "coordinates": [{ring}]}}}}]}}"#
        )
    }

    #[test]
    fn water_and_segments_follow_the_polygons() {
        let f = frame();
        let chart = LandChart::from_geojson(&island_doc(&f), &f, 4000.0, 3000.0).unwrap();
        assert_eq!(chart.polygons().count(), 1);
        assert!(chart.is_water(500.0, 500.0));
        assert!(!chart.is_water(1500.0, 1500.0), "inside the island");
        assert!(
            !chart.is_water(4000.0, 10.0) && !chart.is_water(-1.0, 10.0),
            "outside the area"
        );
        assert!(
            !chart.segment_over_water((500.0, 1500.0), (3500.0, 1500.0)),
            "crosses the island"
        );
        assert!(
            chart.segment_over_water((500.0, 500.0), (3500.0, 500.0)),
            "passes south of it"
        );
        assert!(
            chart.segment_over_water((500.0, 2500.0), (3500.0, 2900.0)),
            "passes north of it"
        );
        // Cutting a corner only: blocked.
        assert!(!chart.segment_over_water((900.0, 1800.0), (1200.0, 2100.0)));
    }

    #[test]
    fn segment_test_agrees_with_dense_sampling() {
        let f = frame();
        let chart = LandChart::from_geojson(&island_doc(&f), &f, 4000.0, 3000.0).unwrap();
        let mut rng = auv_core::rng::PlannerRng::new(5);
        let (mut open, mut blocked) = (0, 0);
        for _ in 0..1000 {
            let a = (rng.uniform(0.0, 4000.0), rng.uniform(0.0, 3000.0));
            let b = (rng.uniform(0.0, 4000.0), rng.uniform(0.0, 3000.0));
            let exact = chart.segment_over_water(a, b);
            let sampled = (0..=4000).all(|k| {
                let t = k as f64 / 4000.0;
                chart.is_water(a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))
            });
            // Sampling can only miss a corner the exact test catches.
            if sampled != exact {
                assert!(sampled && !exact, "{a:?} → {b:?}");
            }
            if exact { open += 1 } else { blocked += 1 }
        }
        assert!(open > 100 && blocked > 100, "{open} / {blocked}");
    }

    #[test]
    fn multipolygons_holes_and_collections_are_read() {
        let f = frame();
        let ring = serde_json::to_string(&island_ring(&f)).unwrap();
        let doc = format!(r#"{{"type": "MultiPolygon", "coordinates": [[{ring}]]}}"#);
        let chart = LandChart::from_geojson(&doc, &f, 4000.0, 3000.0).unwrap();
        assert!(!chart.is_water(1500.0, 1500.0));
        let doc = format!(
            r#"{{"type": "GeometryCollection", "geometries": [{{"type": "Polygon", "coordinates": [{ring}]}}]}}"#
        );
        assert!(
            !LandChart::from_geojson(&doc, &f, 4000.0, 3000.0)
                .unwrap()
                .is_water(1500.0, 1500.0)
        );
        // A lake: an island ring with a hole is water inside the hole.
        let outer: Vec<[f64; 2]> = lon_lat_ring(
            &f,
            &[
                (500.0, 500.0),
                (3500.0, 500.0),
                (3500.0, 2500.0),
                (500.0, 2500.0),
                (500.0, 500.0),
            ],
        );
        let doc = format!(
            r#"{{"type": "Polygon", "coordinates": [{}, {ring}]}}"#,
            serde_json::to_string(&outer).unwrap()
        );
        let chart = LandChart::from_geojson(&doc, &f, 4000.0, 3000.0).unwrap();
        assert!(chart.is_water(1500.0, 1500.0) && !chart.is_water(700.0, 700.0) && chart.is_water(100.0, 100.0));
    }

    #[test]
    fn bad_documents_are_named() {
        let f = frame();
        let cases = [
            ("{", "not GeoJSON"),
            (
                r#"{"type": "Point", "coordinates": [-58.1, 49.0]}"#,
                "a Point is not a land polygon",
            ),
            (
                r#"{"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": [[-58.1, 49.0], [-58.0, 49.0]]}}]}"#,
                "features[0]: a LineString",
            ),
            (
                r#"{"type": "Polygon", "coordinates": [[[-58.1, 49.0], [-58.0, 49.0], [-58.1, 49.0]]]}"#,
                "3 positions",
            ),
            (
                r#"{"type": "Polygon", "coordinates": [[[-58.1, 49.0], [-58.0, 49.0], [-58.0, 49.1], [-58.1, 49.1]]]}"#,
                "not closed",
            ),
            (
                r#"{"type": "Polygon", "coordinates": [[[-58.1, 99.0], [-58.0, 49.0], [-58.0, 49.1], [-58.1, 99.0]]]}"#,
                "latitude 99",
            ),
        ];
        for (doc, needle) in cases {
            let e = LandChart::from_geojson(doc, &f, 4000.0, 3000.0)
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle), "{doc}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
        // Land over the whole area.
        let all: Vec<[f64; 2]> = lon_lat_ring(
            &f,
            &[
                (-10.0, -10.0),
                (5000.0, -10.0),
                (5000.0, 5000.0),
                (-10.0, 5000.0),
                (-10.0, -10.0),
            ],
        );
        let doc = format!(
            r#"{{"type": "Polygon", "coordinates": [{}]}}"#,
            serde_json::to_string(&all).unwrap()
        );
        assert_eq!(
            LandChart::from_geojson(&doc, &f, 4000.0, 3000.0),
            Err(LandError::NoWater)
        );
    }
}
