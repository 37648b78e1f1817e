//! The robot description (`robots/*.toml`): which services make up a robot, how each is
//! started, which interfaces it provides (with a quality and a cost; the cost is read as the
//! percent of one core the service uses, until the broker measures it) and requires, and how
//! the broker watches it (restart policy, heartbeat deadline, start mode, fail back).
//!
//! [`parse`] and [`load`] turn the TOML text into a validated [`Robot`] or a
//! [`RobotError`] listing every problem as `file:line:column: what is wrong`. The set of
//! known interface names is a parameter, so tests and future interfaces need no change here.
//!
//! ```toml
//! [robot]
//! name = "test"
//! description = "a laser and a sonar made of test services"
//!
//! [broker]
//! heartbeat_period_ms = 10        # how often every service sends a heartbeat
//! heartbeat_deadline_ms = 50      # default: silence longer than this is a stall
//! startup_deadline_ms = 5000      # default: time from start to the first heartbeat
//! fail_back = false               # default for every interface
//! restart = { max_restarts = 3, window_ms = 10000, backoff_initial_ms = 50, backoff_max_ms = 2000 }
//! # retry_failed_after_ms = 10000 # optional: try a failed service again after this cool-down,
//! # retry_failed_max_ms = 160000   # doubled each time a retry fails again, up to this (16x)
//! # retry_probation_ms = 5000      # a retried service proves itself: clients fail back after
//!
//! data_checks = true              # check what providers publish (default: false)
//! nice = -10                      # run the robot ahead of other work (default: as started)
//! keep_cores_awake = true         # idle cores poll rather than sleep (default: false)
//! heartbeat_priority = 1          # SCHED_FIFO priority of heartbeat threads (default 1; 0: none)
//! # cpu_budget_percent = 150       # optional: CPU the services may use together, in percent
//! #                                # of one core (measured, or `cost` until measured)
//!
//! [broker.interfaces.RangeFinder]
//! fail_back = true                # per-interface override
//! # The data checks of the interface's providers; what is not given keeps the
//! # interface's default (`DataChecks::default_for`).
//! checks = { rate = 0.5, window_ms = 1000, freshness_ms = 500, values = true, frozen = 5, on_failure = "failed" }
//! # A provision may have checks of its own, over its interface's:
//! # provides = [{ interface = "RangeFinder", quality = 5, cost = 1, checks = { frozen = 0 } }]
//!
//! [[services]]
//! name = "laser"
//! kind = "test-range"             # run as `lewis service laser --robot FILE`
//! # command = ["/usr/bin/laserd", "--port", "/dev/ttyS0"]   # or a command line, no shell
//! start = "on-demand"             # or "standby" (hot standby) or "always"
//! heartbeat_deadline_ms = 50
//! restart = { max_restarts = 2, window_ms = 10000 }
//! provides = [
//!     { interface = "RangeFinder", quality = 10, cost = 2, data_rate_hz = 10.0 },
//! ]
//! requires = []                   # or ["Mover", { interface = "ImageSource", min_rate_hz = 20 }]
//! # excludes = "pan-tilt"         # services with the same group are never used together
//! environment = { RUST_LOG = "info" }
//! [services.parameters]           # free table handed to the service
//! beams = 181
//! ```

mod checks;
mod error;
mod hosts;
mod raw;
mod restart;
mod validate;

#[cfg(test)]
mod tests;

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::{Path, PathBuf};

use serde::Deserialize;

pub use checks::{DataChecks, MIN_FROZEN_COUNT, OnCheckFailure};
pub use error::RobotError;
pub use hosts::{Endpoint, HostSpec, NetworkSettings, TlsFiles};
pub use lewis_stdx::Diagnostic;

pub use restart::RestartPolicy;

/// The heartbeat threads' `SCHED_FIFO` priority unless the robot file says otherwise: the
/// lowest real-time one, ahead of every normal thread and behind any control loop a robot
/// team runs at a real-time priority of its own.
pub const DEFAULT_HEARTBEAT_PRIORITY: u8 = 1;

