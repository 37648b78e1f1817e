//! The `lewis` command line: clap definitions and the dispatch to the library crates.
//! Every behaviour lives in a library crate; this one parses, calls, and prints.
//!
//! Exit codes: 0 success; 1 the command ran and found problems (invalid definitions,
//! a failed check); 2 the command could not run (bad arguments, unreadable files).

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod idl;
mod info;
mod seq;
mod service;
mod status;
mod up;

/// The `lewis` command line.
#[derive(Debug, Parser)]
#[command(
    name = "lewis",
    version,
    about = "Fault-tolerant robot control, recorded and replayed",
    long_about = "Lewis runs robot software as small services that implement interfaces \
                  defined in XML, records every publication into MCAP, and replays \
                  recordings deterministically."
)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Check and show interface definitions.
    #[command(subcommand)]
    Idl(idl::IdlCommand),
    /// Describe an MCAP recording: channels, counts, rates, losses, and decoded messages.
    Info(info::InfoArgs),
    /// Check and run mission scripts (the sequencer).
    #[command(subcommand)]
    Seq(seq::SeqCommand),
    /// Start the broker and a robot's services; run until Ctrl-C or --duration.
    Up(up::UpArgs),
    /// Run one service of a robot in this process (what `lewis up` starts).
    Service(service::ServiceArgs),
    /// Show the broker's services, health, restarts and bindings.
    Status(status::StatusArgs),
}

/// Runs the parsed command and returns the process exit code.
///
/// # Errors
/// When the command cannot run; the caller prints the error chain and exits with 2.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Idl(command) => idl::run(command),
        Command::Info(args) => info::run(&args),
        Command::Seq(command) => seq::run(command),
        Command::Up(args) => up::run(&args),
        Command::Service(args) => service::run(&args),
        Command::Status(args) => status::run(&args),
    }
}
