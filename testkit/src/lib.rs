//! The test kit: what every crate's tests share, below the runtime.
//!
//! - The service test kit: the one recording [`Backend`] and the one [`Harness`] that
//!   every crate's tests use to run a service as the live harness does, without processes
//!   or shared memory, on a clock the test sets. It owns: building a service of a robot
//!   file through a registry ([`Harness::build`]), handing it events one at a time (start,
//!   tick, input, command, call reply) with the provenance the live harness gives them,
//!   keeping what it did ([`RecordingBackend`]: publications, log lines, health changes,
//!   calls).
//! - The processes of an end-to-end test ([`process`]): the `lewis` binary built and
//!   located, commands run to completion, children awaited under the [`WATCHDOG`], the
//!   independent MCAP checkers ([`doctor`]); a browser for the GUI tests ([`browser`]), a
//!   small disk ([`small_disk`]), several hosts on one machine ([`hosts`]) and the robot
//!   files they run ([`robot_files`]); files of the repository ([`repository_path`],
//!   [`shared_data`]); a test that cannot set up what it needs, skipped on a developer's
//!   machine and failed under CI ([`skip_unless_ci!`]).
//!
//! It does not own any service kind, world or device model: the tests bring their own
//! registry and use the real simulator (`lewis-sim`) for a world. It is a test-support
//! crate: only dev-dependencies and `lewis-tests` (the end-to-end tests' helpers) name it
//! (the layers test in `tests/` checks that). It depends on the interfaces, the robot file
//! and the service model, never on the runtime (no iceoryx2, no Zenoh), so a component's
//! own tests, and the tests of the crates the end-to-end tests use, can use it without a
//! cycle and without compiling IPC.

// Helpers of tests: a message that does not decode or a robot text that does not parse is
// the test's failure, said with its reason.
#![allow(clippy::expect_used)]

pub mod browser;
pub mod hosts;
pub mod process;
pub mod robot_files;
pub mod scene;
pub mod skip;
pub mod small_disk;

pub use process::{
    WATCHDOG, Watched, descendants, doctor, lewis_exe, python_tool, run_ok, signal, wait_child,
    wait_child_within,
};

use std::path::{Path, PathBuf};

use lewis_interfaces::msg::{INTERFACES, InputRef};
use lewis_interfaces::{Command, Interface, cdr};
use lewis_robot::Robot;
use lewis_service::Health;
use lewis_service::wire;
use lewis_service::{
    Backend, BuildError, CallFailure, CallId, CommandError, ContextError, ContextState,
    IncomingCommand, Input, Level, ReplyEvent, Service, ServiceConfig, ServiceRegistry,
    decode_header_seq,
};

/// The repository's root folder.
#[must_use]
pub fn repository_root() -> PathBuf {
    // The kit is one folder below the root.
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from(".."), Path::to_path_buf)
}

/// A path from the repository's root.
#[must_use]
pub fn repository_path(relative: &str) -> PathBuf {
    repository_root().join(relative)
}

/// A file or folder of the shared data folder beside the repository (`../shared/data/`),
/// real data recorded by others.
///
/// # Panics
/// When it is missing: the message says where it was looked for.
#[must_use]
pub fn shared_data(relative: &str) -> PathBuf {
    let path = repository_path("../shared/data").join(relative);
    assert!(
        path.exists(),
        "{} is missing: the tests read real data from ../shared/data beside the repository",
        path.display()
    );
    path
}

/// A robot description from TOML text, knowing every compiled interface.
///
/// # Panics
/// When the text does not parse: the test's robot is wrong.
#[must_use]
pub fn robot(text: &str) -> Robot {
    let known: Vec<&str> = INTERFACES.iter().map(|i| i.name).collect();
    lewis_robot::parse(text, Path::new("test-robot.toml"), &known)
        .unwrap_or_else(|e| panic!("the test's robot file does not parse: {e}"))
}

/// One publication: the interface and the CDR bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Publication {
    /// The interface published.
    pub interface: String,
    /// The message, CDR-encoded.
    pub bytes: Vec<u8>,
}

