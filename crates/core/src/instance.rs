//! The `auv-route-instance/1` interchange format
//! (`shared/design/instance-format.md`): one snapshot of the routing problem
//! as JSON, read by `solve` and written by `export`.
//!
//! Contract: [`Instance::from_json`] accepts exactly the documented format and
//! rejects anything else with an [`InstanceError`] that names the offending
//! field; [`Instance::to_json`] writes a document that reads back to an equal
//! [`Instance`] (f64 values are printed shortest-round-trip). The derived
//! quantities (edge length, time, weight, route figures) are computed in one
//! place, [`crate::route::RouteStats`], straight from this type.
//!
//! Units: metres, seconds, m/s; x east, y north, z depth (positive down).

use serde::{Deserialize, Serialize};

/// 3-D Euclidean distance between two points (x, y, z in m), m: the one
/// formula the format's figures use, so every copy of a position (instance,
/// world, snapshot, vehicle) measures it bit for bit alike.
#[inline]
pub fn distance_3d_m(p: [f64; 3], q: [f64; 3]) -> f64 {
    let (dx, dy, dz) = (p[0] - q[0], p[1] - q[1], p[2] - q[2]);
    (dx * dx + dy * dy + dz * dz).sqrt()
}

/// The only accepted value of the `format` field.
pub const FORMAT_TAG: &str = "auv-route-instance/1";

/// A validated routing instance. Nodes are stored by id (index = id).
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Free text.
    pub name: String,
    /// Vehicle speed through water, m/s, > 0.
    pub speed_mps: f64,
    /// Time budget T_available, s, > 0.
    pub time_available_s: f64,
    /// Start node id.
    pub start: usize,
    /// Goal node id.
    pub goal: usize,
    /// Waypoints, indexed by id.
    pub nodes: Vec<Node>,
    /// Undirected edges, each carrying one task.
    pub edges: Vec<Edge>,
    /// What "best route" means.
    pub objective: Objective,
}

/// A waypoint position (m) and the prize collected when a route visits it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    /// East, m.
    pub x: f64,
    /// North, m.
    pub y: f64,
    /// Depth, m, positive down.
    pub z: f64,
    /// Collected once when the route visits the node; ≥ 0.
    pub prize: f64,
}

/// An undirected edge `a`–`b` and its task.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    /// One end (node id).
    pub a: usize,
    /// Other end (node id), ≠ `a`.
    pub b: usize,
    /// Task priority ρ ≥ 0.
    pub priority: f64,
    /// Task risk ξ > 0.
    pub risk: f64,
    /// Task completion time δ ≥ 0, s.
    pub task_time_s: f64,
}

/// The objective of the instance.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Objective {
    /// Largest total weight Σρ/ξ + Σprize among feasible routes; ties to the
    /// shorter route time.
    #[default]
    MaxWeight,
    /// The paper's cost, minimised: φ1·|T_R − T_available| + φ2·Σ ξ/ρ.
    PaperCost {
        /// Weight of the time-use term.
        phi1: f64,
        /// Weight of the risk/priority term.
        phi2: f64,
    },
}

/// Why an instance document was rejected. Each variant names the field.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum InstanceError {
    /// Not valid JSON, or a field of the wrong type or missing.
    #[error("instance JSON: {0}")]
    Json(String),
    /// `format` is not [`FORMAT_TAG`].
    #[error("unsupported format {found:?}: expected \"{FORMAT_TAG}\"")]
    WrongFormat {
        /// The tag that was found.
        found: String,
    },
    /// A number that must be finite and within a range is not.
    #[error("{field} = {value} is invalid: must be {rule}")]
    BadNumber {
        /// Path of the field, e.g. `edges[3].risk`.
        field: String,
        /// The value found.
        value: f64,
        /// The rule it breaks.
        rule: &'static str,
    },
    /// The instance has no nodes.
    #[error("instance has no nodes")]
    NoNodes,
    /// Node ids are not exactly 0..n-1.
    #[error("node ids must be 0..{n} without gaps or repeats: {detail}")]
    BadNodeIds {
        /// Node count.
        n: usize,
        /// What is wrong.
        detail: String,
    },
    /// A reference to a node id that does not exist.
    #[error("{field} refers to unknown node id {id} (instance has {n} nodes)")]
    UnknownNode {
        /// Where the reference is.
        field: String,
        /// The id.
        id: u64,
        /// Node count.
        n: usize,
    },
    /// `a == b` on an edge.
    #[error("edges[{index}] is a self-loop on node {node}")]
    SelfLoop {
        /// Edge index in the file.
        index: usize,
        /// The node.
        node: usize,
    },
    /// Two edges join the same pair.
    #[error("edges[{second}] duplicates edges[{first}] (both join {a} and {b})")]
    DuplicateEdge {
        /// First edge index.
        first: usize,
        /// Second edge index.
        second: usize,
        /// One end.
        a: usize,
        /// Other end.
        b: usize,
    },
    /// `start == goal`, which no shipped instance uses and the planner does not plan.
    #[error("start and goal are both node {0}: closed tours are not supported")]
    StartIsGoal(usize),
    /// An unknown objective kind.
    #[error("unknown objective kind {0:?}: expected \"max_weight\" or \"paper_cost\"")]
    UnknownObjective(String),
    /// `paper_cost` without its weights.
    #[error("objective paper_cost needs numeric phi1 and phi2")]
    MissingPhi,
}

