//! The planner's core, with no I/O: the interchange format
//! ([`instance::Instance`]), the compiled fixed-capacity problem the solvers
//! read ([`problem::Problem`], in capacity classes of 64 to 512 nodes:
//! [`capacity`]), priority-vector decoding ([`decode`]), routes
//! and their figures ([`route`]), and the anytime solvers ([`solver`]: PSO and
//! BBO as in the paper, `auto`, the exact branch-and-bound).
//!
//! The data path inside the core reads top to bottom: instance → problem →
//! solver (decode) → route → solution. It depends on nothing of ours; the
//! clock of the anytime runner is injected.
#![warn(missing_docs)]

pub mod capacity;
pub mod decode;
pub mod fixtures;
pub mod instance;
pub mod oplib;
pub mod problem;
pub mod rng;
pub mod route;
pub mod solution;
pub mod solver;
pub mod tsplib;
