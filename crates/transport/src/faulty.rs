//! Bad-message injection for tests, as a decorator of an [`Outbox`].
//!
//! A process that is asked to inject (`sensor-sim --inject`, `vehicle-sim
//! --inject`) wraps its outbox in a [`FaultyOutbox`]; its loop then
//! publishes as always, and the decorator sends one bad message next to
//! each good one, the [`FaultCycle`]'s kinds in turn. Without `--inject`
//! the cycle is empty and the decorator is a pass-through, so the
//! production loop has no injection branch.
//!
//! Contract, for each good message with a fault due:
//! - a sequence fault ([`Fault::after_good`]: repeated, out of order) goes
//!   just after the good message, its header rewritten from the good one's
//!   sequence number;
//! - a header fault ([`Fault::in_header`]: foreign scenario) goes just before;
//! - a payload fault goes just before, its payload made bad by the
//!   process's [`Corrupt`] (which knows what a bad snapshot or state is).
//!
//! Either way receivers still get every good message. [`FaultyOutbox::publish_alone`]
//! sends a message without a bad twin and without using up a fault (a
//! vehicle's first and last state).

use auv_messages::msg::Message;
use auv_messages::wire::{Fault, FaultCycle, tamper_header};

use crate::{Outbox, TransportError};

/// An outbox that can let a caller rewrite the stamped message before it
/// goes out (header included): what [`FaultyOutbox`] needs of the outbox
/// it decorates.
pub trait TamperOutbox<T: Message>: Outbox<T> {
    /// Like [`Outbox::publish`], then `tamper` rewrites the stamped message
    /// before it is sent. The sequence counter advances as usual.
    fn publish_tampered(
        &mut self,
        fill: &mut dyn FnMut(&mut T),
        tamper: &mut dyn FnMut(&mut T),
    ) -> Result<u64, TransportError>;
}

/// Makes the payload of a good message bad in the way `fault` names.
pub trait Corrupt<T> {
    /// Rewrites `m` (already filled as the good message would be).
    fn corrupt(&mut self, fault: Fault, m: &mut T);
}

impl<T, F: FnMut(Fault, &mut T)> Corrupt<T> for F {
    fn corrupt(&mut self, fault: Fault, m: &mut T) {
        self(fault, m);
    }
}

/// An outbox that sends a bad message next to each good one (see the
/// module doc); a pass-through when its cycle is empty.
pub struct FaultyOutbox<O, C> {
    inner: O,
    faults: FaultCycle,
    corrupt: C,
}

impl<O, C> FaultyOutbox<O, C> {
    /// Decorates `inner` with the faults of `faults` ([`FaultCycle::NONE`]:
    /// none), made by `corrupt`.
    pub fn new(inner: O, faults: FaultCycle, corrupt: C) -> Self {
        Self { inner, faults, corrupt }
    }

    /// The decorated outbox.
    pub fn inner_mut(&mut self) -> &mut O {
        &mut self.inner
    }

    /// Publishes `fill`'s message alone: no bad twin, no fault used up.
    pub fn publish_alone<T: Message>(&mut self, fill: &mut dyn FnMut(&mut T)) -> Result<u64, TransportError>
    where
        O: Outbox<T>,
    {
        self.inner.publish(fill)
    }
}

impl<T: Message, O: TamperOutbox<T>, C: Corrupt<T>> Outbox<T> for FaultyOutbox<O, C> {
    fn publish(&mut self, fill: &mut dyn FnMut(&mut T)) -> Result<u64, TransportError> {
        let Some(f) = self.faults.advance() else {
            return self.inner.publish(fill);
        };
        if f.after_good() {
            let seq = self.inner.publish(fill)?;
            self.inner
                .publish_tampered(fill, &mut |m| tamper_header(f, m.header_mut(), seq))?;
            return Ok(seq);
        }
        if f.in_header() {
            self.inner
                .publish_tampered(fill, &mut |m| tamper_header(f, m.header_mut(), 0))?;
        } else {
            let corrupt = &mut self.corrupt;
            self.inner.publish_tampered(fill, &mut |m| corrupt.corrupt(f, m))?;
        }
        self.inner.publish(fill)
    }

    fn refresh(&mut self) {
        self.inner.refresh();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use auv_messages::msg::VehicleState;
    use auv_messages::wire::VEHICLE_FAULTS;

    /// Records what would have been sent: (seq in the header, position x).
    #[derive(Default)]
    struct Recorder {
        seq: u64,
        sent: Vec<(u64, f64)>,
    }

    impl Recorder {
        fn send(
            &mut self,
            fill: &mut dyn FnMut(&mut VehicleState),
            tamper: Option<&mut dyn FnMut(&mut VehicleState)>,
        ) -> u64 {
            let mut m = *auv_messages::msg::boxed_zeroed::<VehicleState>();
            fill(&mut m);
            self.seq += 1;
            m.header.seq = self.seq;
            if let Some(t) = tamper {
                t(&mut m);
            }
            self.sent.push((m.header.seq, m.position[0]));
            self.seq
        }
    }

    impl Outbox<VehicleState> for Recorder {
        fn publish(&mut self, fill: &mut dyn FnMut(&mut VehicleState)) -> Result<u64, TransportError> {
            Ok(self.send(fill, None))
        }
        fn refresh(&mut self) {}
    }

    impl TamperOutbox<VehicleState> for Recorder {
        fn publish_tampered(
            &mut self,
            fill: &mut dyn FnMut(&mut VehicleState),
            tamper: &mut dyn FnMut(&mut VehicleState),
        ) -> Result<u64, TransportError> {
            Ok(self.send(fill, Some(tamper)))
        }
    }

    fn good(m: &mut VehicleState) {
        m.position[0] = 1.0;
    }

    #[test]
    fn without_faults_it_passes_every_message_through() {
        let mut out = FaultyOutbox::new(
            Recorder::default(),
            FaultCycle::NONE,
            |_: Fault, _: &mut VehicleState| unreachable!("no fault to make"),
        );
        for _ in 0..3 {
            out.publish(&mut good).unwrap();
        }
        assert_eq!(out.inner_mut().sent, vec![(1, 1.0), (2, 1.0), (3, 1.0)]);
    }

    #[test]
    fn each_kind_goes_where_the_contract_says() {
        let faults = FaultCycle::parse("--inject", "non_finite,repeated,out_of_order", &VEHICLE_FAULTS).unwrap();
        let mut out = FaultyOutbox::new(Recorder::default(), faults, |f: Fault, m: &mut VehicleState| {
            assert_eq!(f, Fault::NonFinite);
            m.position[0] = f64::NAN;
        });
        // A payload fault before the good message.
        assert_eq!(out.publish(&mut good).unwrap(), 2);
        // A repeated sequence number after it, then one below it.
        assert_eq!(out.publish(&mut good).unwrap(), 3);
        assert_eq!(out.publish(&mut good).unwrap(), 5);
        // Alone: no twin, and the cycle does not move on.
        assert_eq!(out.publish_alone(&mut good).unwrap(), 7);
        let sent = &out.inner_mut().sent;
        assert!(sent[0].1.is_nan() && sent[0].0 == 1);
        assert_eq!(
            &sent[1..],
            &[(2, 1.0), (3, 1.0), (3, 1.0), (5, 1.0), (4, 1.0), (7, 1.0)]
        );
    }
}
