//! The kinds of service a `lewis` binary can run: a map from a kind name (`kind = "sick"` in
//! the robot file) to a constructor, the type of its parameters and its [`Role`]. The
//! runtime knows no kind; the `lewis` binary registers those of `lewis-kinds`, and a binary
//! of a team's own adds theirs (`lewis::main_with`).

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::Path;

use serde::de::DeserializeOwned;

use super::Service;
use super::rng::Rng;
use lewis_robot::{Known, Robot, RobotError, ServiceSpec};

/// What a constructor is given: the service's name and its part of the robot file.
#[derive(Debug, Clone, Copy)]
pub struct ServiceConfig<'a> {
    /// The service's entry in the robot file.
    pub spec: &'a ServiceSpec,
    /// The broker's heartbeat period, in milliseconds.
    pub heartbeat_period_ms: u64,
}

impl ServiceConfig<'_> {
    /// The service's name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.spec.name
    }

    /// The parameters table as a typed struct (use `#[serde(deny_unknown_fields)]` so that a
    /// misspelt parameter is an error, and `#[serde(default)]` for optional ones).
    ///
    /// # Errors
    /// A [`BuildError::Parameters`] naming the service and what serde found wrong.
    pub fn parameters<P: DeserializeOwned>(&self) -> Result<P, BuildError> {
        toml::Value::Table(self.spec.parameters.clone())
            .try_into()
            .map_err(|e: toml::de::Error| BuildError::Parameters {
                service: self.spec.name.clone(),
                reason: e.message().to_owned(),
            })
    }

    /// The seed of the service's random source: its `seed` parameter when it is a
    /// non-negative integer, otherwise a hash of its name (stable across runs).
    #[must_use]
    pub fn seed(&self) -> u64 {
        self.spec
            .parameters
            .get("seed")
            .and_then(toml::Value::as_integer)
            .and_then(|s| u64::try_from(s).ok())
            .unwrap_or_else(|| Rng::seed_from_name(&self.spec.name))
    }
}

/// Why a service could not be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BuildError {
    /// No constructor is registered for the kind.
    #[error(
        "service `{service}` has kind `{kind}`, which this lewis does not know; known kinds: {known}"
    )]
    UnknownKind {
        /// The service.
        service: String,
        /// The kind asked for.
        kind: String,
        /// The registered kinds, comma-separated.
        known: String,
    },
    /// The service is run from a command line, not a kind.
    #[error("service `{service}` is started from its own command line, not by `lewis service`")]
    NotAKind {
        /// The service.
        service: String,
    },
    /// The parameters do not fit the kind.
    #[error("parameters of service `{service}`: {reason}")]
    Parameters {
        /// The service.
        service: String,
        /// What is wrong.
        reason: String,
    },
}

/// Builds a service of one kind.
pub type Constructor =
    Box<dyn Fn(&ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> + Send + Sync>;

/// Checks a kind's parameters table without building anything: what serde finds wrong.
type ParameterCheck = Box<dyn Fn(&toml::Table) -> Result<(), String> + Send + Sync>;

/// What a kind is to a replay: whether its publications are re-computed or fed from the
/// recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Role {
    /// Computes from what it requires (an avoider, a blob finder): replay runs it again on
    /// the recorded inputs. The default.
    #[default]
    Algorithm,
    /// Talks to hardware, or to an emulator of it (a laser driver, a camera): replay feeds
    /// its publications from the recording, even when it requires something.
    Device,
    /// A device simulated from the recorded world and seeds (the simulator's sensors):
    /// replay feeds it from the recording by default, and `lewis replay --all` runs it
    /// again so that the world reacts to what the robot does.
    SimulatedDevice,
}

/// A registered kind: how to build it, when known how to check its parameters, and its
/// role in a replay.
struct Kind {
    constructor: Constructor,
    check: Option<ParameterCheck>,
    role: Role,
}

/// The kinds of service known to a binary.
#[derive(Default)]
pub struct ServiceRegistry {
    kinds: BTreeMap<String, Kind>,
}

impl fmt::Debug for ServiceRegistry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ServiceRegistry")
            .field("kinds", &self.kinds.keys().collect::<Vec<_>>())
            .finish()
    }
}

