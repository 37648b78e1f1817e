//! Replaying with a changed robot: what a team does to ask "would my change have behaved
//! the same on this run?".
//!
//! - `--robot FILE` replays with another robot description instead of the one stored in the
//!   recording, typically the robot file of the repository after the change under test
//!   (`lewis replay tests/data/reference/run.mcap --robot robots/sim.toml --check`).
//! - `--set SERVICE.PARAMETER=VALUE` changes one parameter (after `--robot`, if given), for
//!   a quick what-if: `--set obstacle_avoider.clearance_m=0.3`. The value is TOML (`0.3`,
//!   `true`, `"text"`, `[1, 2]`, `{ x_m = 3.0 }`); a bare word is taken as a string. A dotted
//!   PARAMETER reaches into a table: `--set base.start.x_m=3.5`.
//!
//! The report lists every parameter of a re-simulated service that differs from the
//! recording. A change to a service fed from the recording would change nothing: `--set`
//! refuses it, naming the option that re-simulates the service.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use lewis_robot::{Robot, RobotError};

use crate::report::ParameterChange;

/// One `--set SERVICE.PARAMETER=VALUE`.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamEdit {
    /// The text it was parsed from.
    pub text: String,
    /// The service.
    pub service: String,
    /// The parameter, then the keys of nested tables.
    pub path: Vec<String>,
    /// The new value.
    pub value: toml::Value,
}

/// Why a robot edit cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum EditError {
    /// `--set` is not `SERVICE.PARAMETER=VALUE`.
    #[error(
        "--set `{text}`: {reason}; write SERVICE.PARAMETER=VALUE, e.g. obstacle_avoider.clearance_m=0.3"
    )]
    Syntax {
        /// The option's text.
        text: String,
        /// What is wrong.
        reason: String,
    },
    /// `--set` names a service the robot does not have.
    #[error("--set `{text}`: the robot has no service `{service}`; it has: {known}")]
    UnknownService {
        /// The option's text.
        text: String,
        /// The name given.
        service: String,
        /// The services it has.
        known: String,
    },
    /// `--set` reaches into a parameter that is not a table.
    #[error("--set `{text}`: `{at}` is not a table, so it has no key `{key}`")]
    NotATable {
        /// The option's text.
        text: String,
        /// The parameter that is not a table.
        at: String,
        /// The key asked for.
        key: String,
    },
    /// `--set` changes a service that is fed from the recording.
    #[error(
        "--set `{text}`: `{service}` is fed from the recording, not re-simulated, so its parameters change nothing; re-simulate it with --services {service},... or --all"
    )]
    Fed {
        /// The option's text.
        text: String,
        /// The service.
        service: String,
    },
    /// The robot file of `--robot` cannot be read.
    #[error("--robot {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The robot description is not valid (after the edits).
    #[error("{0}")]
    Robot(#[from] RobotError),
    /// The robot description is not valid TOML (it is checked by [`lewis_robot::parse`] first, so
    /// this is an internal limit of the editor).
    #[error("cannot edit the robot description: {0}")]
    Toml(String),
}

