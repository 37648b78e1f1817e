//! What a long run costs the machine, read from `/proc` and `/dev/shm`: the proportional
//! memory, open descriptors and CPU of every process of the run (this one and its
//! descendants, named by what they run), and the entries in shared memory. A leak shows as
//! a slope over the missions ([`slope`]).

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

/// One process as `/proc` tells it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProcessUse {
    /// The process id.
    pub pid: i32,
    /// What it runs: the service's name for `lewis service NAME`, else the subcommand
    /// (`record`, `program`), `lewis` for this process.
    pub name: String,
    /// Its memory, in KiB: the proportional set size (`Pss` of `smaps_rollup`), each page
    /// shared with other processes counted in part. Resident memory (`VmRSS`) counts the
    /// shared memory of the channels in every process that maps it, and a forked
    /// supervisor guard as big as its parent.
    pub pss_kib: u64,
    /// Open file descriptors.
    pub fds: u64,
    /// CPU time used so far, user and system, in clock ticks.
    pub cpu_ticks: u64,
}

/// Every process of the run now: this one and its descendants.
#[must_use]
pub fn processes_of_run() -> Vec<ProcessUse> {
    let me = std::process::id() as i32;
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    let mut parents = BTreeMap::new();
    for entry in entries.flatten() {
        let Some(pid) = entry
            .file_name()
            .to_str()
            .and_then(|s| s.parse::<i32>().ok())
        else {
            continue;
        };
        if let Some(stat) = read_stat(pid) {
            parents.insert(pid, stat);
        }
    }
    let mine = command_line(me);
    let mut run = vec![me];
    // Descendants, generation by generation (a process's parent has a lower place here).
    let mut i = 0;
    while i < run.len() {
        let parent = run[i];
        run.extend(
            parents
                .iter()
                .filter(|(_, stat)| stat.ppid == parent)
                .map(|(&pid, _)| pid),
        );
        i += 1;
    }
    run.into_iter()
        .filter_map(|pid| {
            let stat = parents.get(&pid)?;
            Some(ProcessUse {
                pid,
                name: if pid == me {
                    "lewis".to_owned()
                } else {
                    let cmdline = command_line(pid)?;
                    if Some(&cmdline) == mine.as_ref() {
                        // Forked and never run anything else: a supervisor's guard.
                        "guard".to_owned()
                    } else {
                        process_name(&cmdline)
                    }
                },
                pss_kib: pss_kib(pid)?,
                fds: std::fs::read_dir(format!("/proc/{pid}/fd")).ok()?.count() as u64,
                cpu_ticks: stat.cpu_ticks,
            })
        })
        .collect()
}

/// The fields of `/proc/PID/stat` read here.
struct Stat {
    ppid: i32,
    cpu_ticks: u64,
}

fn read_stat(pid: i32) -> Option<Stat> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    parse_stat(&text)
}

/// `/proc/PID/stat`: the name in parentheses may hold spaces and parentheses, so the
/// fields are counted from the last `)`: state, ppid, ..., utime (14th), stime (15th).
fn parse_stat(text: &str) -> Option<Stat> {
    let rest = &text[text.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // After the name: state is field 3 of the line, so field N is fields[N - 3].
    let ppid = fields.get(1)?.parse().ok()?;
    let utime: u64 = fields.get(11)?.parse().ok()?;
    let stime: u64 = fields.get(12)?.parse().ok()?;
    Some(Stat {
        ppid,
        cpu_ticks: utime + stime,
    })
}

fn pss_kib(pid: i32) -> Option<u64> {
    let rollup = std::fs::read_to_string(format!("/proc/{pid}/smaps_rollup")).ok()?;
    rollup
        .lines()
        .find_map(|line| line.strip_prefix("Pss:"))
        .and_then(|rest| rest.split_whitespace().next()?.parse().ok())
}

/// A process's command line (`None`: gone, or not ours to read).
fn command_line(pid: i32) -> Option<Vec<u8>> {
    std::fs::read(format!("/proc/{pid}/cmdline")).ok()
}

/// What a process of the run runs, from its command line.
fn process_name(cmdline: &[u8]) -> String {
    let args: Vec<String> = cmdline
        .split(|&b| b == 0)
        .filter(|a| !a.is_empty())
        .map(|a| String::from_utf8_lossy(a).into_owned())
        .collect();
    name_of_command(&args)
}

/// `lewis service laser --robot F` is `laser`; `lewis record ...` is `record`; another
/// program is its file name.
fn name_of_command(args: &[String]) -> String {
    let program = args
        .first()
        .and_then(|p| Path::new(p).file_name())
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    if program != "lewis" {
        return program;
    }
    // The subcommand is the first word that is not a flag (`lewis -q service laser`).
    let mut words = args.iter().skip(1).filter(|a| !a.starts_with('-'));
    match words.next().map(String::as_str) {
        Some("service") => words.next().cloned().unwrap_or(program),
        Some(sub) => sub.to_owned(),
        None => program,
    }
}

/// Entries (files and folders, counted through) under `/dev/shm` and iceoryx2's
/// `/tmp/iceoryx2`: what shared memory the machine holds.
#[must_use]
pub fn shared_memory_entries() -> u64 {
    ["/dev/shm", "/tmp/iceoryx2"]
        .iter()
        .map(|root| count_entries(Path::new(root)))
        .sum()
}

/// Entries under `root` whose name starts with `prefix` (a namespace's files and
/// folders), counted through.
#[must_use]
pub fn entries_with_prefix(root: &Path, prefix: &str) -> u64 {
    let Ok(entries) = std::fs::read_dir(root) else {
        return 0;
    };
    entries
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(prefix))
        .map(|e| 1 + count_entries(&e.path()))
        .sum()
}

