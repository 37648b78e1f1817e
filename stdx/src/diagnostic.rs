//! The one diagnostic of Lewis: a finding in a file people wrote (an interface definition, a
//! script, a robot file, a world file), printed as `file:line:column: message` with its hints
//! on the lines after, and the list printer that shows several, one per line in file order.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::position::line_column;

/// How serious a finding is: errors stop the file from being used, warnings do not.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// The file cannot be used.
    Error,
    /// The file can be used, but probably not as meant.
    Warning,
}

impl fmt::Display for Severity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Error => "error",
            Self::Warning => "warning",
        })
    }
}

/// A 1-based line and column (columns count characters) in a file; line 0 means the file as
/// a whole (a file that cannot be read, a folder without files).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Position {
    /// The line, from 1; 0 for the whole file.
    pub line: u32,
    /// The column in characters, from 1; 0 for the whole file.
    pub column: u32,
}

impl Position {
    /// The file as a whole.
    pub const WHOLE_FILE: Self = Self { line: 0, column: 0 };

    /// The place at `line` and `column`.
    #[must_use]
    pub fn new(line: u32, column: u32) -> Self {
        Self { line, column }
    }

    /// The place of byte `offset` in `text` (see [`line_column`]).
    #[must_use]
    pub fn of_offset(text: &str, offset: usize) -> Self {
        let (line, column) = line_column(text, offset);
        Self {
            line: u32::try_from(line).unwrap_or(u32::MAX),
            column: u32::try_from(column).unwrap_or(u32::MAX),
        }
    }

    /// Whether this is the file as a whole rather than a place in it.
    #[must_use]
    pub fn is_whole_file(self) -> bool {
        self.line == 0
    }
}

/// One finding: what is wrong at a place of a file, and what to do about it.
///
/// Display gives `file:line:column: error: message` (only `file: ...` for the whole file),
/// then each hint on a line of its own as `  hint: ...`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Diagnostic {
    /// The file, as the user named it.
    pub file: PathBuf,
    /// Where in the file.
    pub position: Position,
    /// How serious, printed after the place; `None` prints no label, for files whose every
    /// finding is an error and whose messages say what to do themselves (the robot file, the
    /// world file).
    pub severity: Option<Severity>,
    /// What is wrong.
    pub message: String,
    /// What to do about it (did you mean, the syntax, where it was first written), in order.
    pub hints: Vec<String>,
}

impl Diagnostic {
    /// An error at `position` of `file`, without hints.
    pub fn error(file: impl Into<PathBuf>, position: Position, message: impl Into<String>) -> Self {
        Self {
            file: file.into(),
            position,
            severity: Some(Severity::Error),
            message: message.into(),
            hints: Vec::new(),
        }
    }

    /// A warning at `position` of `file`, without hints.
    pub fn warning(
        file: impl Into<PathBuf>,
        position: Position,
        message: impl Into<String>,
    ) -> Self {
        Self {
            severity: Some(Severity::Warning),
            ..Self::error(file, position, message)
        }
    }

    /// An error at byte `offset` of `text`, the contents of `file`, printed without a label.
    pub fn plain_at_offset(
        file: impl Into<PathBuf>,
        text: &str,
        offset: usize,
        message: impl Into<String>,
    ) -> Self {
        Self {
            severity: None,
            ..Self::error(file, Position::of_offset(text, offset), message)
        }
    }

    /// Adds a hint after those it has.
    #[must_use]
    pub fn with_hint(mut self, hint: impl Into<String>) -> Self {
        self.hints.push(hint.into());
        self
    }

    /// Whether it stops the file from being used (an unlabelled finding is an error).
    #[must_use]
    pub fn is_error(&self) -> bool {
        self.severity != Some(Severity::Warning)
    }

    /// The file.
    #[must_use]
    pub fn file(&self) -> &Path {
        &self.file
    }

    /// The line, from 1; 0 for the whole file.
    #[must_use]
    pub fn line(&self) -> u32 {
        self.position.line
    }

    /// The column in characters, from 1; 0 for the whole file.
    #[must_use]
    pub fn column(&self) -> u32 {
        self.position.column
    }

