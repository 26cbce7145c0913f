//! OPLib orienteering files (`shared/benchmarks/oplib/`: TSPLIB graphs with
//! a cost limit and node scores) and their exact encoding into the
//! interchange format.
//!
//! Contract: [`parse_oplib`] reads one `.oplib` file (TSPLIB header
//! `KEY : value` lines, `TYPE : OP`, `DIMENSION`, `COST_LIMIT`,
//! `EDGE_WEIGHT_TYPE` `EUC_2D`, `ATT`, `GEO` or `EXPLICIT` with any of
//! TSPLIB's matrix layouts, then `NODE_COORD_SECTION` or
//! `EDGE_WEIGHT_SECTION`, optional `DISPLAY_DATA_SECTION`,
//! `NODE_SCORE_SECTION`, `DEPOT_SECTION`, `EOF`) and computes the integer
//! TSPLIB distance of every pair exactly as TSPLIB defines it.
//! [`OplibInstance::to_instance`] encodes it as the OPLib README says, so the
//! published optima stay valid: city k → node k−1, the depot copied as the
//! goal (id n, same position, prize 0), an edge between every pair with
//! priority 0, risk 1 and task time = the TSPLIB distance, a speed so large
//! that travel adds under 0.001 s to any route, and a budget of
//! `COST_LIMIT + 0.5`. Nothing assumes the triangle inequality (rounded and
//! explicit distances break it). Malformed files give a [`TsplibError`]
//! naming the line.

use crate::instance::{Edge, Instance, Node, Objective};

/// One `.oplib` file as read.
#[derive(Clone, Debug, PartialEq)]
pub struct OplibInstance {
    /// `NAME` (free text; empty when absent).
    pub name: String,
    /// Number of cities.
    pub dimension: usize,
    /// The tour length limit.
    pub cost_limit: f64,
    /// The depot, 0-based.
    pub depot: usize,
    /// Score of each city, 0-based.
    pub scores: Vec<f64>,
    /// Plane position of each city for pictures (coordinates, display data
    /// or, without either, a circle).
    pub positions: Vec<(f64, f64)>,
    /// TSPLIB distance of every pair, row-major `dimension × dimension`.
    pub distances: Vec<f64>,
}

/// Why an `.oplib` file was rejected (lines are 1-based).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TsplibError {
    /// A header key this reader needs is missing.
    #[error("missing header `{0}`")]
    MissingHeader(&'static str),
    /// A header value is malformed or unsupported.
    #[error("line {line}: `{key}` = {value:?}: {rule}")]
    BadHeader {
        /// Line number.
        line: usize,
        /// The key.
        key: String,
        /// The value found.
        value: String,
        /// What was expected.
        rule: &'static str,
    },
    /// A line that is neither a header, a section name nor section data.
    #[error("line {line}: unexpected {text:?}")]
    Unexpected {
        /// Line number.
        line: usize,
        /// The text.
        text: String,
    },
    /// A field that is not a number, or breaks its rule.
    #[error("line {line}: {field} {text:?} is invalid: must be {rule}")]
    BadNumber {
        /// Line number.
        line: usize,
        /// Field name.
        field: &'static str,
        /// The text found.
        text: String,
        /// The rule.
        rule: &'static str,
    },
    /// A section has the wrong number of entries.
    #[error("{section}: expected {expected} entries, found {found}")]
    Count {
        /// Section name.
        section: &'static str,
        /// Entries expected.
        expected: usize,
        /// Entries found.
        found: usize,
    },
    /// A city id outside 1..=DIMENSION, or listed twice.
    #[error("line {line}: {section}: city {id} is out of range 1..={dimension} or listed twice")]
    BadCity {
        /// Line number.
        line: usize,
        /// Section name.
        section: &'static str,
        /// The id.
        id: i64,
        /// DIMENSION.
        dimension: usize,
    },
}

/// How distances are given.
#[derive(Clone, Copy, Debug, PartialEq)]
enum WeightType {
    Euc2d,
    Att,
    Geo,
    Explicit,
}

/// Layout of an explicit matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Layout {
    Full,
    UpperRow,
    LowerRow,
    UpperDiagRow,
    LowerDiagRow,
}

/// TSPLIB's `nint`: round half up.
fn nint(x: f64) -> f64 {
    (x + 0.5).floor()
}

