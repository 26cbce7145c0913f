//! What crosses a process boundary: the fixed-size `repr(C)` payloads with
//! versioned type names ([`msg`]), the receive-side checks that need the
//! world ([`wire`]), the conversions between a waypoint snapshot and the
//! core's instance and problem ([`network`]), and the vehicle's journal, the
//! record a restarted vehicle resumes from ([`journal`]).
#![warn(missing_docs)]

pub mod journal;
pub mod msg;
pub mod network;
pub mod wire;
