//! The re-planning service (in progress).
pub mod alloc;
