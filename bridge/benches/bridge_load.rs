//! The bridge's CPU at the simulated robot's full traffic: `robots/sim.toml` on two hosts of
//! [`lewis_testkit::hosts`] (the robot host with the simulated devices, the broker and the
//! recorder; the workstation with the perception: blob finder and sign detector, reading
//! the robot's camera across the link and sending their results and heartbeats back), as
//! the multi-host tests run it ([`lewis_testkit::robot_files::sim_on_two_hosts`]).
//!
//! Once the workstation has joined and its perception has warmed up, it measures for
//! `--seconds` (default 20) the CPU of each thread of both hosts' `lewis up` processes
//! (`/proc/PID/task/*/stat`) and the bytes that crossed the link (`/proc/net/dev` of the
//! workstation), then prints the bridge's share: its own threads (`lewis-bridge`, which
//! forwards, and on the robot host `lewis-hosts`, which watches the other hosts) and
//! Zenoh's runtime threads on each host, in percent of one core, beside the rest of
//! each process. Goal: the bridge under 5% of a core.
//!
//! `cargo bench -p lewis-bridge --bench bridge_load` (`-- --seconds N`). Needs root for the
//! network namespaces; skipped with the reason where they are forbidden.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::print_stdout,
    clippy::print_stderr,
    clippy::cast_precision_loss,
    reason = "a benchmark: it reports on stdout, and its figures are floating point"
)]

use std::collections::BTreeMap;
use std::fs::File;
use std::path::Path;
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use lewis_testkit::hosts::{Host, Hosts};
use lewis_testkit::{lewis_exe, repository_root};

/// How long the perception warms up after the workstation joined.
const WARM_UP: Duration = Duration::from_secs(5);

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let seconds: u64 = match args.as_slice() {
        [] => 20,
        [flag, n] if flag == "--seconds" => n.parse().expect("--seconds takes a number"),
        _ => panic!("usage: bridge_load [--seconds N]"),
    };
    let hosts = match Hosts::new(&["robot", "workstation"]) {
        Ok(hosts) => hosts,
        Err(why) => {
            eprintln!("bridge_load: skipped: {}", why.0);
            return;
        }
    };
    let dir = tempfile::tempdir().unwrap();
    let robot = dir.path().join("two-hosts.toml");
    std::fs::write(&robot, lewis_testkit::robot_files::sim_on_two_hosts("")).unwrap();
    let robot = robot.to_str().unwrap();
    let mcap = dir.path().join("run.mcap");
    let (robot_log, ws_log) = (dir.path().join("robot.log"), dir.path().join("ws.log"));
    let run_for = format!("{}s", seconds + 60);
    let mut on_robot = up(
        hosts.host("robot"),
        &[
            "up",
            robot,
            "--namespace",
            "load",
            "--duration",
            &run_for,
            "-o",
            mcap.to_str().unwrap(),
        ],
        &robot_log,
    );
    let mut on_ws = up(
        hosts.host("workstation"),
        &["up", robot, "--host", "workstation", "--namespace", "load"],
        &ws_log,
    );
    wait_for(&robot_log, "host workstation joined");
    std::thread::sleep(WARM_UP);

    let pids = [("robot", on_robot.id()), ("workstation", on_ws.id())];
    let link = |host: &Host| link_bytes(host);
    let (threads0, link0, t0) = (
        pids.map(|(_, pid)| thread_ticks(pid)),
        link(hosts.host("workstation")),
        Instant::now(),
    );
    std::thread::sleep(Duration::from_secs(seconds));
    let (threads1, link1, elapsed) = (
        pids.map(|(_, pid)| thread_ticks(pid)),
        link(hosts.host("workstation")),
        t0.elapsed(),
    );
    // `/proc`'s clock ticks: USER_HZ, which Linux fixes at 100 a second.
    let ticks_per_s = 100.0;
    let percent = |ticks: u64| ticks as f64 / ticks_per_s / elapsed.as_secs_f64() * 100.0;

    println!(
        "the simulated robot on two hosts, perception on the workstation, {:.0} s measured",
        elapsed.as_secs_f64()
    );
    println!(
        "link: {:.2} MB/s to the workstation, {:.2} MB/s back",
        (link1.0 - link0.0) as f64 / elapsed.as_secs_f64() / 1e6,
        (link1.1 - link0.1) as f64 / elapsed.as_secs_f64() / 1e6
    );
    println!(
        "{:<12} {:>14} {:>14} {:>14}",
        "host", "bridge threads", "zenoh threads", "rest of lewis up"
    );
    for (k, (host, _)) in pids.iter().enumerate() {
        let (mut forwarding, mut zenoh, mut rest) = (0, 0, 0);
        let mut by_name: BTreeMap<String, u64> = BTreeMap::new();
        for (tid, (name, after)) in &threads1[k] {
            let before = threads0[k].get(tid).map_or(0, |(_, t)| *t);
            let used = after.saturating_sub(before);
            *by_name.entry(name.clone()).or_default() += used;
            match thread_kind(name) {
                Kind::Forwarding => forwarding += used,
                Kind::Zenoh => zenoh += used,
                Kind::Other => rest += used,
            }
        }
        println!(
            "{:<12} {:>13.1}% {:>13.1}% {:>13.1}%",
            host,
            percent(forwarding),
            percent(zenoh),
            percent(rest)
        );
        let busiest: Vec<String> = by_name
            .iter()
            .filter(|(_, t)| **t > 0)
            .map(|(n, t)| format!("{n} {:.1}%", percent(*t)))
            .collect();
        println!("  threads: {}", busiest.join(", "));
    }

    for child in [&mut on_ws, &mut on_robot] {
        let pid = nix::unistd::Pid::from_raw(i32::try_from(child.id()).unwrap());
        let _ = nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT);
        let _ = lewis_testkit::wait_child_within(child, Duration::from_secs(30));
    }
}

