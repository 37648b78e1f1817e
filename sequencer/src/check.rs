//! The checker: every finding about a parsed script, and the [`Mission`] it describes when
//! none of them is an error.
//!
//! Errors: no `start`; undefined states in `start`, `recovery` or `trans`; duplicate
//! states; two actions for one exit code in a state; a program that cannot be found or
//! executed. Warnings: no `recovery`; a state unreachable from `start` (through actions,
//! and through recovery after a failure); a state with no chain of actions to `stop`; a
//! variable set twice in one scope.

use std::collections::{BTreeMap, VecDeque};
use std::path::{Path, PathBuf};

use crate::diagnostic::{Diagnostic, Diagnostics, Problem, diagnostic};
use crate::location::Location;
use crate::mission::{Mission, MissionState, Target};
use crate::resolve::{ProgramResolver, ResolveError, SystemResolver};
use crate::script::{EnvVar, Script, parse};
use crate::source::{FileSystem, SourceLoader};
use lewis_stdx::closest;

/// A script without errors: what was written, the mission it describes, and its warnings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CheckedScript {
    /// The script as parsed.
    pub script: Script,
    /// The mission to run.
    pub mission: Mission,
    /// The warnings, possibly none.
    pub warnings: Diagnostics,
}

/// Parses and checks the script at `path` on this machine, resolving programs through
/// `PATH`: what `lewis seq check SCRIPT` runs.
///
/// # Errors
/// Every syntax error, or (when the syntax is fine) every finding, warnings included, when
/// at least one of them is an error.
pub fn check_file(path: &Path) -> Result<CheckedScript, Diagnostics> {
    check_with(path, &FileSystem, &SystemResolver::from_env())
}

/// Parses the script at `path` through `loader` and checks it with `resolver`.
///
/// # Errors
/// As [`check_file`].
pub fn check_with(
    path: &Path,
    loader: &dyn SourceLoader,
    resolver: &dyn ProgramResolver,
) -> Result<CheckedScript, Diagnostics> {
    check_script(parse(path, loader)?, resolver)
}

/// Checks a parsed script, resolving its programs with `resolver`.
///
/// # Errors
/// Every finding, warnings included, when at least one of them is an error.
pub fn check_script(
    script: Script,
    resolver: &dyn ProgramResolver,
) -> Result<CheckedScript, Diagnostics> {
    let mut checker = Checker {
        script: &script,
        findings: Vec::new(),
        first_of: BTreeMap::new(),
    };
    let mission = checker.run(resolver);
    let findings = Diagnostics::new(checker.findings);
    match mission {
        Some(mission) if !findings.has_errors() => Ok(CheckedScript {
            script,
            mission,
            warnings: findings,
        }),
        _ => Err(findings),
    }
}

struct Checker<'s> {
    script: &'s Script,
    findings: Vec<Diagnostic>,
    /// Each name's first definition: the state index the mission uses.
    first_of: BTreeMap<&'s str, usize>,
}

impl<'s> Checker<'s> {
    fn report(&mut self, location: &Location, problem: Problem) {
        self.findings.push(diagnostic(location.clone(), problem));
    }

    /// Records every finding; returns the mission when the names and programs allow one.
    fn run(&mut self, resolver: &dyn ProgramResolver) -> Option<Mission> {
        let script = self.script;
        for (index, state) in script.states.iter().enumerate() {
            match self.first_of.get(state.name.value.as_str()) {
                Some(&first) => self.report(
                    &state.name.location,
                    Problem::DuplicateState {
                        name: state.name.value.clone(),
                        first: script.states[first].name.location.clone(),
                    },
                ),
                None => {
                    self.first_of.insert(&state.name.value, index);
                }
            }
        }
        let start = match &script.start {
            None => {
                self.report(&Location::whole_file(&script.root), Problem::MissingStart);
                None
            }
            Some(start) => self.lookup(&start.value, &start.location, "start"),
        };
        let recovery = match &script.recovery {
            None => {
                let gui = script.use_gui.is_some();
                self.report(
                    &Location::whole_file(&script.root),
                    Problem::MissingRecovery { gui },
                );
                None
            }
            Some(recovery) => self.lookup(&recovery.value, &recovery.location, "recovery"),
        };
        self.check_env(&script.env);
        let mut states = Vec::with_capacity(script.states.len());
        for state in &script.states {
            self.check_env(&state.env);
            let actions = self.actions(state);
            let mut env = BTreeMap::new();
            for var in script.env.iter().chain(&state.env) {
                env.insert(var.key.value.clone(), var.value.clone());
            }
            states.push(MissionState {
                name: state.name.value.clone(),
                program: PathBuf::new(),
                args: state.args.iter().map(|a| a.value.clone()).collect(),
                env,
                timeout_ns: state.timeout_ns.as_ref().map(|t| t.value),
                restart_limit: state
                    .restart
                    .as_ref()
                    .or(script.restart.as_ref())
                    .map_or(0, |r| r.value),
                actions,
            });
        }
        // On a graph with broken names the graph's warnings would only echo the errors.
        let names_are_sound = !self.findings.iter().any(Diagnostic::is_error);
        if names_are_sound && let Some(start) = start {
            self.reachability(&states, start, recovery);
            self.paths_to_stop(&states);
        }
        for (state, resolved) in script.states.iter().zip(&mut states) {
            match resolver.resolve(&state.program.value, state.program.location.folder()) {
                Ok(program) => resolved.program = program,
                Err(error) => self.program_error(state, error),
            }
        }
        let start = start?;
        if script.recovery.is_some() && recovery.is_none() {
            return None;
        }
        Some(Mission::new(
            states,
            start,
            recovery,
            script.use_gui.is_some(),
        ))
    }