#[derive(Serialize, Deserialize)]
struct RawInstance {
    format: String,
    #[serde(default)]
    name: String,
    speed_mps: f64,
    time_available_s: f64,
    start: u64,
    goal: u64,
    nodes: Vec<RawNode>,
    edges: Vec<RawEdge>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    objective: Option<RawObjective>,
}

#[derive(Serialize, Deserialize)]
struct RawNode {
    id: u64,
    x: f64,
    y: f64,
    z: f64,
    prize: f64,
}

#[derive(Serialize, Deserialize)]
struct RawEdge {
    a: u64,
    b: u64,
    priority: f64,
    risk: f64,
    task_time_s: f64,
}

#[derive(Serialize, Deserialize)]
struct RawObjective {
    kind: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    phi1: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    phi2: Option<f64>,
}

fn check(field: impl FnOnce() -> String, value: f64, ok: bool, rule: &'static str) -> Result<(), InstanceError> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(InstanceError::BadNumber {
            field: field(),
            value,
            rule,
        })
    }
}

impl Instance {
    /// Parses and validates a JSON document.
    pub fn from_json(text: &str) -> Result<Self, InstanceError> {
        let raw: RawInstance = serde_json::from_str(text).map_err(|e| InstanceError::Json(e.to_string()))?;
        Self::from_raw(raw)
    }

    fn from_raw(raw: RawInstance) -> Result<Self, InstanceError> {
        if raw.format != FORMAT_TAG {
            return Err(InstanceError::WrongFormat { found: raw.format });
        }
        check(|| "speed_mps".into(), raw.speed_mps, raw.speed_mps > 0.0, "> 0")?;
        check(
            || "time_available_s".into(),
            raw.time_available_s,
            raw.time_available_s > 0.0,
            "> 0",
        )?;
        let n = raw.nodes.len();
        if n == 0 {
            return Err(InstanceError::NoNodes);
        }
        let mut slots: Vec<Option<Node>> = vec![None; n];
        for (i, rn) in raw.nodes.iter().enumerate() {
            let id = usize::try_from(rn.id)
                .ok()
                .filter(|&id| id < n)
                .ok_or_else(|| InstanceError::BadNodeIds {
                    n,
                    detail: format!("nodes[{i}] has id {}", rn.id),
                })?;
            if slots[id].is_some() {
                return Err(InstanceError::BadNodeIds {
                    n,
                    detail: format!("id {id} appears twice"),
                });
            }
            for (name, v) in [("x", rn.x), ("y", rn.y), ("z", rn.z)] {
                check(|| format!("nodes[{i}].{name}"), v, true, "finite")?;
            }
            check(|| format!("nodes[{i}].prize"), rn.prize, rn.prize >= 0.0, ">= 0")?;
            slots[id] = Some(Node {
                x: rn.x,
                y: rn.y,
                z: rn.z,
                prize: rn.prize,
            });
        }
        // n slots filled by n distinct ids in 0..n: none can be empty.
        let nodes: Vec<Node> = slots.into_iter().flatten().collect();
        let node_id = |field: &str, id: u64| -> Result<usize, InstanceError> {
            usize::try_from(id)
                .ok()
                .filter(|&v| v < n)
                .ok_or_else(|| InstanceError::UnknownNode {
                    field: field.to_string(),
                    id,
                    n,
                })
        };
        let start = node_id("start", raw.start)?;
        let goal = node_id("goal", raw.goal)?;
        if start == goal {
            return Err(InstanceError::StartIsGoal(start));
        }
        let mut seen = std::collections::HashMap::with_capacity(raw.edges.len());
        let mut edges = Vec::with_capacity(raw.edges.len());
        for (i, re) in raw.edges.iter().enumerate() {
            let a = node_id(&format!("edges[{i}].a"), re.a)?;
            let b = node_id(&format!("edges[{i}].b"), re.b)?;
            if a == b {
                return Err(InstanceError::SelfLoop { index: i, node: a });
            }
            if let Some(&first) = seen.get(&(a.min(b), a.max(b))) {
                return Err(InstanceError::DuplicateEdge {
                    first,
                    second: i,
                    a: a.min(b),
                    b: a.max(b),
                });
            }
            seen.insert((a.min(b), a.max(b)), i);
            check(
                || format!("edges[{i}].priority"),
                re.priority,
                re.priority >= 0.0,
                ">= 0",
            )?;
            check(|| format!("edges[{i}].risk"), re.risk, re.risk > 0.0, "> 0")?;
            check(
                || format!("edges[{i}].task_time_s"),
                re.task_time_s,
                re.task_time_s >= 0.0,
                ">= 0",
            )?;
            edges.push(Edge {
                a,
                b,
                priority: re.priority,
                risk: re.risk,
                task_time_s: re.task_time_s,
            });
        }
        let objective = match raw.objective {
            None => Objective::MaxWeight,
            Some(o) => match o.kind.as_str() {
                "max_weight" => Objective::MaxWeight,
                "paper_cost" => {
                    let (Some(phi1), Some(phi2)) = (o.phi1, o.phi2) else {
                        return Err(InstanceError::MissingPhi);
                    };
                    check(|| "objective.phi1".into(), phi1, phi1 >= 0.0, ">= 0")?;
                    check(|| "objective.phi2".into(), phi2, phi2 >= 0.0, ">= 0")?;
                    Objective::PaperCost { phi1, phi2 }
                }
                other => return Err(InstanceError::UnknownObjective(other.to_string())),
            },
        };
        Ok(Self {
            name: raw.name,
            speed_mps: raw.speed_mps,
            time_available_s: raw.time_available_s,
            start,
            goal,
            nodes,
            edges,
            objective,
        })
    }

