//! The key expressions of one vehicle, all under `auv/<vehicle>/`.

/// Vehicle state, onboard → shore.
pub const STATE: &str = "state";
/// Each plan, onboard → shore.
pub const PLAN: &str = "plan";
/// Planner status, onboard → shore.
pub const STATUS: &str = "status";
/// Waypoint snapshot summary, onboard → shore.
pub const SNAPSHOT: &str = "snapshot";
/// Link and mission events (link lost/restored, mission ended), onboard → shore.
pub const EVENT: &str = "event";
/// Command acks, onboard → shore.
pub const ACK: &str = "ack";
/// Operator commands, shore → onboard.
pub const COMMAND: &str = "command";
/// The bridge's heartbeat, onboard → shore.
pub const HEARTBEAT_ONBOARD: &str = "heartbeat/onboard";
/// The console's heartbeat, shore → onboard.
pub const HEARTBEAT_SHORE: &str = "heartbeat/shore";

/// Every plan the bridge forwarded (up to its history), for a console that
/// (re)connects: the plans it missed.
pub const PLAN_HISTORY: &str = "history/plan";

/// The leaves the bridge's catch-up queryable answers for.
pub const LATEST: [&str; 4] = [STATE, PLAN, STATUS, SNAPSHOT];

/// `auv/<vehicle>/<leaf>`.
pub fn key(vehicle: &str, leaf: &str) -> String {
    format!("auv/{vehicle}/{leaf}")
}

/// Everything of one vehicle: `auv/<vehicle>/**`.
pub fn all(vehicle: &str) -> String {
    format!("auv/{vehicle}/**")
}

/// What the catch-up query asks for: `auv/<vehicle>/*` (the queryable
/// answers with the latest state, plan, status and snapshot).
pub fn latest(vehicle: &str) -> String {
    format!("auv/{vehicle}/*")
}

/// The leaf of `key` below `auv/<vehicle>/`, if it is one of that vehicle's keys.
pub fn leaf<'k>(vehicle: &str, key: &'k str) -> Option<&'k str> {
    key.strip_prefix("auv/")?.strip_prefix(vehicle)?.strip_prefix('/')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_namespaced_per_vehicle() {
        assert_eq!(key("auv1", PLAN), "auv/auv1/plan");
        assert_eq!(key("auv1", HEARTBEAT_SHORE), "auv/auv1/heartbeat/shore");
        assert_eq!(leaf("auv1", "auv/auv1/heartbeat/onboard"), Some(HEARTBEAT_ONBOARD));
        assert_eq!(leaf("auv1", "auv/auv12/plan"), None);
        assert_eq!(leaf("auv1", "x/auv1/plan"), None);
    }
}
