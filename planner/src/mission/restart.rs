//! The restart budget of one supervised process: a crash loop must end in a
//! safe state, not in restarts forever.
//!
//! Contract: a process may be restarted at most `max_restarts` times within
//! any `window`; the restart that would exceed that is refused. Restarts
//! wait a back-off that doubles with each restart already in the window,
//! from `backoff` up to [`BACKOFF_MAX`], so a process that dies at once is
//! not restarted at full speed. Times are passed in, so the policy is
//! deterministic and tested without a clock.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// Longest back-off between two restarts.
pub const BACKOFF_MAX: Duration = Duration::from_secs(5);

/// Default most restarts of one process within [`DEFAULT_WINDOW_S`].
pub const DEFAULT_MAX_RESTARTS: u32 = 5;

/// Default window of the restart budget, real s.
pub const DEFAULT_WINDOW_S: f64 = 60.0;

/// Default first back-off, real ms.
pub const DEFAULT_BACKOFF_MS: f64 = 100.0;

/// The limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestartPolicy {
    /// Most restarts within `window`.
    pub max_restarts: u32,
    /// The sliding window.
    pub window: Duration,
    /// Wait before the first restart in a window; doubles with each one.
    pub backoff: Duration,
}

impl Default for RestartPolicy {
    fn default() -> Self {
        Self {
            max_restarts: DEFAULT_MAX_RESTARTS,
            window: Duration::from_secs_f64(DEFAULT_WINDOW_S),
            backoff: Duration::from_secs_f64(DEFAULT_BACKOFF_MS / 1000.0),
        }
    }
}

/// What to do about a process that exited unasked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Restart it at this time.
    RestartAt(Instant),
    /// The budget is spent: `restarts` within the window already.
    Exhausted {
        /// Restarts in the window.
        restarts: u32,
    },
}

/// The restarts of one process in the current window.
#[derive(Clone, Debug)]
pub struct RestartBudget {
    policy: RestartPolicy,
    recent: VecDeque<Instant>,
}

impl RestartBudget {
    /// A fresh budget.
    pub fn new(policy: RestartPolicy) -> Self {
        Self {
            policy,
            recent: VecDeque::new(),
        }
    }

    /// The process exited unasked at `now`: restart it (when), or not.
    pub fn on_exit(&mut self, now: Instant) -> Verdict {
        while let Some(&t) = self.recent.front() {
            if now.duration_since(t) > self.policy.window {
                self.recent.pop_front();
            } else {
                break;
            }
        }
        let n = self.recent.len() as u32;
        if n >= self.policy.max_restarts {
            return Verdict::Exhausted { restarts: n };
        }
        let wait = self
            .policy
            .backoff
            .saturating_mul(1u32 << n.min(16))
            .min(BACKOFF_MAX.max(self.policy.backoff));
        self.recent.push_back(now);
        Verdict::RestartAt(now + wait)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn policy(k: u32, window_s: u64, backoff_ms: u64) -> RestartPolicy {
        RestartPolicy {
            max_restarts: k,
            window: Duration::from_secs(window_s),
            backoff: Duration::from_millis(backoff_ms),
        }
    }

    #[test]
    fn restarts_back_off_doubling_until_the_budget_is_spent() {
        let t0 = Instant::now();
        let mut b = RestartBudget::new(policy(3, 60, 100));
        let ms = |v: Verdict| match v {
            Verdict::RestartAt(t) => Some(t.duration_since(t0).as_millis()),
            Verdict::Exhausted { .. } => None,
        };
        assert_eq!(ms(b.on_exit(t0)), Some(100));
        assert_eq!(ms(b.on_exit(t0)), Some(200));
        assert_eq!(ms(b.on_exit(t0)), Some(400));
        assert_eq!(b.on_exit(t0), Verdict::Exhausted { restarts: 3 });
    }

    #[test]
    fn restarts_older_than_the_window_no_longer_count() {
        let t0 = Instant::now();
        let mut b = RestartBudget::new(policy(2, 10, 50));
        assert!(matches!(b.on_exit(t0), Verdict::RestartAt(_)));
        assert!(matches!(b.on_exit(t0 + Duration::from_secs(5)), Verdict::RestartAt(_)));
        assert!(matches!(
            b.on_exit(t0 + Duration::from_secs(9)),
            Verdict::Exhausted { .. }
        ));
        // The first restart left the window: one more is allowed, after the
        // back-off of the one restart still in it.
        let later = t0 + Duration::from_secs(12);
        assert_eq!(b.on_exit(later), Verdict::RestartAt(later + Duration::from_millis(100)));
    }

    #[test]
    fn the_back_off_is_capped() {
        let t0 = Instant::now();
        let mut b = RestartBudget::new(policy(40, 3600, 1000));
        let mut last = Duration::ZERO;
        for _ in 0..40 {
            if let Verdict::RestartAt(t) = b.on_exit(t0) {
                last = t.duration_since(t0);
            }
        }
        assert_eq!(last, BACKOFF_MAX);
    }
}
