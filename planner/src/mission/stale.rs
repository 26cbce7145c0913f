//! Leftovers of supervisors that died without cleaning up (SIGKILL, power
//! loss): every mission marks the iceoryx2 domain it runs in with a small
//! file naming its process (`<tmp>/auv-planner-runs/<prefix>`: pid and start
//! time, so a reused pid is not mistaken for it), and removes the mark when
//! it has retired the domain. A mission that starts cleans the domains of
//! marks whose process is gone: dead nodes' resources first, then, once no
//! node of the domain is alive (children stop when their supervisor dies),
//! the domain itself and the mark.

use std::path::{Path, PathBuf};

use auv_transport::ipc::{cleanup_dead_nodes, domain_config, retire_domain};

/// Where the marks live.
fn marks_dir() -> PathBuf {
    std::env::temp_dir().join("auv-planner-runs")
}

/// Start time of process `pid` in clock ticks since boot (field 22 of
/// `/proc/<pid>/stat`); `None` when there is no such process.
fn start_time(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let rest = stat.get(stat.rfind(')')? + 2..)?;
    rest.split(' ').nth(22 - 3)?.parse().ok()
}

/// The mark of this process's run in domain `prefix`; removed on drop.
pub struct RunMark {
    path: PathBuf,
}

impl RunMark {
    /// Marks domain `prefix` as this process's (best effort: without the
    /// mark only the automatic clean-up of a later run is lost).
    pub fn new(prefix: &str) -> Self {
        let dir = marks_dir();
        let path = dir.join(prefix);
        let me = std::process::id();
        if std::fs::create_dir_all(&dir).is_ok() {
            let _ = std::fs::write(&path, format!("{me} {}\n", start_time(me).unwrap_or(0)));
        }
        Self { path }
    }
}

impl Drop for RunMark {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Whether the process a mark names is still the one that wrote it.
fn owner_alive(mark: &Path) -> bool {
    let Ok(text) = std::fs::read_to_string(mark) else {
        return false;
    };
    let mut it = text.split_whitespace().map(|w| w.parse::<u64>().ok());
    let (Some(Some(pid)), Some(Some(start))) = (it.next(), it.next()) else {
        return false;
    };
    u32::try_from(pid).ok().and_then(start_time) == Some(start)
}

/// Cleans the domains of runs whose supervisor is gone; returns the domains
/// removed whole (a domain whose nodes still live is left for a later run).
pub fn clean_stale_runs() -> usize {
    let Ok(entries) = std::fs::read_dir(marks_dir()) else {
        return 0;
    };
    let mut removed = 0;
    for e in entries.flatten() {
        let path = e.path();
        if owner_alive(&path) {
            continue;
        }
        let prefix = e.file_name().to_string_lossy().into_owned();
        let Ok(cfg) = domain_config(&prefix) else {
            let _ = std::fs::remove_file(&path);
            continue;
        };
        cleanup_dead_nodes(&cfg);
        if retire_domain(&prefix).unwrap_or(false) {
            let _ = std::fs::remove_file(&path);
            removed += 1;
        }
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mark_is_alive_while_its_process_runs_and_goes_with_it() {
        let prefix = auv_transport::unique_prefix("sm");
        let mark = RunMark::new(&prefix);
        assert!(owner_alive(&mark.path));
        // A mark of a process that is gone (pid 0 never names one).
        let dead = marks_dir().join(auv_transport::unique_prefix("sd"));
        std::fs::write(&dead, "0 1\n").unwrap();
        assert!(!owner_alive(&dead));
        clean_stale_runs();
        assert!(!dead.exists(), "the dead run's empty domain is cleaned with its mark");
        assert!(mark.path.exists(), "a live run is left alone");
        let p = mark.path.clone();
        drop(mark);
        assert!(!p.exists());
    }
}