/// Quality and cost are relative scores within this range (higher quality is better,
/// lower cost is better).
pub const SCORE_RANGE: std::ops::RangeInclusive<i64> = 0..=100;

/// A validated robot description.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    /// The robot's name (an identifier: letters, digits, `-` and `_`).
    pub name: String,
    /// What this robot is, for people.
    pub description: String,
    /// How the broker watches and chooses services.
    pub broker: BrokerSettings,
    /// The services, in the order the file declares them (the start order at boot).
    pub services: Vec<ServiceSpec>,
    /// The computers it runs on (`[[hosts]]`), the robot's own first; empty for a robot
    /// on one machine.
    pub hosts: Vec<HostSpec>,
    /// How its hosts talk (`[network]`).
    pub network: NetworkSettings,
}

impl Robot {
    /// The service with this name.
    #[must_use]
    pub fn service(&self, name: &str) -> Option<&ServiceSpec> {
        self.services.iter().find(|s| s.name == name)
    }

    /// The world folder the first service with a `world` parameter names (a simulated
    /// robot's, or an emulated one's), as written in the file; see [`lewis_stdx::world::find_world`].
    #[must_use]
    pub fn world_folder(&self) -> Option<&str> {
        self.services
            .iter()
            .find_map(|s| s.parameters.get("world").and_then(toml::Value::as_str))
    }

    /// The host whose broker decides for the robot: the first of `[[hosts]]`, `None` for a
    /// robot on one machine.
    #[must_use]
    pub fn robot_host(&self) -> Option<&HostSpec> {
        self.hosts.first()
    }

    /// The host with this name.
    #[must_use]
    pub fn host(&self, name: &str) -> Option<&HostSpec> {
        self.hosts.iter().find(|h| h.name == name)
    }

    /// The host `service` runs on: the one it names, else the robot host; `None` for a
    /// robot on one machine or a service it does not have.
    #[must_use]
    pub fn host_of(&self, service: &str) -> Option<&str> {
        let spec = self.service(service)?;
        spec.host
            .as_deref()
            .or_else(|| self.robot_host().map(|h| h.name.as_str()))
    }

    /// The services that run on `host` ([`Robot::host_of`] each), in the file's order.
    pub fn services_on<'a>(&'a self, host: &'a str) -> impl Iterator<Item = &'a ServiceSpec> {
        let hub = self.robot_host().map(|h| h.name.as_str());
        self.services
            .iter()
            .filter(move |s| s.host.as_deref().or(hub) == Some(host))
    }

