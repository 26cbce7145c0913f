//! One supervised child process: how it is started (again), signalled,
//! reaped and stopped, with its stderr appended to `<out>/<name>.log`.
//!
//! Every child is tied to the life of the thread that started it
//! (`PR_SET_PDEATHSIG`): when the supervisor dies, even by SIGKILL, the
//! kernel sends the child SIGTERM, and the child stops the way Ctrl-C stops
//! it (ports dropped, its shared memory removed). A supervisor that died
//! between `fork` and the `prctl` is caught by comparing the parent pid.
//! The children must therefore be started from a thread that lives as long
//! as the mission (the mission's own thread).

use std::fs::File;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// A child process and where its stderr goes.
pub struct Kid {
    /// Its name in logs and reports (`planner`, `sensor-sim`, `vehicle-sim`).
    pub name: &'static str,
    child: Option<Child>,
    log: PathBuf,
    status: Option<ExitStatus>,
    bin: PathBuf,
    args: Vec<String>,
    /// Played by a process the operator started (`--external-vehicle`):
    /// never started, signalled or restarted here, and never seen to exit.
    outside: bool,
}

/// Why a child could not be started.
#[derive(Debug, thiserror::Error)]
pub enum ChildError {
    /// Its log could not be opened.
    #[error("{path}: {message}")]
    Log {
        /// The log file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// `fork`/`exec` failed.
    #[error("cannot start {bin}: {message}")]
    Spawn {
        /// The binary.
        bin: String,
        /// What went wrong.
        message: String,
    },
}

impl Kid {
    /// `bin` with `args`, named `name`; its log starts empty. Not started yet.
    pub fn new(name: &'static str, bin: PathBuf, args: &[String], out: &Path) -> Result<Self, ChildError> {
        let log = out.join(format!("{name}.log"));
        File::create(&log).map_err(|e| ChildError::Log {
            path: log.display().to_string(),
            message: e.to_string(),
        })?;
        Ok(Self {
            name,
            child: None,
            log,
            status: None,
            bin,
            args: args.to_vec(),
            outside: false,
        })
    }

    /// The role `name` played by an outside process: the supervisor only
    /// watches its messages.
    pub fn outside(name: &'static str, out: &Path) -> Result<Self, ChildError> {
        let mut k = Self::new(name, PathBuf::new(), &[], out)?;
        k.outside = true;
        Ok(k)
    }

    /// Starts the process (again), with `extra` flags; stderr appends to its log.
    pub fn start(&mut self, extra: &[String]) -> Result<(), ChildError> {
        if self.outside {
            return Ok(());
        }
        let err = File::options()
            .append(true)
            .open(&self.log)
            .map_err(|e| ChildError::Log {
                path: self.log.display().to_string(),
                message: e.to_string(),
            })?;
        let parent = std::process::id() as libc::pid_t;
        let mut cmd = Command::new(&self.bin);
        cmd.args(&self.args)
            .args(extra)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(err);
        // SAFETY: the closure runs in the forked child before exec and only
        // makes async-signal-safe system calls (prctl, getppid).
        unsafe {
            cmd.pre_exec(move || {
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM as libc::c_ulong, 0, 0, 0) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                // The supervisor died before the prctl: do not start orphaned.
                if libc::getppid() != parent {
                    return Err(std::io::Error::from_raw_os_error(libc::ESRCH));
                }
                Ok(())
            });
        }
        let child = cmd.spawn().map_err(|e| ChildError::Spawn {
            bin: self.bin.display().to_string(),
            message: e.to_string(),
        })?;
        self.child = Some(child);
        self.status = None;
        Ok(())
    }

    /// Its pid while it runs.
    pub fn pid(&self) -> Option<u32> {
        self.child.as_ref().map(Child::id)
    }

    /// Whether it has exited (reaps it).
    pub fn poll(&mut self) -> bool {
        if self.outside {
            return false;
        }
        if self.status.is_some() {
            return true;
        }
        if let Some(c) = &mut self.child
            && let Ok(Some(st)) = c.try_wait()
        {
            self.status = Some(st);
            self.child = None;
        }
        self.status.is_some()
    }

    /// Whether it runs now (started, not exited).
    pub fn running(&mut self) -> bool {
        self.outside || (self.child.is_some() && !self.poll())
    }

    /// How it exited, once it has.
    pub fn exit_status(&self) -> Option<ExitStatus> {
        self.status
    }

    /// Forgets the last exit (the supervisor has handled it).
    pub fn clear_exit(&mut self) {
        self.status = None;
    }

    /// Resident set size now, kB (`None`: not running).
    pub fn rss_kb(&self) -> Option<u64> {
        rss_kb_of(self.child.as_ref()?.id())
    }

    /// Sends `sig` while it runs.
    pub fn signal(&self, sig: i32) {
        if let Some(c) = &self.child {
            // SAFETY: a signal to our own, not yet reaped child's pid.
            unsafe { libc::kill(c.id() as libc::pid_t, sig) };
        }
    }

    /// Waits up to `t`, then SIGTERM, then SIGKILL.
    pub fn finish(&mut self, t: Duration) {
        let t0 = Instant::now();
        while !self.poll() && self.child.is_some() && t0.elapsed() < t {
            std::thread::sleep(Duration::from_millis(10));
        }
        if !self.poll() && self.child.is_some() {
            self.signal(libc::SIGCONT);
            self.signal(libc::SIGTERM);
            let t1 = Instant::now();
            while !self.poll() && t1.elapsed() < Duration::from_secs(2) {
                std::thread::sleep(Duration::from_millis(10));
            }
        }
        if !self.poll()
            && let Some(c) = &mut self.child
        {
            let _ = c.kill();
            self.status = c.wait().ok();
            self.child = None;
        }
    }

    /// The last lines of its log, for error messages.
    pub fn log_tail(&self) -> String {
        let tail = std::fs::read_to_string(&self.log).unwrap_or_default();
        tail.lines().rev().take(3).collect::<Vec<_>>().join(" | ")
    }
}

impl Drop for Kid {
    fn drop(&mut self) {
        if self.child.is_some() {
            self.finish(Duration::ZERO);
        }
    }
}

/// Resident set size of process `pid`, kB (`VmRSS` in `/proc/<pid>/status`).
pub fn rss_kb_of(pid: u32) -> Option<u64> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    text.lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

/// Parent pid of process `pid` (`None`: no such process).
pub fn parent_of(pid: u32) -> Option<u32> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // Fields after the parenthesised command name: state, then ppid.
    let rest = stat.get(stat.rfind(')')? + 2..)?;
    rest.split(' ').nth(1)?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_child_reports_its_exit_and_its_parent() {
        let dir = std::env::temp_dir().join(auv_transport::unique_prefix("kid"));
        std::fs::create_dir_all(&dir).unwrap();
        let mut k = Kid::new("sleeper", "sleep".into(), &["30".into()], &dir).unwrap();
        k.start(&[]).unwrap();
        let pid = k.pid().unwrap();
        assert_eq!(parent_of(pid), Some(std::process::id()));
        assert!(k.running());
        k.signal(libc::SIGKILL);
        let t0 = Instant::now();
        while !k.poll() {
            assert!(t0.elapsed() < Duration::from_secs(30), "not reaped");
            std::thread::sleep(Duration::from_millis(5));
        }
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(k.exit_status().and_then(|s| s.signal()), Some(libc::SIGKILL));
        assert!(!k.running());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
