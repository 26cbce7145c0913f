//! `route.geojson`: the route travelled and the waypoints of a mission as an
//! RFC 7946 FeatureCollection, so the run opens in QGIS, geojson.io or
//! Foxglove's Map panel.
//!
//! Contract (the mission format): one `LineString` feature, the route
//! travelled (the start, then every arrival where the vehicle actually was,
//! in order; at least two positions, the start repeated when the vehicle
//! never left), with `arrival_times_s` (mission time at each position), and
//! one `Point` feature per waypoint at its nominal position, with properties
//! `name`, `id`, `role`, `dynamic`, `visited`. Positions are
//! [longitude, latitude] (WGS 84) when the mission has a frame origin;
//! without one they stay in the local frame ([x east, y north], m) and the
//! collection says so in a foreign member `local_frame_m` = true (RFC 7946
//! §6.1), since RFC 7946 has no other coordinate reference.

use geojson::{Feature, FeatureCollection, Geometry, GeometryValue, JsonObject, JsonValue};

use auv_world::load::MissionWorld;

/// One position the vehicle reached: mission time (s), node id, (x, y) m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Visit {
    /// Mission time, s.
    pub t: f64,
    /// The waypoint.
    pub node: usize,
    /// Where the vehicle was, m.
    pub at: (f64, f64),
}

