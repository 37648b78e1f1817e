//! Faults injected into a running service from outside (`lewis fault`), for demonstrations
//! and tests, with no cooperation from the service's code.
//!
//! Every live service's harness serves the command channel `/lewis/fault/<service>` (see
//! [`fault_channel`]). A request is a [`wire`] frame whose command name is the fault's word
//! ([`LIVE_FAULTS`] of the one fault vocabulary, [`lewis_service::fault`]) and whose message
//! is empty; the harness answers with an empty reply once the fault is in effect:
//!
//! | fault | what the harness does |
//! |---|---|
//! | `stall` | it stops running the service: no ticks, inputs, commands, publications or heartbeats (the broker sees a missed heartbeat deadline, as for a service stuck in a handler); it still ends on SIGTERM and still hears `clear` |
//! | `out-of-service` | it drops the service's publications and declares the service out of service in every heartbeat, whatever the service itself declares; the service keeps running |
//! | `frozen` | it publishes the first payload the service publishes after the fault again and again, each time with the new sample's header (as a stuck device's driver does); heartbeats as usual |
//! | `garbage` | it publishes bytes that do not decode in place of each sample, of the sample's length; heartbeats as usual |
//! | `clear` | back to normal: publications flow, heartbeats say what the service declares |
//!
//! `frozen` and `garbage` publish the bytes replay's faults of the same names make
//! ([`lewis_service::fault::frozen_payload`], [`lewis_service::fault::garbled_payload`]),
//! so that the data checks see the same thing live and in a replay.
//!
//! A crash needs no cooperation: `lewis fault NAME --kill` sends SIGKILL to the process.
//!
//! The same three words are the fault kinds that replay can inject into a recording, so
//! that a fault seen live and one injected in replay mean the same thing to the broker.

use std::time::Duration;

use crate::ipc::{CallError, CommandClient, CommandConfig, Ipc, IpcError, WakeMode};
use crate::names;
pub use lewis_service::fault::{LIVE_FAULTS, ServiceFault};
use lewis_service::wire;

/// A fault the live harness can put its service in ([`ServiceFault::Stall`],
/// [`ServiceFault::OutOfService`], [`ServiceFault::Frozen`] or [`ServiceFault::Garbage`]),
/// or `None` to clear any; its word is
/// [`LIVE_FAULTS`]`.word(fault)`.
pub type InjectedFault = Option<ServiceFault>;

/// The command channel on which the harness of `service` takes injected faults.
#[must_use]
pub fn fault_channel(service: &str) -> String {
    format!("/lewis/fault/{service}")
}

/// The settings of fault channels: one tool at a time sends, rarely.
#[must_use]
pub fn fault_config() -> CommandConfig {
    CommandConfig {
        max_pending: 2,
        max_clients: 8,
        ..names::command_config()
    }
}

/// Why a fault could not be injected.
#[derive(Debug, thiserror::Error)]
pub enum InjectError {
    /// The channel could not be opened.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// Nobody serves the fault channel: the service does not run now.
    #[error(
        "service `{service}` does not run in this namespace now (nobody serves {channel}): check `lewis status`"
    )]
    NotRunning {
        /// The service.
        service: String,
        /// The channel.
        channel: String,
    },
    /// The harness did not answer (it may be stalled already) or refused.
    #[error("service `{service}` did not take fault `{}`: {reason}", LIVE_FAULTS.word(*fault))]
    Failed {
        /// The service.
        service: String,
        /// The fault.
        fault: InjectedFault,
        /// Why.
        reason: String,
    },
}

