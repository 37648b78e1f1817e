//! A sub-task program run as the sequencer's child: one process, the live program harness.

use lewis_apps::App;
use lewis_runtime::ipc::Namespace;
use lewis_runtime::live::{ClockSource, LiveError, ProgramSpec, run_program};

/// Runs `app` in this process until it finishes or is stopped; returns the exit code the
/// process must end with.
///
/// The node (and the broker's client) is named after the program and this process,
/// `door-navigator-4242`: a program the sequencer restarts after a crash is a new client,
/// and the broker drops the dead one's bindings when its process is gone.
///
/// # Errors
/// When IPC fails or the program does not start.
pub fn run_app(app: App, namespace: &Namespace, clock: ClockSource) -> Result<i32, LiveError> {
    let spec = ProgramSpec {
        name: format!("{}-{}", app.name(), std::process::id()),
        requires: app.requires().iter().map(|s| (*s).to_owned()).collect(),
        seed: 1,
    };
    let mut program = app.program();
    run_program(&spec, program.as_mut(), namespace, clock)
}