impl FromStr for ParamEdit {
    type Err = EditError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let syntax = |reason: &str| EditError::Syntax {
            text: text.to_owned(),
            reason: reason.to_owned(),
        };
        let (name, value) = text
            .split_once('=')
            .ok_or_else(|| syntax("no `=` before the value"))?;
        let mut parts = name.trim().split('.').map(str::trim);
        let service = parts.next().unwrap_or_default().to_owned();
        let path: Vec<String> = parts.map(str::to_owned).collect();
        if service.is_empty() || path.is_empty() || path.iter().any(String::is_empty) {
            return Err(syntax("name a service, a dot, then a parameter"));
        }
        let value = value.trim();
        if value.is_empty() {
            return Err(syntax("no value after `=`"));
        }
        let value = toml::from_str::<toml::Table>(&format!("v = {value}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(value.to_owned()));
        Ok(Self {
            text: text.to_owned(),
            service,
            path,
            value,
        })
    }
}

/// The robot to replay, its text (stored in the output) and what differs from the recording.
#[derive(Debug, Clone)]
pub struct ReplayedRobot {
    /// The robot.
    pub robot: Robot,
    /// The file name stored with it.
    pub file_name: String,
    /// Its TOML text.
    pub toml: String,
    /// `recorded`, or the file given with `--robot`.
    pub source: String,
    /// The parameters that differ from the recorded robot's, for every service.
    pub changes: Vec<(String, ParameterChange)>,
}

/// The robot to replay: the recorded one (`recorded`, with its file name and text), or the
/// file `replacement`, with `edits` applied.
///
/// # Errors
/// When the file cannot be read, an edit does not fit, or the result is not a valid robot.
pub fn replayed_robot(
    recorded: &Robot,
    recorded_file_name: &str,
    recorded_toml: &str,
    replacement: Option<&Path>,
    edits: &[ParamEdit],
) -> Result<ReplayedRobot, EditError> {
    let (mut text, file_name, source) = match replacement {
        Some(path) => (
            std::fs::read_to_string(path).map_err(|source| EditError::Read {
                path: path.to_path_buf(),
                source,
            })?,
            path.file_name().map_or_else(
                || "robot.toml".to_owned(),
                |n| n.to_string_lossy().into_owned(),
            ),
            path.display().to_string(),
        ),
        None => (
            recorded_toml.to_owned(),
            recorded_file_name.to_owned(),
            "recorded".to_owned(),
        ),
    };
    let origin = replacement.map_or_else(
        || PathBuf::from(format!("{recorded_file_name} (stored in the recording)")),
        Path::to_path_buf,
    );
    let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
        .iter()
        .map(|i| i.name)
        .collect();
    // Checked before the edits, so that its errors point at the file's own lines.
    let mut robot = lewis_robot::parse(&text, &origin, &known)?;
    if !edits.is_empty() {
        let mut table: toml::Table =
            toml::from_str(&text).map_err(|e| EditError::Toml(e.to_string()))?;
        for edit in edits {
            apply(&mut table, &robot, edit)?;
        }
        text = toml::to_string(&table).map_err(|e| EditError::Toml(e.to_string()))?;
        let origin = PathBuf::from(format!("{} with --set", origin.display()));
        robot = lewis_robot::parse(&text, &origin, &known)?;
    }
    let changes = parameter_changes(recorded, &robot);
    Ok(ReplayedRobot {
        robot,
        file_name,
        toml: text,
        source,
        changes,
    })
}

/// Refuses `--set` on services that are not re-simulated.
///
/// # Errors
/// [`EditError::Fed`] for the first edit of a service not in `resimulated`.
pub fn check_edits_resimulated(
    edits: &[ParamEdit],
    resimulated: &std::collections::BTreeSet<String>,
) -> Result<(), EditError> {
    match edits.iter().find(|e| !resimulated.contains(&e.service)) {
        Some(edit) => Err(EditError::Fed {
            text: edit.text.clone(),
            service: edit.service.clone(),
        }),
        None => Ok(()),
    }
}

fn apply(table: &mut toml::Table, robot: &Robot, edit: &ParamEdit) -> Result<(), EditError> {
    let unknown = || EditError::UnknownService {
        text: edit.text.clone(),
        service: edit.service.clone(),
        known: robot.service_names(),
    };
    let service = table
        .get_mut("services")
        .and_then(toml::Value::as_array_mut)
        .and_then(|services| {
            services.iter_mut().find(|s| {
                s.get("name").and_then(toml::Value::as_str) == Some(edit.service.as_str())
            })
        })
        .and_then(toml::Value::as_table_mut)
        .ok_or_else(unknown)?;
    let mut at = service
        .entry("parameters")
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    let mut walked = format!("{}.parameters", edit.service);
    let (last, inner) = edit.path.split_last().ok_or_else(|| EditError::Syntax {
        text: edit.text.clone(),
        reason: "no parameter".to_owned(),
    })?;
    for key in inner.iter().chain(std::iter::once(last)) {
        let Some(table) = at.as_table_mut() else {
            return Err(EditError::NotATable {
                text: edit.text.clone(),
                at: walked,
                key: key.clone(),
            });
        };
        walked = format!("{walked}.{key}");
        if key == last {
            table.insert(key.clone(), edit.value.clone());
            return Ok(());
        }
        at = table
            .entry(key.clone())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    }
    Ok(())
}

/// Every parameter that differs between the two robots, per service present in both, as
/// `(service, change)`, in the order of the services and of the parameters' names.
fn parameter_changes(recorded: &Robot, replayed: &Robot) -> Vec<(String, ParameterChange)> {
    let mut changes = Vec::new();
    for spec in &replayed.services {
        let Some(old) = recorded.service(&spec.name) else {
            continue;
        };
        let mut before = Vec::new();
        let mut after = Vec::new();
        flatten(&spec.name, &old.parameters, &mut before);
        flatten(&spec.name, &spec.parameters, &mut after);
        let before: std::collections::BTreeMap<String, String> = before.into_iter().collect();
        let after: std::collections::BTreeMap<String, String> = after.into_iter().collect();
        let names: std::collections::BTreeSet<&String> =
            before.keys().chain(after.keys()).collect();
        for name in names {
            let (r, p) = (before.get(name), after.get(name));
            if r != p {
                changes.push((
                    spec.name.clone(),
                    ParameterChange {
                        parameter: name.clone(),
                        recorded: r.cloned(),
                        replayed: p.cloned(),
                    },
                ));
            }
        }
    }
    changes
}

/// The parameters of a table as `(dotted name, TOML value)`, nested tables flattened.
fn flatten(prefix: &str, table: &toml::Table, out: &mut Vec<(String, String)>) {
    for (key, value) in table {
        let name = format!("{prefix}.{key}");
        match value {
            toml::Value::Table(inner) => flatten(&name, inner, out),
            other => out.push((name, other.to_string())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROBOT: &str = r#"
[robot]
name = "r"

[[services]]
name = "avoider"
kind = "k"
provides = [{ interface = "Mover", quality = 1, cost = 1 }]
[services.parameters]
rate_hz = 10.0
start = { x_m = 1.0 }

[[services]]
name = "laser"
kind = "k"
provides = [{ interface = "RangeFinder", quality = 1, cost = 1 }]
"#;

    fn recorded() -> Robot {
        let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
            .iter()
            .map(|i| i.name)
            .collect();
        lewis_robot::parse(ROBOT, Path::new("r.toml"), &known).unwrap()
    }

    fn edit(texts: &[&str]) -> Result<ReplayedRobot, EditError> {
        let edits = texts
            .iter()
            .map(|t| t.parse::<ParamEdit>())
            .collect::<Result<Vec<_>, _>>()?;
        replayed_robot(&recorded(), "r.toml", ROBOT, None, &edits)
    }

    fn changes(texts: &[&str]) -> Vec<String> {
        edit(texts)
            .unwrap()
            .changes
            .iter()
            .map(|(_, c)| c.to_string())
            .collect()
    }

    #[test]
    fn set_changes_parameters_nested_ones_and_new_ones() {
        assert_eq!(
            changes(&[
                "avoider.rate_hz=5",
                "avoider.start.x_m = 2.5",
                "laser.port=/dev/ttyS0"
            ]),
            [
                "avoider.rate_hz = 5 (recorded: 10.0)",
                "avoider.start.x_m = 2.5 (recorded: 1.0)",
                "laser.port = \"/dev/ttyS0\" (recorded: its default)",
            ]
        );
        assert!(changes(&[]).is_empty());
        let robot = edit(&["avoider.clearance_m=0.3"]).unwrap();
        assert_eq!(
            robot.robot.service("avoider").unwrap().parameters["clearance_m"],
            toml::Value::Float(0.3)
        );
        assert!(robot.toml.contains("clearance_m = 0.3"), "{}", robot.toml);
    }

    #[test]
    fn bad_edits_are_clear_errors() {
        let check = |text: &str, expected: &str| {
            let e = edit(&[text]).unwrap_err().to_string();
            assert!(e.contains(expected), "{e}");
        };
        check("avoider.rate_hz", "no `=` before the value");
        check("avoider=3", "name a service, a dot, then a parameter");
        check("avoider.rate_hz=", "no value after `=`");
        check(
            "lidar.rate_hz=3",
            "no service `lidar`; it has: avoider, laser",
        );
        check(
            "avoider.rate_hz.x=3",
            "`avoider.parameters.rate_hz` is not a table",
        );
        let resimulated = ["avoider".to_owned()].into_iter().collect();
        let edits = ["laser.rate_hz=3".parse::<ParamEdit>().unwrap()];
        let e = check_edits_resimulated(&edits, &resimulated)
            .unwrap_err()
            .to_string();
        assert!(e.contains("`laser` is fed from the recording"), "{e}");
    }
}
