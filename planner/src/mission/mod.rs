//! `planner mission`: the three-process run, its report, log and plot; and
//! the entry points of the three-process subcommands.
pub mod bench;
pub mod cli;
pub mod world;
