//! A stand-in for a robot's sub-task program in sequencer tests: it exits with a given code,
//! crashes with a signal, sleeps, or waits for a file, run after run.
//!
//! ```text
//! lewis-seq-testprog [--runs COUNTER_FILE] PLAN [PLAN...]
//! ```
//!
//! Each PLAN is what one run does, as comma-separated steps, the last step usually ending
//! the run: `exit:N`, `signal:SEGV` (or a number; core dumps are disabled), `sleep:MS`,
//! `wait:PATH` (until the file exists), `print:TEXT` (a stdout line), `eprint:TEXT` (a
//! stderr line), `touch:PATH`, `pidfile:PATH` (its own pid), `child:PATH` (starts a
//! grandchild that sleeps for a minute and writes its pid to PATH), `ignore-term` (SIGTERM
//! does nothing, so only SIGKILL stops it). A plan that ends without exiting exits with 0.
//!
//! With `--runs`, the counter file (created when missing) says which run this is: run 1
//! follows the first plan, run 2 the second, and the last plan repeats. So
//! `--runs c signal:SEGV signal:SEGV signal:SEGV signal:SEGV exit:0` crashes four times,
//! then succeeds.
//!
//! **Stand-in mode.** Called by another name (a symbolic link `bin/DoorNavigator` to this
//! program, so that a shipped mission script runs unchanged in a test), it ignores its
//! arguments (it prints them, `PROGRAM args: ...`) and reads its plans from the file
//! `PROGRAM.plans` beside the link, one plan per line, counting its runs in
//! `PROGRAM.runs`.

use std::path::Path;
use std::process::ExitCode;
use std::str::FromStr;
use std::time::Duration;

use nix::sys::signal::{self, SigHandler, Signal};

/// This program's own name; any other name is a stand-in.
const OWN_NAME: &str = "lewis-seq-testprog";

fn main() -> ExitCode {
    let mut argv = std::env::args();
    let called = argv.next().unwrap_or_default();
    let args: Vec<String> = argv.collect();
    let result = match Path::new(&called).file_name().and_then(|n| n.to_str()) {
        Some(name) if name != OWN_NAME && !name.starts_with(&format!("{OWN_NAME}-")) => {
            stand_in(&called, &args)
        }
        _ => run(&args),
    };
    match result {
        Ok(code) => code,
        Err(message) => {
            #[allow(clippy::print_stderr)]
            {
                eprintln!("lewis-seq-testprog: {message}");
            }
            ExitCode::from(64)
        }
    }
}

