//! Helpers for the end-to-end tests in `tests/tests/`: where the repository, the shared
//! data and the independent Python readers are, and a fresh temporary directory and IPC
//! namespace for each test.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository's root folder.
#[must_use]
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// A file or folder of `../shared/data/`, real data recorded by others.
///
/// # Panics
/// When the shared data folder is not beside the repository: the message says where it
/// was looked for.
#[must_use]
pub fn shared_data(relative: &str) -> PathBuf {
    let path = repo_root().join("../shared/data").join(relative);
    assert!(
        path.exists(),
        "{} is missing: the tests read real data from ../shared/data beside the repository",
        path.display()
    );
    path
}

/// A command running a program of the Python environment made by
/// `scripts/setup-python.sh` (`python`, `pymcap-cli`, ...).
///
/// # Panics
/// When the environment is missing, saying how to make it.
#[must_use]
pub fn python_tool(name: &str) -> Command {
    let venv =
        std::env::var_os("LEWIS_VENV").map_or_else(|| repo_root().join(".venv"), PathBuf::from);
    let program = venv.join("bin").join(name);
    assert!(
        program.exists(),
        "{} is missing: run scripts/setup-python.sh to install the independent MCAP readers",
        program.display()
    );
    Command::new(program)
}

/// Runs a command to completion and returns its stdout, or panics with everything it
/// printed.
///
/// # Panics
/// When the command cannot start or exits unsuccessfully.
#[must_use]
pub fn run_ok(command: &mut Command) -> String {
    let output = command
        .output()
        .unwrap_or_else(|err| panic!("cannot run {command:?}: {err}"));
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        output.status.success(),
        "{command:?} failed ({}):\n{stdout}\n{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    stdout
}
