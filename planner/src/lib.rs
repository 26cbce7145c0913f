//! Real-time task-assign route planner for autonomous underwater vehicles.
//!
//! The data path reads top to bottom, nothing reaching back up:
//! chart → world/scenario → snapshot ([`instance::Instance`]) →
//! [`problem::Problem`] → [`solver`] → [`route::Route`] → message.
#![warn(missing_docs)]

pub mod decode;
pub mod fixtures;
pub mod instance;
pub mod problem;
pub mod rng;
pub mod route;
pub mod solver;