fn up(host: &Host, args: &[&str], log: &Path) -> Child {
    let log = File::create(log).unwrap();
    host.command(lewis_exe())
        .current_dir(repository_root())
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::from(log.try_clone().unwrap()))
        .stderr(Stdio::from(log))
        .spawn()
        .unwrap()
}

/// Waits (at most a minute) until `log` holds `needle`.
fn wait_for(log: &Path, needle: &str) {
    let start = Instant::now();
    while !std::fs::read_to_string(log)
        .unwrap_or_default()
        .contains(needle)
    {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no `{needle}` in {}:\n{}",
            log.display(),
            std::fs::read_to_string(log).unwrap_or_default()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

enum Kind {
    Forwarding,
    Zenoh,
    Other,
}

/// Which part of `lewis up` a thread of this name belongs to. Zenoh's threads are its
/// runtimes' workers (`app-N`, `net-N`, `rx-N`, `tx-N`, `acc-N`) and its timer.
fn thread_kind(name: &str) -> Kind {
    // The forwarding thread, and the robot host's watcher of the other hosts.
    if name == "lewis-bridge" || name == "lewis-hosts" {
        return Kind::Forwarding;
    }
    let base = name.trim_end_matches(|c: char| c.is_ascii_digit() || c == '-');
    if ["app", "net", "rx", "tx", "acc", "zenoh", "Timer", "timer"].contains(&base) {
        Kind::Zenoh
    } else {
        Kind::Other
    }
}

/// Each thread of `pid`: its name and its CPU (user and system) in clock ticks.
fn thread_ticks(pid: u32) -> BTreeMap<u32, (String, u64)> {
    let mut threads = BTreeMap::new();
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return threads;
    };
    for task in tasks.flatten() {
        let Ok(stat) = std::fs::read_to_string(task.path().join("stat")) else {
            continue;
        };
        // `tid (name) state ...`: the name may hold spaces and parentheses.
        let (Some(open), Some(close)) = (stat.find('('), stat.rfind(')')) else {
            continue;
        };
        let name = stat[open + 1..close].to_owned();
        let fields: Vec<&str> = stat[close + 2..].split(' ').collect();
        // Fields 14 and 15 of stat (utime, stime), counted from the state (field 3).
        let ticks = |i: usize| {
            fields
                .get(i)
                .and_then(|f| f.parse::<u64>().ok())
                .unwrap_or(0)
        };
        let tid = stat[..open].trim().parse().unwrap_or(0);
        threads.insert(tid, (name, ticks(11) + ticks(12)));
    }
    threads
}

/// The bytes `host` received and sent on its link (`veth0`), from its `/proc/net/dev`.
fn link_bytes(host: &Host) -> (u64, u64) {
    let out = host.command("cat").arg("/proc/net/dev").output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines()
        .find_map(|line| {
            let (device, counters) = line.split_once(':')?;
            (device.trim() == "veth0").then(|| {
                let n: Vec<u64> = counters
                    .split_whitespace()
                    .map(|f| f.parse().unwrap_or(0))
                    .collect();
                (
                    n.first().copied().unwrap_or(0),
                    n.get(8).copied().unwrap_or(0),
                )
            })
        })
        .unwrap_or((0, 0))
}