    /// Writes the instance as a pretty-printed JSON document.
    pub fn to_json(&self) -> String {
        let raw = RawInstance {
            format: FORMAT_TAG.to_string(),
            name: self.name.clone(),
            speed_mps: self.speed_mps,
            time_available_s: self.time_available_s,
            start: self.start as u64,
            goal: self.goal as u64,
            nodes: self
                .nodes
                .iter()
                .enumerate()
                .map(|(id, n)| RawNode {
                    id: id as u64,
                    x: n.x,
                    y: n.y,
                    z: n.z,
                    prize: n.prize,
                })
                .collect(),
            edges: self
                .edges
                .iter()
                .map(|e| RawEdge {
                    a: e.a as u64,
                    b: e.b as u64,
                    priority: e.priority,
                    risk: e.risk,
                    task_time_s: e.task_time_s,
                })
                .collect(),
            objective: Some(match self.objective {
                Objective::MaxWeight => RawObjective {
                    kind: "max_weight".into(),
                    phi1: None,
                    phi2: None,
                },
                Objective::PaperCost { phi1, phi2 } => RawObjective {
                    kind: "paper_cost".into(),
                    phi1: Some(phi1),
                    phi2: Some(phi2),
                },
            }),
        };
        // Serialising plain structs of finite numbers and strings cannot fail.
        serde_json::to_string_pretty(&raw).expect("instance serialises")
    }

    /// 3-D Euclidean distance between two nodes, m (f64, not rounded).
    #[inline]
    pub fn distance(&self, a: usize, b: usize) -> f64 {
        let (p, q) = (&self.nodes[a], &self.nodes[b]);
        distance_3d_m([p.x, p.y, p.z], [q.x, q.y, q.z])
    }

    /// The edge joining `a` and `b`, if any (linear scan: not for hot paths).
    pub fn edge_between(&self, a: usize, b: usize) -> Option<&Edge> {
        self.edges
            .iter()
            .find(|e| (e.a == a && e.b == b) || (e.a == b && e.b == a))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLE: &str = r#"{
      "format": "auv-route-instance/1",
      "name": "benoits-cove-seed-42-t0",
      "speed_mps": 1.5,
      "time_available_s": 31000.0,
      "start": 0,
      "goal": 1,
      "nodes": [
        {"id": 1, "x": 2210.5, "y": 1875.2, "z": 410.0, "prize": 0.0},
        {"id": 0, "x": 1510.0, "y": 220.0, "z": 35.0, "prize": 0.0}
      ],
      "edges": [
        {"a": 0, "b": 1, "priority": 7.0, "risk": 0.35, "task_time_s": 240.0}
      ],
      "objective": {"kind": "max_weight"}
    }"#;

