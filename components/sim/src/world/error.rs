//! Why a world could not be loaded: each problem placed at a line and column of world.toml.

use std::fmt;
use std::path::PathBuf;

use lewis_stdx::Diagnostic;
use lewis_stdx::diagnostic::write_list;

/// Why a world could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum WorldError {
    /// The world file could not be read.
    #[error(
        "cannot read world file {}: {source} (a world is a folder holding world.toml and its map image)",
        path.display()
    )]
    Read {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The world file, or the map it names, is not usable.
    #[error("{}", Problems(problems))]
    Invalid {
        /// The world file.
        path: PathBuf,
        /// Every problem found, in the order of the file.
        problems: Vec<WorldProblem>,
    },
}

impl WorldError {
    /// The problems, empty when the file could not be read at all.
    #[must_use]
    pub fn problems(&self) -> &[WorldProblem] {
        match self {
            Self::Read { .. } => &[],
            Self::Invalid { problems, .. } => problems,
        }
    }
}

/// The sort of a problem, for callers and tests that react to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ProblemKind {
    /// Not TOML, or a key that does not belong, or a value of the wrong type.
    Syntax,
    /// The map image named by `map` does not exist.
    MissingMap,
    /// The map image exists but cannot be decoded.
    BadMap,
    /// The map image's size in metres disagrees with `size_m`.
    MapSizeMismatch,
    /// An object lies (partly) outside the map.
    OutsideMap,
    /// An object's `kind` is not one the simulator knows.
    UnknownKind,
    /// A colour that is neither `#rrggbb` nor a known name.
    BadColour,
    /// A value out of its range, a field missing, or one that does not apply.
    BadValue,
}

/// One problem in a world file: its sort, and the one diagnostic of Lewis that places it
/// (`world.toml:3:7: message`, no `error:` label: the message says what to do).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WorldProblem {
    /// The sort of problem.
    pub kind: ProblemKind,
    /// Where it is and what is wrong.
    pub diagnostic: Diagnostic,
}

impl fmt::Display for WorldProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.diagnostic.fmt(f)
    }
}

struct Problems<'a>(&'a [WorldProblem]);

impl fmt::Display for Problems<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_list(f, self.0.iter().map(|p| &p.diagnostic))
    }
}
