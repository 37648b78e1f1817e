//! The robot description as written, with the places of the values that later checks
//! may need to point at. Unknown keys are errors, so a misspelt key is not silently ignored.

use std::collections::BTreeMap;

use serde::Deserialize;
use toml::Spanned;

use super::StartMode;
use super::checks::OnCheckFailure;
use crate::RestartPolicy;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRobot {
    pub robot: RawHeader,
    #[serde(default)]
    pub broker: RawBroker,
    #[serde(default)]
    pub services: Vec<RawService>,
    #[serde(default)]
    pub hosts: Vec<Spanned<RawHost>>,
    pub network: Option<Spanned<RawNetwork>>,
}

/// One computer of the robot (`[[hosts]]`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawHost {
    pub name: Spanned<String>,
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub listen: Vec<Spanned<String>>,
    pub connect: Option<Vec<Spanned<String>>>,
}

/// How the hosts talk (`[network]`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawNetwork {
    pub key_file: Option<Spanned<String>>,
    pub link_deadline_ms: Option<Spanned<i64>>,
    pub tls: Option<RawTls>,
}

/// The files of TLS between the hosts (`[network.tls]`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTls {
    pub ca: Spanned<String>,
    pub certificate: Spanned<String>,
    pub private_key: Spanned<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawHeader {
    pub name: Spanned<String>,
    #[serde(default)]
    pub description: String,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBroker {
    pub heartbeat_period_ms: Option<Spanned<i64>>,
    pub heartbeat_deadline_ms: Option<Spanned<i64>>,
    pub startup_deadline_ms: Option<Spanned<i64>>,
    #[serde(default)]
    pub fail_back: bool,
    #[serde(default)]
    pub interfaces: BTreeMap<Spanned<String>, RawInterfaceSettings>,
    pub restart: Option<Spanned<RestartPolicy>>,
    pub retry_failed_after_ms: Option<Spanned<i64>>,
    pub retry_failed_max_ms: Option<Spanned<i64>>,
    pub retry_probation_ms: Option<Spanned<i64>>,
    pub data_checks: Option<bool>,
    pub nice: Option<Spanned<i64>>,
    pub keep_cores_awake: Option<bool>,
    pub heartbeat_priority: Option<Spanned<i64>>,
    pub cpu_budget_percent: Option<Spanned<i64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawInterfaceSettings {
    pub fail_back: Option<bool>,
    pub checks: Option<Spanned<RawChecks>>,
}

/// Overrides of an interface's data checks; what is not given keeps the interface's default.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawChecks {
    pub rate: Option<Spanned<f64>>,
    pub window_ms: Option<Spanned<i64>>,
    pub freshness_ms: Option<Spanned<i64>>,
    pub values: Option<bool>,
    pub frozen: Option<Spanned<i64>>,
    pub on_failure: Option<OnCheckFailure>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawService {
    pub name: Spanned<String>,
    #[serde(default)]
    pub description: String,
    pub kind: Option<Spanned<String>>,
    pub command: Option<Spanned<Vec<Spanned<String>>>>,
    pub parameters: Option<Spanned<toml::Table>>,
    #[serde(default)]
    pub provides: Vec<Spanned<RawProvision>>,
    #[serde(default)]
    pub requires: Vec<Spanned<RawRequirement>>,
    pub excludes: Option<Spanned<String>>,
    pub restart: Option<Spanned<RestartPolicy>>,
    pub heartbeat_deadline_ms: Option<Spanned<i64>>,
    pub startup_deadline_ms: Option<Spanned<i64>>,
    #[serde(default)]
    pub start: StartMode,
    #[serde(default)]
    pub environment: BTreeMap<Spanned<String>, Spanned<String>>,
    pub host: Option<Spanned<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawProvision {
    pub interface: Spanned<String>,
    pub quality: Spanned<i64>,
    pub cost: Spanned<i64>,
    pub data_rate_hz: Option<Spanned<f64>>,
    pub checks: Option<Spanned<RawChecks>>,
}

/// A required interface: its name, or a table with the least data rate the client needs.
/// Read by hand rather than as an untagged enum, so that a misspelt key in the table is
/// named in the error.
#[derive(Debug)]
pub(super) enum RawRequirement {
    /// `"ImageSource"`.
    Name(String),
    /// `{ interface = "ImageSource", min_rate_hz = 20 }`.
    Table(RawRequirementTable),
}

impl<'de> Deserialize<'de> for RawRequirement {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = RawRequirement;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("an interface name or { interface = ..., min_rate_hz = ... }")
            }
            fn visit_str<E: serde::de::Error>(self, name: &str) -> Result<Self::Value, E> {
                Ok(RawRequirement::Name(name.to_owned()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<Self::Value, A::Error> {
                RawRequirementTable::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(RawRequirement::Table)
            }
        }
        deserializer.deserialize_any(Visitor)
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRequirementTable {
    pub interface: String,
    pub min_rate_hz: Option<f64>,
}

impl RawRequirement {
    pub fn interface(&self) -> &str {
        match self {
            Self::Name(name) => name,
            Self::Table(table) => &table.interface,
        }
    }
}
