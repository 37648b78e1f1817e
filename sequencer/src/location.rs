//! Where a thing is written: the file, line and column every parsed item carries.

use std::fmt;
use std::path::{Path, PathBuf};

/// A place in a script: the file as the user named it (relative paths stay relative), a
/// 1-based line and a 1-based column counted in characters.
///
/// Line 0 means the file as a whole (for example a file that cannot be read).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Location {
    /// The script file, as reached from the root script (`missions/common.seq`).
    pub file: PathBuf,
    /// The line, from 1; 0 for the whole file.
    pub line: u32,
    /// The column in characters, from 1; 0 for the whole file.
    pub column: u32,
}

impl Location {
    /// A place at `line` and `column` of `file`.
    #[must_use]
    pub fn new(file: impl Into<PathBuf>, line: u32, column: u32) -> Self {
        Self {
            file: file.into(),
            line,
            column,
        }
    }

    /// The file as a whole, for findings that have no line.
    #[must_use]
    pub fn whole_file(file: impl Into<PathBuf>) -> Self {
        Self::new(file, 0, 0)
    }

    /// The folder that holds the file, against which relative paths in it are resolved.
    #[must_use]
    pub fn folder(&self) -> &Path {
        self.file.parent().unwrap_or_else(|| Path::new(""))
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line == 0 {
            write!(f, "{}", self.file.display())
        } else {
            write!(f, "{}:{}:{}", self.file.display(), self.line, self.column)
        }
    }
}

/// A value with the place it was written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Spanned<T> {
    /// The value.
    pub value: T,
    /// Where it was written.
    pub location: Location,
}

impl<T> Spanned<T> {
    /// Pairs a value with its place.
    #[must_use]
    pub fn new(value: T, location: Location) -> Self {
        Self { value, location }
    }
}