/// TSPLIB `EUC_2D`.
fn euc_2d(p: (f64, f64), q: (f64, f64)) -> f64 {
    nint((p.0 - q.0).hypot(p.1 - q.1))
}

/// TSPLIB `ATT` (pseudo-Euclidean, rounded up when `nint` rounds down).
fn att(p: (f64, f64), q: (f64, f64)) -> f64 {
    let (dx, dy) = (p.0 - q.0, p.1 - q.1);
    let r = ((dx * dx + dy * dy) / 10.0).sqrt();
    let t = nint(r);
    if t < r { t + 1.0 } else { t }
}

/// Latitude or longitude in radians of a TSPLIB `DDD.MM` coordinate (degrees
/// truncated, as TSPLIB's reference code does).
fn geo_radians(x: f64) -> f64 {
    // TSPLIB's own truncated π: the published distances depend on it.
    #[allow(clippy::approx_constant)]
    const PI: f64 = 3.141592;
    let deg = x.trunc();
    let min = x - deg;
    PI * (deg + 5.0 * min / 3.0) / 180.0
}

/// TSPLIB `GEO` (great circle on TSPLIB's idealised sphere, truncated + 1).
fn geo(p: (f64, f64), q: (f64, f64)) -> f64 {
    const RRR: f64 = 6378.388;
    let (lat_i, lon_i) = (geo_radians(p.0), geo_radians(p.1));
    let (lat_j, lon_j) = (geo_radians(q.0), geo_radians(q.1));
    let q1 = (lon_i - lon_j).cos();
    let q2 = (lat_i - lat_j).cos();
    let q3 = (lat_i + lat_j).cos();
    (RRR * (0.5 * ((1.0 + q1) * q2 - (1.0 - q1) * q3)).acos() + 1.0).trunc()
}

/// The section a data line belongs to.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Section {
    Header,
    Coords,
    Weights,
    Display,
    Scores,
    Depot,
    End,
}

fn number(line: usize, field: &'static str, text: &str) -> Result<f64, TsplibError> {
    text.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| TsplibError::BadNumber {
            line,
            field,
            text: text.to_string(),
            rule: "a finite number",
        })
}

/// A city id of a section line, 0-based, checked against `dimension`.
fn city(line: usize, section: &'static str, text: &str, dimension: usize) -> Result<usize, TsplibError> {
    let id = text.parse::<i64>().map_err(|_| TsplibError::BadNumber {
        line,
        field: "city id",
        text: text.to_string(),
        rule: "a whole number",
    })?;
    if id < 1 || id as u64 > dimension as u64 {
        return Err(TsplibError::BadCity {
            line,
            section,
            id,
            dimension,
        });
    }
    Ok(id as usize - 1)
}

/// Fills one `k x y` line of a per-city section.
fn city_pair(
    line: usize,
    section: &'static str,
    fields: &[&str],
    dimension: usize,
    out: &mut [Option<(f64, f64)>],
) -> Result<(), TsplibError> {
    if fields.len() != 3 {
        return Err(TsplibError::Unexpected {
            line,
            text: fields.join(" "),
        });
    }
    let k = city(line, section, fields[0], dimension)?;
    if out[k].is_some() {
        return Err(TsplibError::BadCity {
            line,
            section,
            id: k as i64 + 1,
            dimension,
        });
    }
    out[k] = Some((number(line, "x", fields[1])?, number(line, "y", fields[2])?));
    Ok(())
}

