//! The other process of the cross-process IPC tests (`runtime/tests/ipc_cross_process.rs`):
//! it joins the namespace of `LEWIS_NAMESPACE` as node `peer-ROLE`, plays one role and keeps
//! its endpoints until its standard input closes, so the test decides when it goes away.
//!
//! Usage: `lewis-ipc-peer ROLE`, ROLE one of:
//! - `publish-sizes`: publishes on `sizes` one payload of 64 B, 64 KiB and 1 MiB, each
//!   filled with [`pattern`];
//! - `publish-on-line`: reads one line from stdin and publishes it on `wake`;
//! - `publish-then-hang`: publishes `alive` on `alive`;
//! - `serve-echo`: serves the command `echo`, publishes `serving` on `ready`, answers one
//!   request with its bytes reversed.
//!
//! Exits 0 when its role went through, 1 with a message otherwise, 2 on a bad role.

use std::io::{BufRead, Read, Write};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use lewis_runtime::ipc::{ChannelConfig, CommandConfig, Ipc, WaitSet, WakeMode};

/// Payload sizes of `publish-sizes`.
const SIZES: [usize; 3] = [64, 64 << 10, 1 << 20];
/// The longest the echo server waits for its request.
const WATCHDOG: Duration = Duration::from_secs(30);

/// The bytes of a payload of `len` bytes (the test checks them).
fn pattern(len: usize) -> impl Fn(&mut [u8]) {
    move |buf: &mut [u8]| {
        for (i, b) in buf.iter_mut().enumerate() {
            *b = u8::try_from((i * 31 + len) % 251).unwrap_or(0);
        }
    }
}

/// The channel settings both sides use.
fn config() -> ChannelConfig {
    ChannelConfig {
        buffer: 8,
        ..ChannelConfig::sensor(64)
    }
}

fn main() -> ExitCode {
    let Some(role) = std::env::args().nth(1) else {
        let _ = writeln!(std::io::stderr(), "usage: lewis-ipc-peer ROLE");
        return ExitCode::from(2);
    };
    match run(&role) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            let _ = writeln!(std::io::stderr(), "lewis-ipc-peer {role}: {message}");
            ExitCode::FAILURE
        }
    }
}

/// An error as the text the test will show.
fn text(e: impl std::fmt::Display) -> String {
    e.to_string()
}

fn run(role: &str) -> Result<(), String> {
    let ipc = Ipc::open_from_env(&format!("peer-{role}")).map_err(text)?;
    let mut stdin = std::io::stdin().lock();
    match role {
        "publish-sizes" => {
            let mut publisher = ipc.publisher("sizes", &config()).map_err(text)?;
            for len in SIZES {
                publisher.publish_with(len, pattern(len)).map_err(text)?;
            }
            hold_until_stdin_closes(&mut stdin);
        }
        "publish-on-line" => {
            let mut publisher = ipc.publisher("wake", &config()).map_err(text)?;
            let mut line = String::new();
            stdin.read_line(&mut line).map_err(text)?;
            publisher
                .publish(line.trim_end().as_bytes())
                .map_err(text)?;
            hold_until_stdin_closes(&mut stdin);
        }
        "publish-then-hang" => {
            let mut publisher = ipc.publisher("alive", &config()).map_err(text)?;
            publisher.publish(b"alive").map_err(text)?;
            hold_until_stdin_closes(&mut stdin);
        }
        "serve-echo" => {
            let server = ipc
                .command_server("echo", &CommandConfig::default())
                .map_err(text)?;
            let mut ready = ipc.publisher("ready", &config()).map_err(text)?;
            ready.publish(b"serving").map_err(text)?;
            let waits = WaitSet::new(WakeMode::Event);
            let deadline = Instant::now() + WATCHDOG;
            let request = loop {
                if let Some(request) = server.receive().map_err(text)? {
                    break request;
                }
                if Instant::now() >= deadline {
                    return Err(format!("no request within {WATCHDOG:?}"));
                }
                waits.wait(&[&server], Some(deadline)).map_err(text)?;
            };
            let mut answer = request.bytes().to_vec();
            answer.reverse();
            server.reply(request, &answer).map_err(text)?;
            hold_until_stdin_closes(&mut stdin);
        }
        other => return Err(format!("unknown role `{other}`")),
    }
    Ok(())
}

/// Keeps the caller's endpoints alive until the test closes our stdin: a publisher that
/// goes takes its undelivered samples with it.
fn hold_until_stdin_closes(stdin: &mut impl Read) {
    let mut rest = Vec::new();
    let _ = stdin.read_to_end(&mut rest);
}
