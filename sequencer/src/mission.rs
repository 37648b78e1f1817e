//! A checked mission: states with resolved programs and transitions that all lead somewhere.
//!
//! Only the checker builds one, so the FSM can rely on every name it holds.

use std::collections::BTreeMap;
use std::path::PathBuf;

/// Where an exit code leads.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// The state of this name.
    State(String),
    /// The end of the mission.
    Stop,
}

impl Target {
    /// The target's name as written in scripts (`stop` for the end).
    #[must_use]
    pub fn name(&self) -> &str {
        match self {
            Self::State(name) => name,
            Self::Stop => "stop",
        }
    }
}

/// One state of a checked mission, with everything needed to run its program.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MissionState {
    /// The state's name.
    pub name: String,
    /// The program to execute, resolved.
    pub program: PathBuf,
    /// Its arguments.
    pub args: Vec<String>,
    /// Its environment variables beyond the sequencer's own: the script's, then the
    /// state's (which win).
    pub env: BTreeMap<String, String>,
    /// How long the program may run before it is stopped and counted as crashed.
    pub timeout_ns: Option<i64>,
    /// How many times the program is restarted after crashes within one visit.
    pub restart_limit: u32,
    /// Where each listed exit code leads.
    pub actions: BTreeMap<i32, Target>,
}

/// A checked mission, ready for the FSM.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mission {
    states: Vec<MissionState>,
    start: usize,
    recovery: Option<usize>,
    use_gui: bool,
}

impl Mission {
    /// Builds a mission whose indices and targets the checker has verified.
    pub(crate) fn new(
        states: Vec<MissionState>,
        start: usize,
        recovery: Option<usize>,
        use_gui: bool,
    ) -> Self {
        Self {
            states,
            start,
            recovery,
            use_gui,
        }
    }

    /// The states, in script order.
    #[must_use]
    pub fn states(&self) -> &[MissionState] {
        &self.states
    }

    /// The state named `name`.
    #[must_use]
    pub fn state(&self, name: &str) -> Option<&MissionState> {
        self.index_of(name).map(|i| &self.states[i])
    }

    /// The first state.
    #[must_use]
    pub fn start(&self) -> &MissionState {
        &self.states[self.start]
    }

    /// The recovery state, when the script has one.
    #[must_use]
    pub fn recovery(&self) -> Option<&MissionState> {
        self.recovery.map(|i| &self.states[i])
    }

    /// Whether the supervisor is asked where to resume after recovery (`use gui`).
    #[must_use]
    pub fn use_gui(&self) -> bool {
        self.use_gui
    }

    pub(crate) fn index_of(&self, name: &str) -> Option<usize> {
        self.states.iter().position(|s| s.name == name)
    }

    pub(crate) fn start_index(&self) -> usize {
        self.start
    }

    pub(crate) fn recovery_index(&self) -> Option<usize> {
        self.recovery
    }
}
