//! The apps layer of the AUV route planner: the mission supervisor and its
//! report, log and plot (`mission`), the planner service process (`serve`),
//! the latency bench and the soak, and the study tools (`montecarlo`, `plot`).
//!
//! The layers below, each a crate of its own, nothing reaching back up:
//! `auv_platform` → `auv_core` → `auv_world` → `auv_messages` →
//! `auv_transport` → `auv_service` → this crate. The data path reads top to
//! bottom: chart → scenario (the world) → snapshot (instance) → problem →
//! solver → route → message.
#![warn(missing_docs)]

pub mod mission;
pub mod montecarlo;
pub mod plot;
pub mod plot_quality;
pub mod serve;
pub mod shore;
