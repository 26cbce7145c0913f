//! Graceful shutdown on SIGINT / SIGTERM.
//!
//! Contract: [`install`] replaces the default action of SIGINT and SIGTERM
//! with a handler that only records the request; loops poll
//! [`shutdown_requested`] and return normally, so every iceoryx2 port and
//! node is dropped and its shared memory removed (a process killed by the
//! default action leaves a dead node behind). The handler is installed
//! without `SA_RESTART`, so a blocking wait returns early with `EINTR` and
//! the loop notices at once. iceoryx2's own lazy handlers are disabled on our
//! nodes (`SignalHandlingMode::Disabled`) so exactly one handler owns them.

use std::sync::atomic::{AtomicI32, Ordering};

static SIGNAL: AtomicI32 = AtomicI32::new(0);

extern "C" fn record(sig: libc::c_int) {
    // Only an atomic store: async-signal-safe.
    SIGNAL.store(sig, Ordering::SeqCst);
}

/// Installs the recording handler for SIGINT and SIGTERM (idempotent).
pub fn install() {
    for sig in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: a zeroed sigaction is a valid starting value; we set a plain
        // handler (no SA_SIGINFO) whose body is async-signal-safe, with an
        // empty mask, and pass valid pointers.
        unsafe {
            let mut sa: libc::sigaction = core::mem::zeroed();
            sa.sa_sigaction = record as extern "C" fn(libc::c_int) as usize;
            libc::sigemptyset(&mut sa.sa_mask);
            sa.sa_flags = 0;
            libc::sigaction(sig, &sa, core::ptr::null_mut());
        }
    }
}

/// Whether SIGINT or SIGTERM arrived since [`install`].
#[inline]
pub fn shutdown_requested() -> bool {
    SIGNAL.load(Ordering::Relaxed) != 0
}

/// The signal that requested shutdown (0: none).
pub fn received_signal() -> i32 {
    SIGNAL.load(Ordering::Relaxed)
}

/// Records a shutdown request from inside the process (tests, orchestrators).
pub fn request_shutdown() {
    SIGNAL.store(libc::SIGTERM, Ordering::SeqCst);
}

static HOLD: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);

extern "C" fn record_hold(_sig: libc::c_int) {
    // Only an atomic store: async-signal-safe.
    HOLD.store(true, Ordering::SeqCst);
}

/// Installs the handler of SIGUSR1, the supervisor's request for a safe
/// hold (the vehicle stops at its next waypoint and ends the mission there).
pub fn install_hold() {
    // SAFETY: as in `install`: a plain, async-signal-safe handler.
    unsafe {
        let mut sa: libc::sigaction = core::mem::zeroed();
        sa.sa_sigaction = record_hold as extern "C" fn(libc::c_int) as usize;
        libc::sigemptyset(&mut sa.sa_mask);
        sa.sa_flags = 0;
        libc::sigaction(libc::SIGUSR1, &sa, core::ptr::null_mut());
    }
}

/// Whether a safe hold was requested since [`install_hold`].
#[inline]
pub fn hold_requested() -> bool {
    HOLD.load(Ordering::Relaxed)
}