/// Puts `service` (running in `ipc`'s namespace) in `fault`, waiting at most `timeout` for
/// its harness to say the fault is in effect.
///
/// # Errors
/// When the service does not run, does not answer in time, or refuses.
pub fn inject(
    ipc: &Ipc,
    service: &str,
    fault: InjectedFault,
    timeout: Duration,
) -> Result<(), InjectError> {
    let channel = fault_channel(service);
    let mut client: CommandClient = ipc.command_client(&channel, &fault_config())?;
    let frame = wire::request_to_vec(LIVE_FAULTS.word(fault), &[]);
    let failed = |reason: String| InjectError::Failed {
        service: service.to_owned(),
        fault,
        reason,
    };
    let reply = client
        .call_blocking(
            frame.len(),
            timeout,
            |buf| buf.copy_from_slice(&frame),
            WakeMode::Event,
        )
        .map_err(|e| match e {
            CallError::NoServer { .. } => InjectError::NotRunning {
                service: service.to_owned(),
                channel: channel.clone(),
            },
            e => failed(e.to_string()),
        })?;
    match wire::read_reply(reply.bytes()) {
        Ok(Ok(_)) => Ok(()),
        Ok(Err(refusal)) => Err(failed(refusal)),
        Err(e) => Err(failed(e.to_string())),
    }
}

/// Why a service's process could not be killed.
#[derive(Debug, thiserror::Error)]
pub enum KillError {
    /// The broker's command channel could not be opened.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// No broker answers in the namespace.
    #[error("no broker runs in namespace `{namespace}`: start one with `lewis up`")]
    NoBroker {
        /// The namespace.
        namespace: String,
    },
    /// The broker did not give its status.
    #[error("the broker did not give its status: {0}")]
    Status(#[source] crate::client::ClientError),
    /// The broker knows no process of the service.
    #[error(
        "service `{service}` has no running process in namespace `{namespace}` (running: {})",
        if running.is_empty() { "none".to_owned() } else { running.join(", ") }
    )]
    NotRunning {
        /// The service.
        service: String,
        /// The namespace.
        namespace: String,
        /// The services that run a process.
        running: Vec<String>,
    },
    /// The signal could not be sent.
    #[error("cannot send SIGKILL to {service} (pid {pid}): {errno}")]
    Signal {
        /// The service.
        service: String,
        /// Its process.
        pid: i32,
        /// What the system said.
        errno: nix::errno::Errno,
    },
}

/// Kills `service`'s process (SIGKILL: a crash, which the broker handles within its
/// policy), found in the status of the broker of `ipc`'s namespace. Returns the pid.
///
/// # Errors
/// When no broker answers, the service runs no process, or the signal cannot be sent.
pub fn kill(ipc: &Ipc, service: &str, timeout: Duration) -> Result<i32, KillError> {
    let namespace = ipc.namespace().to_string();
    let mut broker = ipc.command_client(names::BROKER_COMMAND, &names::broker_command_config())?;
    let status = match crate::client::call_blocking(
        &mut broker,
        &lewis_interfaces::msg::BrokerStatus::default(),
        timeout,
    ) {
        Ok(reply) => reply,
        Err(crate::client::ClientError::Call(CallError::NoServer { .. })) => {
            return Err(KillError::NoBroker { namespace });
        }
        Err(e) => return Err(KillError::Status(e)),
    };
    let Some(pid) = crate::broker::status::pid_of(&status, service) else {
        return Err(KillError::NotRunning {
            service: service.to_owned(),
            namespace,
            running: status
                .services
                .iter()
                .filter(|s| s.pid > 0)
                .map(|s| s.name.clone())
                .collect(),
        });
    };
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(pid),
        nix::sys::signal::Signal::SIGKILL,
    )
    .map_err(|errno| KillError::Signal {
        service: service.to_owned(),
        pid,
        errno,
    })?;
    Ok(pid)
}

/// What the harness holds the service in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) enum FaultState {
    /// No injected fault.
    #[default]
    Normal,
    /// Out of service: publications dropped, heartbeats say so.
    OutOfService,
    /// Stalled: nothing runs.
    Stalled,
    /// Frozen: the first payload after the fault, again and again.
    Frozen,
    /// Garbage: bytes that do not decode.
    Garbage,
}

