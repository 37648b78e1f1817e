//! Calls between services in the harness: to another re-simulated service (taken up at
//! once, or when its recorded command log says), to a fed service (answered from the
//! recording), and the command log of every command a re-simulated service answered.

use lewis_interfaces::msg::{CommandLog, CommandLogStatus, Header};
use lewis_service::wire;
use lewis_service::{CallFailure, CallId, IncomingCommand};

use super::engine::{Timer, Work};
use super::{Emitted, Lockstep, Sink, default_reply};
use crate::fault::FaultKind;

/// Who waits for the answer of a command: the caller, its generation, its call and the
/// call's timeout.
pub(super) type ReplyTo = (String, u64, CallId, i64);

impl Lockstep<'_> {
    /// Carries out a call `caller` made (its frame is a [`wire`] request).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn call(
        &mut self,
        caller: &str,
        generation: u64,
        call: CallId,
        interface: &str,
        command: &'static str,
        frame: &[u8],
        timeout_ns: i64,
    ) {
        let reply = |result| Work::Reply {
            caller: caller.to_owned(),
            generation,
            call,
            interface: interface.to_owned(),
            command: command.to_owned(),
            result,
        };
        let request = match wire::read_request(frame) {
            Ok((_, message)) => message.to_vec(),
            Err(e) => {
                self.stats.calls_failed += 1;
                self.work
                    .push_back(reply(Err(CallFailure::Transport(e.to_string()))));
                return;
            }
        };
        let Some(provider) = self
            .bindings
            .get(&(caller.to_owned(), interface.to_owned()))
            .cloned()
        else {
            self.stats.calls_failed += 1;
            self.work.push_back(reply(Err(CallFailure::NoProvider {
                interface: interface.to_owned(),
            })));
            return;
        };
        if self.sims.contains_key(&provider) {
            self.stats.calls_between_resimulated += 1;
            let taken = self
                .script
                .call_time(&provider, caller, &request, self.now_ns);
            let running = self
                .sims
                .get(&provider)
                .is_some_and(|s| s.instance.is_some() || s.stalled);
            let work = Work::Command {
                target: provider,
                interface: interface.to_owned(),
                command: command.to_owned(),
                request,
                reply_to: Some((caller.to_owned(), generation, call, timeout_ns)),
            };
            match taken {
                Some(at) => {
                    self.stats.calls_at_recorded_time += 1;
                    self.schedule(at, Timer::Work(Box::new(work)));
                }
                None if running => self.work.push_back(work),
                None => {
                    // Its process is not up: live, the call finds no server.
                    self.stats.calls_failed += 1;
                    self.work.push_back(reply(Err(CallFailure::NoProvider {
                        interface: interface.to_owned(),
                    })));
                }
            }
            return;
        }
        if matches!(
            self.fault_of(&provider),
            Some(FaultKind::Stall | FaultKind::Crash | FaultKind::Stuck)
        ) {
            self.stats.calls_failed += 1;
            let at = self.now_ns.saturating_add(timeout_ns);
            self.schedule(
                at,
                Timer::Work(Box::new(reply(Err(CallFailure::Timeout { timeout_ns })))),
            );
            return;
        }
        let result = match self
            .book
            .take(&provider, interface, command, caller, self.now_ns)
        {
            Some(recorded) => {
                self.stats.calls_answered_from_log += 1;
                recorded.map_err(CallFailure::Refused)
            }
            None => {
                self.stats.calls_defaulted += 1;
                default_reply(interface, command).ok_or_else(|| {
                    CallFailure::Transport(format!(
                        "no recorded answer of {provider} to {interface}.{command}, and no such command to make a default reply for"
                    ))
                })
            }
        };
        self.work.push_back(reply(result));
    }

    /// A re-simulated service takes up a command; the answer goes to `reply_to`, and into
    /// its command log.
    pub(super) fn run_command(
        &mut self,
        target: &str,
        interface: &str,
        command: &str,
        request: Vec<u8>,
        reply_to: Option<ReplyTo>,
        sink: &mut dyn Sink,
    ) {
        let mut outcome = None;
        self.dispatch(target, Vec::new(), sink, |s, ctx| {
            let incoming = IncomingCommand {
                interface,
                command,
                bytes: &request,
            };
            outcome = Some(
                s.on_command(ctx, &incoming)
                    .map(|reply| reply.bytes().to_vec())
                    .map_err(|e| e.0),
            );
        });
        let Some(result) = outcome else {
            // The target did not run (stalled, stopped): the caller times out.
            if let Some((caller, generation, call, timeout_ns)) = reply_to {
                self.stats.calls_failed += 1;
                let at = self.now_ns.saturating_add(timeout_ns);
                self.schedule(
                    at,
                    Timer::Work(Box::new(Work::Reply {
                        caller,
                        generation,
                        call,
                        interface: interface.to_owned(),
                        command: command.to_owned(),
                        result: Err(CallFailure::Timeout { timeout_ns }),
                    })),
                );
            }
            return;
        };
        let seq = self.sims.get_mut(target).map_or(0, |s| {
            s.commands_answered += 1;
            s.commands_answered
        });
        let mut log = CommandLog {
            header: Header {
                provider: target.to_owned(),
                seq,
                publish_time_ns: self.now_ns,
                inputs: Vec::new(),
            },
            interface: interface.to_owned(),
            command: command.to_owned(),
            request,
            received_ns: self.now_ns,
            ..CommandLog::default()
        };
        match &result {
            Ok(reply) => {
                log.status = CommandLogStatus::Ok.into();
                log.reply.clone_from(reply);
            }
            Err(error) => {
                log.status = CommandLogStatus::Refused.into();
                log.error.clone_from(error);
            }
        }
        sink.emit(Emitted::Command {
            service: target,
            time_ns: self.now_ns,
            log: &log,
        });
        if let Some((caller, generation, call, _)) = reply_to {
            self.work.push_back(Work::Reply {
                caller,
                generation,
                call,
                interface: interface.to_owned(),
                command: command.to_owned(),
                result: result.map_err(CallFailure::Refused),
            });
        }
    }
}
