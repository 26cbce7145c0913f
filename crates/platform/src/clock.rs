//! The monotonic clock shared by every process on the host.
//!
//! `CLOCK_MONOTONIC` is one clock for the whole machine, so a time stamped by
//! one process can be subtracted from a time read in another: that is how
//! trigger → plan latency is measured across processes. (`std::time::Instant`
//! reads the same clock but does not expose its value.)

/// `CLOCK_MONOTONIC` now, ns.
#[inline]
pub fn mono_now_ns() -> u64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC always exists
    // on Linux, so the call cannot fail.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    (ts.tv_sec as u64)
        .wrapping_mul(1_000_000_000)
        .wrapping_add(ts.tv_nsec as u64)
}

/// CPU time consumed by the calling thread, s.
pub fn thread_cpu_time_s() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes into the timespec we own; the clock id is
    // a constant Linux supports.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc != 0 {
        return 0.0;
    }
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn advances_at_least_as_much_as_a_sleep() {
        let t0 = mono_now_ns();
        std::thread::sleep(std::time::Duration::from_millis(2));
        let t1 = mono_now_ns();
        // Lower bound only: no upper timing bounds on a shared machine.
        assert!(t1 >= t0 + 2_000_000);
    }
}
