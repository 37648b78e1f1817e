//! What a provider's process uses of the CPU, read from /proc for the live broker, which
//! hands each measurement to the core as an [`Event::CpuMeasured`](super::Event::CpuMeasured)
//! (the core smooths them; replay feeds the recorded ones).
//!
//! The time a process ran comes from `/proc/PID/stat` (`utime` plus `stime`, every thread
//! of the process, ended ones included), not from `/proc/PID/schedstat`, which is precise
//! but counts only the main thread. They are in clock ticks of `USER_HZ`, which Linux
//! fixes at 100 a second on every architecture Lewis runs on (`sysconf(_SC_CLK_TCK)`), so a
//! sample over a second is good to 1% of a core; the core smooths them. Only the service's
//! own process is counted, not children it spawns.

use std::collections::BTreeMap;

/// The CPU time of each watched process at its last sample, to measure the next against.
#[derive(Debug, Default)]
pub struct CpuSampler {
    /// Process id, then (CPU time ns, wall time ns) at the last sample.
    last: BTreeMap<u32, (u64, i64)>,
}

impl CpuSampler {
    /// A sampler that has seen no process yet.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// What process `pid` used of one core since its last sample, in thousandths of a core
    /// (1000: a whole core), at `now_ns` (the broker's clock). `None` at its first sample,
    /// when no time passed, or when its `/proc` entry cannot be read (it has gone).
    pub fn sample(&mut self, pid: u32, now_ns: i64) -> Option<u32> {
        let Some(cpu_ns) = read_cpu_ns(pid) else {
            self.last.remove(&pid);
            return None;
        };
        let before = self.last.insert(pid, (cpu_ns, now_ns))?;
        milli_cores(cpu_ns.checked_sub(before.0)?, now_ns.checked_sub(before.1)?)
    }

    /// Forgets the processes not in `alive` (a service's process that ended: its next one
    /// has another pid).
    pub fn retain(&mut self, alive: impl Fn(u32) -> bool) {
        self.last.retain(|pid, _| alive(*pid));
    }
}

/// The length of a clock tick of `/proc/PID/stat`: `USER_HZ` is 100 on Linux.
const NS_PER_TICK: u64 = 10_000_000;

/// The CPU time process `pid` has used, in nanoseconds.
fn read_cpu_ns(pid: u32) -> Option<u64> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    parse_stat(&text)
}

/// `utime` plus `stime` of a `/proc/PID/stat` line (fields 14 and 15), in nanoseconds. The
/// command name (field 2, in parentheses) may hold spaces and parentheses: the fields are
/// counted after the last `)`.
fn parse_stat(text: &str) -> Option<u64> {
    let (_, rest) = text.rsplit_once(')')?;
    let mut fields = rest.split_whitespace().skip(11);
    let utime: u64 = fields.next()?.parse().ok()?;
    let stime: u64 = fields.next()?.parse().ok()?;
    utime.checked_add(stime)?.checked_mul(NS_PER_TICK)
}

/// CPU time over wall time, in thousandths of a core; `None` when no wall time passed.
fn milli_cores(cpu_ns: u64, wall_ns: i64) -> Option<u32> {
    let wall_ns = u64::try_from(wall_ns).ok().filter(|w| *w > 0)?;
    let milli = u128::from(cpu_ns) * 1000 / u128::from(wall_ns);
    Some(u32::try_from(milli).unwrap_or(u32::MAX))
}

#[cfg(test)]
mod tests {
    use std::time::Instant;

    use super::*;

    #[test]
    fn a_stat_line_gives_its_user_and_system_time() {
        let line =
            "4242 (lewis (cam) 1) S 1 4242 4242 0 -1 4194560 120 0 0 0 17 3 0 0 20 0 4 0 98 0\n";
        assert_eq!(parse_stat(line), Some(200_000_000));
        assert_eq!(parse_stat(""), None);
        assert_eq!(parse_stat("1 (x) S 1"), None);
    }

    #[test]
    fn cpu_over_wall_time_is_in_thousandths_of_a_core() {
        assert_eq!(milli_cores(18_000_000, 100_000_000), Some(180));
        assert_eq!(milli_cores(2_000_000_000, 1_000_000_000), Some(2_000));
        assert_eq!(milli_cores(5, 0), None);
    }

    #[test]
    fn this_process_busy_for_a_while_is_measured_busy() {
        let pid = std::process::id();
        let mut sampler = CpuSampler::new();
        let start = Instant::now();
        let ns = |i: Instant| i64::try_from(i.duration_since(start).as_nanos()).unwrap();
        assert_eq!(
            sampler.sample(pid, 0),
            None,
            "the first sample has nothing to compare"
        );
        let mut x = 0u64;
        while start.elapsed().as_millis() < 200 {
            x = std::hint::black_box(x.wrapping_mul(31).wrapping_add(7));
        }
        let busy = sampler.sample(pid, ns(Instant::now())).unwrap();
        // This thread ran nearly all the while (other test threads may add to it).
        assert!(busy > 100, "{busy} thousandths of a core");
        assert_eq!(sampler.sample(u32::MAX, 1), None, "no such process");
    }
}
