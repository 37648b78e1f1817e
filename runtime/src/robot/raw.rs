//! The robot description as written, with the places of the values that later checks
//! may need to point at. Unknown keys are errors, so a misspelt key is not silently ignored.

use std::collections::BTreeMap;

use serde::Deserialize;
use toml::Spanned;

use super::StartMode;
use super::checks::OnCheckFailure;
use crate::supervise::RestartPolicy;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRobot {
    pub robot: RawHeader,
    #[serde(default)]
    pub broker: RawBroker,
    #[serde(default)]
    pub services: Vec<RawService>,
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
    pub requires: Vec<Spanned<String>>,
    pub restart: Option<Spanned<RestartPolicy>>,
    pub heartbeat_deadline_ms: Option<Spanned<i64>>,
    pub startup_deadline_ms: Option<Spanned<i64>>,
    #[serde(default)]
    pub start: StartMode,
    #[serde(default)]
    pub environment: BTreeMap<Spanned<String>, Spanned<String>>,
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
