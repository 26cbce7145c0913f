//! `planner mission`: the three-process run, its report, log and plot; the
//! latency bench; and the entry points of the three-process subcommands.
pub mod bench;
pub mod child;
pub mod cli;
pub mod external;
pub mod external_kills;
pub mod log;
pub mod mcap_log;
pub mod picture;
pub mod replace;
pub mod report;
pub mod restart;
pub mod route_geojson;
pub mod run;
pub mod shore_report;
pub mod soak;
pub mod stale;
pub mod supervise;
pub mod supervisor;
