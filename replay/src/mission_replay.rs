//! `lewis seq replay`: a recorded mission replayed on a script's state machine, from an
//! MCAP recording (its `/lewis/sequencer` channel, [`crate::mission_log`]) or from the JSON
//! lines of `lewis seq run --events`, to the first place where the script decides
//! differently.

use std::fmt;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use lewis_sequencer::replay::{
    Comparison, ReadError, Recording, RecordingError, compare, read_json_lines, split_missions,
};
use lewis_sequencer::resolve::{ProgramResolver, SystemResolver, TrustingResolver};
use lewis_sequencer::{FileSystem, check_with};

use crate::mission_log::{McapReadError, is_mcap, read_mcap};

/// Why a recorded mission could not be replayed.
#[derive(Debug, thiserror::Error)]
pub enum MissionReplayError {
    /// The file could not be opened or read.
    #[error("cannot read the recording {}: {source}", path.display())]
    Open {
        /// The recording.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The MCAP recording could not be read.
    #[error(transparent)]
    Mcap(#[from] McapReadError),
    /// The JSON lines could not be read.
    #[error("{}: {source}", path.display())]
    Events {
        /// The events file.
        path: PathBuf,
        /// What is wrong.
        source: ReadError,
    },
    /// The file holds several missions and none was chosen.
    #[error("{} holds {count} missions; choose one with --mission 1..{count}", path.display())]
    Ambiguous {
        /// The recording.
        path: PathBuf,
        /// How many.
        count: usize,
    },
    /// The mission chosen is not in the file.
    #[error("--mission {chosen}: {} holds {count} missions, numbered from 1", path.display())]
    NoSuchMission {
        /// The recording.
        path: PathBuf,
        /// The number asked for.
        chosen: usize,
        /// How many there are.
        count: usize,
    },
    /// The mission's records do not make a recording.
    #[error("{}: {source}", path.display())]
    Recording {
        /// The recording.
        path: PathBuf,
        /// What is wrong.
        source: RecordingError,
    },
    /// The script has errors.
    #[error("{diagnostics}\n{}: the script has errors", script.display())]
    Script {
        /// The script.
        script: PathBuf,
        /// What is wrong, with places.
        diagnostics: String,
    },
}

/// A recorded mission replayed on a script.
#[derive(Debug, Clone)]
pub struct MissionReplay {
    /// The recording.
    pub recording: PathBuf,
    /// The script replayed (the recorded one unless another was given).
    pub script: PathBuf,
    /// Why the recording ends early, when its writer died: the records before the cut
    /// are replayed.
    pub cut: Option<String>,
    /// Records read before the cut.
    pub records: usize,
    /// Events replayed.
    pub events: usize,
    /// Decisions recorded.
    pub decisions: usize,
    /// Where the script first decides differently, if it does.
    pub comparison: Comparison,
}

impl MissionReplay {
    /// Whether the script decided as recorded throughout.
    #[must_use]
    pub fn identical(&self) -> bool {
        self.comparison.difference.is_none()
    }
}

/// The verdict for people: `identical`, or the first decision that differs.
impl fmt::Display for MissionReplay {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.comparison.difference {
            None => write!(
                f,
                "{}: {} events and {} decisions replayed on {}: identical",
                self.recording.display(),
                self.events,
                self.decisions,
                self.script.display()
            ),
            Some(difference) => write!(
                f,
                "{}: {} decisions identical, then {} decides differently {difference}",
                self.recording.display(),
                self.comparison.identical_decisions,
                self.script.display()
            ),
        }
    }
}

/// Replays mission `mission` (from 1; may be omitted when the file holds one) of the
/// recording at `path` on `script` (the recorded one when `None`).
///
/// # Errors
/// When the recording or the script cannot be read, or the mission cannot be chosen.
pub fn replay_mission(
    path: &Path,
    script: Option<&Path>,
    mission: Option<usize>,
) -> Result<MissionReplay, MissionReplayError> {
    let open = |source| MissionReplayError::Open {
        path: path.to_path_buf(),
        source,
    };
    let (records, cut) = if is_mcap(path).map_err(open)? {
        let found = read_mcap(path)?;
        (found.records, found.cut)
    } else {
        let file = File::open(path).map_err(open)?;
        let records =
            read_json_lines(BufReader::new(file)).map_err(|source| MissionReplayError::Events {
                path: path.to_path_buf(),
                source,
            })?;
        (records, None)
    };
    let missions = split_missions(&records);
    let chosen = match (mission, missions.len()) {
        (None, 0 | 1) => missions.first().copied().unwrap_or(&[]),
        (None, count) => {
            return Err(MissionReplayError::Ambiguous {
                path: path.to_path_buf(),
                count,
            });
        }
        (Some(n), count) => match n.checked_sub(1).and_then(|i| missions.get(i)) {
            Some(mission) => mission,
            None => {
                return Err(MissionReplayError::NoSuchMission {
                    path: path.to_path_buf(),
                    chosen: n,
                    count,
                });
            }
        },
    };
    let recording =
        Recording::from_records(chosen).map_err(|source| MissionReplayError::Recording {
            path: path.to_path_buf(),
            source,
        })?;
    let script = script.map_or_else(|| recording.script.clone(), Path::to_path_buf);
    // The programs need not be installed where a recording is replayed: those that are
    // resolve as on the robot, the others are taken as written.
    let system = SystemResolver::from_env();
    let resolver = |program: &str, folder: &Path| {
        system
            .resolve(program, folder)
            .or_else(|_| TrustingResolver.resolve(program, folder))
    };
    let checked = check_with(&script, &FileSystem, &resolver).map_err(|diagnostics| {
        MissionReplayError::Script {
            script: script.clone(),
            diagnostics: diagnostics.to_string(),
        }
    })?;
    let comparison = compare(checked.mission, &recording);
    Ok(MissionReplay {
        recording: path.to_path_buf(),
        script,
        cut,
        records: records.len(),
        events: recording.steps.len().saturating_sub(1),
        decisions: recording.decision_count(),
        comparison,
    })
}
