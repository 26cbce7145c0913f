//! Real-time task-assign route planner for autonomous underwater vehicles.
//!
//! The data path reads top to bottom, nothing reaching back up:
//! [`chart`] → [`scenario`] (the world) → snapshot ([`instance::Instance`]) →
//! [`problem::Problem`] → [`solver`] → [`route::Route`] → message.
#![warn(missing_docs)]

pub mod alloc_counter;
pub mod chart;
pub mod decode;
pub mod fixtures;
pub mod instance;
pub mod mission;
pub mod montecarlo;
pub mod msg;
pub mod oplib;
pub mod plot;
pub mod plot_quality;
pub mod problem;
pub mod rng;
pub mod route;
pub mod scenario;
pub mod service;
pub mod solution;
pub mod solver;
pub mod transport;
pub mod truncnorm;
pub mod tsplib;
pub mod wire;
