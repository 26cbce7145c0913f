//! Latitude/longitude (WGS 84) ↔ the planner's local frame (x east, y north,
//! metres) by the local tangent plane at an origin.
//!
//! Contract (the mission format, `auv-mission/1`): a geodetic position at sea
//! level (height 0 on the WGS 84 ellipsoid) goes to Earth-centred Earth-fixed
//! coordinates (ECEF), then to east/north/up (ENU) at the origin; x = east,
//! y = north, "up" is dropped. [`LocalFrame::to_geodetic`] is the exact
//! inverse on the ellipsoid surface: it finds the sea-level point whose ENU
//! east/north are (x, y) (Newton's method; a round trip agrees to far better
//! than 1e-9 degrees anywhere within [`MAX_LOCAL_M`] of the origin).
//! Nothing here allocates or panics; bad input is a [`FrameError`].

use std::fmt;

/// WGS 84 semi-major axis, m.
pub const WGS84_A: f64 = 6_378_137.0;
/// WGS 84 flattening.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;
/// WGS 84 first eccentricity squared, e² = f (2 − f).
pub const WGS84_E2: f64 = WGS84_F * (2.0 - WGS84_F);
/// Largest |x| or |y| converted back to lat/lon, m. Our choice: a tangent
/// plane stops being a one-to-one map long before a quarter of the Earth;
/// 1000 km is far beyond any AUV mission area and well inside that.
pub const MAX_LOCAL_M: f64 = 1.0e6;
/// Largest |latitude| of an origin, degrees. Our choice: east and north are
/// undefined at a pole; 89.9° leaves a well-conditioned frame.
pub const MAX_ORIGIN_LAT_DEG: f64 = 89.9;

/// Why a conversion was refused.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum FrameError {
    /// A latitude outside [−90, 90] (or non-finite).
    #[error("latitude {0} is not a number in [-90, 90]")]
    BadLatitude(f64),
    /// A longitude outside [−180, 180] (or non-finite).
    #[error("longitude {0} is not a number in [-180, 180]")]
    BadLongitude(f64),
    /// An origin too close to a pole for east and north to mean anything.
    #[error("origin latitude {0} is too close to a pole (|lat| must be <= {MAX_ORIGIN_LAT_DEG})")]
    PolarOrigin(f64),
    /// A local position too far from the origin to convert back.
    #[error("local position ({0}, {1}) m is not finite or farther than {MAX_LOCAL_M} m from the origin")]
    TooFar(f64, f64),
}

/// A geodetic position, degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LatLon {
    /// Latitude, degrees north.
    pub lat: f64,
    /// Longitude, degrees east.
    pub lon: f64,
}

impl fmt::Display for LatLon {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "({}, {})", self.lat, self.lon)
    }
}

impl LatLon {
    /// Checks the ranges.
    pub fn validate(self) -> Result<Self, FrameError> {
        if !(self.lat.is_finite() && (-90.0..=90.0).contains(&self.lat)) {
            return Err(FrameError::BadLatitude(self.lat));
        }
        if !(self.lon.is_finite() && (-180.0..=180.0).contains(&self.lon)) {
            return Err(FrameError::BadLongitude(self.lon));
        }
        Ok(self)
    }
}

/// Sea-level geodetic position (radians) → ECEF, m.
fn ecef(lat: f64, lon: f64) -> [f64; 3] {
    let (sp, cp) = lat.sin_cos();
    let (sl, cl) = lon.sin_cos();
    let n = WGS84_A / (1.0 - WGS84_E2 * sp * sp).sqrt();
    [n * cp * cl, n * cp * sl, n * (1.0 - WGS84_E2) * sp]
}

/// The tangent-plane frame at one origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalFrame {
    origin: LatLon,
    origin_ecef: [f64; 3],
    /// Rows: the east and north unit vectors at the origin, in ECEF.
    east: [f64; 3],
    north: [f64; 3],
}

impl LocalFrame {
    /// The frame whose (0, 0) is `origin`.
    pub fn new(origin: LatLon) -> Result<Self, FrameError> {
        origin.validate()?;
        if origin.lat.abs() > MAX_ORIGIN_LAT_DEG {
            return Err(FrameError::PolarOrigin(origin.lat));
        }
        let (lat, lon) = (origin.lat.to_radians(), origin.lon.to_radians());
        let (sp, cp) = lat.sin_cos();
        let (sl, cl) = lon.sin_cos();
        Ok(Self {
            origin,
            origin_ecef: ecef(lat, lon),
            east: [-sl, cl, 0.0],
            north: [-sp * cl, -sp * sl, cp],
        })
    }

