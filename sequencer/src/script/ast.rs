//! The parsed script, as written: every item keeps the place it came from.

use std::path::PathBuf;

use crate::location::{Location, Spanned};

/// A parsed mission script, its includes merged in, not yet checked.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Script {
    /// The root script file, as given.
    pub root: PathBuf,
    /// `start STATE`: the first state.
    pub start: Option<Spanned<String>>,
    /// `restart N` outside any state: how many times a crashed program is restarted.
    pub restart: Option<Spanned<u32>>,
    /// `recovery STATE`: the state that brings the robot to a safe state after a failure.
    pub recovery: Option<Spanned<String>>,
    /// `use gui`: where it is written, when it is.
    pub use_gui: Option<Location>,
    /// `env KEY=VALUE` outside any state: variables for every program.
    pub env: Vec<EnvVar>,
    /// The states, in the order they are written (includes expanded in place).
    pub states: Vec<State>,
}

impl Script {
    /// An empty script for `root`.
    #[must_use]
    pub fn new(root: impl Into<PathBuf>) -> Self {
        Self {
            root: root.into(),
            start: None,
            restart: None,
            recovery: None,
            use_gui: None,
            env: Vec::new(),
            states: Vec::new(),
        }
    }
}

/// `state NAME PROGRAM [ARGS...]` and the lines that belong to it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct State {
    /// The state's name.
    pub name: Spanned<String>,
    /// The program as written: a path relative to the script's folder when it has a `/`,
    /// otherwise a name looked up in `PATH`.
    pub program: Spanned<String>,
    /// The program's arguments.
    pub args: Vec<Spanned<String>>,
    /// `action CODE trans STATE` lines.
    pub actions: Vec<Action>,
    /// `timeout DURATION`, in nanoseconds.
    pub timeout_ns: Option<Spanned<i64>>,
    /// `restart N` inside the state: overrides the script's limit for this state.
    pub restart: Option<Spanned<u32>>,
    /// `env KEY=VALUE` inside the state: added to (and overriding) the script's variables.
    pub env: Vec<EnvVar>,
}

/// `action CODE trans STATE`: exit code `CODE` leads to `STATE` (or `stop`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Action {
    /// Where the `action` keyword is.
    pub location: Location,
    /// The exit code, 0 to 255.
    pub code: Spanned<i32>,
    /// The next state, or `stop`.
    pub target: Spanned<String>,
}

/// `env KEY=VALUE`: one environment variable.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EnvVar {
    /// The variable's name; its place is the assignment's.
    pub key: Spanned<String>,
    /// Its value.
    pub value: String,
}
