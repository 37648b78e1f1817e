//! Injected faults as the harness carries them out: which provider is faulty now, what
//! becomes of its publications, and what starts and ends.

use std::borrow::Cow;

use lewis_runtime::broker::{Event, ExitStatus};
use lewis_service::Health;
use lewis_service::fault::{frozen_payload, garbled_payload};

use super::engine::Work;
use super::{Emitted, Lockstep, Sink};
use crate::fault::FaultKind;

/// SIGABRT: how an injected crash ends a process.
pub(super) const SIGABRT: i32 = 6;

impl Lockstep<'_> {
    /// The kind of the fault `provider` suffers now, if any: its own, or its host's loss.
    pub(super) fn fault_of(&self, provider: &str) -> Option<FaultKind> {
        let host = self.robot.host_of(provider);
        self.faults
            .iter()
            .find(|f| {
                f.active_at(self.now_ns)
                    && (f.provider == provider
                        || (f.kind == FaultKind::HostLost && Some(f.provider.as_str()) == host))
            })
            .map(|f| f.kind)
    }

    /// The bytes a provider's publication on `interface` has after the faults: `None` when
    /// it is lost.
    pub(super) fn through_faults<'b>(
        &mut self,
        provider: &str,
        interface: &str,
        seq: u64,
        bytes: &'b [u8],
    ) -> Option<Cow<'b, [u8]>> {
        let key = (provider.to_owned(), interface.to_owned());
        match self.fault_of(provider) {
            None => {
                // Kept only for a provider a frozen fault is injected into.
                if self
                    .faults
                    .iter()
                    .any(|f| f.provider == provider && f.kind == FaultKind::Frozen)
                {
                    self.last_good.insert(key, bytes.to_vec());
                }
                Some(Cow::Borrowed(bytes))
            }
            Some(FaultKind::Garbage) => {
                self.stats.faulted_publications += 1;
                Some(Cow::Owned(garbled_payload(provider, seq, bytes.len())))
            }
            Some(FaultKind::Frozen) => {
                self.stats.faulted_publications += 1;
                let Some(last) = self.last_good.get(&key) else {
                    // Nothing good was published before: the first sample is the one repeated.
                    self.last_good.insert(key, bytes.to_vec());
                    return Some(Cow::Borrowed(bytes));
                };
                Some(Cow::Owned(frozen_payload(last, bytes)))
            }
            Some(FaultKind::Slow) => {
                if seq.is_multiple_of(3) {
                    Some(Cow::Borrowed(bytes))
                } else {
                    self.stats.faulted_publications += 1;
                    None
                }
            }
            Some(
                FaultKind::Stall
                | FaultKind::Crash
                | FaultKind::OutOfService
                | FaultKind::Stuck
                | FaultKind::HostLost,
            ) => {
                self.stats.faulted_publications += 1;
                None
            } // Not replay's kinds (the fault file's of `test-range`): a SPEC never names them.
            Some(FaultKind::Nan | FaultKind::Degraded) => Some(Cow::Borrowed(bytes)),
        }
    }

    pub(super) fn fault_starts(&mut self, i: usize, sink: &mut dyn Sink) {
        let fault = self.faults[i].clone();
        sink.emit(Emitted::Fault {
            fault: &fault,
            time_ns: self.now_ns,
            starts: true,
        });
        let provider = fault.provider.clone();
        match fault.kind {
            // Between a death and its restart: the restarted process is the one struck.
            FaultKind::Crash | FaultKind::Stuck if self.core.restart_pending(&provider) => {
                self.strikes
                    .entry(provider)
                    .or_default()
                    .push_back(fault.kind);
            }
            FaultKind::Crash => {
                if let Some(sim) = self.sims.get_mut(&provider) {
                    if sim.instance.take().is_none() {
                        return;
                    }
                    sim.generation += 1;
                }
                self.work.push_back(Work::Broker(Event::ProcessExited {
                    service: provider,
                    status: ExitStatus::Signal(SIGABRT),
                }));
            }
            FaultKind::Stuck => {
                self.stick(&provider, &format!("its loop stuck (fault {})", fault.spec));
            }
            FaultKind::Stall => {
                if let Some(sim) = self.sims.get_mut(&provider) {
                    sim.stalled = true;
                }
            }
            FaultKind::OutOfService => {
                self.work.push_back(Work::Broker(Event::Heartbeat {
                    service: provider,
                    health: injected_out_of_service(),
                }));
            }
            FaultKind::HostLost => {
                self.work.push_back(Work::Broker(Event::HostLost {
                    host: provider,
                    why: format!("injected fault {}", fault.spec),
                }));
            }
            // Nan and Degraded are not replay's kinds: a SPEC never names them.
            FaultKind::Garbage
            | FaultKind::Frozen
            | FaultKind::Slow
            | FaultKind::Nan
            | FaultKind::Degraded => {}
        }
    }

    /// `service`'s event loop sticks: its heartbeat thread says so, then it is silent until
    /// its process is stopped.
    pub(super) fn stick(&mut self, service: &str, why: &str) {
        if let Some(sim) = self.sims.get_mut(service) {
            sim.stalled = true;
        }
        self.work.push_back(Work::Broker(Event::LoopStuck {
            service: service.to_owned(),
            why: why.to_owned(),
        }));
    }

    pub(super) fn fault_ends(&mut self, i: usize, sink: &mut dyn Sink) {
        let fault = self.faults[i].clone();
        sink.emit(Emitted::Fault {
            fault: &fault,
            time_ns: self.now_ns,
            starts: false,
        });
        match fault.kind {
            FaultKind::Stall => {
                if let Some(sim) = self.sims.get_mut(&fault.provider) {
                    sim.stalled = false;
                }
            }
            FaultKind::OutOfService => {
                let health = self
                    .sims
                    .get(&fault.provider)
                    .map_or(Health::Ok, |s| s.state.health().clone());
                self.work.push_back(Work::Broker(Event::Heartbeat {
                    service: fault.provider,
                    health,
                }));
            }
            FaultKind::HostLost => {
                self.work.push_back(Work::Broker(Event::HostJoined {
                    host: fault.provider,
                }));
            }
            // A stuck process stays stuck until the broker stops it.
            FaultKind::Crash
            | FaultKind::Stuck
            | FaultKind::Garbage
            | FaultKind::Frozen
            | FaultKind::Slow
            | FaultKind::Nan
            | FaultKind::Degraded => {}
        }
    }

    /// `host` is lost: its services' processes are out of reach. The broker sends them no
    /// stop (their host stops them itself), so they end here without an exit.
    pub(super) fn host_lost(&mut self, host: &str) {
        for (name, sim) in &mut self.sims {
            if self.robot.host_of(name) == Some(host) && sim.instance.take().is_some() {
                sim.stalled = false;
                sim.generation += 1;
                sim.held.clear();
            }
        }
    }
}

/// The health an out-of-service fault declares.
pub(super) fn injected_out_of_service() -> Health {
    Health::OutOfService("injected fault: out-of-service".to_owned())
}