    /// The index of the state `name` used as `role`, or a finding.
    fn lookup(&mut self, name: &str, location: &Location, role: &'static str) -> Option<usize> {
        let found = self.first_of.get(name).copied();
        if found.is_none() {
            let suggestion = closest(name, self.first_of.keys().copied()).map(str::to_owned);
            self.report(
                location,
                Problem::UndefinedState {
                    name: name.to_owned(),
                    role,
                    suggestion,
                },
            );
        }
        found
    }

    fn actions(&mut self, state: &crate::script::State) -> BTreeMap<i32, Target> {
        let mut actions = BTreeMap::new();
        let mut first_at: BTreeMap<i32, &Location> = BTreeMap::new();
        for action in &state.actions {
            let code = action.code.value;
            if let Some(first) = first_at.get(&code) {
                let first = (*first).clone();
                self.report(
                    &action.code.location,
                    Problem::DuplicateAction {
                        code,
                        state: state.name.value.clone(),
                        first,
                    },
                );
                continue;
            }
            first_at.insert(code, &action.location);
            let target = &action.target;
            let target = if target.value == "stop" {
                Target::Stop
            } else {
                // An undefined target leaves no mission, so its stand-in is never run.
                self.lookup(&target.value, &target.location, "trans");
                Target::State(target.value.clone())
            };
            actions.insert(code, target);
        }
        actions
    }

    fn program_error(&mut self, state: &crate::script::State, error: ResolveError) {
        let name = state.name.value.clone();
        let problem = match error {
            ResolveError::NotFound { searched } => Problem::ProgramNotFound {
                program: state.program.value.clone(),
                state: name,
                searched,
            },
            ResolveError::NotExecutable { path } => {
                Problem::ProgramNotExecutable { path, state: name }
            }
            ResolveError::IsFolder { path } => Problem::ProgramIsFolder { path, state: name },
        };
        self.report(&state.program.location, problem);
    }

    fn check_env(&mut self, vars: &[EnvVar]) {
        let mut first_at: BTreeMap<&str, &Location> = BTreeMap::new();
        for var in vars {
            if let Some(first) = first_at.get(var.key.value.as_str()) {
                let first = (*first).clone();
                self.report(
                    &var.key.location,
                    Problem::DuplicateEnv {
                        key: var.key.value.clone(),
                        first,
                    },
                );
            } else {
                first_at.insert(&var.key.value, &var.key.location);
            }
        }
    }

    /// The states (first definitions) each state's actions lead to.
    fn successors(&self, state: &MissionState) -> Vec<usize> {
        state
            .actions
            .values()
            .filter_map(|target| match target {
                Target::State(name) => self.first_of.get(name.as_str()).copied(),
                Target::Stop => None,
            })
            .collect()
    }

    /// Warns about states that no run reaches: from `start` through actions, and from any
    /// reached state to the recovery state (a failure can happen anywhere).
    fn reachability(&mut self, states: &[MissionState], start: usize, recovery: Option<usize>) {
        let mut reached = vec![false; states.len()];
        let mut queue = VecDeque::from([start]);
        reached[start] = true;
        if let Some(recovery) = recovery {
            reached[recovery] = true;
            queue.push_back(recovery);
        }
        while let Some(index) = queue.pop_front() {
            for next in self.successors(&states[index]) {
                if !reached[next] {
                    reached[next] = true;
                    queue.push_back(next);
                }
            }
        }
        let gui = self.script.use_gui.is_some();
        for (index, state) in self.script.states.iter().enumerate() {
            if !reached[index] && self.is_first_definition(index) {
                self.report(
                    &state.name.location,
                    Problem::UnreachableState {
                        name: state.name.value.clone(),
                        gui,
                    },
                );
            }
        }
    }

    /// Warns about states from which no chain of actions reaches `stop`.
    fn paths_to_stop(&mut self, states: &[MissionState]) {
        let mut finishes: Vec<bool> = states
            .iter()
            .map(|s| s.actions.values().any(|t| *t == Target::Stop))
            .collect();
        // A fixed point over at most one pass per state.
        let mut changed = true;
        while changed {
            changed = false;
            for (index, state) in states.iter().enumerate() {
                if !finishes[index] && self.successors(state).iter().any(|&next| finishes[next]) {
                    finishes[index] = true;
                    changed = true;
                }
            }
        }
        for (index, state) in self.script.states.iter().enumerate() {
            if !finishes[index] && self.is_first_definition(index) {
                self.report(
                    &state.name.location,
                    Problem::NoPathToStop {
                        name: state.name.value.clone(),
                    },
                );
            }
        }
    }

    fn is_first_definition(&self, index: usize) -> bool {
        self.first_of
            .get(self.script.states[index].name.value.as_str())
            == Some(&index)
    }
}
