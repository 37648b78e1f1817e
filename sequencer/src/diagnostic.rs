//! Findings about a script: typed problems with a severity and a hint, placed and rendered
//! by the one diagnostic of Lewis ([`lewis_stdx::Diagnostic`]) as
//! `mission.seq:7:12: error: ...` with the hint on the next line.

use std::path::PathBuf;

pub use lewis_stdx::{Diagnostic, Diagnostics, Position, Severity};

use crate::location::Location;

/// Everything that can be wrong with a script, from a stray quote to an unreachable state.
///
/// The message (Display) says what is wrong; [`Problem::hint`] says what to do.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Problem {
    // ---- Reading files.
    /// The script or an included file cannot be read.
    #[error("cannot read `{}`: {error}", path.display())]
    Unreadable {
        /// The file.
        path: PathBuf,
        /// The operating system's reason.
        error: String,
    },
    /// A file includes itself, directly or through others.
    #[error("include cycle: {}", chain.iter().map(|p| format!("`{}`", p.display())).collect::<Vec<_>>().join(" -> "))]
    IncludeCycle {
        /// The files from the one first included to the one included again.
        chain: Vec<PathBuf>,
    },
    /// Includes nest deeper than the parser follows.
    #[error("includes nest deeper than {limit} files")]
    IncludeTooDeep {
        /// The deepest nesting followed.
        limit: usize,
    },

    // ---- Words and strings.
    /// A quoted string has no closing quote on its line.
    #[error("unterminated string")]
    UnterminatedString,
    /// A backslash escape that strings do not know.
    #[error("unknown escape `{escape}` in a string")]
    UnknownEscape {
        /// The escape as written, backslash included.
        escape: String,
    },
    /// A quote in the middle of a bare word.
    #[error("unexpected `\"` inside the word `{word}`")]
    QuoteInsideWord {
        /// The word up to the quote.
        word: String,
    },
    /// Something glued to the closing quote of a string.
    #[error("expected a space after the closing quote")]
    NoSpaceAfterString,

    // ---- Lines.
    /// A line starts with a word that is not a keyword.
    #[error("unknown keyword `{found}`")]
    UnknownKeyword {
        /// The word.
        found: String,
        /// The keyword it was probably meant to be.
        suggestion: Option<&'static str>,
    },
    /// A line starts with a quoted string instead of a keyword.
    #[error("a line must start with a keyword, not a quoted string")]
    QuotedKeyword,
    /// A fixed word of the syntax is missing or misspelt (`trans` in an action).
    #[error("expected `{expected}`, found `{found}`")]
    ExpectedWord {
        /// The word the syntax needs here.
        expected: &'static str,
        /// What is written instead.
        found: String,
        /// The line's syntax.
        usage: &'static str,
    },
    /// A line ends before a required argument.
    #[error("`{keyword}` needs {what}")]
    MissingArgument {
        /// The line's keyword.
        keyword: &'static str,
        /// The missing argument, described (`a state name`).
        what: &'static str,
        /// The line's syntax.
        usage: &'static str,
    },
    /// A line goes on after its last argument.
    #[error("unexpected `{found}` after the end of the `{keyword}` line")]
    UnexpectedArgument {
        /// The line's keyword.
        keyword: &'static str,
        /// The first word too many.
        found: String,
        /// The line's syntax.
        usage: &'static str,
    },
    /// `use` names something other than `gui`.
    #[error("unknown feature `{found}`")]
    UnknownFeature {
        /// The name after `use`.
        found: String,
    },
    /// A state name that is not a bare identifier.
    #[error("invalid state name `{found}`")]
    InvalidStateName {
        /// The name as written.
        found: String,
    },
    /// A state named `stop`, which is the final state and runs nothing.
    #[error("`stop` is the final state and cannot be defined")]
    StopDefined,
    /// `start` or `recovery` names `stop`.
    #[error("`{keyword}` cannot name `stop`")]
    StopNotAllowed {
        /// `start` or `recovery`.
        keyword: &'static str,
    },
    /// A string for a program (its path, an argument, a variable) holding a NUL character,
    /// which no process can receive.
    #[error("`{what}` contains a NUL character")]
    NulCharacter {
        /// What holds it: `program`, `argument` or `env`.
        what: &'static str,
    },
    /// An empty program path.
    #[error("empty program")]
    EmptyProgram,
    /// An exit code that is not an integer from 0 to 255.
    #[error("invalid exit code `{found}`")]
    InvalidExitCode {
        /// The code as written.
        found: String,
    },
    /// A restart limit that is not a non-negative integer.
    #[error("invalid restart limit `{found}`")]
    InvalidRestartLimit {
        /// The limit as written.
        found: String,
    },
    /// A duration that cannot be read.
    #[error("invalid duration `{found}`: {reason}")]
    InvalidDuration {
        /// The duration as written.
        found: String,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// An environment assignment that is not `KEY=VALUE` with a valid key.
    #[error("invalid environment variable `{found}`: {reason}")]
    InvalidEnv {
        /// The assignment as written.
        found: String,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// A state-only line (`action`, `timeout`) before any `state` line.
    #[error("`{keyword}` outside a state")]
    OutsideState {
        /// The line's keyword.
        keyword: &'static str,
    },
    /// A setting given twice in the same scope.
    #[error("duplicate `{what}`")]
    DuplicateSetting {
        /// The setting (`start`, `restart`, `timeout` of state `door`, ...).
        what: String,
        /// Where it was first given.
        first: Location,
    },

    // ---- The checker.
    /// The script names no start state.
    #[error("no `start` line")]
    MissingStart,
    /// `start`, `recovery` or a transition names a state that is not defined.
    #[error("undefined state `{name}` in `{role}`")]
    UndefinedState {
        /// The name.
        name: String,
        /// Where it is used: `start`, `recovery` or `trans`.
        role: &'static str,
        /// A defined state with a close name.
        suggestion: Option<String>,
    },
    /// Two states with the same name.
    #[error("duplicate state `{name}`")]
    DuplicateState {
        /// The name.
        name: String,
        /// Where it was first defined.
        first: Location,
    },
    /// Two actions for the same exit code in one state.
    #[error("duplicate action for exit code {code} in state `{state}`")]
    DuplicateAction {
        /// The exit code.
        code: i32,
        /// The state.
        state: String,
        /// Where the first action for the code is.
        first: Location,
    },
    /// The same environment variable set twice in one scope; the later one wins.
    #[error("`{key}` is set twice")]
    DuplicateEnv {
        /// The variable.
        key: String,
        /// Where it was first set.
        first: Location,
    },
    /// A state that no run can reach from `start` through actions and recovery.
    #[error("state `{name}` is unreachable from `start`")]
    UnreachableState {
        /// The state.
        name: String,
        /// Whether `use gui` lets the supervisor choose it after recovery.
        gui: bool,
    },
    /// A state from which no chain of actions leads to `stop`.
    #[error("state `{name}` has no path to `stop` through its actions")]
    NoPathToStop {
        /// The state.
        name: String,
    },
    /// The script has no `recovery` state.
    #[error("no `recovery` state")]
    MissingRecovery {
        /// Whether `use gui` is on, which changes what a failure does.
        gui: bool,
    },
    /// A program that cannot be found.
    #[error("program `{program}` of state `{state}` not found")]
    ProgramNotFound {
        /// The program as written.
        program: String,
        /// The state.
        state: String,
        /// Where it was looked for.
        searched: Vec<PathBuf>,
    },
    /// A program that exists but cannot be executed.
    #[error("program `{}` of state `{state}` is not executable", path.display())]
    ProgramNotExecutable {
        /// The file.
        path: PathBuf,
        /// The state.
        state: String,
    },
    /// A program path that names a folder.
    #[error("program `{}` of state `{state}` is a folder", path.display())]
    ProgramIsFolder {
        /// The folder.
        path: PathBuf,
        /// The state.
        state: String,
    },
}

impl Problem {
    /// Whether the problem stops the script from running.
    #[must_use]
    pub fn severity(&self) -> Severity {
        match self {
            Self::DuplicateEnv { .. }
            | Self::UnreachableState { .. }
            | Self::NoPathToStop { .. }
            | Self::MissingRecovery { .. } => Severity::Warning,
            _ => Severity::Error,
        }
    }

    /// What to do about it, when there is something useful to say.
    #[must_use]
    pub fn hint(&self) -> Option<String> {
        Some(match self {
            Self::Unreadable { .. } => "check the path; includes are relative to the including file".into(),
            Self::IncludeCycle { .. } => "remove one of the `include` lines of the cycle".into(),
            Self::IncludeTooDeep { .. } => "flatten the includes".into(),
            Self::UnterminatedString => "close the string with `\"` on the same line".into(),
            Self::UnknownEscape { .. } => {
                r#"strings know `\\`, `\"`, `\n`, `\t`, `\r`, `\0` and `\u{HEX}`"#.into()
            }
            Self::QuoteInsideWord { .. } => "quote the whole argument: \"like this\"".into(),
            Self::NoSpaceAfterString => "separate arguments with spaces".into(),
            Self::UnknownKeyword { found, suggestion } => match suggestion {
                Some(keyword) => format!("did you mean `{keyword}`?"),
                None if found == "trans" => "`trans` goes inside an action: `action CODE trans STATE`".into(),
                None => "lines start with `start`, `restart`, `recovery`, `use`, `state`, `action`, `timeout`, `env` or `include`".into(),
            },
            Self::QuotedKeyword => "write the keyword without quotes".into(),
            Self::ExpectedWord { expected, found, usage } => {
                if lewis_stdx::is_close(found, expected) {
                    format!("did you mean `{expected}`?")
                } else {
                    format!("write `{usage}`")
                }
            }
            Self::MissingArgument { usage, .. } | Self::UnexpectedArgument { usage, .. } => {
                format!("write `{usage}`")
            }
            Self::UnknownFeature { .. } => "the only feature is `gui`: write `use gui`".into(),
            Self::InvalidStateName { .. } => {
                "state names start with a letter or `_` and go on with letters, digits, `_` or `-`".into()
            }
            Self::StopDefined => "name the state differently; `action CODE trans stop` ends the mission".into(),
            Self::StopNotAllowed { keyword } => format!("`{keyword}` must name a defined state"),
            Self::NulCharacter { .. } => "remove the `\\0`".into(),
            Self::EmptyProgram => "give the path of the state's program".into(),
            Self::InvalidExitCode { .. } => "exit codes are integers from 0 to 255".into(),
            Self::InvalidRestartLimit { .. } => "write a whole number of restarts, such as `restart 3`".into(),
            Self::InvalidDuration { .. } => {
                "write a number and a unit: `500ms`, `30s`, `1.5s`, `2m` or `1h`".into()
            }
            Self::InvalidEnv { .. } => {
                "write `env KEY=VALUE`, or `env \"KEY=VALUE WITH SPACES\"`; keys are letters, digits and `_`".into()
            }
            Self::OutsideState { keyword } => {
                format!("put `{keyword}` after the `state NAME PROGRAM` line it belongs to")
            }
            Self::DuplicateSetting { first, .. } => format!("first given at {first}"),
            Self::MissingStart => "add `start NAME` naming the first state".into(),
            Self::UndefinedState { suggestion, .. } => match suggestion {
                Some(name) => format!("did you mean `{name}`?"),
                None => "define it with `state NAME PROGRAM`, or use `stop` to end the mission".into(),
            },
            Self::DuplicateState { first, .. } => format!("first defined at {first}"),
            Self::DuplicateAction { first, .. } => format!("first action for this code at {first}"),
            Self::DuplicateEnv { first, .. } => format!("first set at {first}; the later value wins"),
            Self::UnreachableState { gui: true, .. } => {
                "only the supervisor can choose it after recovery; add an action leading to it if the mission should reach it by itself".into()
            }
            Self::UnreachableState { gui: false, .. } => {
                "no action leads to it from `start`; add one or remove the state".into()
            }
            Self::NoPathToStop { .. } => {
                "every run through it ends in recovery or loops for ever; add an action leading towards `stop`".into()
            }
            Self::MissingRecovery { gui: true } => {
                "a crash beyond the restart limit or an unlisted exit code asks the supervisor straight away; add `recovery STATE` to reach a safe state first".into()
            }
            Self::MissingRecovery { gui: false } => {
                "a crash beyond the restart limit or an unlisted exit code aborts the mission; add `recovery STATE` to reach a safe state".into()
            }
            Self::ProgramNotFound { searched, .. } => {
                if searched.is_empty() {
                    "relative paths are relative to the script's folder".into()
                } else {
                    format!(
                        "looked in {}; relative paths with a `/` are relative to the script's folder",
                        searched.iter().map(|p| format!("`{}`", p.display())).collect::<Vec<_>>().join(", ")
                    )
                }
            }
            Self::ProgramNotExecutable { path, .. } => {
                format!("make it executable: `chmod +x {}`", path.display())
            }
            Self::ProgramIsFolder { .. } => "name the program file inside the folder".into(),
        })
    }
}

/// The finding of `problem` at `location`: the one diagnostic of Lewis, with the problem's
/// severity, message and hint.
#[must_use]
#[expect(
    clippy::needless_pass_by_value,
    reason = "a finding is made of its problem: callers write `diagnostic(at, Problem::...)`"
)]
pub fn diagnostic(location: Location, problem: Problem) -> Diagnostic {
    let position = Position::new(location.line, location.column);
    let mut finding = Diagnostic::error(location.file, position, problem.to_string());
    finding.severity = Some(problem.severity());
    finding.hints.extend(problem.hint());
    finding
}
