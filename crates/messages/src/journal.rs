//! The vehicle's journal: an append-only file of JSON lines, one per event
//! the vehicle acted on (start or resume, plan accepted, arrival, task
//! completed, mission end), written and flushed to the OS as it happens.
//!
//! Contract:
//! - A line is complete or absent: each is written with one `write` call on
//!   an unbuffered file opened for appending, so a SIGKILL at any moment
//!   loses no event already acted on and leaves no half line (a torn last
//!   line, e.g. after a power cut, is ignored when reading).
//! - [`JournalSummary::read`] is the single source of the report's
//!   figures: tasks, weight, route, distance and time are what the journal
//!   says, so the report adds up across restarts of any process.
//! - A restarted vehicle resumes from [`JournalSummary::resume`]: at the
//!   last waypoint it arrived at, at the mission time of its last event,
//!   with the tasks, weight, visited waypoints and the plan it had.
//! - Floats print shortest-round-trip and parse exactly (serde_json
//!   `float_roundtrip`), so sums read back are bit-identical.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use serde_json::{Value, json};

use crate::msg::{FromCode, Outcome};

/// Why the journal could not be used.
#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    /// The file could not be opened, read or written.
    #[error("journal {path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// A complete line that is not a journal event.
    #[error("journal {path}, line {line}: {message}")]
    Bad {
        /// The file.
        path: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// One journal event.
#[derive(Clone, Debug, PartialEq)]
pub enum JournalEvent {
    /// The vehicle started (`resumed`: from an earlier journal) at mission time `t`, s.
    Start {
        /// Mission time, s.
        t: f64,
        /// Waypoint it starts at.
        node: usize,
        /// Whether it resumed from an earlier process's journal.
        resumed: bool,
    },
    /// A plan was accepted.
    Plan {
        /// Mission time, s.
        t: f64,
        /// The plan's sequence number (its sender's).
        seq: u64,
        /// The route from the vehicle's next waypoint to the goal.
        route: Vec<usize>,
    },
    /// The vehicle reached `node`; its task (`task_s`, worth `task_weight`) starts.
    Arrival {
        /// Mission time, s.
        t: f64,
        /// The waypoint.
        node: usize,
        /// Position (x east, y north, z depth down), m.
        pos: [f64; 3],
        /// Distance travelled so far, m.
        distance_m: f64,
        /// Duration of the task that starts, s.
        task_s: f64,
        /// Weight the task earns.
        task_weight: f64,
    },
    /// The task at `node` is done and earned `weight`.
    Task {
        /// Mission time, s.
        t: f64,
        /// The waypoint.
        node: usize,
        /// Weight earned by this task.
        weight: f64,
    },
    /// The vehicle stopped at waypoint `node` to hold there (a safe hold:
    /// the supervisor asked for it because a process kept failing).
    Hold {
        /// Mission time, s.
        t: f64,
        /// The waypoint it holds at.
        node: usize,
    },
    /// The mission ended.
    End {
        /// Mission time, s.
        t: f64,
        /// How.
        outcome: Outcome,
    },
}

fn outcome_code(s: &str) -> Option<Outcome> {
    [
        Outcome::Running,
        Outcome::GoalReached,
        Outcome::TimedOut,
        Outcome::Aborted,
        Outcome::SafeHold,
    ]
    .into_iter()
    .find(|&o| crate::msg::outcome_name(o) == s)
}

impl JournalEvent {
    /// The event as one JSON object.
    pub fn to_json(&self) -> Value {
        match self {
            Self::Start { t, node, resumed } => json!({"event": "start", "t": t, "node": node, "resumed": resumed}),
            Self::Plan { t, seq, route } => json!({"event": "plan", "t": t, "seq": seq, "route": route}),
            Self::Arrival {
                t,
                node,
                pos,
                distance_m,
                task_s,
                task_weight,
            } => json!({
                "event": "arrival", "t": t, "node": node, "x": pos[0], "y": pos[1], "z": pos[2],
                "distance_m": distance_m, "task_s": task_s, "task_weight": task_weight,
            }),
            Self::Task { t, node, weight } => json!({"event": "task", "t": t, "node": node, "weight": weight}),
            Self::Hold { t, node } => json!({"event": "hold", "t": t, "node": node}),
            Self::End { t, outcome } => {
                json!({"event": "end", "t": t, "outcome": crate::msg::outcome_name(*outcome)})
            }
        }
    }

    /// Parses one JSON line; `Err` names what is missing.
    pub fn from_json(v: &Value) -> Result<Self, String> {
        let f = |k: &str| v[k].as_f64().ok_or_else(|| format!("no number \"{k}\""));
        let u = |k: &str| v[k].as_u64().ok_or_else(|| format!("no integer \"{k}\""));
        let t = f("t")?;
        match v["event"].as_str() {
            Some("start") => Ok(Self::Start {
                t,
                node: u("node")? as usize,
                resumed: v["resumed"].as_bool().unwrap_or(false),
            }),
            Some("plan") => Ok(Self::Plan {
                t,
                seq: u("seq")?,
                route: v["route"]
                    .as_array()
                    .ok_or("no \"route\"")?
                    .iter()
                    .map(|x| x.as_u64().map(|x| x as usize).ok_or("bad route entry"))
                    .collect::<Result<_, _>>()?,
            }),
            Some("arrival") => Ok(Self::Arrival {
                t,
                node: u("node")? as usize,
                pos: [f("x")?, f("y")?, f("z")?],
                distance_m: f("distance_m")?,
                task_s: f("task_s")?,
                task_weight: f("task_weight")?,
            }),
            Some("task") => Ok(Self::Task {
                t,
                node: u("node")? as usize,
                weight: f("weight")?,
            }),
            Some("hold") => Ok(Self::Hold {
                t,
                node: u("node")? as usize,
            }),
            Some("end") => Ok(Self::End {
                t,
                outcome: v["outcome"]
                    .as_str()
                    .and_then(outcome_code)
                    .or_else(|| v["outcome"].as_u64().and_then(|c| Outcome::from_code(c as u32)))
                    .ok_or("bad \"outcome\"")?,
            }),
            other => Err(format!("unknown event {other:?}")),
        }
    }
}

/// The append-only writer.
pub struct Journal {
    file: File,
    path: PathBuf,
    line: Vec<u8>,
}

impl Journal {
    /// Opens `path` for appending (created if missing).
    pub fn open(path: &Path) -> Result<Self, JournalError> {
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(|e| io_err(path, e))?;
        Ok(Self {
            file,
            path: path.to_path_buf(),
            line: Vec::with_capacity(512),
        })
    }

    /// Appends `e` as one line in one write (no user-space buffer: the
    /// event is in the OS once this returns).
    pub fn append(&mut self, e: &JournalEvent) -> Result<(), JournalError> {
        self.line.clear();
        // Writing a Value into a Vec cannot fail.
        let _ = serde_json::to_writer(&mut self.line, &e.to_json());
        self.line.push(b'\n');
        self.file.write_all(&self.line).map_err(|err| io_err(&self.path, err))
    }
}

fn io_err(path: &Path, e: impl std::fmt::Display) -> JournalError {
    JournalError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Where a restarted vehicle picks up.
#[derive(Clone, Debug, PartialEq)]
pub struct Resume {
    /// Mission time of the last event, s.
    pub t: f64,
    /// Waypoints visited in order (start first; the last is where it is).
    pub route: Vec<usize>,
    /// Tasks completed.
    pub tasks: u32,
    /// Weight collected.
    pub weight: f64,
    /// Distance travelled up to the last arrival, m.
    pub distance_m: f64,
    /// The task started at the last waypoint and not yet done: (s, weight).
    pub pending_task: Option<(f64, f64)>,
    /// The last plan accepted: (seq, route).
    pub plan: Option<(u64, Vec<usize>)>,
}

/// What a journal says, read back.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JournalSummary {
    /// Every event, in order.
    pub events: Vec<JournalEvent>,
}

impl JournalSummary {
    /// Reads `path` (missing file: empty). A torn last line is ignored; a
    /// bad complete line is an error.
    pub fn read(path: &Path) -> Result<Self, JournalError> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Self::default()),
            Err(e) => return Err(io_err(path, e)),
        };
        let complete = text.ends_with('\n');
        let lines: Vec<&str> = text.lines().collect();
        let mut events = Vec::with_capacity(lines.len());
        for (i, l) in lines.iter().enumerate() {
            let torn_tail = i + 1 == lines.len() && !complete;
            let parsed = serde_json::from_str::<Value>(l)
                .map_err(|e| e.to_string())
                .and_then(|v| JournalEvent::from_json(&v));
            match parsed {
                Ok(e) => events.push(e),
                Err(_) if torn_tail => {}
                Err(message) => {
                    return Err(JournalError::Bad {
                        path: path.display().to_string(),
                        line: i + 1,
                        message,
                    });
                }
            }
        }
        Ok(Self { events })
    }

    /// Tasks completed.
    pub fn tasks(&self) -> u32 {
        self.events
            .iter()
            .filter(|e| matches!(e, JournalEvent::Task { .. }))
            .count() as u32
    }

    /// Weight collected (the sum of the tasks' weights, in order).
    pub fn weight(&self) -> f64 {
        self.events
            .iter()
            .map(|e| match e {
                JournalEvent::Task { weight, .. } => *weight,
                _ => 0.0,
            })
            .fold(0.0, |a, w| a + w)
    }

    /// Waypoints visited in order: the first start's node, then every arrival.
    pub fn route(&self) -> Vec<usize> {
        let mut r = Vec::new();
        for e in &self.events {
            match e {
                JournalEvent::Start { node, .. } if r.is_empty() => r.push(*node),
                JournalEvent::Arrival { node, .. } => r.push(*node),
                _ => {}
            }
        }
        r
    }

    /// Distance travelled up to the last arrival, m.
    pub fn distance_m(&self) -> f64 {
        self.events
            .iter()
            .rev()
            .find_map(|e| match e {
                JournalEvent::Arrival { distance_m, .. } => Some(*distance_m),
                _ => None,
            })
            .unwrap_or(0.0)
    }

    /// Mission time of the last event, s.
    pub fn time_s(&self) -> f64 {
        self.events.iter().map(Self::t).fold(0.0, f64::max)
    }

    fn t(e: &JournalEvent) -> f64 {
        match e {
            JournalEvent::Start { t, .. }
            | JournalEvent::Plan { t, .. }
            | JournalEvent::Arrival { t, .. }
            | JournalEvent::Task { t, .. }
            | JournalEvent::Hold { t, .. }
            | JournalEvent::End { t, .. } => *t,
        }
    }

    /// How the mission ended (`None`: no end recorded yet).
    pub fn outcome(&self) -> Option<Outcome> {
        self.events.iter().rev().find_map(|e| match e {
            JournalEvent::End { outcome, .. } => Some(*outcome),
            _ => None,
        })
    }

    /// Plans the vehicle accepted.
    pub fn plans_accepted(&self) -> u64 {
        self.events
            .iter()
            .filter(|e| matches!(e, JournalEvent::Plan { .. }))
            .count() as u64
    }

    /// Times the vehicle was restarted and resumed from the journal.
    pub fn restarts(&self) -> u64 {
        self.events
            .iter()
            .filter(|e| matches!(e, JournalEvent::Start { resumed: true, .. }))
            .count() as u64
    }

    /// Where a restarted vehicle picks up (`None`: nothing to resume, i.e.
    /// no start recorded, or the mission already ended).
    pub fn resume(&self) -> Option<Resume> {
        if self.outcome().is_some() {
            return None;
        }
        let route = self.route();
        if route.is_empty() {
            return None;
        }
        let mut pending_task = None;
        let mut plan = None;
        for e in &self.events {
            match e {
                JournalEvent::Arrival {
                    task_s, task_weight, ..
                } => pending_task = Some((*task_s, *task_weight)),
                JournalEvent::Task { .. } => pending_task = None,
                JournalEvent::Plan { seq, route, .. } => plan = Some((*seq, route.clone())),
                _ => {}
            }
        }
        Some(Resume {
            t: self.time_s(),
            route,
            tasks: self.tasks(),
            weight: self.weight(),
            distance_m: self.distance_m(),
            pending_task,
            plan,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("journal-test-{}-{name}", std::process::id()));
        let _ = std::fs::remove_file(&d);
        d
    }

    fn sample() -> Vec<JournalEvent> {
        vec![
            JournalEvent::Start {
                t: 0.0,
                node: 0,
                resumed: false,
            },
            JournalEvent::Plan {
                t: 0.0,
                seq: 1,
                route: vec![0, 4, 2, 9],
            },
            JournalEvent::Arrival {
                t: 100.25,
                node: 4,
                pos: [1.5, -2.0, 30.0],
                distance_m: 150.125,
                task_s: 10.0,
                task_weight: 0.1,
            },
            JournalEvent::Task {
                t: 110.25,
                node: 4,
                weight: 0.1,
            },
            JournalEvent::Arrival {
                t: 200.0,
                node: 2,
                pos: [3.0, 4.0, 5.0],
                distance_m: 300.0,
                task_s: 20.0,
                task_weight: 0.2,
            },
        ]
    }

    #[test]
    fn events_round_trip_and_the_summary_adds_up() {
        let p = temp("rt");
        let mut j = Journal::open(&p).unwrap();
        for e in sample() {
            j.append(&e).unwrap();
        }
        let s = JournalSummary::read(&p).unwrap();
        assert_eq!(s.events, sample());
        assert_eq!(s.tasks(), 1);
        assert_eq!(s.weight(), 0.1);
        assert_eq!(s.route(), vec![0, 4, 2]);
        assert_eq!(s.distance_m(), 300.0);
        assert_eq!(s.time_s(), 200.0);
        assert_eq!(s.outcome(), None);
        let r = s.resume().unwrap();
        assert_eq!(r.pending_task, Some((20.0, 0.2)), "the task at 2 was not done");
        assert_eq!(r.plan, Some((1, vec![0, 4, 2, 9])));
        assert_eq!(r.t, 200.0);
        // The mission ends: nothing left to resume.
        j.append(&JournalEvent::End {
            t: 220.0,
            outcome: Outcome::TimedOut,
        })
        .unwrap();
        let s = JournalSummary::read(&p).unwrap();
        assert_eq!(s.outcome(), Some(Outcome::TimedOut));
        assert_eq!(s.resume(), None);
        let _ = std::fs::remove_file(&p);
    }

    #[test]
    fn a_torn_last_line_is_ignored_but_a_bad_complete_line_is_an_error() {
        let p = temp("torn");
        let mut j = Journal::open(&p).unwrap();
        j.append(&sample()[0]).unwrap();
        drop(j);
        let mut f = OpenOptions::new().append(true).open(&p).unwrap();
        f.write_all(b"{\"event\":\"arr").unwrap();
        assert_eq!(JournalSummary::read(&p).unwrap().events.len(), 1);
        f.write_all(b"\n").unwrap();
        let e = JournalSummary::read(&p).unwrap_err().to_string();
        assert!(e.contains("line 2"), "{e}");
        let _ = std::fs::remove_file(&p);
        assert_eq!(JournalSummary::read(&p).unwrap(), JournalSummary::default());
    }
}
