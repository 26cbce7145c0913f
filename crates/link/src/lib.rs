//! The shore link: the vehicle's onboard topics on Zenoh, for an operator's
//! console on another machine, and the operator's commands back.
//!
//! Contract:
//! - Onboard, one bridge process ([`bridge`]) subscribes to the iceoryx2
//!   topics (vehicle state, plans, planner status, waypoint snapshots, command
//!   acks) as one outside client and publishes each message as JSON on a key
//!   expression of our own ([`keys`]): `auv/<vehicle>/state`, `…/plan`,
//!   `…/status`, `…/snapshot`, `…/event`, `…/ack`, `…/heartbeat/onboard`.
//!   Every payload carries its format ([`encode::FORMAT`], `auv-shore/1`) and
//!   its type name (the iceoryx2 type it came from, `auv.Plan.v3`), so a
//!   Python or ROS 2 (`rmw_zenoh`) client can read it with a JSON parser.
//! - Shore → vehicle: `…/heartbeat/shore` and `…/command` (a command names
//!   waypoints by name; the bridge resolves and forwards it as an
//!   `auv.OperatorCommand.v1`, the planner validates and acknowledges it).
//! - Both sides watch the other's heartbeats ([`monitor::LinkMonitor`]): the
//!   link is lost after `--link-timeout-ms` of silence, restored at the next
//!   heartbeat. A shore that (re)connects asks the bridge's queryable on
//!   `auv/<vehicle>/*` for the latest of each topic.
//! - The vehicle never depends on the link: the bridge only reads the
//!   onboard topics (history, safe overflow: it can never block a publisher)
//!   and publishes commands; killing it changes nothing onboard.
//! - Sessions ([`session`]): TCP only, multicast scouting and gossip always
//!   off, explicit endpoints; authentication (user/password) and access
//!   control come from a Zenoh configuration file the operator controls.
#![warn(missing_docs)]

pub mod bridge;
pub mod console;
pub mod encode;
pub mod keys;
pub mod monitor;
pub mod replace;
pub mod session;
