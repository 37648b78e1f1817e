//! The faults file of a suite (`lewis test --faults FILE`): which fault sweeps to run over
//! which runs, what must hold at their points, and the failures known for now.
//!
//! ```toml
//! [[sweep]]
//! name = "laser dies"          # default: the providers and the kind, `laser crash`
//! runs = ["runs/demo-*.mcap"]  # globs over the runs' names; default: every run
//! providers = ["laser"]        # fail together at each point
//! kind = "crash"               # default crash
//! steps = 10                   # points spread across the run; default 10
//! expect = [{ after = "door", mission = "succeeds" }]
//!
//! [[known_failure]]
//! case = "runs/demo-2.mcap: laser dies @ *"   # a glob over `RUN: CASE`
//! reason = "the avoider's fix for the door is in review"
//! ```
//!
//! An expectation names a state of the run's recorded mission: `before` (the fault strikes
//! before the state was first entered), `during` (while it was first visited) or `after`
//! (once it was first left), and `mission` says whether the mission lived again must
//! `succeed` or `fail`. The recorded mission's times place a point, so which expectations
//! apply is decided in the plan, before anything is replayed.
//!
//! Every problem of the file is reported at its `file:line:column`
//! ([`lewis_stdx::Diagnostic`]); unknown keys are errors.

use std::path::{Path, PathBuf};

use lewis_replay::fault::{FaultKind, REPLAY_FAULTS};
use lewis_stdx::{Diagnostic, Diagnostics};
use serde::{Deserialize, Serialize};
use toml::Spanned;

/// The points a sweep tries when the file does not say.
pub const DEFAULT_STEPS: u32 = 10;

/// The most points one sweep may try on one run: a typing slip (`steps = 10000`) would
/// otherwise plan days of replays.
pub const MAX_STEPS: u32 = 1000;

/// A faults file, checked.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FaultsFile {
    /// The sweeps, in the file's order.
    pub sweeps: Vec<SweepDecl>,
    /// The failures known for now.
    pub known_failures: Vec<KnownFailure>,
}

/// One `[[sweep]]`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SweepDecl {
    /// Its name in the reports.
    pub name: String,
    /// Globs over the runs' names (as the paths name them); empty: every run.
    pub runs: Vec<String>,
    /// The providers that fail together at each point.
    pub providers: Vec<String>,
    /// How they fail, as replay's word (`crash`).
    pub kind: String,
    /// How many points across each run.
    pub steps: u32,
    /// What must hold at the points.
    pub expect: Vec<Expectation>,
}

impl SweepDecl {
    /// Whether the sweep is run over the run named `run`.
    #[must_use]
    pub fn applies_to(&self, run: &str) -> bool {
        self.runs.is_empty()
            || self
                .runs
                .iter()
                .any(|g| glob::Pattern::new(g).is_ok_and(|p| p.matches(run)))
    }

    /// The kind as replay takes it; the file was checked, so this is `None` only for a
    /// plan edited by hand.
    #[must_use]
    pub fn fault_kind(&self) -> Option<FaultKind> {
        REPLAY_FAULTS.parse(&self.kind).ok().flatten()
    }
}

/// When a fault strikes, against a state of the recorded mission.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum When {
    /// Before the state was first entered.
    Before,
    /// While it was first visited.
    During,
    /// Once it was first left.
    After,
}

impl When {
    /// The word of the file.
    #[must_use]
    pub fn word(self) -> &'static str {
        match self {
            Self::Before => "before",
            Self::During => "during",
            Self::After => "after",
        }
    }
}

/// What must hold at the points of a sweep that fall `when` the `state`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Expectation {
    /// Before, during or after.
    pub when: When,
    /// The state of the recorded mission.
    pub state: String,
    /// Whether the mission lived again must succeed (else fail).
    pub succeeds: bool,
}

impl Expectation {
    /// For people: `the mission succeeds when the fault strikes after `door``.
    #[must_use]
    pub fn describe(&self) -> String {
        format!(
            "the mission {} when the fault strikes {} `{}`",
            if self.succeeds { "succeeds" } else { "fails" },
            self.when.word(),
            self.state
        )
    }
}

/// A case that fails for now, and why; it is reported, not counted as a failure.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct KnownFailure {
    /// A glob over the case's id, `RUN: CASE` (`runs/a.mcap: check`).
    pub case: String,
    /// Why it fails, for people.
    pub reason: String,
}

impl KnownFailure {
    /// Whether the case `id` is this known failure.
    #[must_use]
    pub fn matches(&self, id: &str) -> bool {
        glob::Pattern::new(&self.case).is_ok_and(|p| p.matches(id))
    }
}

