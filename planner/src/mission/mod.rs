//! `planner mission`: the three-process run, its report, log and plot.
pub mod world;
