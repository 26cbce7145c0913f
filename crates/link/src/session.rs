//! Zenoh sessions of the link: the onboard side listens, the shore side
//! connects; TCP only, explicit endpoints, multicast scouting and gossip off
//! whatever the configuration file says (the notes' rule for tests and for
//! every configuration we ship).
//!
//! Authentication and access control are Zenoh's own: a configuration file
//! the operator controls (`--zenoh-config FILE`, JSON5) with
//! `transport/auth/usrpwd` (the shore's user and password; onboard, the
//! dictionary of accepted users) and `access_control` (rules by key
//! expression and user name). We add only the mode, the endpoint and the
//! scouting switches to it.

use std::path::Path;

use zenoh::{Config, Session, Wait};

/// Why a session could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The endpoint is not `tcp/HOST:PORT`.
    #[error("endpoint {0:?}: expected tcp/HOST:PORT (e.g. tcp/127.0.0.1:7447)")]
    Endpoint(String),
    /// The configuration file could not be read or is not a Zenoh configuration.
    #[error("{path}: {detail}")]
    ConfigFile {
        /// The file.
        path: String,
        /// What was wrong.
        detail: String,
    },
    /// Zenoh refused the configuration or could not open the session
    /// (e.g. the port is taken).
    #[error("zenoh: {0}")]
    Open(String),
}

/// Which side of the link a session is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The vehicle's bridge: listens on the endpoint.
    Onboard,
    /// The operator's console: connects to the endpoint, and keeps trying.
    Shore,
}

/// Checks that `endpoint` is `tcp/HOST:PORT` with a port number.
pub fn check_endpoint(endpoint: &str) -> Result<(), SessionError> {
    let bad = || SessionError::Endpoint(endpoint.to_string());
    let rest = endpoint.strip_prefix("tcp/").ok_or_else(bad)?;
    let (host, port) = rest.rsplit_once(':').ok_or_else(bad)?;
    if host.is_empty() || port.parse::<u16>().is_err() {
        return Err(bad());
    }
    Ok(())
}

/// The configuration of one side: `file` (if any) with our mode, endpoint
/// and scouting settings on top.
pub fn config(side: Side, endpoint: &str, file: Option<&Path>) -> Result<Config, SessionError> {
    check_endpoint(endpoint)?;
    let mut cfg = match file {
        Some(p) => Config::from_file(p).map_err(|e| SessionError::ConfigFile {
            path: p.display().to_string(),
            detail: e.to_string(),
        })?,
        None => Config::default(),
    };
    let endpoints = serde_json::to_string(&[endpoint]).unwrap_or_default();
    let mut set = |key: &str, value: &str| {
        cfg.insert_json5(key, value)
            .map_err(|e| SessionError::Open(format!("{key} = {value}: {e}")))
    };
    set("mode", "\"peer\"")?;
    set("scouting/multicast/enabled", "false")?;
    set("scouting/gossip/enabled", "false")?;
    match side {
        Side::Onboard => {
            set("listen/endpoints", &endpoints)?;
            set("connect/endpoints", "[]")?;
        }
        Side::Shore => {
            set("listen/endpoints", "[]")?;
            set("connect/endpoints", &endpoints)?;
            // Never give up and connect in the background (an infinite
            // timeout with exit_on_failure off; a zero timeout would mean
            // one attempt and no retry), retrying quickly: the console must
            // start before the vehicle and come back with the link.
            set("connect/timeout_ms", "-1")?;
            set("connect/exit_on_failure", "false")?;
            set(
                "connect/retry",
                "{period_init_ms: 100, period_max_ms: 1000, period_increase_factor: 2}",
            )?;
        }
    }
    Ok(cfg)
}

/// Opens the session of `side` on `endpoint`.
pub fn open(side: Side, endpoint: &str, file: Option<&Path>) -> Result<Session, SessionError> {
    // Zenoh's own diagnostics on stderr, at the level `RUST_LOG` asks for
    // (errors only by default): a link that does not come up says why.
    zenoh::init_log_from_env_or("error");
    let cfg = config(side, endpoint, file)?;
    zenoh::open(cfg).wait().map_err(|e| SessionError::Open(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints_must_be_tcp_host_port() {
        assert!(check_endpoint("tcp/127.0.0.1:7447").is_ok());
        for bad in [
            "udp/1.2.3.4:5",
            "tcp/127.0.0.1",
            "tcp/:80",
            "tcp/h:99999",
            "127.0.0.1:7447",
        ] {
            let e = check_endpoint(bad).unwrap_err();
            assert!(e.to_string().contains("tcp/HOST:PORT"), "{e}");
        }
    }

    #[test]
    fn scouting_is_off_even_when_the_file_turns_it_on() {
        let dir = std::env::temp_dir().join(format!("auv-link-cfg-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("z.json5");
        std::fs::write(
            &f,
            "{ scouting: { multicast: { enabled: true }, gossip: { enabled: true } } }",
        )
        .unwrap();
        let cfg = config(Side::Shore, "tcp/127.0.0.1:7447", Some(&f)).unwrap();
        assert_eq!(cfg.get_json("scouting/multicast/enabled").unwrap(), "false");
        assert_eq!(cfg.get_json("scouting/gossip/enabled").unwrap(), "false");
        assert_eq!(cfg.get_json("connect/endpoints").unwrap(), "[\"tcp/127.0.0.1:7447\"]");
        std::fs::write(&f, "{ not json5").unwrap();
        let e = config(Side::Onboard, "tcp/127.0.0.1:7447", Some(&f)).unwrap_err();
        assert!(e.to_string().contains("z.json5"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