    /// The origin.
    pub fn origin(&self) -> LatLon {
        self.origin
    }

    /// East/north of a sea-level point given in radians.
    fn en(&self, lat: f64, lon: f64) -> (f64, f64) {
        let p = ecef(lat, lon);
        let d = [
            p[0] - self.origin_ecef[0],
            p[1] - self.origin_ecef[1],
            p[2] - self.origin_ecef[2],
        ];
        let dot = |u: &[f64; 3]| u[0] * d[0] + u[1] * d[1] + u[2] * d[2];
        (dot(&self.east), dot(&self.north))
    }

    /// Lat/lon → (x east, y north), m.
    pub fn to_local(&self, p: LatLon) -> Result<(f64, f64), FrameError> {
        p.validate()?;
        Ok(self.en(p.lat.to_radians(), p.lon.to_radians()))
    }

    /// (x east, y north), m → lat/lon: the sea-level point whose ENU
    /// east/north are (x, y).
    pub fn to_geodetic(&self, x: f64, y: f64) -> Result<LatLon, FrameError> {
        if !(x.is_finite() && y.is_finite() && x.abs() <= MAX_LOCAL_M && y.abs() <= MAX_LOCAL_M) {
            return Err(FrameError::TooFar(x, y));
        }
        let (mut lat, mut lon) = (self.origin.lat.to_radians(), self.origin.lon.to_radians());
        // Newton on (lat, lon) ↦ (e, n) with the analytic Jacobian: the
        // meridian and prime-vertical radii times the local unit vectors,
        // projected on east and north. Quadratic convergence: 3–5 steps.
        for _ in 0..32 {
            let (e, n) = self.en(lat, lon);
            let (re, rn) = (x - e, y - n);
            let (sp, cp) = lat.sin_cos();
            let (sl, cl) = lon.sin_cos();
            let w = 1.0 - WGS84_E2 * sp * sp;
            let m = WGS84_A * (1.0 - WGS84_E2) / (w * w.sqrt());
            let nv = WGS84_A / w.sqrt();
            let d_lat = [-m * sp * cl, -m * sp * sl, m * cp];
            let d_lon = [-nv * cp * sl, nv * cp * cl, 0.0];
            let dot = |u: &[f64; 3], v: &[f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
            let (a, b) = (dot(&self.east, &d_lat), dot(&self.east, &d_lon));
            let (c, d) = (dot(&self.north, &d_lat), dot(&self.north, &d_lon));
            let det = a * d - b * c;
            if det == 0.0 || !det.is_finite() {
                return Err(FrameError::TooFar(x, y));
            }
            let dlat = (d * re - b * rn) / det;
            let dlon = (a * rn - c * re) / det;
            lat += dlat;
            lon += dlon;
            if dlat.abs() < 1e-15 && dlon.abs() < 1e-15 {
                break;
            }
        }
        let mut lon_deg = lon.to_degrees();
        if lon_deg > 180.0 {
            lon_deg -= 360.0;
        } else if lon_deg < -180.0 {
            lon_deg += 360.0;
        }
        Ok(LatLon {
            lat: lat.to_degrees(),
            lon: lon_deg,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(lat: f64, lon: f64) -> LocalFrame {
        LocalFrame::new(LatLon { lat, lon }).unwrap()
    }

    /// Reference figures computed once, independently of this code, with
    /// pyproj 3.7.2: `Transformer.from_crs("EPSG:4979", "EPSG:4978")` for
    /// geodetic (h = 0) → ECEF, then the textbook ENU rotation
    /// e = −sin λ0·dX + cos λ0·dY, n = −sin φ0 cos λ0·dX − sin φ0 sin λ0·dY + cos φ0·dZ
    /// in Python floats, printed to 6 decimals.
    const PYPROJ: [(f64, f64, f64, f64, f64, f64); 4] = [
        // Benoit's Cove SW → NE corner (the chart is 5 km × 10 km).
        (48.99, -58.17, 49.08, -58.1015, 5004.234222, 10011.190628),
        // The format's example start waypoint.
        (48.99, -58.17, 48.9920, -58.1620, 585.468091, 222.449970),
        // Bay of Islands SW → NE corner (25 km × 25 km).
        (48.93, -58.42, 49.155, -58.0777, 24968.742944, 25078.542232),
        // South-west of the origin: negative both ways.
        (48.99, -58.17, 48.95, -58.25, -5859.598808, -4445.279031),
    ];

    #[test]
    fn matches_pyproj_to_the_micrometre() {
        for (lat0, lon0, lat, lon, e, n) in PYPROJ {
            let (x, y) = frame(lat0, lon0).to_local(LatLon { lat, lon }).unwrap();
            assert!(
                (x - e).abs() < 1e-5 && (y - n).abs() < 1e-5,
                "{lat},{lon}: {x} {y} vs {e} {n}"
            );
        }
    }

    #[test]
    fn hand_checked_equator_and_origin() {
        // On the equator at lon 0, one degree east: ECEF (a cos 1°, a sin 1°, 0),
        // so e = dY = a·sin 1° = 6378137 × 0.017452406437 = 111 313.839 m, n = 0.
        let f = frame(0.0, 0.0);
        let (x, y) = f.to_local(LatLon { lat: 0.0, lon: 1.0 }).unwrap();
        assert!((x - 111_313.839_237).abs() < 1e-5 && y.abs() < 1e-9, "{x} {y}");
        // The origin maps to (0, 0) exactly.
        let g = frame(48.99, -58.17);
        assert_eq!(g.to_local(g.origin()).unwrap(), (0.0, 0.0));
        // ECEF of the Benoit's Cove origin (pyproj: 2211535.849347,
        // -3562675.620145, 4789829.073340).
        let p = ecef(48.99f64.to_radians(), (-58.17f64).to_radians());
        for (got, want) in p.iter().zip([2_211_535.849_347, -3_562_675.620_145, 4_789_829.073_340]) {
            assert!((got - want).abs() < 1e-5, "{got} {want}");
        }
    }

    #[test]
    fn round_trip_agrees_to_1e_9_degrees() {
        let f = frame(48.93, -58.42);
        let mut rng = auv_core::rng::PlannerRng::new(3);
        for _ in 0..2000 {
            let p = LatLon {
                lat: rng.uniform(48.5, 49.5),
                lon: rng.uniform(-59.0, -57.5),
            };
            let (x, y) = f.to_local(p).unwrap();
            let q = f.to_geodetic(x, y).unwrap();
            assert!(
                (p.lat - q.lat).abs() < 1e-9 && (p.lon - q.lon).abs() < 1e-9,
                "{p} → {q}"
            );
            // And back: metres agree to well under a millimetre.
            let (x2, y2) = f.to_local(q).unwrap();
            assert!((x - x2).abs() < 1e-6 && (y - y2).abs() < 1e-6);
        }
        // Across the antimeridian the longitude is wrapped into [-180, 180].
        let g = frame(10.0, 179.99);
        let (x, y) = g
            .to_local(LatLon {
                lat: 10.0,
                lon: -179.99,
            })
            .unwrap();
        let back = g.to_geodetic(x, y).unwrap();
        assert!(
            (back.lon + 179.99).abs() < 1e-9 && (back.lat - 10.0).abs() < 1e-9,
            "{back}"
        );
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(matches!(
            LocalFrame::new(LatLon { lat: 91.0, lon: 0.0 }),
            Err(FrameError::BadLatitude(_))
        ));
        assert!(matches!(
            LocalFrame::new(LatLon {
                lat: 0.0,
                lon: f64::NAN
            }),
            Err(FrameError::BadLongitude(_))
        ));
        assert!(matches!(
            LocalFrame::new(LatLon { lat: 90.0, lon: 0.0 }),
            Err(FrameError::PolarOrigin(_))
        ));
        let f = frame(48.99, -58.17);
        assert!(matches!(f.to_geodetic(f64::INFINITY, 0.0), Err(FrameError::TooFar(..))));
        assert!(matches!(f.to_geodetic(2e6, 0.0), Err(FrameError::TooFar(..))));
        assert!(f.to_local(LatLon { lat: 0.0, lon: 181.0 }).is_err());
    }
}
