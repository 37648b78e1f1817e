//! `lewis fault SERVICE --kill|--stall|--out-of-service|--frozen|--garbage|--clear`: take a
//! service of a running `lewis up` down, for demonstrations and tests.
//!
//! `--kill` sends SIGKILL to the service's process, found in the broker's status reply
//! (the broker sees a crash and restarts it within its policy; kill it often enough and it
//! fails for good, and its clients move to the next provider). The others ask the
//! service's live harness, on `/lewis/fault/<service>` (see
//! [`lewis_runtime::live::fault`]): `--stall` stops it dead, heartbeats included (the
//! broker sees a missed deadline); `--out-of-service` silences it and declares it out of
//! service (the broker moves its clients at once); `--frozen` and `--garbage` make it
//! publish the same payload again and again, or bytes that do not decode, under good
//! heartbeats (the broker's data checks must catch them); `--clear` ends any of them.

use std::process::ExitCode;
use std::time::Duration;

use clap::{ArgGroup, Args};
use lewis_runtime::ipc::Ipc;
use lewis_runtime::live::fault::{InjectError, KillError, LIVE_FAULTS, ServiceFault, inject, kill};

use lewis_runtime::ipc::Namespace;

/// Arguments of `lewis fault`.
#[derive(Debug, Args)]
#[command(group(
    ArgGroup::new("fault")
        .required(true)
        .args(["kill", "stall", "out_of_service", "frozen", "garbage", "clear"])
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
    /// Publish its first sample from now on again and again (new headers), heartbeats as
    /// usual.
    #[arg(long)]
    pub frozen: bool,
    /// Publish bytes that do not decode in place of its samples, heartbeats as usual.
    #[arg(long)]
    pub garbage: bool,
    /// End an injected stall, out-of-service, freeze or garbage.
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
    let namespace = Namespace::from_arg(args.namespace.as_deref())?;
    let timeout = Duration::try_from_secs_f64(args.timeout)
        .map_err(|_| anyhow::anyhow!("--timeout {}: give a number of seconds", args.timeout))?;
    let ipc = Ipc::open(&namespace, &format!("lewis-fault-{}", std::process::id()))?;
    let fault = if args.stall {
        Some(ServiceFault::Stall)
    } else if args.out_of_service {
        Some(ServiceFault::OutOfService)
    } else if args.frozen {
        Some(ServiceFault::Frozen)
    } else if args.garbage {
        Some(ServiceFault::Garbage)
    } else if args.clear {
        None
    } else {
        return match kill(&ipc, &args.service, timeout) {
            Ok(pid) => {
                say(&format!("{}: killed (pid {pid})", args.service));
                Ok(ExitCode::SUCCESS)
            }
            Err(e @ (KillError::NoBroker { .. } | KillError::NotRunning { .. })) => {
                complain(&e.to_string());
                Ok(ExitCode::from(1))
            }
            Err(e) => Err(e.into()),
        };
    };
    match inject(&ipc, &args.service, fault, timeout) {
        Ok(()) => {
            say(&format!("{}: {}", args.service, LIVE_FAULTS.word(fault)));
            Ok(ExitCode::SUCCESS)
        }
        Err(e @ InjectError::NotRunning { .. }) => {
            complain(&e.to_string());
            Ok(ExitCode::from(1))
        }
        Err(e) => Err(e.into()),
    }
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