    /// The order of findings in a list: by file, place, then errors before warnings.
    fn order_key(&self) -> (&Path, Position, bool) {
        (&self.file, self.position, !self.is_error())
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if !self.position.is_whole_file() {
            write!(f, ":{}:{}", self.position.line, self.position.column)?;
        }
        if let Some(severity) = self.severity {
            write!(f, ": {severity}")?;
        }
        write!(f, ": {}", self.message)?;
        for hint in &self.hints {
            write!(f, "\n  hint: {hint}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Diagnostic {}

/// Several findings; Display gives one per line (each followed by its hint lines), in the
/// order held ([`Diagnostics::new`] puts them in file order).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Diagnostics(pub Vec<Diagnostic>);

impl Diagnostics {
    /// The findings, sorted by file and place (errors before warnings at the same place;
    /// findings at one place keep the order in which they were found).
    #[must_use]
    pub fn new(findings: Vec<Diagnostic>) -> Self {
        let mut diagnostics = Self(findings);
        diagnostics.sort();
        diagnostics
    }

    /// Sorts by file and place, so that output does not depend on discovery order.
    pub fn sort(&mut self) {
        self.0.sort_by(|a, b| a.order_key().cmp(&b.order_key()));
    }

    /// Whether any finding is an error.
    #[must_use]
    pub fn has_errors(&self) -> bool {
        self.0.iter().any(Diagnostic::is_error)
    }

    /// The number of errors.
    #[must_use]
    pub fn error_count(&self) -> usize {
        self.0.iter().filter(|d| d.is_error()).count()
    }

    /// The number of warnings.
    #[must_use]
    pub fn warning_count(&self) -> usize {
        self.0.len() - self.error_count()
    }

    /// Whether there are no findings.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The number of findings.
    #[must_use]
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// The findings in order.
    pub fn iter(&self) -> std::slice::Iter<'_, Diagnostic> {
        self.0.iter()
    }

    /// The findings, owned.
    #[must_use]
    pub fn into_vec(self) -> Vec<Diagnostic> {
        self.0
    }
}

impl From<Diagnostic> for Diagnostics {
    fn from(diagnostic: Diagnostic) -> Self {
        Self(vec![diagnostic])
    }
}

impl<'a> IntoIterator for &'a Diagnostics {
    type Item = &'a Diagnostic;
    type IntoIter = std::slice::Iter<'a, Diagnostic>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

impl fmt::Display for Diagnostics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_list(f, &self.0)
    }
}

impl std::error::Error for Diagnostics {}

/// Writes `findings` one per line (each followed by its hint lines), in the order given: the
/// list printer, for error types that hold their findings themselves.
///
/// # Errors
///
/// When the formatter fails.
pub fn write_list<'a>(
    f: &mut fmt::Formatter<'_>,
    findings: impl IntoIterator<Item = &'a Diagnostic>,
) -> fmt::Result {
    for (i, diagnostic) in findings.into_iter().enumerate() {
        if i > 0 {
            writeln!(f)?;
        }
        write!(f, "{diagnostic}")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_finding_shows_its_place_label_message_and_hints() {
        let d = Diagnostic::error("m.seq", Position::new(7, 12), "unknown keyword `stat`")
            .with_hint("did you mean `state`?");
        assert_eq!(
            d.to_string(),
            "m.seq:7:12: error: unknown keyword `stat`\n  hint: did you mean `state`?"
        );
        let w = Diagnostic::warning("m.seq", Position::WHOLE_FILE, "no `recovery` state");
        assert_eq!(w.to_string(), "m.seq: warning: no `recovery` state");
        let plain = Diagnostic::plain_at_offset("r.toml", "a\nbé c", 6, "unknown key `c`");
        assert_eq!(plain.to_string(), "r.toml:2:4: unknown key `c`");
        assert!(plain.is_error() && !w.is_error());
    }

    #[test]
    fn a_list_is_one_finding_per_line_in_file_order_errors_first() {
        let list = Diagnostics::new(vec![
            Diagnostic::warning("b", Position::new(1, 1), "w"),
            Diagnostic::error("b", Position::new(1, 1), "e"),
            Diagnostic::error("a", Position::new(9, 1), "first file").with_hint("h"),
            Diagnostic::error("b", Position::new(0, 0), "whole"),
        ]);
        assert_eq!(
            list.to_string(),
            "a:9:1: error: first file\n  hint: h\nb: error: whole\nb:1:1: error: e\nb:1:1: warning: w"
        );
        assert_eq!((list.error_count(), list.warning_count()), (3, 1));
        assert!(list.has_errors());
    }
}