/// Parses one `.oplib` file.
pub fn parse_oplib(text: &str) -> Result<OplibInstance, TsplibError> {
    let mut name = String::new();
    let mut dimension: Option<usize> = None;
    let mut cost_limit: Option<f64> = None;
    let mut weight_type: Option<WeightType> = None;
    let mut layout: Option<Layout> = None;
    let mut section = Section::Header;
    let mut coords: Vec<Option<(f64, f64)>> = Vec::new();
    let mut display: Vec<Option<(f64, f64)>> = Vec::new();
    let mut scores: Vec<Option<f64>> = Vec::new();
    let mut weights: Vec<f64> = Vec::new();
    let mut depots: Vec<usize> = Vec::new();
    let need_dim = |d: Option<usize>| d.ok_or(TsplibError::MissingHeader("DIMENSION"));
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let l = raw.trim();
        if l.is_empty() {
            continue;
        }
        let keyword = l.trim_end_matches(':').trim();
        let next = match keyword {
            "NODE_COORD_SECTION" => Some(Section::Coords),
            "EDGE_WEIGHT_SECTION" => Some(Section::Weights),
            "DISPLAY_DATA_SECTION" => Some(Section::Display),
            "NODE_SCORE_SECTION" => Some(Section::Scores),
            "DEPOT_SECTION" => Some(Section::Depot),
            "EOF" => Some(Section::End),
            _ => None,
        };
        if let Some(next) = next {
            let n = need_dim(dimension)?;
            match next {
                Section::Coords => coords = vec![None; n],
                Section::Display => display = vec![None; n],
                Section::Scores => scores = vec![None; n],
                _ => {}
            }
            section = next;
            continue;
        }
        if let Some((key, value)) = l.split_once(':')
            && matches!(section, Section::Header | Section::Depot | Section::End)
            && key.trim().chars().all(|c| c.is_ascii_uppercase() || c == '_')
        {
            let (key, value) = (key.trim(), value.trim());
            let bad = |rule| TsplibError::BadHeader {
                line,
                key: key.to_string(),
                value: value.to_string(),
                rule,
            };
            match key {
                "NAME" => name = value.to_string(),
                "TYPE" if value != "OP" => return Err(bad("only orienteering files (TYPE : OP) are read")),
                "DIMENSION" => {
                    dimension = Some(
                        value
                            .parse::<usize>()
                            .ok()
                            .filter(|&d| (1..=1_000_000).contains(&d))
                            .ok_or_else(|| bad("a whole number of cities ≥ 1"))?,
                    )
                }
                "COST_LIMIT" => {
                    cost_limit = Some(
                        value
                            .parse::<f64>()
                            .ok()
                            .filter(|c| c.is_finite() && *c >= 0.0)
                            .ok_or_else(|| bad("a finite number ≥ 0"))?,
                    )
                }
                "EDGE_WEIGHT_TYPE" => {
                    weight_type = Some(match value {
                        "EUC_2D" => WeightType::Euc2d,
                        "ATT" => WeightType::Att,
                        "GEO" => WeightType::Geo,
                        "EXPLICIT" => WeightType::Explicit,
                        _ => return Err(bad("one of EUC_2D, ATT, GEO, EXPLICIT")),
                    })
                }
                "EDGE_WEIGHT_FORMAT" => {
                    layout = Some(match value {
                        "FULL_MATRIX" => Layout::Full,
                        "UPPER_ROW" => Layout::UpperRow,
                        "LOWER_ROW" => Layout::LowerRow,
                        "UPPER_DIAG_ROW" => Layout::UpperDiagRow,
                        "LOWER_DIAG_ROW" => Layout::LowerDiagRow,
                        _ => {
                            return Err(bad(
                                "one of FULL_MATRIX, UPPER_ROW, LOWER_ROW, UPPER_DIAG_ROW, LOWER_DIAG_ROW",
                            ));
                        }
                    })
                }
                // COMMENT, DISPLAY_DATA_TYPE and the like: free text or pictures.
                _ => {}
            }
            continue;
        }
        let fields: Vec<&str> = l.split_whitespace().collect();
        match section {
            Section::Header | Section::End => {
                return Err(TsplibError::Unexpected {
                    line,
                    text: l.to_string(),
                });
            }
            Section::Coords => {
                let n = need_dim(dimension)?;
                city_pair(line, "NODE_COORD_SECTION", &fields, n, &mut coords)?;
            }
            Section::Display => {
                let n = need_dim(dimension)?;
                city_pair(line, "DISPLAY_DATA_SECTION", &fields, n, &mut display)?;
            }
            Section::Weights => {
                for f in fields {
                    let w = number(line, "edge weight", f)?;
                    if w < 0.0 {
                        return Err(TsplibError::BadNumber {
                            line,
                            field: "edge weight",
                            text: f.to_string(),
                            rule: "≥ 0",
                        });
                    }
                    weights.push(w);
                }
            }
            Section::Scores => {
                let n = need_dim(dimension)?;
                if fields.len() != 2 {
                    return Err(TsplibError::Unexpected {
                        line,
                        text: l.to_string(),
                    });
                }
                let k = city(line, "NODE_SCORE_SECTION", fields[0], n)?;
                let s = number(line, "score", fields[1])?;
                if s < 0.0 || scores[k].is_some() {
                    return Err(TsplibError::BadNumber {
                        line,
                        field: "score",
                        text: l.to_string(),
                        rule: "≥ 0, once per city",
                    });
                }
                scores[k] = Some(s);
            }
            Section::Depot => {
                let n = need_dim(dimension)?;
                for f in fields {
                    if f == "-1" {
                        section = Section::End;
                        break;
                    }
                    depots.push(city(line, "DEPOT_SECTION", f, n)?);
                }
            }
        }
    }
    let n = need_dim(dimension)?;
    let cost_limit = cost_limit.ok_or(TsplibError::MissingHeader("COST_LIMIT"))?;
    let weight_type = weight_type.ok_or(TsplibError::MissingHeader("EDGE_WEIGHT_TYPE"))?;
    let complete = |v: &[Option<(f64, f64)>], section| -> Result<Vec<(f64, f64)>, TsplibError> {
        let found = v.iter().filter(|c| c.is_some()).count();
        if found != n {
            return Err(TsplibError::Count {
                section,
                expected: n,
                found,
            });
        }
        Ok(v.iter().flatten().copied().collect())
    };
    let mut distances = vec![0.0; n * n];
    let positions = match weight_type {
        WeightType::Euc2d | WeightType::Att | WeightType::Geo => {
            let c = complete(&coords, "NODE_COORD_SECTION")?;
            let metric = match weight_type {
                WeightType::Euc2d => euc_2d,
                WeightType::Att => att,
                _ => geo,
            };
            for a in 0..n {
                for b in 0..n {
                    if a != b {
                        distances[a * n + b] = metric(c[a], c[b]);
                    }
                }
            }
            // GEO coordinates are (latitude, longitude): draw east as x.
            if weight_type == WeightType::Geo {
                c.iter().map(|&(lat, lon)| (lon, lat)).collect()
            } else {
                c
            }
        }
        WeightType::Explicit => {
            let layout = layout.ok_or(TsplibError::MissingHeader("EDGE_WEIGHT_FORMAT"))?;
            let expected = match layout {
                Layout::Full => n * n,
                Layout::UpperRow | Layout::LowerRow => n * (n - 1) / 2,
                Layout::UpperDiagRow | Layout::LowerDiagRow => n * (n + 1) / 2,
            };
            if weights.len() != expected {
                return Err(TsplibError::Count {
                    section: "EDGE_WEIGHT_SECTION",
                    expected,
                    found: weights.len(),
                });
            }
            let mut w = weights.iter().copied();
            for a in 0..n {
                let cols = match layout {
                    Layout::Full => 0..n,
                    Layout::UpperRow => a + 1..n,
                    Layout::LowerRow => 0..a,
                    Layout::UpperDiagRow => a..n,
                    Layout::LowerDiagRow => 0..a + 1,
                };
                for b in cols {
                    let d = w.next().unwrap_or(0.0);
                    if a != b {
                        // A full matrix may be asymmetric; a tour can run either
                        // way, so only symmetric ones are meaningful here.
                        distances[a * n + b] = d;
                        if layout != Layout::Full {
                            distances[b * n + a] = d;
                        }
                    }
                }
            }
            if layout == Layout::Full {
                for a in 0..n {
                    for b in a + 1..n {
                        if distances[a * n + b] != distances[b * n + a] {
                            return Err(TsplibError::BadHeader {
                                line: 0,
                                key: "EDGE_WEIGHT_SECTION".into(),
                                value: format!(
                                    "{} vs {} for cities {} and {}",
                                    distances[a * n + b],
                                    distances[b * n + a],
                                    a + 1,
                                    b + 1
                                ),
                                rule: "a symmetric matrix",
                            });
                        }
                    }
                }
            }
            if display.iter().any(Option::is_some) {
                complete(&display, "DISPLAY_DATA_SECTION")?
            } else {
                // No plane: a circle, for pictures only.
                (0..n)
                    .map(|k| {
                        let a = k as f64 * core::f64::consts::TAU / n as f64;
                        (1000.0 * a.cos(), 1000.0 * a.sin())
                    })
                    .collect()
            }
        }
    };
    let found = scores.iter().filter(|s| s.is_some()).count();
    if found != n {
        return Err(TsplibError::Count {
            section: "NODE_SCORE_SECTION",
            expected: n,
            found,
        });
    }
    let depot = match depots.as_slice() {
        [d] => *d,
        other => {
            return Err(TsplibError::Count {
                section: "DEPOT_SECTION",
                expected: 1,
                found: other.len(),
            });
        }
    };
    Ok(OplibInstance {
        name,
        dimension: n,
        cost_limit,
        depot,
        scores: scores.into_iter().flatten().collect(),
        positions,
        distances,
    })
}

