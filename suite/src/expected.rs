//! The results accepted as expected (`lewis test --accept`), kept beside each recording as
//! `RUN.expected.json` to be reviewed in a diff: the check's outcome, and the mission's
//! fate at each point of each sweep. A case whose result differs from the accepted one
//! fails; a case with nothing accepted is judged on its own (the check against the
//! recording, a point against the faults file's expectations).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// What was accepted for one run.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Accepted {
    /// The check's outcome.
    pub check: Option<AcceptedCheck>,
    /// The sweeps' points.
    pub points: Vec<AcceptedPoint>,
}

/// A check's outcome as accepted.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AcceptedCheck {
    /// Whether the replay matched the recording.
    pub passed: bool,
    /// The output channels beyond the tolerance.
    pub failing: Vec<String>,
    /// Whether the mission lived again succeeded (`None`: none was).
    pub succeeded: Option<bool>,
    /// The states it went through.
    pub course: Vec<String>,
}

/// A point's outcome as accepted.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AcceptedPoint {
    /// The sweep's name.
    pub sweep: String,
    /// The fault's time, from the start of the recording.
    pub at_ns: i64,
    /// Whether the mission succeeded.
    pub succeeded: bool,
}

/// Where the accepted results of the run in `file` are kept: `FILE.expected.json`.
#[must_use]
pub fn expected_path(file: &Path) -> PathBuf {
    let mut name = file.file_name().unwrap_or_default().to_os_string();
    name.push(".expected.json");
    file.with_file_name(name)
}

/// The accepted results at `path` (`None`: nothing accepted yet).
///
/// # Errors
/// When the file is there but cannot be read or is not such a file, for people.
pub fn read(path: &Path) -> Result<Option<Accepted>, String> {
    match std::fs::read_to_string(path) {
        Ok(text) => serde_json::from_str(&text).map(Some).map_err(|e| {
            format!(
                "its accepted results {} cannot be read: {e}",
                path.display()
            )
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(format!(
            "its accepted results {} cannot be read: {e}",
            path.display()
        )),
    }
}