    /// The names of its hosts, comma-separated, for an error about an unknown host.
    #[must_use]
    pub fn host_names(&self) -> String {
        self.hosts
            .iter()
            .map(|h| h.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The names of its services, comma-separated: what an error about an unknown service
    /// lists as the valid ones.
    #[must_use]
    pub fn service_names(&self) -> String {
        self.services
            .iter()
            .map(|s| s.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The broker's settings for the whole robot.
#[derive(Debug, Clone, PartialEq)]
pub struct BrokerSettings {
    /// How often every service sends a heartbeat, in milliseconds.
    pub heartbeat_period_ms: u64,
    /// The default heartbeat deadline of a service, in milliseconds.
    pub heartbeat_deadline_ms: u64,
    /// The default time a service has from its start to its first heartbeat, in milliseconds.
    pub startup_deadline_ms: u64,
    /// Whether clients move back to a better provider once it is healthy again, by default.
    pub fail_back: bool,
    /// Per-interface overrides of `fail_back`.
    pub fail_back_per_interface: BTreeMap<String, bool>,
    /// The default restart policy of a service.
    pub restart: RestartPolicy,
    /// When set, a service that failed (gave up restarting, or stalled) is tried again
    /// after a cool-down; a service that could not be started at all is not.
    pub retry: Option<RetryPolicy>,
    /// Whether the broker checks the data providers publish (`[broker] data_checks`, off
    /// unless the robot file turns it on: the robots of this repository were tuned
    /// without it, see ARCHITECTURE.md).
    pub data_checks: bool,
    /// Per-interface data checks, where the robot file overrides the interface's default.
    pub checks_per_interface: BTreeMap<String, DataChecks>,
    /// The nice value `lewis up` runs the robot at (broker, recorder, services and programs
    /// inherit it), from -20 (first) to 19 (last); `None` leaves the one it was started with.
    pub nice: Option<i32>,
    /// Whether `lewis up` keeps its machine's cores out of deep idle states while the robot
    /// runs (`[broker] keep_cores_awake`, off by default): see
    /// `lewis_runtime::supervise::keep_cores_awake`.
    pub keep_cores_awake: bool,
    /// The `SCHED_FIFO` priority each service's heartbeat thread asks for (1 to 99; 0 leaves
    /// it to the normal scheduler), so that a busy machine cannot delay a heartbeat: the
    /// thread wakes at the heartbeat period for microseconds. Where the machine does not
    /// allow it, `lewis up` says so and the heartbeats run at normal priority.
    pub heartbeat_priority: u8,
    /// The CPU the robot's services may use together, in percent of one core (150 is one
    /// and a half cores), when the robot file gives one (`[broker] cpu_budget_percent`):
    /// the broker then chooses providers so that starting one does not go beyond it,
    /// counting each running service's measured CPU, or its declared cost
    /// ([`ServiceSpec::declared_cpu_percent`]) until it is measured.
    pub cpu_budget_percent: Option<u32>,
}

/// When and how a failed service gets another chance (`[broker]`'s `retry_failed_after_ms`,
/// `retry_failed_max_ms` and `retry_probation_ms`): as systemd's `StartLimitIntervalSec`
/// lets a unit start again once its interval is over, and an OTP supervisor escalates, the
/// cool-down doubles each time a retried service fails again before it has proven itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RetryPolicy {
    /// The first cool-down, from the failure to the retry, in milliseconds.
    pub after_ms: u64,
    /// The longest cool-down, however often the retries failed, in milliseconds.
    pub max_ms: u64,
    /// How long a retried service must stay up before clients fail back to it and its
    /// cool-down starts again from `after_ms`, in milliseconds.
    pub probation_ms: u64,
}

impl RetryPolicy {
    /// The longest cool-down when the robot file gives only the first: four doublings.
    pub const DEFAULT_MAX_FACTOR: u64 = 16;
    /// The probation when the robot file gives none, in milliseconds.
    pub const DEFAULT_PROBATION_MS: u64 = 5000;

    /// The cool-down before retry number `retries + 1` (`retries` retries failed before it).
    #[must_use]
    pub fn cool_down_ms(&self, retries: u32) -> u64 {
        let factor = 1u64.checked_shl(retries.min(32)).unwrap_or(u64::MAX);
        self.after_ms.saturating_mul(factor).min(self.max_ms)
    }
}

impl BrokerSettings {
    /// Whether clients of `interface` fail back to a better provider when it is healthy again.
    #[must_use]
    pub fn fail_back_for(&self, interface: &str) -> bool {
        self.fail_back_per_interface
            .get(interface)
            .copied()
            .unwrap_or(self.fail_back)
    }

    /// The data checks of `interface`'s providers: none when the robot turns data checks
    /// off, the robot file's where it declares them, the interface's default otherwise.
    #[must_use]
    pub fn checks_for(&self, interface: &str) -> DataChecks {
        if !self.data_checks {
            return DataChecks::none();
        }
        self.interface_checks(interface)
    }

    /// The data checks of one provider: its provision's own where the robot file gives
    /// them, else its interface's ([`BrokerSettings::checks_for`]).
    #[must_use]
    pub fn checks_of(&self, provision: &Provision) -> DataChecks {
        match provision.checks {
            Some(checks) if self.data_checks => checks,
            _ => self.checks_for(&provision.interface),
        }
    }

    /// The checks of `interface` when data checks are on: the file's or the default.
    pub(crate) fn interface_checks(&self, interface: &str) -> DataChecks {
        self.checks_per_interface
            .get(interface)
            .copied()
            .unwrap_or_else(|| DataChecks::default_for(interface))
    }
}

impl Default for BrokerSettings {
    fn default() -> Self {
        Self {
            heartbeat_period_ms: validate::DEFAULT_HEARTBEAT_PERIOD_MS,
            heartbeat_deadline_ms: validate::DEFAULT_HEARTBEAT_DEADLINE_MS,
            startup_deadline_ms: validate::DEFAULT_STARTUP_DEADLINE_MS,
            fail_back: false,
            fail_back_per_interface: BTreeMap::new(),
            restart: RestartPolicy::default(),
            retry: None,
            data_checks: false,
            checks_per_interface: BTreeMap::new(),
            nice: None,
            keep_cores_awake: false,
            heartbeat_priority: DEFAULT_HEARTBEAT_PRIORITY,
            cpu_budget_percent: None,
        }
    }
}

/// One service of the robot: how to start it, what it provides and requires, how it is watched.
#[derive(Debug, Clone, PartialEq)]
pub struct ServiceSpec {
    /// The service's name, unique in the robot (an identifier).
    pub name: String,
    /// What it does, for people.
    pub description: String,
    /// How its process is started.
    pub launch: Launch,
    /// The free table of parameters handed to the service.
    pub parameters: toml::Table,
    /// The interfaces it provides, in declaration order.
    pub provides: Vec<Provision>,
    /// The interfaces it asks the broker for when it runs.
    pub requires: Vec<String>,
    /// The least data rate it needs of some of the interfaces it requires, in hertz
    /// (`requires = [{ interface = "ImageSource", min_rate_hz = 20 }]`): the broker prefers
    /// a provider whose `data_rate_hz` is at least this.
    pub min_rates_hz: BTreeMap<String, f64>,
    /// The group of services that exclude each other (`excludes = "pan-tilt"`: two drivers
    /// of one device): the broker binds clients to at most one service of a group at a time.
    pub excludes: Option<String>,
    /// How it is restarted after a crash (the broker's default unless given).
    pub restart: RestartPolicy,
    /// Silence longer than this (milliseconds) after a heartbeat means the service stalled.
    pub heartbeat_deadline_ms: u64,
    /// Time from its start to its first heartbeat, in milliseconds.
    pub startup_deadline_ms: u64,
    /// When it is started.
    pub start: StartMode,
    /// Environment variables set for its process (on top of the broker's own).
    pub environment: BTreeMap<String, String>,
    /// The host it runs on, where the file names one (`host = "workstation"`); else the
    /// robot host ([`Robot::host_of`]).
    pub host: Option<String>,
}

impl ServiceSpec {
    /// What this service offers for `interface`, if it provides it.
    #[must_use]
    pub fn provision(&self, interface: &str) -> Option<&Provision> {
        self.provides.iter().find(|p| p.interface == interface)
    }

    /// What this service is taken to use of the CPU until it is measured, in percent of one
    /// core: the highest `cost` of its provisions (a process runs once, whatever it
    /// provides).
    #[must_use]
    pub fn declared_cpu_percent(&self) -> u32 {
        self.provides.iter().map(|p| p.cost).max().unwrap_or(0)
    }

    /// The program and arguments that start this service: `lewis_exe service NAME --robot
    /// robot_file` for a built-in kind, the given command line otherwise. Never a shell.
    #[must_use]
    pub fn argv(&self, lewis_exe: &Path, robot_file: &Path) -> Vec<OsString> {
        match &self.launch {
            Launch::Kind(_) => vec![
                lewis_exe.as_os_str().to_owned(),
                "service".into(),
                self.name.clone().into(),
                "--robot".into(),
                robot_file.as_os_str().to_owned(),
            ],
            Launch::Command(argv) => argv.iter().map(OsString::from).collect(),
        }
    }
}

/// How a service's process is started.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Launch {
    /// A built-in service kind, run as `lewis service NAME --robot FILE`.
    Kind(String),
    /// A program and its arguments (the program is never empty; no shell is involved).
    Command(Vec<String>),
}

/// What a service offers for one interface.
#[derive(Debug, Clone, PartialEq)]
pub struct Provision {
    /// The interface's name.
    pub interface: String,
    /// How good this provider is (in [`SCORE_RANGE`], higher is better).
    pub quality: u32,
    /// What it costs to run (in [`SCORE_RANGE`], lower is better).
    pub cost: u32,
    /// The rate it publishes at, in hertz, when known.
    pub data_rate_hz: Option<f64>,
    /// The data checks of this provider where the robot file gives them on the provision
    /// (`checks = { ... }`, over its interface's): a sonar ring's still readings are not a
    /// frozen laser's.
    pub checks: Option<DataChecks>,
}

/// When the broker starts a service.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StartMode {
    /// When a client needs one of its interfaces and it is the best provider.
    #[default]
    OnDemand,
    /// At once, as a hot standby: failing over to it needs no process start.
    Standby,
    /// At once, because the robot needs it whatever the clients ask; if it fails for good
    /// the broker asks for help.
    Always,
}

/// The service kinds a robot file's `kind`s and `parameters` are checked against when it
/// is loaded, so that a misspelt kind or parameter stops `lewis up` before anything starts
/// (implemented by `lewis_service::ServiceRegistry`).
pub trait Kinds {
    /// Every known kind, sorted.
    fn kind_names(&self) -> Vec<&str>;
    /// `None` when `kind` is unknown; otherwise whether `parameters` fit it, and what is
    /// wrong when they do not.
    fn check_parameters(&self, kind: &str, parameters: &toml::Table) -> Option<Result<(), String>>;
}

/// What a robot file is checked against: the interface names it may use and, when given,
/// the service kinds it may name.
#[derive(Clone, Copy)]
pub struct Known<'a> {
    /// The interfaces a service may provide or require.
    pub interfaces: &'a [&'a str],
    /// The service kinds and their parameters; `None` checks only that a kind is a name.
    pub kinds: Option<&'a dyn Kinds>,
}

