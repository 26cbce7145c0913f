//! The world the vehicle plans in: charts with their water masks
//! ([`chart`]), the paper's network of static and drifting waypoints on a
//! chart ([`scenario`]), the operator's mission files (`auv-mission/1`,
//! [`mission_file`]) and the lat/lon ↔ local frame ([`frame`]), the truncated normal that moves the drifting ones
//! ([`truncnorm`]), and the world every process of a mission loads from the
//! same arguments ([`load`]). Above the core, below the messages.
#![warn(missing_docs)]

pub mod chart;
pub mod frame;
pub mod load;
pub mod mission_file;
pub mod scenario;
pub mod truncnorm;