impl ServiceRegistry {
    /// An empty registry.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers `kind` (a later registration of the same kind replaces the earlier one).
    /// Its parameters are checked only when it is built; prefer
    /// [`Self::register_with_parameters`].
    pub fn register(
        &mut self,
        kind: &str,
        constructor: impl Fn(&ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError>
        + Send
        + Sync
        + 'static,
    ) -> &mut Self {
        self.insert(kind, Box::new(constructor), None)
    }

    /// Registers `kind` whose parameters table is a `P` (with `deny_unknown_fields`, so that
    /// a misspelt parameter is an error): a robot file is checked against `P` when it is
    /// loaded, before any service starts.
    pub fn register_with_parameters<P: DeserializeOwned>(
        &mut self,
        kind: &str,
        constructor: impl Fn(&ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError>
        + Send
        + Sync
        + 'static,
    ) -> &mut Self {
        let check: ParameterCheck = Box::new(|table: &toml::Table| {
            toml::Value::Table(table.clone())
                .try_into::<P>()
                .map(drop)
                .map_err(|e| with_suggestion(e.message().trim_end().trim_end_matches('.')))
        });
        self.insert(kind, Box::new(constructor), Some(check))
    }

    fn insert(
        &mut self,
        kind: &str,
        constructor: Constructor,
        check: Option<ParameterCheck>,
    ) -> &mut Self {
        self.kinds.insert(
            kind.to_owned(),
            Kind {
                constructor,
                check,
                role: Role::default(),
            },
        );
        self
    }

    /// Gives a registered `kind` its role in a replay (kinds are [`Role::Algorithm`]s until
    /// told otherwise); a kind not registered is left alone.
    pub fn set_role(&mut self, kind: &str, role: Role) -> &mut Self {
        if let Some(entry) = self.kinds.get_mut(kind) {
            entry.role = role;
        }
        self
    }

    /// The role of `kind` in a replay, `None` when it is not registered.
    #[must_use]
    pub fn role(&self, kind: &str) -> Option<Role> {
        self.kinds.get(kind).map(|entry| entry.role)
    }

    /// The kinds a replay feeds from the recording: [`Role::Device`]s and
    /// [`Role::SimulatedDevice`]s.
    #[must_use]
    pub fn source_kinds(&self) -> BTreeSet<String> {
        self.kinds_where(|role| role != Role::Algorithm)
    }

    /// The [`Role::SimulatedDevice`]s, which `lewis replay --all` runs again.
    #[must_use]
    pub fn simulated_kinds(&self) -> BTreeSet<String> {
        self.kinds_where(|role| role == Role::SimulatedDevice)
    }

    fn kinds_where(&self, keep: impl Fn(Role) -> bool) -> BTreeSet<String> {
        self.kinds
            .iter()
            .filter(|(_, kind)| keep(kind.role))
            .map(|(name, _)| name.clone())
            .collect()
    }

    /// Reads a robot file and checks it whole before anything starts: its syntax, its
    /// interfaces, and each service's kind and parameters against this registry.
    ///
    /// # Errors
    /// [`RobotError::Read`] when the file cannot be read; [`RobotError::Invalid`] with every
    /// problem at its `file:line:column` otherwise.
    pub fn load_robot(&self, path: &Path) -> Result<Robot, RobotError> {
        let interfaces = lewis_interfaces::interface_names();
        let known = Known {
            interfaces: &interfaces,
            kinds: Some(self),
        };
        lewis_robot::load_checked(path, known)
    }

    /// The kinds registered without a parameter type, whose mistakes show only at start-up.
    #[must_use]
    pub fn kinds_without_parameter_check(&self) -> Vec<&str> {
        self.kinds
            .iter()
            .filter(|(_, kind)| kind.check.is_none())
            .map(|(name, _)| name.as_str())
            .collect()
    }

    /// The registered kinds, sorted.
    #[must_use]
    pub fn kinds(&self) -> Vec<&str> {
        self.kinds.keys().map(String::as_str).collect()
    }

    /// Builds the service `config.spec` describes.
    ///
    /// # Errors
    /// When its kind is unknown, it has a command line instead, or its parameters do not fit.
    pub fn build(&self, config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
        let kind = match &config.spec.launch {
            lewis_robot::Launch::Kind(kind) => kind,
            lewis_robot::Launch::Command(_) => {
                return Err(BuildError::NotAKind {
                    service: config.spec.name.clone(),
                });
            }
        };
        let entry = self
            .kinds
            .get(kind)
            .ok_or_else(|| BuildError::UnknownKind {
                service: config.spec.name.clone(),
                kind: kind.clone(),
                known: self.kinds().join(", "),
            })?;
        (entry.constructor)(config)
    }
}

impl lewis_robot::Kinds for ServiceRegistry {
    fn kind_names(&self) -> Vec<&str> {
        self.kinds()
    }

    fn check_parameters(&self, kind: &str, parameters: &toml::Table) -> Option<Result<(), String>> {
        let entry = self.kinds.get(kind)?;
        Some(
            entry
                .check
                .as_ref()
                .map_or(Ok(()), |check| check(parameters)),
        )
    }
}

/// serde's "unknown field `x`, expected one of `a`, `b`" as "unknown field `x`: did you
/// mean `a`?" when one is close; the message as it is otherwise.
fn with_suggestion(message: &str) -> String {
    let suggestion = message
        .strip_prefix("unknown field `")
        .and_then(|rest| rest.split_once('`'))
        .and_then(|(found, rest)| {
            let expected = rest.split('`').skip(1).step_by(2);
            lewis_stdx::closest(found, expected).map(|near| (found, near))
        });
    match suggestion {
        Some((found, near)) => format!("unknown field `{found}`: did you mean `{near}`?"),
        None => message.to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unknown_field_close_to_a_known_one_is_suggested() {
        assert_eq!(
            with_suggestion("unknown field `max_rnage_m`, expected one of `world`, `max_range_m`"),
            "unknown field `max_rnage_m`: did you mean `max_range_m`?"
        );
        let far = "unknown field `banana`, expected one of `world`, `seed`";
        assert_eq!(with_suggestion(far), far);
        assert_eq!(with_suggestion("invalid type"), "invalid type");
    }
}