impl Publication {
    /// The message decoded as `T`.
    ///
    /// # Panics
    /// When it is not a `T`.
    #[must_use]
    pub fn decode<T: Interface>(&self) -> T {
        assert_eq!(
            self.interface,
            T::NAME,
            "a publication of another interface"
        );
        cdr::from_bytes(&self.bytes).expect("a publication decodes")
    }
}

/// One call the service made.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Call {
    /// The call's id, for the reply.
    pub id: CallId,
    /// The interface called.
    pub interface: String,
    /// The command's name.
    pub command: &'static str,
    /// The command message, CDR-encoded (the request frame's payload).
    pub message: Vec<u8>,
}

/// A backend that keeps everything the service did, on a clock the test sets.
#[derive(Debug, Default)]
pub struct RecordingBackend {
    /// The service's clock, in ns.
    pub now_ns: i64,
    /// When set, the interfaces the service may publish: any other is refused as the live
    /// harness refuses it.
    pub provides: Option<Vec<String>>,
    /// Every publication, in order.
    pub published: Vec<Publication>,
    /// Every log line.
    pub logs: Vec<(Level, String)>,
    /// Every health change.
    pub health: Vec<Health>,
    /// Every call sent, in order; the test answers them with [`Harness::reply`].
    pub calls: Vec<Call>,
    /// When set, every call fails to be sent with this (no provider, a full queue).
    pub refuse_calls: Option<CallFailure>,
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
        if let Some(provides) = &self.provides
            && !provides.iter().any(|p| p == interface)
        {
            return Err(ContextError::NotProvided {
                service: "under-test".into(),
                interface: interface.into(),
            });
        }
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
        call: CallId,
        interface: &str,
        command: &'static str,
        frame: &[u8],
        _timeout_ns: i64,
    ) -> Result<(), CallFailure> {
        if let Some(failure) = &self.refuse_calls {
            return Err(failure.clone());
        }
        let (name, message) = wire::read_request(frame).expect("a call's frame is a request");
        assert_eq!(name, command, "the frame names the command called");
        self.calls.push(Call {
            id: call,
            interface: interface.to_owned(),
            command,
            message: message.to_vec(),
        });
        Ok(())
    }

    fn health_changed(&mut self, health: &Health) {
        self.health.push(health.clone());
    }

    fn log(&mut self, _service: &str, level: Level, text: &str) {
        self.logs.push((level, text.to_owned()));
    }
}

/// A service under test and the backend that records it. Each event method takes the time
/// it happens at and sets the backend's clock to it first.
pub struct Harness {
    service: Box<dyn Service>,
    state: ContextState,
    /// What the service did.
    pub backend: RecordingBackend,
    name: String,
}

impl std::fmt::Debug for Harness {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Harness")
            .field("name", &self.name)
            .field("backend", &self.backend)
            .finish_non_exhaustive()
    }
}