impl std::fmt::Debug for Known<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Known")
            .field("interfaces", &self.interfaces)
            .field("kinds", &self.kinds.map(Kinds::kind_names))
            .finish()
    }
}

/// Parses and validates a robot description against `known` interfaces and kinds.
///
/// # Errors
/// A [`RobotError::Invalid`] listing every problem found, with its line and column.
pub fn parse_checked(text: &str, origin: &Path, known: Known<'_>) -> Result<Robot, RobotError> {
    validate::parse(text, origin, known)
}

/// Reads, parses and validates the robot description at `path` against `known` interfaces
/// and kinds: what `lewis up`, `lewis service` and replay load robots with.
///
/// # Errors
/// [`RobotError::Read`] when the file cannot be read, [`RobotError::Invalid`] otherwise.
pub fn load_checked(path: &Path, known: Known<'_>) -> Result<Robot, RobotError> {
    let text = std::fs::read_to_string(path).map_err(|source| RobotError::Read {
        path: PathBuf::from(path),
        source,
    })?;
    parse_checked(&text, path, known)
}

/// Parses and validates a robot description. `origin` names the text in error messages
/// (usually its path); `known_interfaces` are the interface names a service may provide
/// or require.
///
/// # Errors
/// A [`RobotError::Invalid`] listing every problem found, with its line and column.
pub fn parse(text: &str, origin: &Path, known_interfaces: &[&str]) -> Result<Robot, RobotError> {
    let known = Known {
        interfaces: known_interfaces,
        kinds: None,
    };
    validate::parse(text, origin, known)
}

/// Reads, parses and validates the robot description at `path`.
///
/// # Errors
/// [`RobotError::Read`] when the file cannot be read, [`RobotError::Invalid`] otherwise.
pub fn load(path: &Path, known_interfaces: &[&str]) -> Result<Robot, RobotError> {
    let text = std::fs::read_to_string(path).map_err(|source| RobotError::Read {
        path: PathBuf::from(path),
        source,
    })?;
    parse(&text, path, known_interfaces)
}
