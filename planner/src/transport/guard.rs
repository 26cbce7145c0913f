//! Validation on the receiving side: a wrapper that passes on only messages
//! that are well-formed ([`Validate`]), fit the receiver's world (an optional
//! [`ContextCheck`], e.g. waypoints over water and inside their bounds), are
//! from our scenario and in sequence ([`SeqGuard`]), and counts the rest by
//! [`RejectKind`]. A rejected message never advances the sequence check.
//!
//! Rejections are reported on stderr without flooding: the first of each kind
//! at once, then at most one line per kind per [`REPORT_INTERVAL_NS`] with the
//! count since the last line.

use super::{Inbox, TransportError, clock};
use crate::msg::{Message, RejectCounters, RejectKind, SeqGuard};

/// Least time between two stderr lines about the same kind of rejection, ns.
pub const REPORT_INTERVAL_NS: u64 = 1_000_000_000;

/// A receiver-side check that needs more than the message itself (the
/// scenario's chart, bounds, node count). Runs after [`Validate`], so it sees
/// only well-formed messages; it must not allocate.
pub type ContextCheck<T> = Box<dyn Fn(&T) -> Result<(), RejectKind>>;

/// An [`Inbox`] behind the validators.
pub struct Guarded<T: Message, I: Inbox<T>> {
    inbox: I,
    check: Option<ContextCheck<T>>,
    seq: SeqGuard,
    rejected: RejectCounters,
    last_report_ns: [u64; crate::msg::REJECT_KINDS],
    unreported: [u64; crate::msg::REJECT_KINDS],
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
            last_report_ns: [0; crate::msg::REJECT_KINDS],
            unreported: [0; crate::msg::REJECT_KINDS],
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
        let last = &mut self.last_report_ns;
        let unreported = &mut self.unreported;
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
                    report(who, T::NAME, kind, m.header().fingerprint, fp, last, unreported);
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
        report(
            self.who,
            T::NAME,
            kind,
            sender_fingerprint,
            fp,
            &mut self.last_report_ns,
            &mut self.unreported,
        );
    }

    /// (session, seq) of the last accepted message.
    pub fn last(&self) -> (u64, u64) {
        self.seq.last()
    }
}

fn report(
    who: &str,
    what: &str,
    kind: RejectKind,
    theirs: u64,
    ours: u64,
    last: &mut [u64; crate::msg::REJECT_KINDS],
    unreported: &mut [u64; crate::msg::REJECT_KINDS],
) {
    let k = kind as usize;
    unreported[k] += 1;
    let now = clock::mono_now_ns();
    if last[k] != 0 && now.saturating_sub(last[k]) < REPORT_INTERVAL_NS {
        return;
    }
    let n = unreported[k];
    unreported[k] = 0;
    last[k] = now.max(1);
    if kind == RejectKind::ForeignScenario {
        eprintln!(
            "{who}: refusing {what} from another scenario (fingerprint {theirs:016x}, ours {ours:016x}): \
             were all processes started with the same seed and scenario? ({n} refused)"
        );
    } else {
        eprintln!("{who}: rejected {n} {what} message(s): {}", kind.as_str());
    }
}
