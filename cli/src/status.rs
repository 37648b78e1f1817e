//! `lewis status`: what the broker of a namespace says: services, health, restarts,
//! processes and bindings.

use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use lewis_interfaces::msg::BrokerStatus;
use lewis_runtime::broker::status::StatusText;
use lewis_runtime::client::{ClientError, call_blocking};
use lewis_runtime::ipc::{CallError, Ipc};
use lewis_runtime::names;

use lewis_runtime::ipc::Namespace;

/// Arguments of `lewis status`.
#[derive(Debug, Args)]
pub struct StatusArgs {
    /// The IPC namespace (default: `LEWIS_NAMESPACE`, else `default`).
    #[arg(long)]
    pub namespace: Option<String>,
    /// Seconds to wait for the broker's answer.
    #[arg(long, default_value_t = 2.0)]
    pub timeout: f64,
}

/// Runs `lewis status`: prints the report and exits 0, or exits 1 when no broker answers.
pub fn run(args: &StatusArgs) -> anyhow::Result<ExitCode> {
    let namespace = Namespace::from_arg(args.namespace.as_deref())?;
    let ipc = Ipc::open(&namespace, &format!("lewis-status-{}", std::process::id()))?;
    let mut broker = ipc.command_client(names::BROKER_COMMAND, &names::broker_command_config())?;
    let timeout = Duration::try_from_secs_f64(args.timeout)
        .map_err(|_| anyhow::anyhow!("--timeout {}: give a number of seconds", args.timeout))?;
    match call_blocking(&mut broker, &BrokerStatus::default(), timeout) {
        Ok(reply) => {
            #[allow(clippy::print_stdout)]
            {
                print!("{}", StatusText(&reply));
            }
            Ok(ExitCode::SUCCESS)
        }
        Err(ClientError::Call(CallError::NoServer { .. })) => {
            #[allow(clippy::print_stderr)]
            {
                eprintln!("no broker runs in namespace `{namespace}`: start one with `lewis up`");
            }
            Ok(ExitCode::from(1))
        }
        Err(e) => Err(e.into()),
    }
}
