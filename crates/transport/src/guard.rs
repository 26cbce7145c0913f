//! Validation on the receiving side: a wrapper that passes on only messages
//! that are well-formed ([`Validate`]), fit the receiver's world (an optional
//! [`ContextCheck`], e.g. waypoints over water and inside their bounds), are
//! from our scenario and in sequence ([`SeqGuard`]), and counts the rest by
//! [`RejectKind`]. A rejected message never advances the sequence check.
//!
//! Rejections are reported on stderr without flooding: the first of each kind
//! at once, then at most one line per kind per [`REPORT_INTERVAL_NS`] with the
//! count since the last line.

use super::{Inbox, TransportError};
use auv_messages::msg::{Message, RejectCounters, RejectKind, SeqGuard};
use auv_platform::clock;

/// Least time between two stderr lines about the same kind of rejection, ns.
pub const REPORT_INTERVAL_NS: u64 = 1_000_000_000;

pub use auv_messages::msg::ContextCheck;

/// An [`Inbox`] behind the validators.
pub struct Guarded<T: Message, I: Inbox<T>> {
    inbox: I,
    check: Option<ContextCheck<T>>,
    seq: SeqGuard,
    rejected: RejectCounters,
    limit: RateLimit,
    who: &'static str,
    _t: core::marker::PhantomData<T>,
}

impl<T: Message, I: Inbox<T>> Guarded<T, I> {
    /// Guards `inbox` for receivers of scenario `fingerprint`; `who` names the
    /// receiving process in messages.
    pub fn new(inbox: I, fingerprint: u64, who: &'static str) -> Self {
        Self {
            inbox,
            check: None,
            seq: SeqGuard::new(fingerprint),
            rejected: RejectCounters::default(),
            limit: RateLimit::default(),
            who,
            _t: core::marker::PhantomData,
        }
    }

    /// The same guard with `check` run on every well-formed message before
    /// its sequence number is looked at.
    pub fn with_check(mut self, check: ContextCheck<T>) -> Self {
        self.check = Some(check);
        self
    }

    /// Calls `each` for every accepted message, oldest first; returns how
    /// many were accepted.
    pub fn drain(&mut self, each: &mut dyn FnMut(&T)) -> Result<usize, TransportError> {
        let mut accepted = 0;
        let seq = &mut self.seq;
        let rejected = &mut self.rejected;
        let limit = &mut self.limit;
        let who = self.who;
        let fp = seq.fingerprint();
        let check = &self.check;
        self.inbox.drain(&mut |m: &T| {
            // The scenario first: a message of another world would otherwise
            // be misreported as, e.g., a waypoint outside its bound.
            let verdict = seq
                .same_scenario(m.header())
                .and_then(|()| m.validate())
                .and_then(|()| check.as_ref().map_or(Ok(()), |c| c(m)))
                .and_then(|()| seq.accept(m.header()));
            match verdict {
                Ok(()) => {
                    accepted += 1;
                    each(m);
                }
                Err(kind) => {
                    rejected.add(kind);
                    report(who, T::NAME, kind, m.header().fingerprint, fp, limit);
                }
            }
        })?;
        Ok(accepted)
    }

    /// Rejections so far, by kind.
    pub fn rejected(&self) -> &RejectCounters {
        &self.rejected
    }

    /// Counts a rejection found later by the receiver itself (a check that
    /// needs more context than the message alone, e.g. a plan against the
    /// network).
    pub fn reject_later(&mut self, kind: RejectKind, sender_fingerprint: u64) {
        self.rejected.add(kind);
        let fp = self.seq.fingerprint();
        report(self.who, T::NAME, kind, sender_fingerprint, fp, &mut self.limit);
    }

    /// (session, seq) of the last accepted message.
    pub fn last(&self) -> (u64, u64) {
        self.seq.last()
    }
}

/// Per-kind rate limit of log lines: the first rejection of a kind is
/// reported at once, later ones at most once per [`REPORT_INTERVAL_NS`],
/// each line carrying the count since the previous one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RateLimit {
    last_ns: [u64; auv_messages::msg::REJECT_KINDS],
    unreported: [u64; auv_messages::msg::REJECT_KINDS],
}

impl RateLimit {
    /// Counts one rejection of `kind` at `now_ns`; returns the count to
    /// report now (this one included), or `None` while the kind is muted.
    pub fn note(&mut self, kind: RejectKind, now_ns: u64) -> Option<u64> {
        let k = kind as usize;
        self.unreported[k] += 1;
        if self.last_ns[k] != 0 && now_ns.saturating_sub(self.last_ns[k]) < REPORT_INTERVAL_NS {
            return None;
        }
        self.last_ns[k] = now_ns.max(1);
        Some(core::mem::take(&mut self.unreported[k]))
    }

    /// Rejections counted but not reported yet, by kind.
    pub fn pending(&self, kind: RejectKind) -> u64 {
        self.unreported[kind as usize]
    }
}

fn report(who: &str, what: &str, kind: RejectKind, theirs: u64, ours: u64, limit: &mut RateLimit) {
    let Some(n) = limit.note(kind, clock::mono_now_ns()) else {
        return;
    };
    if kind == RejectKind::ForeignScenario {
        eprintln!(
            "{who}: refusing {what} from another scenario (fingerprint {theirs:016x}, ours {ours:016x}): \
             were all processes started with the same seed and scenario? ({n} refused)"
        );
    } else {
        eprintln!("{who}: rejected {n} {what} message(s): {}", kind.as_str());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_of_each_kind_is_reported_then_one_line_a_second_with_the_count() {
        const S: u64 = REPORT_INTERVAL_NS;
        let mut l = RateLimit::default();
        assert_eq!(l.note(RejectKind::NonFinite, 5 * S), Some(1));
        // Muted within the interval, counted all the same.
        for k in 1..100 {
            assert_eq!(l.note(RejectKind::NonFinite, 5 * S + k * S / 100), None);
        }
        assert_eq!(l.pending(RejectKind::NonFinite), 99);
        // Another kind has its own limit.
        assert_eq!(l.note(RejectKind::Repeated, 5 * S + 1), Some(1));
        // After the interval, one line with everything since the last one.
        assert_eq!(l.note(RejectKind::NonFinite, 6 * S), Some(100));
        assert_eq!(l.pending(RejectKind::NonFinite), 0);
        assert_eq!(l.note(RejectKind::NonFinite, 6 * S + 1), None);
        // A reading of 0 still counts as a line sent (the next comes an
        // interval later), and a clock that steps back mutes only until it
        // has caught up.
        let mut z = RateLimit::default();
        assert_eq!(z.note(RejectKind::OffWater, 0), Some(1));
        assert_eq!(z.note(RejectKind::OffWater, S / 2), None);
        assert_eq!(z.note(RejectKind::OffWater, S + 1), Some(2));
        assert_eq!(z.note(RejectKind::OffWater, 1), None);
        assert_eq!(z.note(RejectKind::OffWater, 2 * S + 1), Some(2));
    }
}
