//! What the host did to this machine: the guest's steal time (the host ran
//! something else while a guest CPU wanted to run), for the latency bench and
//! the soak to set next to their misses.

/// The steal field of `/proc/stat`'s first line (`cpu  user nice system idle
/// iowait irq softirq steal ...`): time the host ran something else while a
/// guest CPU wanted to run, summed over CPUs, in clock ticks.
pub fn parse_steal_ticks(proc_stat: &str) -> Option<u64> {
    let line = proc_stat.lines().next()?;
    let mut fields = line.split_ascii_whitespace();
    (fields.next()? == "cpu").then_some(())?;
    fields.nth(7)?.parse().ok()
}

/// Steal ticks so far (None where `/proc/stat` has none, e.g. not Linux).
pub fn host_steal_ticks() -> Option<u64> {
    parse_steal_ticks(&std::fs::read_to_string("/proc/stat").ok()?)
}

/// Milliseconds per clock tick of `/proc/stat`.
pub fn ms_per_tick() -> f64 {
    // SAFETY: sysconf has no preconditions.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    if hz > 0 { 1000.0 / hz as f64 } else { 10.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steal_is_the_eighth_number_of_the_cpu_line() {
        let stat = "cpu  4981377 49434 336106 1489454 44662 0 3981 8053 0 0\ncpu0 1 2 3 4 5 6 7 99 0 0\n";
        assert_eq!(parse_steal_ticks(stat), Some(8053));
        // Older kernels without the field, or another first line: unknown.
        assert_eq!(parse_steal_ticks("cpu  1 2 3 4 5 6 7\n"), None);
        assert_eq!(parse_steal_ticks("intr 1 2 3 4 5 6 7 8 9\n"), None);
        assert_eq!(parse_steal_ticks(""), None);
    }
}