/// The collection for `world` and the visits in order (the first one the
/// start). A position that cannot be converted (never for a mission whose
/// waypoints passed its checks) keeps its local coordinates.
pub fn route_geojson(world: &MissionWorld, visits: &[Visit]) -> FeatureCollection {
    let frame = world.frame();
    let position = |(x, y): (f64, f64)| -> Vec<f64> {
        match frame.and_then(|f| f.to_geodetic(x, y).ok()) {
            Some(p) => vec![p.lon, p.lat],
            None => vec![x, y],
        }
    };
    let w = world.world();
    let start = w.nominal_positions()[w.start()];
    let mut line: Vec<Vec<f64>> = visits.iter().map(|v| position(v.at)).collect();
    let mut times: Vec<f64> = visits.iter().map(|v| v.t).collect();
    if line.is_empty() {
        line.push(position((start.x, start.y)));
        times.push(0.0);
    }
    if line.len() == 1 {
        line.push(line[0].clone());
        times.push(times[0]);
    }
    let mut props = JsonObject::new();
    props.insert("name".into(), "route travelled".into());
    props.insert("arrival_times_s".into(), JsonValue::from(times));
    let mut features = vec![Feature {
        geometry: Some(Geometry::new(GeometryValue::LineString {
            coordinates: line.into_iter().map(Into::into).collect(),
        })),
        properties: Some(props),
        ..Feature::default()
    }];
    let visited: Vec<bool> = (0..w.n()).map(|i| visits.iter().any(|v| v.node == i)).collect();
    for (i, info) in world.waypoints().iter().enumerate() {
        let p = w.nominal_positions()[i];
        let mut props = JsonObject::new();
        props.insert("name".into(), info.name.clone().into());
        props.insert("id".into(), i.into());
        props.insert("role".into(), info.role.as_str().into());
        props.insert("dynamic".into(), w.is_dynamic(i).into());
        props.insert("visited".into(), visited[i].into());
        features.push(Feature {
            geometry: Some(Geometry::new(GeometryValue::Point {
                coordinates: position((p.x, p.y)).into(),
            })),
            properties: Some(props),
            ..Feature::default()
        });
    }
    let foreign_members = frame.is_none().then(|| {
        let mut m = JsonObject::new();
        m.insert("local_frame_m".into(), true.into());
        m
    });
    FeatureCollection {
        bbox: None,
        features,
        foreign_members,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_world::load::{ScenarioArgs, load_world};

    fn default_world() -> MissionWorld {
        load_world(&ScenarioArgs::default()).unwrap()
    }

    /// Checks what RFC 7946 and the mission format ask of the file, on the
    /// JSON text itself (not on our own types).
    fn check(text: &str, n: usize, lonlat: bool) -> serde_json::Value {
        let v: serde_json::Value = serde_json::from_str(text).unwrap();
        assert_eq!(v["type"], "FeatureCollection");
        let features = v["features"].as_array().unwrap();
        let lines: Vec<_> = features
            .iter()
            .filter(|f| f["geometry"]["type"] == "LineString")
            .collect();
        let points: Vec<_> = features.iter().filter(|f| f["geometry"]["type"] == "Point").collect();
        assert_eq!(lines.len(), 1, "one LineString");
        assert_eq!(points.len(), n, "one Point per waypoint");
        for f in features {
            assert_eq!(f["type"], "Feature");
            assert!(f["properties"].is_object());
        }
        let coords = lines[0]["geometry"]["coordinates"].as_array().unwrap();
        assert!(coords.len() >= 2, "a LineString has at least two positions");
        let all = coords
            .iter()
            .chain(points.iter().map(|p| &p["geometry"]["coordinates"]));
        for c in all {
            let c = c.as_array().unwrap();
            assert_eq!(c.len(), 2);
            let (a, b) = (c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
            if lonlat {
                // [longitude, latitude]: Benoit's Cove is at 58.1 W, 49.0 N.
                assert!(
                    (-58.18..=-58.09).contains(&a) && (48.98..=49.09).contains(&b),
                    "{a}, {b}"
                );
            }
        }
        for (i, p) in points.iter().enumerate() {
            let pr = &p["properties"];
            assert_eq!(pr["id"], i);
            assert!(pr["name"].is_string() && pr["role"].is_string());
            assert!(pr["dynamic"].is_boolean() && pr["visited"].is_boolean());
        }
        // And the geojson crate reads it back as a FeatureCollection.
        assert!(matches!(
            text.parse::<geojson::GeoJson>(),
            Ok(geojson::GeoJson::FeatureCollection(_))
        ));
        v
    }

    #[test]
    fn the_default_mission_writes_lon_lat_in_rfc_7946_order() {
        let world = default_world();
        let w = world.world();
        let pos = |i: usize| (w.nominal_positions()[i].x, w.nominal_positions()[i].y);
        let visits = [
            Visit {
                t: 0.0,
                node: 0,
                at: pos(0),
            },
            Visit {
                t: 900.0,
                node: 12,
                at: pos(12),
            },
            Visit {
                t: 2000.0,
                node: w.goal(),
                at: pos(w.goal()),
            },
        ];
        let text = route_geojson(&world, &visits).to_string();
        let v = check(&text, w.n(), true);
        let f = &v["features"];
        assert_eq!(
            f[0]["properties"]["arrival_times_s"],
            serde_json::json!([0.0, 900.0, 2000.0])
        );
        assert_eq!(f[1]["properties"]["role"], "start");
        assert_eq!(f[1]["properties"]["name"], "start");
        assert_eq!(f[1 + 12]["properties"]["visited"], true);
        assert_eq!(f[1 + 13]["properties"]["visited"], false);
        assert_eq!(f[1 + 1]["properties"]["dynamic"], true);
        // The start's position converts back to its local coordinates.
        let c = &f[0]["geometry"]["coordinates"][0];
        let back = world
            .frame()
            .unwrap()
            .to_local(auv_world::frame::LatLon {
                lat: c[1].as_f64().unwrap(),
                lon: c[0].as_f64().unwrap(),
            })
            .unwrap();
        assert!((back.0 - pos(0).0).abs() < 1e-6 && (back.1 - pos(0).1).abs() < 1e-6);
    }

    #[test]
    fn a_vehicle_that_never_left_still_gives_a_valid_line() {
        let world = default_world();
        let text = route_geojson(&world, &[]).to_string();
        check(&text, world.world().n(), true);
    }
}
