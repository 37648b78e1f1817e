//! The [`Backend`] of the lockstep harness: the virtual clock, and an outbox of what the
//! service did while it handled one event (the harness carries it out once the handler has
//! returned, so every service runs to completion before anything it caused happens).

use std::collections::{BTreeMap, BTreeSet};

use lewis_service::Health;
use lewis_service::{Backend, CallFailure, CallId, ContextError, Level};

/// Something a service did while handling an event.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Effect {
    /// It published a message of `interface`.
    Publish { interface: String, bytes: Vec<u8> },
    /// It called `interface.command` (the frame is a [`lewis_service::wire`] request).
    Call {
        call: CallId,
        interface: String,
        command: &'static str,
        frame: Vec<u8>,
        timeout_ns: i64,
    },
    /// It declared a new health.
    Health(Health),
    /// It wrote a log line.
    Log { level: Level, text: String },
}

/// One re-simulated service's backend.
#[derive(Debug, Clone)]
pub(crate) struct StepBackend {
    pub(crate) now_ns: i64,
    service: String,
    provides: BTreeSet<String>,
    requires: BTreeSet<String>,
    /// The service's current providers, by interface (set by the harness before each event).
    pub(crate) bound: BTreeMap<String, String>,
    pub(crate) effects: Vec<Effect>,
}

impl StepBackend {
    pub(crate) fn new(
        service: &str,
        provides: impl IntoIterator<Item = String>,
        requires: impl IntoIterator<Item = String>,
    ) -> Self {
        Self {
            now_ns: 0,
            service: service.to_owned(),
            provides: provides.into_iter().collect(),
            requires: requires.into_iter().collect(),
            bound: BTreeMap::new(),
            effects: Vec::new(),
        }
    }
}

impl Backend for StepBackend {
    fn now_ns(&self) -> i64 {
        self.now_ns
    }

    fn publish(
        &mut self,
        interface: &str,
        len_bytes: usize,
        encode: &mut dyn FnMut(&mut [u8]),
    ) -> Result<(), ContextError> {
        if !self.provides.contains(interface) {
            return Err(ContextError::NotProvided {
                service: self.service.clone(),
                interface: interface.to_owned(),
            });
        }
        let mut bytes = vec![0; len_bytes];
        encode(&mut bytes);
        self.effects.push(Effect::Publish {
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
        timeout_ns: i64,
    ) -> Result<(), CallFailure> {
        if !self.requires.contains(interface) {
            return Err(CallFailure::NotRequired {
                interface: interface.to_owned(),
            });
        }
        if !self.bound.contains_key(interface) {
            return Err(CallFailure::NoProvider {
                interface: interface.to_owned(),
            });
        }
        self.effects.push(Effect::Call {
            call,
            interface: interface.to_owned(),
            command,
            frame: frame.to_vec(),
            timeout_ns,
        });
        Ok(())
    }

    fn health_changed(&mut self, health: &Health) {
        self.effects.push(Effect::Health(health.clone()));
    }

    fn log(&mut self, _service: &str, level: Level, text: &str) {
        self.effects.push(Effect::Log {
            level,
            text: text.to_owned(),
        });
    }
}
