//! `lewis fault SERVICE --kill|--stall|--out-of-service|--clear`: take a service of a
//! running `lewis up` down, for demonstrations and tests.
//!
//! `--kill` sends SIGKILL to the service's process, found in the broker's status report
//! (the broker sees a crash and restarts it within its policy; kill it often enough and it
//! fails for good, and its clients move to the next provider). The others ask the
//! service's live harness, on `/lewis/fault/<service>` (see
//! [`lewis_runtime::live::fault`]): `--stall` stops it dead, heartbeats included (the
//! broker sees a missed deadline); `--out-of-service` silences it and declares it out of
//! service (the broker moves its clients at once); `--clear` ends either.

use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context as _;
use clap::{ArgGroup, Args};
use lewis_interfaces::msg::BrokerStatus;
use lewis_runtime::client::{ClientError, call_blocking};
use lewis_runtime::ipc::{CallError, Ipc};
use lewis_runtime::live::fault::{InjectError, InjectedFault, inject};
use lewis_runtime::names;

use crate::up::namespace;

/// Arguments of `lewis fault`.
#[derive(Debug, Args)]
#[command(group(
    ArgGroup::new("fault")
        .required(true)
        .args(["kill", "stall", "out_of_service", "clear"])
))]
pub struct FaultArgs {
    /// The service, by its name in the robot file (`laser`).
    pub service: String,
    /// Kill its process with SIGKILL (a crash: the broker restarts it within its policy).
    #[arg(long)]
    pub kill: bool,
    /// Stall it: no data, no heartbeats, no answers, until killed or cleared.
    #[arg(long)]
    pub stall: bool,
    /// Silence it and declare it out of service (its clients move away at once).
    #[arg(long)]
    pub out_of_service: bool,
    /// End an injected stall or out-of-service.
    #[arg(long)]
    pub clear: bool,
    /// The IPC namespace of the running `lewis up` (default: `LEWIS_NAMESPACE`, else
    /// `default`).
    #[arg(long)]
    pub namespace: Option<String>,
    /// Seconds to wait for the broker or the service to answer.
    #[arg(long, default_value_t = 2.0)]
    pub timeout: f64,
}

/// Runs `lewis fault`: 0 when the fault is in effect, 1 when the service (or the broker)
/// does not run.
pub fn run(args: &FaultArgs) -> anyhow::Result<ExitCode> {
    let namespace = namespace(args.namespace.as_deref())?;
    let timeout = Duration::try_from_secs_f64(args.timeout)
        .map_err(|_| anyhow::anyhow!("--timeout {}: give a number of seconds", args.timeout))?;
    let ipc = Ipc::open(&namespace, &format!("lewis-fault-{}", std::process::id()))?;
    let fault = if args.stall {
        InjectedFault::Stall
    } else if args.out_of_service {
        InjectedFault::OutOfService
    } else if args.clear {
        InjectedFault::Clear
    } else {
        return kill(&ipc, &args.service, &namespace.to_string(), timeout);
    };
    match inject(&ipc, &args.service, fault, timeout) {
        Ok(()) => {
            say(&format!("{}: {fault}", args.service));
            Ok(ExitCode::SUCCESS)
        }
        Err(e @ InjectError::NotRunning { .. }) => {
            complain(&e.to_string());
            Ok(ExitCode::from(1))
        }
        Err(e) => Err(e.into()),
    }
}

fn kill(ipc: &Ipc, service: &str, namespace: &str, timeout: Duration) -> anyhow::Result<ExitCode> {
    let mut broker = ipc.command_client(names::BROKER_COMMAND, &names::broker_command_config())?;
    let report = match call_blocking(&mut broker, &BrokerStatus::default(), timeout) {
        Ok(reply) => reply.report,
        Err(ClientError::Call(CallError::NoServer { .. })) => {
            complain(&format!(
                "no broker runs in namespace `{namespace}`: start one with `lewis up`"
            ));
            return Ok(ExitCode::from(1));
        }
        Err(e) => return Err(e).context("the broker did not give its status"),
    };
    let Some(pid) = pid_of(&report, service) else {
        let running = processes(&report)
            .map(|(name, _)| name)
            .collect::<Vec<_>>()
            .join(", ");
        complain(&format!(
            "service `{service}` has no running process in namespace `{namespace}` (running: {})",
            if running.is_empty() { "none" } else { &running }
        ));
        return Ok(ExitCode::from(1));
    };
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(pid),
        nix::sys::signal::Signal::SIGKILL,
    )
    .with_context(|| format!("cannot send SIGKILL to {service} (pid {pid})"))?;
    say(&format!("{service}: killed (pid {pid})"));
    Ok(ExitCode::SUCCESS)
}

/// The `process NAME: pid PID` lines of the broker's status report.
fn processes(report: &str) -> impl Iterator<Item = (&str, i32)> {
    report.lines().filter_map(|line| {
        let (name, pid) = line.strip_prefix("process ")?.split_once(": pid ")?;
        Some((name, pid.trim().parse().ok().filter(|p: &i32| *p > 0)?))
    })
}

/// The pid of `service`'s process, as the broker reports it.
fn pid_of(report: &str, service: &str) -> Option<i32> {
    processes(report)
        .find(|(name, _)| *name == service)
        .map(|(_, pid)| pid)
}

fn say(text: &str) {
    #[allow(clippy::print_stdout)]
    {
        println!("{text}");
    }
}

fn complain(text: &str) {
    #[allow(clippy::print_stderr)]
    {
        eprintln!("{text}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pid_of_a_service_is_read_from_the_status_report() {
        fn check(service: &str, expected: Option<i32>) {
            let report = "robot sim in namespace t\n\
                          service laser: running, ok\n\
                          process laser: pid 4242\n\
                          process laser_backup: pid 17\n\
                          process sonar: pid zero\n";
            assert_eq!(pid_of(report, service), expected, "{service}");
        }
        check("laser", Some(4242));
        check("laser_backup", Some(17));
        check("sonar", None);
        check("camera", None);
    }
}
