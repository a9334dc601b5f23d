//! The calling thread's scheduler times, shared by the benchmarks that report CPU time (on a
//! shared machine the CPU time is what the code needs of a core; the wall time also holds the
//! waits for one).

/// This thread's time on a CPU and time waiting for one (run queue), in ns: the first two
/// fields of `/proc/thread-self/schedstat` (Linux); None if unreadable.
pub fn run_and_wait_ns() -> Option<(u64, u64)> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let mut fields = text.split_whitespace().map(str::parse::<u64>);
    Some((fields.next()?.ok()?, fields.next()?.ok()?))
}