/// Why a faults file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum FaultsError {
    /// It cannot be read.
    #[error("cannot read the faults file {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// What is wrong in it, at each place.
    #[error("{0}")]
    Invalid(Diagnostics),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    #[serde(default)]
    sweep: Vec<RawSweep>,
    #[serde(default)]
    known_failure: Vec<RawKnown>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSweep {
    name: Option<Spanned<String>>,
    #[serde(default)]
    runs: Vec<Spanned<String>>,
    providers: Spanned<Vec<Spanned<String>>>,
    kind: Option<Spanned<String>>,
    steps: Option<Spanned<i64>>,
    #[serde(default)]
    expect: Vec<Spanned<RawExpect>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawExpect {
    before: Option<Spanned<String>>,
    during: Option<Spanned<String>>,
    after: Option<Spanned<String>>,
    mission: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKnown {
    case: Spanned<String>,
    reason: Spanned<String>,
}

/// Reads and checks the faults file at `path`.
///
/// # Errors
/// When it cannot be read, or every problem of it at its place.
pub fn load(path: &Path) -> Result<FaultsFile, FaultsError> {
    let text = std::fs::read_to_string(path).map_err(|source| FaultsError::Read {
        path: path.to_owned(),
        source,
    })?;
    parse(path, &text).map_err(FaultsError::Invalid)
}

/// Checks the text of a faults file; `path` names it in the diagnostics.
///
/// # Errors
/// Every problem, at its place.
pub fn parse(path: &Path, text: &str) -> Result<FaultsFile, Diagnostics> {
    let at = |offset: usize, message: String| -> Diagnostic {
        Diagnostic::plain_at_offset(path, text, offset, message)
    };
    let raw: RawFile = toml::from_str(text).map_err(|error| {
        let offset = error.span().map_or(0, |s| s.start);
        Diagnostics::from(at(
            offset,
            error.message().trim_end().trim_end_matches('.').to_owned(),
        ))
    })?;
    let mut problems = Vec::new();
    let mut sweeps = Vec::new();
    for sweep in raw.sweep {
        let providers: Vec<String> = sweep
            .providers
            .get_ref()
            .iter()
            .map(|p| p.get_ref().clone())
            .collect();
        if providers.is_empty() {
            problems.push(at(
                sweep.providers.span().start,
                "`providers` is empty: name the services that fail, like [\"laser\"]".to_owned(),
            ));
        }
        for p in sweep.providers.get_ref() {
            if p.get_ref().trim().is_empty() || p.get_ref().contains(['@', ':', ',']) {
                problems.push(at(
                    p.span().start,
                    format!(
                        "`{}` is no service name: give the name of a service of the robot file",
                        p.get_ref()
                    ),
                ));
            }
        }
        let kind = match &sweep.kind {
            None => "crash".to_owned(),
            Some(kind) => match REPLAY_FAULTS.parse(kind.get_ref()) {
                Ok(Some(_)) => kind.get_ref().clone(),
                Ok(None) | Err(_) => {
                    let near = lewis_stdx::closest(kind.get_ref(), REPLAY_FAULTS.words())
                        .map(|w| format!(" (did you mean `{w}`?)"))
                        .unwrap_or_default();
                    problems.push(at(
                        kind.span().start,
                        format!(
                            "`{}` is no fault kind{near}: give one of {}",
                            kind.get_ref(),
                            REPLAY_FAULTS.names()
                        ),
                    ));
                    String::new()
                }
            },
        };
        let steps = match &sweep.steps {
            None => DEFAULT_STEPS,
            Some(steps) => match u32::try_from(*steps.get_ref()) {
                Ok(n) if (1..=MAX_STEPS).contains(&n) => n,
                _ => {
                    problems.push(at(
                        steps.span().start,
                        format!(
                            "`steps = {}`: give a number of points from 1 to {MAX_STEPS}",
                            steps.get_ref()
                        ),
                    ));
                    DEFAULT_STEPS
                }
            },
        };
        let mut runs = Vec::new();
        for run in &sweep.runs {
            if let Err(e) = glob::Pattern::new(run.get_ref()) {
                problems.push(at(
                    run.span().start,
                    format!("`{}` is not a glob: {}", run.get_ref(), e.msg),
                ));
            }
            runs.push(run.get_ref().clone());
        }
        let mut expect = Vec::new();
        for e in &sweep.expect {
            let raw = e.get_ref();
            let whens: Vec<(When, &Spanned<String>)> = [
                (When::Before, &raw.before),
                (When::During, &raw.during),
                (When::After, &raw.after),
            ]
            .into_iter()
            .filter_map(|(w, s)| s.as_ref().map(|s| (w, s)))
            .collect();
            let [(when, state)] = whens.as_slice() else {
                problems.push(at(
                    e.span().start,
                    "an expectation names one state with one of `before`, `during` or `after`, \
                     like { after = \"door\", mission = \"succeeds\" }"
                        .to_owned(),
                ));
                continue;
            };
            let succeeds = match raw.mission.get_ref().as_str() {
                "succeeds" => true,
                "fails" => false,
                other => {
                    problems.push(at(
                        raw.mission.span().start,
                        format!("`mission = \"{other}\"`: give \"succeeds\" or \"fails\""),
                    ));
                    continue;
                }
            };
            expect.push(Expectation {
                when: *when,
                state: state.get_ref().clone(),
                succeeds,
            });
        }
        let name = sweep.name.as_ref().map_or_else(
            || format!("{} {kind}", providers.join("+")),
            |n| n.get_ref().clone(),
        );
        if let Some(n) = &sweep.name
            && sweeps.iter().any(|s: &SweepDecl| s.name == *n.get_ref())
        {
            problems.push(at(
                n.span().start,
                format!(
                    "a sweep named `{}` is declared before: give each its own name",
                    n.get_ref()
                ),
            ));
        }
        sweeps.push(SweepDecl {
            name,
            runs,
            providers,
            kind,
            steps,
            expect,
        });
    }
    let mut known_failures = Vec::new();
    for known in raw.known_failure {
        if let Err(e) = glob::Pattern::new(known.case.get_ref()) {
            problems.push(at(
                known.case.span().start,
                format!("`{}` is not a glob: {}", known.case.get_ref(), e.msg),
            ));
        }
        if known.reason.get_ref().trim().is_empty() {
            problems.push(at(
                known.reason.span().start,
                "a known failure says why it fails: give a reason".to_owned(),
            ));
        }
        known_failures.push(KnownFailure {
            case: known.case.into_inner(),
            reason: known.reason.into_inner(),
        });
    }
    if problems.is_empty() {
        Ok(FaultsFile {
            sweeps,
            known_failures,
        })
    } else {
        Err(Diagnostics::new(problems))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str, expected: Result<&str, &str>) {
        let got = parse(Path::new("faults.toml"), text);
        match (got, expected) {
            (Ok(faults), Ok(summary)) => {
                let got: Vec<String> = faults
                    .sweeps
                    .iter()
                    .map(|s| {
                        let expect: Vec<String> =
                            s.expect.iter().map(Expectation::describe).collect();
                        format!(
                            "{}: {} {} x{} [{}]",
                            s.name,
                            s.providers.join("+"),
                            s.kind,
                            s.steps,
                            expect.join("; ")
                        )
                    })
                    .collect();
                assert_eq!(got.join("\n"), summary);
            }
            (Err(problems), Err(message)) => assert_eq!(problems.to_string(), message),
            (got, expected) => panic!("{text}\ngot {got:?}\nexpected {expected:?}"),
        }
    }

    #[test]
    fn a_sweep_with_expectations_is_read_with_its_defaults() {
        check(
            r#"
[[sweep]]
providers = ["laser"]
expect = [{ after = "door", mission = "succeeds" }]

[[sweep]]
name = "both"
providers = ["laser", "sonar"]
kind = "stall"
steps = 4
expect = [{ before = "door", mission = "fails" }]
"#,
            Ok(
                "laser crash: laser crash x10 [the mission succeeds when the fault strikes \
                after `door`]\nboth: laser+sonar stall x4 [the mission fails when the fault \
                strikes before `door`]",
            ),
        );
    }

    #[test]
    fn an_unknown_kind_is_named_at_its_place_with_the_closest_word() {
        check(
            "[[sweep]]\nproviders = [\"laser\"]\nkind = \"crsh\"\n",
            Err(
                "faults.toml:3:8: `crsh` is no fault kind (did you mean `crash`?): give one of \
                 crash, stall, garbage, frozen, slow, out-of-service, stuck, host-lost",
            ),
        );
    }

    #[test]
    fn an_unknown_key_and_bad_values_are_errors_at_their_places() {
        check(
            "[[sweep]]\nprovider = [\"laser\"]\n",
            Err(
                "faults.toml:2:1: unknown field `provider`, expected one of `name`, `runs`, \
                 `providers`, `kind`, `steps`, `expect`",
            ),
        );
        check(
            "[[sweep]]\nproviders = []\nsteps = 0\nexpect = [{ after = \"a\", before = \"b\", \
             mission = \"succeeds\" }, { after = \"a\", mission = \"wins\" }]\n",
            Err(
                "faults.toml:2:13: `providers` is empty: name the services that fail, like \
                 [\"laser\"]\nfaults.toml:3:9: `steps = 0`: give a number of points from 1 to \
                 1000\nfaults.toml:4:11: an expectation names one state with one of `before`, \
                 `during` or `after`, like { after = \"door\", mission = \"succeeds\" }\n\
                 faults.toml:4:89: `mission = \"wins\"`: give \"succeeds\" or \"fails\"",
            ),
        );
    }

    #[test]
    fn known_failures_match_case_ids_by_glob() {
        let faults = parse(
            Path::new("f.toml"),
            "[[known_failure]]\ncase = \"runs/a.mcap: laser crash @ *\"\nreason = \"in review\"\n",
        )
        .unwrap_or_default();
        let known = &faults.known_failures[0];
        assert!(known.matches("runs/a.mcap: laser crash @ 12.5s"));
        assert!(!known.matches("runs/a.mcap: check"));
    }
}