impl FaultState {
    /// The state after `fault`.
    pub(crate) const fn after(fault: InjectedFault) -> Self {
        match fault {
            Some(ServiceFault::Stall) => Self::Stalled,
            Some(ServiceFault::OutOfService) => Self::OutOfService,
            Some(ServiceFault::Frozen) => Self::Frozen,
            Some(ServiceFault::Garbage) => Self::Garbage,
            // `clear`; the harness takes no other word ([`read_request`]).
            _ => Self::Normal,
        }
    }
}

/// The reason heartbeats give while a fault is injected.
pub(crate) const OUT_OF_SERVICE_REASON: &str = "fault injected with `lewis fault`";

/// Reads a fault request frame.
pub(crate) fn read_request(frame: &[u8]) -> Result<InjectedFault, String> {
    let (command, _) = wire::read_request(frame).map_err(|e| e.to_string())?;
    LIVE_FAULTS.parse(command).map_err(|e| e.to_string())
}

impl super::Harness<'_> {
    /// Takes in the faults sent since the last call and answers them; returns whether the
    /// service is stalled now.
    pub(super) fn serve_faults(&mut self) -> bool {
        while let Ok(Some(request)) = self.faults.receive() {
            let answer = read_request(request.bytes()).map(|fault| {
                self.apply(fault);
                Vec::new()
            });
            if let Err(e) = self.faults.reply(request, &wire::reply_to_vec(&answer)) {
                tracing::warn!(service = self.backend.service, "cannot answer a fault: {e}");
            }
        }
        self.backend.fault == FaultState::Stalled
    }

    fn apply(&mut self, fault: InjectedFault) {
        let before = self.backend.fault;
        self.backend.fault = FaultState::after(fault);
        // A new freeze repeats what the service publishes next, not what an earlier one
        // repeated.
        self.backend.frozen.clear();
        tracing::warn!(
            service = self.backend.service,
            "fault injected: {} ({OUT_OF_SERVICE_REASON})",
            LIVE_FAULTS.word(fault)
        );
        // The broker hears a change of declared health at once, as with set_health; a
        // stall stops the heartbeats.
        if self.backend.fault != before {
            self.backend.watch.fault(self.backend.fault);
        }
    }

    /// Waits, stalled, for a stop signal or another fault.
    pub(super) fn wait_stalled(
        &self,
        signals: &super::StopSignals,
    ) -> Result<(), super::LiveError> {
        let signal_fd = crate::ipc::FdSource::new(std::os::fd::AsFd::as_fd(signals));
        let sources: [&dyn crate::ipc::Waitable; 2] = [&signal_fd, &self.faults];
        self.waits.wait(&sources, None)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faults_round_trip_through_their_words_and_unknown_words_are_refused() {
        for &fault in LIVE_FAULTS.faults {
            let frame = wire::request_to_vec(LIVE_FAULTS.word(fault), &[]);
            assert_eq!(read_request(&frame), Ok(fault));
        }
        assert_eq!(
            read_request(&wire::request_to_vec("explode", &[])),
            Err(
                "unknown fault `explode`: expected stall, out-of-service, frozen, garbage or clear"
                    .to_owned()
            )
        );
        assert_eq!(
            read_request(&wire::request_to_vec("clera", &[])),
            Err("unknown fault `clera`: expected stall, out-of-service, frozen, garbage or clear; did you mean `clear`?".to_owned())
        );
    }

    #[test]
    fn each_fault_leads_to_its_state() {
        assert_eq!(
            FaultState::after(Some(ServiceFault::Stall)),
            FaultState::Stalled
        );
        assert_eq!(
            FaultState::after(Some(ServiceFault::OutOfService)),
            FaultState::OutOfService
        );
        assert_eq!(
            FaultState::after(Some(ServiceFault::Frozen)),
            FaultState::Frozen
        );
        assert_eq!(
            FaultState::after(Some(ServiceFault::Garbage)),
            FaultState::Garbage
        );
        assert_eq!(FaultState::after(None), FaultState::Normal);
        assert_eq!(fault_channel("laser"), "/lewis/fault/laser");
    }
}
