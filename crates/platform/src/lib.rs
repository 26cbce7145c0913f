//! The platform layer: everything the planner asks of the operating system
//! below the apps — the monotonic clock shared by all processes for latency
//! stamps, signal handling for a clean shutdown, the host's steal time, and a
//! counting allocator for allocation tests. It depends on nothing of ours.
#![warn(missing_docs)]

pub mod alloc_counter;
pub mod clock;
pub mod host;
pub mod signal;
