//! Link liveness from the other side's heartbeats: lost after a timeout of
//! silence, restored by the next heartbeat (both sides run one).

use std::time::{Duration, Instant};

/// What changed at a [`LinkMonitor::poll`] or [`LinkMonitor::heard`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LinkChange {
    /// First heartbeat ever.
    Connected,
    /// Silent for `silent` (≥ the timeout): the link is lost.
    Lost {
        /// Time since the last heartbeat when the loss was declared.
        silent: Duration,
    },
    /// A heartbeat after a loss.
    Restored {
        /// How long the link was down (last heartbeat before → this one).
        down: Duration,
    },
}

/// The link state as one side sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkState {
    /// Nothing heard yet.
    Waiting,
    /// Heartbeats arrive.
    Up,
    /// Silent past the timeout.
    Lost,
}

impl LinkState {
    /// Lower-case name for views and logs.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Waiting => "waiting",
            Self::Up => "up",
            Self::Lost => "lost",
        }
    }
}

/// Watches the heartbeats of the far side.
#[derive(Clone, Debug)]
pub struct LinkMonitor {
    timeout: Duration,
    last: Option<Instant>,
    state: LinkState,
    /// Losses declared.
    pub losses: u64,
    /// Restorations seen.
    pub restores: u64,
    /// Largest silence at a loss's declaration (the detection time).
    pub detect_max: Duration,
}

/// Smallest link timeout worth having, ms (our choice: heartbeats every
/// 12.5 ms at most, see [`heartbeat_period`]).
pub const MIN_TIMEOUT_MS: u64 = 50;

/// The heartbeat period for a link timeout: four heartbeats per timeout, so
/// one lost or late heartbeat is not a loss.
pub fn heartbeat_period(timeout: Duration) -> Duration {
    timeout / 4
}

impl LinkMonitor {
    /// A monitor declaring a loss after `timeout` of silence.
    pub fn new(timeout: Duration) -> Self {
        Self {
            timeout,
            last: None,
            state: LinkState::Waiting,
            losses: 0,
            restores: 0,
            detect_max: Duration::ZERO,
        }
    }

    /// The state now.
    pub fn state(&self) -> LinkState {
        self.state
    }

    /// Time since the last heartbeat (`None` before any).
    pub fn silence(&self, now: Instant) -> Option<Duration> {
        self.last.map(|l| now.saturating_duration_since(l))
    }

    /// A heartbeat (or any message) from the far side arrived at `now`.
    pub fn heard(&mut self, now: Instant) -> Option<LinkChange> {
        let before = self.state;
        let down = self.silence(now).unwrap_or_default();
        self.last = Some(now);
        self.state = LinkState::Up;
        match before {
            LinkState::Waiting => Some(LinkChange::Connected),
            LinkState::Lost => {
                self.restores += 1;
                Some(LinkChange::Restored { down })
            }
            LinkState::Up => None,
        }
    }

    /// Declares a loss once the silence reaches the timeout.
    pub fn poll(&mut self, now: Instant) -> Option<LinkChange> {
        let silent = self.silence(now)?;
        if self.state == LinkState::Up && silent >= self.timeout {
            self.state = LinkState::Lost;
            self.losses += 1;
            self.detect_max = self.detect_max.max(silent);
            return Some(LinkChange::Lost { silent });
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_silence_past_the_timeout_is_one_loss_and_the_next_heartbeat_restores() {
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        let mut m = LinkMonitor::new(ms(200));
        assert_eq!(m.poll(t0), None);
        assert_eq!(m.state(), LinkState::Waiting);
        assert_eq!(m.heard(t0), Some(LinkChange::Connected));
        assert_eq!(m.heard(t0 + ms(50)), None);
        assert_eq!(m.poll(t0 + ms(249)), None);
        assert_eq!(m.poll(t0 + ms(260)), Some(LinkChange::Lost { silent: ms(210) }));
        assert_eq!(m.poll(t0 + ms(900)), None, "one loss, declared once");
        assert_eq!(m.state(), LinkState::Lost);
        assert_eq!(m.heard(t0 + ms(1050)), Some(LinkChange::Restored { down: ms(1000) }));
        assert_eq!((m.losses, m.restores, m.detect_max), (1, 1, ms(210)));
        assert_eq!(heartbeat_period(ms(200)), ms(50));
    }
}
