//! Replacing the mission from shore: the hand-over between the bridge, which
//! receives the new mission file, and the mission's supervisor, which checks
//! it against where the vehicle is and restarts the processes with it.
//!
//! Contract: one folder of files, each written whole under a temporary name
//! and then renamed, so a reader never sees half of one.
//! - `replace-<id>.toml`: the mission file as the operator sent it (the
//!   bridge writes it);
//! - `replace-<id>.answer.json`: the supervisor's [`Answer`], written once.
//!
//! A request without an answer is pending. Answers stay, so a bridge that
//! restarted in between, or the next mission leg's bridge, still finds them:
//! a command sent again is answered again, never carried out twice.

use std::io;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// The largest mission file accepted from shore, bytes (mission files are
/// hand-written TOML: a few kB; this leaves room for hundreds of waypoints).
pub const MAX_MISSION_BYTES: usize = 256 * 1024;

/// The supervisor's answer to one request.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Answer {
    /// Whether the new mission was taken on.
    pub applied: bool,
    /// Why not (`none` when applied): `bad_mission`, `budget_out_of_range`,
    /// `mission_over`, `no_state`, `unsupported`.
    pub reason: String,
    /// The reason in words (the mission file's error line, the budgets).
    pub detail: String,
    /// Mission time of the answer, s.
    pub t: f64,
}

/// The request folder.
#[derive(Clone, Debug)]
pub struct Requests {
    dir: PathBuf,
}

impl Requests {
    /// Requests in `dir` (created on the first [`Requests::submit`]).
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        Self { dir: dir.into() }
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Where request `id`'s mission file is.
    pub fn mission_path(&self, id: u64) -> PathBuf {
        self.dir.join(format!("replace-{id}.toml"))
    }

    fn answer_path(&self, id: u64) -> PathBuf {
        self.dir.join(format!("replace-{id}.answer.json"))
    }

    /// Files request `id` with the mission file `text`.
    pub fn submit(&self, id: u64, text: &str) -> io::Result<PathBuf> {
        std::fs::create_dir_all(&self.dir)?;
        let path = self.mission_path(id);
        write_whole(&path, text.as_bytes())?;
        Ok(path)
    }

    /// Whether request `id` was filed.
    pub fn submitted(&self, id: u64) -> bool {
        self.mission_path(id).is_file()
    }

    /// The ids of the requests not answered yet, oldest id first.
    pub fn pending(&self) -> Vec<u64> {
        let Ok(entries) = std::fs::read_dir(&self.dir) else {
            return Vec::new();
        };
        let mut ids: Vec<u64> = entries
            .filter_map(|e| e.ok())
            .filter_map(|e| {
                let name = e.file_name().into_string().ok()?;
                name.strip_prefix("replace-")?.strip_suffix(".toml")?.parse().ok()
            })
            .filter(|&id| !self.answer_path(id).exists())
            .collect();
        ids.sort_unstable();
        ids
    }

    /// Answers request `id`.
    pub fn answer(&self, id: u64, a: &Answer) -> io::Result<()> {
        let text = serde_json::to_string(a).map_err(io::Error::other)?;
        write_whole(&self.answer_path(id), text.as_bytes())
    }

    /// The answer to request `id`, once there is one.
    pub fn answer_of(&self, id: u64) -> Option<Answer> {
        let text = std::fs::read_to_string(self.answer_path(id)).ok()?;
        serde_json::from_str(&text).ok()
    }
}

/// Writes `bytes` to `path` under a temporary name, then renames it.
fn write_whole(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fresh(tag: &str) -> Requests {
        let dir = std::env::temp_dir().join(format!("auv-replace-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        Requests::new(dir)
    }

    #[test]
    fn a_request_is_pending_until_answered_and_its_answer_stays() {
        let r = fresh("cycle");
        assert!(r.pending().is_empty(), "no folder yet: nothing pending");
        r.submit(9, "format = \"auv-mission/1\"\n").unwrap();
        r.submit(3, "x").unwrap();
        assert_eq!(r.pending(), vec![3, 9]);
        assert!(r.submitted(9) && !r.submitted(4));
        assert_eq!(
            std::fs::read_to_string(r.mission_path(9)).unwrap(),
            "format = \"auv-mission/1\"\n"
        );
        let a = Answer {
            applied: false,
            reason: "bad_mission".into(),
            detail: "mission file x: not TOML".into(),
            t: 12.5,
        };
        r.answer(3, &a).unwrap();
        assert_eq!(r.pending(), vec![9]);
        assert_eq!(r.answer_of(3), Some(a));
        assert_eq!(r.answer_of(9), None);
        let _ = std::fs::remove_dir_all(r.dir());
    }

    #[test]
    fn half_written_files_and_strangers_are_not_requests() {
        let r = fresh("torn");
        std::fs::create_dir_all(r.dir()).unwrap();
        for name in [
            "replace-5.toml.tmp",
            "replace-x.toml",
            "notes.toml",
            "replace-6.answer.json",
        ] {
            std::fs::write(r.dir().join(name), "junk").unwrap();
        }
        assert!(r.pending().is_empty());
        // A torn answer is no answer: the request stays pending.
        r.submit(7, "m").unwrap();
        std::fs::write(r.dir().join("replace-7.answer.json"), "{\"applied\": tr").unwrap();
        assert_eq!(r.answer_of(7), None);
        let _ = std::fs::remove_dir_all(r.dir());
    }
}
