//! The deadline-bounded re-planning service.
//!
//! [`core`] decides (triggers, warm start, deadline), [`run`] moves messages
//! between the transport and the core (a waypoint snapshot becomes a routing
//! problem through `auv_messages::network`), [`plan_out`] is where a plan
//! leaves (and where tests add bad plans), [`alloc`] is the counting, pooling allocator the
//! planner binary installs to prove the steady state allocation-free, and
//! [`standin`] is a small solver for the service's own tests.
#![warn(missing_docs)]

pub mod alloc;
pub mod core;
pub mod plan_out;
pub mod run;
pub mod standin;