fn run(args: &[String]) -> Result<ExitCode, String> {
    let (counter, plans) = match args {
        [flag, counter, plans @ ..] if flag == "--runs" => (Some(counter.as_str()), plans),
        plans => (None, plans),
    };
    let run = match counter {
        Some(path) => next_run(Path::new(path))?,
        None => 1,
    };
    let plan = plans
        .get(run - 1)
        .or_else(|| plans.last())
        .ok_or("no plan given: pass steps such as `exit:0`")?;
    for step in plan.split(',').filter(|s| !s.is_empty()) {
        if let Some(code) = do_step(step)? {
            return Ok(code);
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Runs as the program `called` (a link to this one): the plans of `called.plans`, the
/// counter `called.runs`.
fn stand_in(called: &str, args: &[String]) -> Result<ExitCode, String> {
    let name = Path::new(called)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    #[allow(clippy::print_stdout)]
    {
        println!("{name} args: {args:?}");
    }
    let plans_path = format!("{called}.plans");
    let plans: Vec<String> = std::fs::read_to_string(&plans_path)
        .map_err(|e| format!("stand-in {name}: {plans_path}: {e}"))?
        .lines()
        .map(str::trim)
        .filter(|line| !line.is_empty())
        .map(str::to_owned)
        .collect();
    let mut args = vec!["--runs".to_owned(), format!("{called}.runs")];
    args.extend(plans);
    run(&args)
}

/// Reads, increments and writes back the run counter; returns this run's number from 1.
fn next_run(path: &Path) -> Result<usize, String> {
    let previous = match std::fs::read_to_string(path) {
        Ok(text) => text
            .trim()
            .parse::<usize>()
            .map_err(|e| format!("{}: {e}", path.display()))?,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => 0,
        Err(e) => return Err(format!("{}: {e}", path.display())),
    };
    let run = previous + 1;
    std::fs::write(path, run.to_string()).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(run)
}

/// Does one step; `Some` when the step ends the run with that exit code.
fn do_step(step: &str) -> Result<Option<ExitCode>, String> {
    let (name, value) = step.split_once(':').unwrap_or((step, ""));
    match name {
        "exit" => {
            let code: u8 = value
                .parse()
                .map_err(|e| format!("`{step}`: exit code: {e}"))?;
            Ok(Some(ExitCode::from(code)))
        }
        "signal" => {
            let signal = parse_signal(value)?;
            rustix::process::setrlimit(
                rustix::process::Resource::Core,
                rustix::process::Rlimit {
                    current: Some(0),
                    maximum: None,
                },
            )
            .ok();
            // Rust's runtime handles SIGSEGV and SIGBUS (to report stack overflows) and
            // returns from a raised one: the default action is needed to die of it.
            // SAFETY: installing SIG_DFL runs no code of ours in a handler.
            unsafe { signal::signal(signal, SigHandler::SigDfl) }
                .map_err(|e| format!("`{step}`: {e}"))?;
            signal::raise(signal).map_err(|e| format!("`{step}`: {e}"))?;
            // A signal whose default action is not to terminate leaves us here.
            Ok(Some(ExitCode::from(65)))
        }
        "sleep" => {
            let ms: u64 = value.parse().map_err(|e| format!("`{step}`: {e}"))?;
            std::thread::sleep(Duration::from_millis(ms));
            Ok(None)
        }
        "wait" => {
            while !Path::new(value).exists() {
                std::thread::sleep(Duration::from_millis(10));
            }
            Ok(None)
        }
        "print" => {
            #[allow(clippy::print_stdout)]
            {
                println!("{value}");
            }
            Ok(None)
        }
        "eprint" => {
            #[allow(clippy::print_stderr)]
            {
                eprintln!("{value}");
            }
            Ok(None)
        }
        "touch" => write(value, ""),
        "pidfile" => write(value, &std::process::id().to_string()),
        "child" => {
            let me = std::env::current_exe().map_err(|e| format!("`{step}`: {e}"))?;
            let child = std::process::Command::new(me)
                .arg("sleep:60000")
                .spawn()
                .map_err(|e| format!("`{step}`: {e}"))?;
            write(value, &child.id().to_string())
        }
        "ignore-term" => {
            // SAFETY: installing SIG_IGN runs no code of ours in the handler.
            unsafe { signal::signal(Signal::SIGTERM, SigHandler::SigIgn) }
                .map_err(|e| format!("`{step}`: {e}"))?;
            Ok(None)
        }
        _ => Err(format!(
            "unknown step `{step}`: use exit:N, signal:NAME, sleep:MS, wait:PATH, print:TEXT, \
             eprint:TEXT, touch:PATH, pidfile:PATH, child:PATH or ignore-term"
        )),
    }
}

fn write(path: &str, text: &str) -> Result<Option<ExitCode>, String> {
    // Write then rename, so a reader never sees a half-written pid.
    let tmp = format!("{path}.tmp");
    std::fs::write(&tmp, text).map_err(|e| format!("{tmp}: {e}"))?;
    std::fs::rename(&tmp, path).map_err(|e| format!("{path}: {e}"))?;
    Ok(None)
}

fn parse_signal(value: &str) -> Result<Signal, String> {
    if let Ok(number) = value.parse::<i32>() {
        return Signal::try_from(number).map_err(|e| format!("signal {number}: {e}"));
    }
    let name = if value.starts_with("SIG") {
        value.to_owned()
    } else {
        format!("SIG{value}")
    };
    Signal::from_str(&name).map_err(|_| format!("unknown signal `{value}`"))
}
