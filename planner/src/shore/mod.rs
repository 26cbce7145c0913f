//! The shore link's commands: `planner link` (the onboard bridge, started
//! by `planner mission --shore`) and `planner shore` (the operator's
//! console). The protocol, encoding and sessions live in `auv_link`.

#[cfg(feature = "shore")]
pub mod console;
#[cfg(feature = "shore")]
pub mod link;

use std::path::PathBuf;

/// Smallest `--link-timeout-ms` (our choice: heartbeats every 12.5 ms at
/// most; the link crate checks the same bound).
pub const MIN_TIMEOUT_MS: u64 = 50;

/// Link flags shared by `planner mission --shore`, `planner link` and `planner shore`.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct LinkOptions {
    /// The link counts as lost after this long without the far side's
    /// heartbeat, real ms (heartbeats go out four times per timeout).
    #[arg(long, default_value_t = 1000)]
    pub link_timeout_ms: u64,
    /// Zenoh configuration file (JSON5) for authentication and access
    /// control (`transport/auth/usrpwd`, `access_control`); the mode, the
    /// endpoint and scouting (always off) are set on top of it.
    #[arg(long, value_name = "FILE")]
    pub zenoh_config: Option<PathBuf>,
}

impl LinkOptions {
    /// The link timeout; `Err` names the flag out of range.
    pub fn timeout(&self) -> Result<std::time::Duration, String> {
        let min = MIN_TIMEOUT_MS;
        if self.link_timeout_ms < min || self.link_timeout_ms > 600_000 {
            return Err(format!(
                "--link-timeout-ms {}: must be between {min} and 600000",
                self.link_timeout_ms
            ));
        }
        if let Some(f) = &self.zenoh_config
            && !f.is_file()
        {
            return Err(format!("--zenoh-config {}: no such file", f.display()));
        }
        Ok(std::time::Duration::from_millis(self.link_timeout_ms))
    }

    /// The flags that give these options to a child process.
    pub fn to_flags(&self) -> Vec<String> {
        let mut f = vec!["--link-timeout-ms".to_string(), self.link_timeout_ms.to_string()];
        if let Some(p) = &self.zenoh_config {
            let p = std::path::absolute(p).unwrap_or_else(|_| p.clone());
            f.extend(["--zenoh-config".into(), p.display().to_string()]);
        }
        f
    }
}
