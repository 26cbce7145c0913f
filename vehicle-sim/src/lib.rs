//! vehicle-sim's model, usable from tests: [`sim`] is the motion and task
//! simulation; the binary wraps it in the transport loop.
#![warn(missing_docs)]
pub mod sim;
