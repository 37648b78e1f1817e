//! What a process has used of the machine's memory, as Linux reports it.

/// The peak resident memory of this process (`VmHWM` of `/proc/self/status`), in KiB;
/// `None` where the system does not say.
#[must_use]
pub fn peak_resident_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_linux_process_has_a_peak() {
        assert!(super::peak_resident_kib().is_some_and(|kib| kib > 0));
    }
}