impl Harness {
    /// Builds service `name` of `robot` with `registry`'s kinds (not started yet), with the
    /// robot's heartbeat period and the seed the live harness gives it. The backend refuses
    /// publications of interfaces the service does not provide in the robot file.
    ///
    /// # Errors
    /// The build error of the kind's constructor.
    ///
    /// # Panics
    /// When the robot has no service `name`.
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
            backend: RecordingBackend {
                provides: Some(spec.provides.iter().map(|p| p.interface.clone()).collect()),
                ..RecordingBackend::default()
            },
            name: name.to_owned(),
        })
    }

    /// A harness around a service made by the test itself (a sub-task program, which no
    /// registry builds): it provides nothing, and draws random numbers from `seed`.
    #[must_use]
    pub fn from_service(name: &str, service: Box<dyn Service>, seed: u64) -> Self {
        Self {
            service,
            state: ContextState::new(name, seed),
            backend: RecordingBackend {
                provides: Some(Vec::new()),
                ..RecordingBackend::default()
            },
            name: name.to_owned(),
        }
    }

    /// Whether the service finished, and with which code ([`Service::exit_code`]).
    #[must_use]
    pub fn exit_code(&self) -> Option<i32> {
        self.service.exit_code()
    }

    /// The service's name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The service's tick period, in ns.
    #[must_use]
    pub fn tick_period_ns(&self) -> Option<i64> {
        self.service.tick_period_ns()
    }

    /// Runs `on_start` at `now_ns`.
    ///
    /// # Errors
    /// The service's reason not to start.
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

    /// Runs `on_stop` at `now_ns`: the last handler, as when the live harness is stopped or
    /// the service finished.
    pub fn stop(&mut self, now_ns: i64) {
        self.backend.now_ns = now_ns;
        self.state.set_inputs(Vec::new());
        self.service
            .on_stop(&mut self.state.context(&mut self.backend));
    }

    /// Hands the service a sample that arrived on `channel` from `provider` at `now_ns`, with
    /// the provenance the live harness gives it.
    pub fn input(&mut self, now_ns: i64, provider: &str, channel: &str, publication: &Publication) {
        self.backend.now_ns = now_ns;
        let seq = decode_header_seq(&publication.bytes);
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

    /// Hands the service `message` from `provider` at `now_ns`, on the provider's channel of
    /// `T` (`/provider/T`), as [`Harness::input`] does.
    pub fn send<T: Interface>(&mut self, now_ns: i64, provider: &str, message: &T) {
        let publication = Publication {
            interface: T::NAME.to_owned(),
            bytes: cdr::to_vec(message),
        };
        let channel = format!("/{provider}/{}", T::NAME);
        self.input(now_ns, provider, &channel, &publication);
    }

    /// Sends `command` at `now_ns`; returns the decoded reply or the refusal.
    ///
    /// # Errors
    /// The service's refusal.
    ///
    /// # Panics
    /// When the reply does not decode as the command's reply.
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

    /// Sends a command given as CDR bytes at `now_ns`, as a caller's request frame carries
    /// it; returns the reply's CDR bytes or the refusal. For tests that route one service's
    /// calls to another.
    ///
    /// # Errors
    /// The service's refusal.
    pub fn command_bytes(
        &mut self,
        now_ns: i64,
        interface: &str,
        command: &str,
        bytes: &[u8],
    ) -> Result<Vec<u8>, CommandError> {
        self.backend.now_ns = now_ns;
        self.state.set_inputs(Vec::new());
        let incoming = IncomingCommand {
            interface,
            command,
            bytes,
        };
        let reply = self
            .service
            .on_command(&mut self.state.context(&mut self.backend), &incoming)?;
        Ok(reply.bytes().to_vec())
    }

    /// Answers call `call` at `now_ns`: the reply message's CDR bytes, or the failure.
    pub fn reply(
        &mut self,
        now_ns: i64,
        call: CallId,
        interface: &str,
        command: &str,
        result: Result<&[u8], CallFailure>,
    ) {
        self.backend.now_ns = now_ns;
        self.state.set_inputs(Vec::new());
        let event = ReplyEvent {
            call,
            interface,
            command,
            result,
        };
        self.service
            .on_reply(&mut self.state.context(&mut self.backend), &event);
    }

    /// Takes the publications made since the last call.
    pub fn take_published(&mut self) -> Vec<Publication> {
        std::mem::take(&mut self.backend.published)
    }

    /// Takes the publications of `T` made since the last call, decoded; the others stay.
    pub fn take<T: Interface>(&mut self) -> Vec<T> {
        let (mine, rest): (Vec<_>, Vec<_>) = std::mem::take(&mut self.backend.published)
            .into_iter()
            .partition(|p| p.interface == T::NAME);
        self.backend.published = rest;
        decoded(&mine)
    }

    /// Takes the calls made since the last call.
    pub fn take_calls(&mut self) -> Vec<Call> {
        std::mem::take(&mut self.backend.calls)
    }

    /// The last publication of `T`, decoded.
    #[must_use]
    pub fn last<T: Interface>(&self) -> Option<T> {
        self.backend
            .published
            .iter()
            .rev()
            .find(|p| p.interface == T::NAME)
            .map(Publication::decode)
    }
}

/// The publications of interface `T`, decoded.
#[must_use]
pub fn decoded<T: Interface>(published: &[Publication]) -> Vec<T> {
    published
        .iter()
        .filter(|p| p.interface == T::NAME)
        .map(Publication::decode)
        .collect()
}
