//! `planner mission`: the three-process run, its report, log and plot; the
//! latency bench; and the entry points of the three-process subcommands.
pub mod bench;
pub mod cli;
pub mod external;
pub mod log;
pub mod mcap_log;
pub mod report;
pub mod run;
pub mod soak;
pub mod supervise;