fn count_entries(dir: &Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    entries
        .flatten()
        .map(|e| {
            let below = if e.file_type().is_ok_and(|t| t.is_dir()) {
                count_entries(&e.path())
            } else {
                0
            };
            1 + below
        })
        .sum()
}

/// The run's use of the machine at one moment, summed by process name.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UseSample {
    /// Seconds from the start of the chaos run.
    pub t_s: f64,
    /// The mission running then (0 for the first).
    pub mission: u32,
    /// Memory (PSS) by process name, KiB.
    pub pss_kib: BTreeMap<String, u64>,
    /// Open descriptors of the whole run.
    pub fds: u64,
    /// Entries in shared memory (the whole machine's).
    pub shm_entries: u64,
    /// CPU of the whole run since the previous sample, in % of one core (`None` for the
    /// first sample, or the first after a pause).
    pub cpu_percent: Option<f64>,
}

/// Takes [`UseSample`]s, keeping what CPU needs between two.
#[derive(Debug, Default)]
pub struct UseSampler {
    last: Option<(std::time::Instant, BTreeMap<i32, u64>)>,
}

impl UseSampler {
    /// Forgets the previous sample: the next has no CPU figure (after a pause, which the
    /// next sample must not average over).
    pub fn pause(&mut self) {
        self.last = None;
    }

    /// A sample now, at `t_s` into mission `mission`.
    pub fn sample(&mut self, t_s: f64, mission: u32) -> UseSample {
        let processes = processes_of_run();
        let now = std::time::Instant::now();
        let ticks: BTreeMap<i32, u64> = processes.iter().map(|p| (p.pid, p.cpu_ticks)).collect();
        let cpu_percent = self.last.as_ref().map(|(at, before)| {
            // A process started since counts from zero; one that ended is not counted.
            let used: u64 = ticks
                .iter()
                .map(|(pid, t)| t.saturating_sub(before.get(pid).copied().unwrap_or(0)))
                .sum();
            let elapsed = now.duration_since(*at).as_secs_f64();
            if elapsed > 0.0 {
                100.0 * used as f64 / clock_ticks_per_second() / elapsed
            } else {
                0.0
            }
        });
        self.last = Some((now, ticks));
        let mut pss_kib = BTreeMap::new();
        for p in &processes {
            *pss_kib.entry(p.name.clone()).or_insert(0) += p.pss_kib;
        }
        UseSample {
            t_s,
            mission,
            pss_kib,
            fds: processes.iter().map(|p| p.fds).sum(),
            shm_entries: shared_memory_entries(),
            cpu_percent,
        }
    }
}

/// `/proc` counts CPU time in USER_HZ ticks, 100 a second on every architecture Linux
/// exposes to user space (the kernel's own HZ is converted before it reaches `/proc`).
fn clock_ticks_per_second() -> f64 {
    100.0
}

/// The least-squares slope of `points` (x, y): `None` with fewer than two distinct x.
#[must_use]
pub fn slope(points: &[(f64, f64)]) -> Option<f64> {
    let n = points.len() as f64;
    if points.len() < 2 {
        return None;
    }
    let mean_x = points.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mean_x).powi(2)).sum();
    if sxx == 0.0 {
        return None;
    }
    let sxy: f64 = points.iter().map(|p| (p.0 - mean_x) * (p.1 - mean_y)).sum();
    Some(sxy / sxx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stat_fields_are_counted_from_the_last_parenthesis() {
        let line =
            "1234 (a (weird) name) S 77 1234 1234 0 -1 4194304 100 0 0 0 250 31 0 0 20 0 1 0 5 0 0";
        let stat = parse_stat(line).unwrap();
        assert_eq!(stat.ppid, 77);
        assert_eq!(stat.cpu_ticks, 281);
        assert!(parse_stat("garbage").is_none());
    }

    #[test]
    fn processes_are_named_by_what_they_run() {
        let args = |s: &str| s.split(' ').map(str::to_owned).collect::<Vec<_>>();
        assert_eq!(
            name_of_command(&args("/x/lewis service laser --robot r.toml")),
            "laser"
        );
        assert_eq!(
            name_of_command(&args("/x/lewis record --robot r.toml")),
            "record"
        );
        assert_eq!(
            name_of_command(&args("/usr/bin/python3 peer.py")),
            "python3"
        );
    }

    #[test]
    fn this_process_is_found_with_its_memory_and_descriptors() {
        let run = processes_of_run();
        let me = run
            .iter()
            .find(|p| p.name == "lewis")
            .expect("this process");
        assert!(me.pss_kib > 0 && me.fds > 0, "{me:?}");
    }

    #[test]
    fn a_line_has_its_slope_and_a_flat_one_none_or_zero() {
        let line: Vec<(f64, f64)> = (0..10)
            .map(|i| (f64::from(i), 3.0 * f64::from(i) + 1.0))
            .collect();
        assert!((slope(&line).unwrap() - 3.0).abs() < 1e-9);
        assert_eq!(slope(&[(1.0, 2.0), (1.0, 3.0)]), None);
        assert_eq!(slope(&[(0.0, 5.0), (1.0, 5.0)]), Some(0.0));
    }
}