impl OplibInstance {
    /// TSPLIB distance between cities `a` and `b` (0-based).
    pub fn distance(&self, a: usize, b: usize) -> f64 {
        self.distances[a * self.dimension + b]
    }

    /// The speed of the encoding: a power of ten at least 1000 · nodes · the
    /// largest planar distance, so travel adds under 0.001 s to any route
    /// and the integer task times alone decide feasibility.
    fn speed_mps(&self) -> f64 {
        let p = &self.positions;
        let mut span: f64 = 1.0;
        for a in p {
            for b in p {
                span = span.max((a.0 - b.0).hypot(a.1 - b.1));
            }
        }
        let need = 1000.0 * (self.dimension + 1) as f64 * span;
        10f64.powi(need.log10().ceil() as i32)
    }

    /// Encodes the file as an interchange instance (see the module header):
    /// node n is the depot's copy, the goal.
    pub fn to_instance(&self, name: &str) -> Instance {
        let n = self.dimension;
        let mut nodes: Vec<Node> = (0..n)
            .map(|k| Node {
                x: self.positions[k].0,
                y: self.positions[k].1,
                z: 0.0,
                prize: self.scores[k],
            })
            .collect();
        nodes.push(Node {
            prize: 0.0,
            ..nodes[self.depot]
        });
        let mut edges = Vec::with_capacity((n + 1) * n / 2);
        for a in 0..=n {
            for b in a + 1..=n {
                // The goal copy has the depot's distances (0 to the depot).
                let (ca, cb) = (if a == n { self.depot } else { a }, if b == n { self.depot } else { b });
                edges.push(Edge {
                    a,
                    b,
                    priority: 0.0,
                    risk: 1.0,
                    task_time_s: if ca == cb { 0.0 } else { self.distance(ca, cb) },
                });
            }
        }
        Instance {
            name: name.to_string(),
            speed_mps: self.speed_mps(),
            time_available_s: self.cost_limit + 0.5,
            start: self.depot,
            goal: n,
            nodes,
            edges,
            objective: Objective::MaxWeight,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::route::RouteStats;

    // The default capacity class unless a test names another.
    type Problem = crate::problem::Problem;
    type Route = crate::route::Route;

    const EUC: &str = "NAME : tiny\nTYPE : OP\nCOMMENT : four cities\nDIMENSION : 4\nCOST_LIMIT : 20\n\
        EDGE_WEIGHT_TYPE : EUC_2D\nNODE_COORD_SECTION\n1 0 0\n2 3 4\n3 6 8.4\n4 0 5.5\n\
        NODE_SCORE_SECTION\n1 1\n2 5\n3 7\n4 2\nDEPOT_SECTION\n1\n-1\nEOF\n";

    #[test]
    fn euclidean_distances_are_tsplib_rounded() {
        let op = parse_oplib(EUC).unwrap();
        assert_eq!(op.dimension, 4);
        assert_eq!(op.distance(0, 1), 5.0);
        // hypot(6, 8.4) = 10.32 → 10; hypot(0, 5.5) = 5.5 → 6 (half up).
        assert_eq!(op.distance(0, 2), 10.0);
        assert_eq!(op.distance(0, 3), 6.0);
        assert_eq!(op.distance(3, 0), 6.0);
        assert_eq!(op.scores, vec![1.0, 5.0, 7.0, 2.0]);
    }

    #[test]
    fn att_and_geo_follow_tsplib() {
        // ATT: sqrt((30² + 40²) / 10) = 15.81 → nint 16 ≥ r → 16;
        // sqrt((30² + 10²) / 10) = 10 exactly → 10.
        assert_eq!(att((0.0, 0.0), (30.0, 40.0)), 16.0);
        assert_eq!(att((0.0, 0.0), (30.0, 10.0)), 10.0);
        // sqrt(12.1) = 3.478 → nint 3 < r → 4.
        assert_eq!(att((0.0, 0.0), (11.0, 0.0)), 4.0);
        // GEO: one degree of latitude on TSPLIB's sphere is 111.3 km → 112
        // (truncated + 1); 0.30 is 30 minutes (half a degree).
        assert_eq!(geo((10.0, 20.0), (11.0, 20.0)), 112.0);
        assert_eq!(geo((10.0, 20.0), (10.30, 20.0)), 56.0);
    }

    #[test]
    fn explicit_layouts_agree() {
        // The same symmetric 3-city matrix in four layouts.
        let layouts = [
            ("FULL_MATRIX", "0 2 3\n2 0 4\n3 4 0"),
            ("UPPER_ROW", "2 3\n4"),
            ("LOWER_ROW", "2\n3 4"),
            ("LOWER_DIAG_ROW", "0 2 0 3 4 0"),
            ("UPPER_DIAG_ROW", "0 2 3 0 4 0"),
        ];
        for (layout, data) in layouts {
            let text = format!(
                "NAME: m\nTYPE: OP\nDIMENSION: 3\nCOST_LIMIT : 9\nEDGE_WEIGHT_TYPE: EXPLICIT\n\
                 EDGE_WEIGHT_FORMAT: {layout} \nEDGE_WEIGHT_SECTION\n{data}\nNODE_SCORE_SECTION\n1 0\n2 1\n3 1\n\
                 DEPOT_SECTION\n1\n-1\nEOF\n"
            );
            let op = parse_oplib(&text).unwrap_or_else(|e| panic!("{layout}: {e}"));
            assert_eq!(
                (op.distance(0, 1), op.distance(0, 2), op.distance(1, 2)),
                (2.0, 3.0, 4.0),
                "{layout}"
            );
            assert_eq!(op.distance(2, 1), 4.0);
        }
    }

    #[test]
    fn the_encoding_keeps_tour_lengths_and_scores() {
        let op = parse_oplib(EUC).unwrap();
        let inst = op.to_instance("tiny");
        assert_eq!(inst.nodes.len(), 5);
        assert_eq!((inst.start, inst.goal), (0, 4));
        assert_eq!(inst.time_available_s, 20.5);
        // Tour 1-2-3-1: 5 + 5 + 10 = 20 ≤ 20 → feasible, score 1 + 5 + 7.
        let s = RouteStats::from_instance(&inst, &[0, 1, 2, 4]).unwrap();
        assert!(s.feasible);
        assert_eq!(s.weight, 13.0);
        assert!((s.time_s - 20.0).abs() < 1e-3, "{}", s.time_s);
        // Tour 1-2-3-4-1: 5 + 5 + 7 + 6 > 20 → infeasible.
        let s = RouteStats::from_instance(&inst, &[0, 1, 2, 3, 4]).unwrap();
        assert!(!s.feasible);
        let p = Problem::from_instance(&inst).unwrap();
        let r = Route::from_slice(&[0, 1, 2, 4]).unwrap();
        assert!(p.evaluate(&r).unwrap().feasible);
    }

    #[test]
    fn malformed_files_name_the_problem() {
        let cases: [(&str, &str); 6] = [
            ("TYPE : OP\nDIMENSION : 4\n", "COST_LIMIT"),
            (&EUC.replace("TYPE : OP", "TYPE : TSP"), "TYPE"),
            (&EUC.replace("EUC_2D", "MAN_2D"), "EDGE_WEIGHT_TYPE"),
            (&EUC.replace("4 0 5.5", "4 0 x"), "line 11"),
            (&EUC.replace("3 7\n", ""), "NODE_SCORE_SECTION"),
            (&EUC.replace("4 0 5.5", "9 0 5.5"), "city 9"),
        ];
        for (text, needle) in cases {
            let e = parse_oplib(text).unwrap_err().to_string();
            assert!(e.contains(needle), "{e:?} should name {needle}");
        }
    }
}
