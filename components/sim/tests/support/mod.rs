//! Drives a service through the `Service` trait as the live harness does, on a clock the
//! test sets, and keeps what it published: for tests of service kinds without processes.

// Helpers for tests: they unwrap values the tests built, and not every test file uses all.
#![allow(clippy::unwrap_used, clippy::expect_used, dead_code)]

use std::path::{Path, PathBuf};

use lewis_interfaces::msg::InputRef;
use lewis_interfaces::{Command, Interface, Message, cdr};
use lewis_runtime::broker::Health;
use lewis_runtime::robot::{self, Robot};
use lewis_runtime::service::{
    Backend, BuildError, CallFailure, CallId, CommandError, ContextError, ContextState,
    IncomingCommand, Input, Level, Service, ServiceConfig, ServiceRegistry,
};

/// A path from the repository's root.
pub fn repository_path(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(relative)
}

/// One publication: the interface and the CDR bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Publication {
    /// The interface published.
    pub interface: String,
    /// The message, CDR-encoded.
    pub bytes: Vec<u8>,
}

/// A backend that keeps everything the service did, on a clock the test sets.
#[derive(Debug, Default)]
pub struct RecordingBackend {
    /// The service's clock, in ns.
    pub now_ns: i64,
    /// Every publication, in order.
    pub published: Vec<Publication>,
    /// Every log line.
    pub logs: Vec<(Level, String)>,
    /// Every health change.
    pub health: Vec<Health>,
    /// Every call: interface and command.
    pub calls: Vec<(String, String)>,
}

impl Backend for RecordingBackend {
    fn now_ns(&self) -> i64 {
        self.now_ns
    }

    fn publish(
        &mut self,
        interface: &str,
        len_bytes: usize,
        encode: &mut dyn FnMut(&mut [u8]),
    ) -> Result<(), ContextError> {
        let mut bytes = vec![0; len_bytes];
        encode(&mut bytes);
        self.published.push(Publication {
            interface: interface.to_owned(),
            bytes,
        });
        Ok(())
    }

    fn call(
        &mut self,
        _call: CallId,
        interface: &str,
        command: &'static str,
        _frame: &[u8],
        _timeout_ns: i64,
    ) -> Result<(), CallFailure> {
        self.calls.push((interface.to_owned(), command.to_owned()));
        Err(CallFailure::NoProvider {
            interface: interface.to_owned(),
        })
    }

    fn health_changed(&mut self, health: &Health) {
        self.health.push(health.clone());
    }

    fn log(&mut self, _service: &str, level: Level, text: &str) {
        self.logs.push((level, text.to_owned()));
    }
}

/// A robot description from TOML text, knowing every compiled interface.
pub fn robot(text: &str) -> Robot {
    let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
        .iter()
        .map(|i| i.name)
        .collect();
    robot::parse(text, Path::new("test-robot.toml"), &known)
        .unwrap_or_else(|e| panic!("the test's robot file does not parse: {e}"))
}

/// A service under test and the backend that records it.
pub struct Harness {
    service: Box<dyn Service>,
    state: ContextState,
    /// What the service did.
    pub backend: RecordingBackend,
    name: String,
}

impl Harness {
    /// Builds service `name` of `robot` with `registry`'s kinds (not started yet).
    ///
    /// # Errors
    /// The build error of the kind's constructor.
    pub fn build(
        robot: &Robot,
        name: &str,
        registry: &ServiceRegistry,
    ) -> Result<Self, BuildError> {
        let spec = robot
            .service(name)
            .unwrap_or_else(|| panic!("the test's robot has no service `{name}`"));
        let config = ServiceConfig {
            spec,
            heartbeat_period_ms: robot.broker.heartbeat_period_ms,
        };
        let service = registry.build(&config)?;
        Ok(Self {
            service,
            state: ContextState::new(name, config.seed()),
            backend: RecordingBackend::default(),
            name: name.to_owned(),
        })
    }

    /// The service's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The service's tick period, in ns.
    pub fn tick_period_ns(&self) -> Option<i64> {
        self.service.tick_period_ns()
    }

    /// Runs `on_start` at `now_ns`.
    pub fn start(&mut self, now_ns: i64) -> Result<(), String> {
        self.backend.now_ns = now_ns;
        self.state.set_inputs(Vec::new());
        self.service
            .on_start(&mut self.state.context(&mut self.backend))
    }

    /// Runs `on_tick` at `now_ns`.
    pub fn tick(&mut self, now_ns: i64) {
        self.backend.now_ns = now_ns;
        self.state.set_inputs(Vec::new());
        self.service
            .on_tick(&mut self.state.context(&mut self.backend));
    }

    /// Hands the service a sample that arrived on `channel` from `provider` at `now_ns`, with
    /// the provenance the live harness gives it.
    pub fn input(&mut self, now_ns: i64, provider: &str, channel: &str, publication: &Publication) {
        self.backend.now_ns = now_ns;
        let seq = lewis_runtime::service::decode_header_seq(&publication.bytes);
        self.state.set_inputs(vec![InputRef {
            channel: channel.to_owned(),
            seq,
        }]);
        let input = Input {
            interface: &publication.interface,
            provider,
            channel,
            bytes: &publication.bytes,
        };
        self.service
            .on_input(&mut self.state.context(&mut self.backend), &input);
        self.state.set_inputs(Vec::new());
    }

    /// Sends `command` at `now_ns`; returns the decoded reply or the refusal.
    pub fn command<C: Command>(
        &mut self,
        now_ns: i64,
        command: &C,
    ) -> Result<C::Reply, CommandError> {
        self.backend.now_ns = now_ns;
        self.state.set_inputs(Vec::new());
        let bytes = cdr::to_vec(command);
        let incoming = IncomingCommand {
            interface: <C::Interface as Interface>::NAME,
            command: C::NAME,
            bytes: &bytes,
        };
        let reply = self
            .service
            .on_command(&mut self.state.context(&mut self.backend), &incoming)?;
        Ok(cdr::from_bytes(reply.bytes()).expect("the reply decodes as the command's reply"))
    }

    /// Takes the publications made since the last call.
    pub fn take_published(&mut self) -> Vec<Publication> {
        std::mem::take(&mut self.backend.published)
    }
}

/// The publications of interface `T`, decoded.
pub fn decoded<T: Interface>(published: &[Publication]) -> Vec<T> {
    published
        .iter()
        .filter(|p| p.interface == T::NAME)
        .map(|p| cdr::from_bytes::<T>(&p.bytes).expect("a publication decodes"))
        .collect()
}

/// The header of a message, for provenance checks.
pub fn header_of<T: Message>(message: &T) -> &lewis_interfaces::msg::Header {
    message.header()
}
