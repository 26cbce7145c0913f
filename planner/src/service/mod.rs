//! The deadline-bounded re-planning service.
//!
//! [`core`] decides (triggers, warm start, deadline), [`run`] moves messages
//! between the transport and the core, [`network`] turns a waypoint snapshot
//! into a routing problem, [`alloc`] is the counting, pooling allocator the
//! planner binary installs to prove the steady state allocation-free, and
//! [`standin`] is a small solver for the service's own tests.
pub mod alloc;
pub mod cli;
pub mod core;
pub mod network;
pub mod run;
pub mod standin;