    fn with(edit: impl FnOnce(&mut serde_json::Value)) -> String {
        let mut v: serde_json::Value = serde_json::from_str(EXAMPLE).unwrap();
        edit(&mut v);
        v.to_string()
    }

    #[test]
    fn parses_the_documented_example_with_nodes_in_any_order() {
        let inst = Instance::from_json(EXAMPLE).unwrap();
        assert_eq!(inst.nodes.len(), 2);
        assert_eq!(inst.nodes[0].x, 1510.0);
        assert_eq!(inst.objective, Objective::MaxWeight);
    }

    #[test]
    fn round_trips_exactly() {
        let mut inst = Instance::from_json(EXAMPLE).unwrap();
        inst.nodes[1].x = 0.1 + 0.2;
        inst.objective = Objective::PaperCost { phi1: 0.3, phi2: 1e-3 };
        let back = Instance::from_json(&inst.to_json()).unwrap();
        assert_eq!(back, inst);
    }

    #[test]
    fn objective_defaults_to_max_weight_when_absent() {
        let text = with(|v| {
            v.as_object_mut().unwrap().remove("objective");
        });
        assert_eq!(Instance::from_json(&text).unwrap().objective, Objective::MaxWeight);
    }

    #[test]
    fn rejects_each_kind_of_bad_document_by_name() {
        let cases: Vec<(String, &str)> = vec![
            ("{".into(), "instance JSON"),
            (
                with(|v| v["format"] = "auv-route-instance/2".into()),
                "unsupported format",
            ),
            (
                with(|v| {
                    v.as_object_mut().unwrap().remove("speed_mps");
                }),
                "speed_mps",
            ),
            (with(|v| v["speed_mps"] = (-1.5).into()), "speed_mps = -1.5"),
            (with(|v| v["time_available_s"] = 0.0.into()), "time_available_s"),
            (with(|v| v["nodes"][0]["prize"] = (-1.0).into()), "nodes[0].prize"),
            (with(|v| v["nodes"][0]["id"] = 5.into()), "node ids"),
            (with(|v| v["nodes"][0]["id"] = 0.into()), "appears twice"),
            (with(|v| v["nodes"] = serde_json::json!([])), "no nodes"),
            (with(|v| v["goal"] = 9.into()), "goal refers to unknown node id 9"),
            (with(|v| v["goal"] = 0.into()), "closed tours"),
            (with(|v| v["edges"][0]["b"] = 7.into()), "edges[0].b refers to unknown"),
            (with(|v| v["edges"][0]["b"] = 0.into()), "self-loop"),
            (with(|v| v["edges"][0]["risk"] = 0.0.into()), "edges[0].risk"),
            (with(|v| v["edges"][0]["priority"] = (-2.0).into()), "edges[0].priority"),
            (
                with(|v| v["edges"][0]["task_time_s"] = (-2.0).into()),
                "edges[0].task_time_s",
            ),
            (
                with(|v| {
                    let e = v["edges"][0].clone();
                    let mut rev = e.clone();
                    rev["a"] = 1.into();
                    rev["b"] = 0.into();
                    v["edges"] = serde_json::json!([e, rev]);
                }),
                "duplicates edges[0]",
            ),
            (
                with(|v| v["objective"] = serde_json::json!({"kind": "min_time"})),
                "unknown objective",
            ),
            (
                with(|v| v["objective"] = serde_json::json!({"kind": "paper_cost"})),
                "phi1 and phi2",
            ),
            (with(|v| v["speed_mps"] = "fast".into()), "instance JSON"),
        ];
        for (text, needle) in cases {
            let err = Instance::from_json(&text).expect_err(needle).to_string();
            assert!(err.contains(needle), "error {err:?} should mention {needle:?}");
        }
    }

    #[test]
    fn nan_cannot_sneak_in_through_json() {
        // JSON has no NaN literal; serde_json refuses it, so the error is a JSON one.
        let text = EXAMPLE.replace("1.5,", "NaN,");
        assert!(matches!(Instance::from_json(&text), Err(InstanceError::Json(_))));
    }
}
