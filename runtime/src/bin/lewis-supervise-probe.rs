//! Runs one program under a [`Supervisor`] and prints the supervisor's view of it: a diagnostic
//! for process supervision, and the parent process of the test that kills a supervisor with
//! SIGKILL and checks that its child does not survive.
//!
//! Usage: `lewis-supervise-probe NAME PROGRAM [ARGS...]`. Prints `pid PID` once the child has
//! started, then one line per event, and exits when the child has exited.

use std::io::Write;
use std::process::ExitCode;

use lewis_runtime::supervise::{ChildSpec, Supervisor, SupervisorEvent};

fn main() -> ExitCode {
    let mut args = std::env::args_os().skip(1);
    let (Some(name), Some(program)) = (args.next(), args.next()) else {
        let _ = writeln!(
            std::io::stderr(),
            "usage: lewis-supervise-probe NAME PROGRAM [ARGS...]"
        );
        return ExitCode::from(2);
    };
    match run(
        &name.to_string_lossy(),
        ChildSpec::new(name.to_string_lossy(), program).args(args),
    ) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            let _ = writeln!(std::io::stderr(), "lewis-supervise-probe: {message}");
            ExitCode::FAILURE
        }
    }
}

fn run(name: &str, spec: ChildSpec) -> Result<(), String> {
    let mut supervisor = Supervisor::new().map_err(|e| e.to_string())?;
    let pid = supervisor.start(spec).map_err(|e| e.to_string())?;
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "pid {pid}")
        .and_then(|()| stdout.flush())
        .map_err(|e| e.to_string())?;
    loop {
        let event = supervisor.wait_event(None).map_err(|e| e.to_string())?;
        if let Some(event) = event {
            let _ = writeln!(stdout, "{event:?}").and_then(|()| stdout.flush());
            if matches!(event, SupervisorEvent::Exited { .. }) && supervisor.pid(name).is_none() {
                return Ok(());
            }
        }
    }
}
