//! Drives services through the `Service` trait with a backend that keeps what they publish,
//! on a clock the test sets: the smallest harness that runs a service as the live one does.

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use lewis_interfaces::{Interface, cdr};
use lewis_runtime::broker::Health;
use lewis_runtime::service::{
    Backend, CallFailure, CallId, ContextError, ContextState, IncomingCommand, Input, Level, Reply,
    Service, ServiceConfig, ServiceRegistry,
};

/// What the service did, on the test's clock.
#[derive(Default)]
pub struct TestBackend {
    pub now_ns: i64,
    pub provides: Vec<String>,
    pub published: Vec<(String, Vec<u8>)>,
    pub health: Vec<Health>,
    pub logs: Vec<(Level, String)>,
}

impl Backend for TestBackend {
    fn now_ns(&self) -> i64 {
        self.now_ns
    }

    fn publish(
        &mut self,
        interface: &str,
        len_bytes: usize,
        encode: &mut dyn FnMut(&mut [u8]),
    ) -> Result<(), ContextError> {
        if !self.provides.iter().any(|p| p == interface) {
            return Err(ContextError::NotProvided {
                service: "under-test".into(),
                interface: interface.into(),
            });
        }
        let mut bytes = vec![0; len_bytes];
        encode(&mut bytes);
        self.published.push((interface.to_owned(), bytes));
        Ok(())
    }

    fn call(
        &mut self,
        _call: CallId,
        interface: &str,
        _command: &'static str,
        _frame: &[u8],
        _timeout_ns: i64,
    ) -> Result<(), CallFailure> {
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

/// A service under test, with its context state and backend.
pub struct Harness {
    pub service: Box<dyn Service>,
    pub state: ContextState,
    pub backend: TestBackend,
}

/// Every perception and camera kind, as `lewis service` registers them.
pub fn registry() -> ServiceRegistry {
    let mut registry = ServiceRegistry::new();
    lewis_perception::register(&mut registry);
    lewis_drivers::camera::register(&mut registry);
    registry
}

/// Builds the service `name` of a robot file's text, through the registry.
pub fn build(robot_toml: &str, name: &str) -> Result<Harness, String> {
    let interfaces: Vec<&str> = lewis_interfaces::msg::INTERFACES
        .iter()
        .map(|i| i.name)
        .collect();
    let robot = lewis_runtime::robot::parse(robot_toml, Path::new("robot.toml"), &interfaces)
        .map_err(|e| e.to_string())?;
    let spec = robot.service(name).ok_or("no such service")?;
    let config = ServiceConfig {
        spec,
        heartbeat_period_ms: 100,
    };
    let service = registry().build(&config).map_err(|e| e.to_string())?;
    Ok(Harness {
        service,
        state: ContextState::new(name, config.seed()),
        backend: TestBackend {
            provides: spec.provides.iter().map(|p| p.interface.clone()).collect(),
            ..TestBackend::default()
        },
    })
}

/// A robot file with one service.
pub fn robot(kind: &str, requires: &[&str], provides: &[&str], parameters: &str) -> String {
    let quote = |list: &[&str]| {
        list.iter()
            .map(|s| format!("\"{s}\""))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let provides = provides
        .iter()
        .map(|p| format!("{{ interface = \"{p}\", quality = 1, cost = 1 }}"))
        .collect::<Vec<_>>()
        .join(", ");
    // The robot file must have a provider for each required interface.
    let providers: String = requires
        .iter()
        .map(|r| {
            format!(
                "[[services]]\nname = \"{}\"\nkind = \"source\"\n\
                 provides = [{{ interface = \"{r}\", quality = 1, cost = 1 }}]\n\n",
                r.to_lowercase()
            )
        })
        .collect();
    format!(
        "[robot]\nname = \"t\"\n\n{providers}[[services]]\nname = \"under-test\"\n\
         kind = \"{kind}\"\nrequires = [{}]\nprovides = [{provides}]\n\n\
         [services.parameters]\n{parameters}\n",
        quote(requires)
    )
}

impl Harness {
    pub fn start(&mut self) -> Result<(), String> {
        self.service
            .on_start(&mut self.state.context(&mut self.backend))
    }

    pub fn tick(&mut self, now_ns: i64) {
        self.backend.now_ns = now_ns;
        self.service
            .on_tick(&mut self.state.context(&mut self.backend));
    }

    /// Hands the service a sample of `T` from provider `from`.
    pub fn input<T: Interface>(&mut self, from: &str, message: &T) {
        let bytes = cdr::to_vec(message);
        let channel = format!("/{from}/{}", T::NAME);
        let input = Input {
            interface: T::NAME,
            provider: from,
            channel: &channel,
            bytes: &bytes,
        };
        self.service
            .on_input(&mut self.state.context(&mut self.backend), &input);
    }

    /// Sends a command of interface `T` (its CDR bytes) and returns the reply or refusal.
    pub fn command<T: Interface, C: lewis_interfaces::Command>(
        &mut self,
        command: &C,
    ) -> Result<Reply, String> {
        let bytes = cdr::to_vec(command);
        let incoming = IncomingCommand {
            interface: T::NAME,
            command: C::NAME,
            bytes: &bytes,
        };
        self.service
            .on_command(&mut self.state.context(&mut self.backend), &incoming)
            .map_err(|e| e.0)
    }

    /// Everything published on `T`, decoded, and forgotten.
    pub fn take<T: Interface>(&mut self) -> Vec<T> {
        let (mine, rest): (Vec<_>, Vec<_>) = std::mem::take(&mut self.backend.published)
            .into_iter()
            .partition(|(i, _)| i == T::NAME);
        self.backend.published = rest;
        mine.into_iter()
            .map(|(_, bytes)| cdr::from_bytes(&bytes).unwrap())
            .collect()
    }
}

/// A file of the shared data folder, or a clear failure when it is missing.
pub fn shared_data(relative: &str) -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(relative);
    assert!(
        path.exists(),
        "{} is missing: these tests need the project's shared data folder (/work/shared/data)",
        path.display()
    );
    path
}

/// A file of the repository.
pub fn repository(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(relative)
}
