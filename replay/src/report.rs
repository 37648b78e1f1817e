//! The report of a replay: what was re-simulated, the faults and the broker's reactions to
//! them, the longest time a client went without data, and how far the re-simulated outputs
//! are from the recorded ones. `Display` gives the text for people, `Serialize` the JSON.
//! Times are from the start of the recording, in nanoseconds.

use std::fmt;

use lewis_interfaces::msg::BrokerAction;
use lewis_robot::Robot;
use lewis_runtime::broker::{Action, Decision};
use serde::Serialize;

use crate::compare::ChannelDivergence;
use crate::fault::{Fault, FaultKind, format_seconds};
use crate::lockstep::{Feed, Gap, HarnessStats};

/// At most this many reactions are listed per fault.
pub const MAX_REACTIONS: usize = 32;
/// At most this many takeovers are listed per fault.
pub const MAX_TAKEOVERS: usize = 32;
/// At most this many of the broker's failure decisions are listed.
pub const MAX_FAILURES: usize = 32;

/// The report of one replay.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// The recordings replayed.
    pub inputs: Vec<String>,
    /// The file written.
    pub output: String,
    /// The robot's name.
    pub robot: String,
    /// Where the robot description replayed comes from: `recorded`, or the file given with
    /// `--robot`.
    pub robot_description: String,
    /// The parameters changed with `--set` (or by `--robot`), as `service.parameter`.
    pub parameter_changes: Vec<ParameterChange>,
    /// The log time of the recording's first message (the origin of every other time).
    pub start_ns: i64,
    /// The recording's length.
    pub duration_ns: i64,
    /// The services run in the harness.
    pub resimulated: Vec<String>,
    /// Of those, the services that follow the recording (ticked when they ticked live, fed
    /// the inputs they had): those with recorded outputs and an unchanged tick rate.
    pub followed: Vec<String>,
    /// The services fed from the recording.
    pub fed: Vec<String>,
    /// Recorded messages read.
    pub messages_read: u64,
    /// Messages written (recorded copies and re-simulated outputs).
    pub messages_written: u64,
    /// Broker decisions taken in the replay.
    pub decisions: u64,
    /// The faults injected and what the broker did about them.
    pub faults: Vec<FaultReport>,
    /// Every provider the replay's broker failed or degraded, in order (at most
    /// [`MAX_FAILURES`]), faults or not: a failover that no fault explains shows here, with
    /// the check or deadline that made it.
    pub failures: Vec<Failure>,
    /// The longest time a re-simulated client went without data of an interface.
    pub longest_gap: Option<Gap>,
    /// What each re-simulated client received from each provider (times from the start).
    pub feeds: Vec<Feed>,
    /// Per output channel, how far the re-simulated outputs are from the recorded ones.
    pub divergence: Vec<ChannelDivergence>,
    /// What the harness did.
    pub harness: HarnessStats,
    /// The regression check.
    pub check: CheckOutcome,
    /// The mission: the recorded verdict and, in a closed loop, the replayed one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mission: Option<crate::outcome::MissionReport>,
}

/// A parameter of a re-simulated service that differs from the recorded robot description.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ParameterChange {
    /// `service.parameter` (`.key` for nested tables).
    pub parameter: String,
    /// The recorded value, as TOML (`None`: not given, the service's default).
    pub recorded: Option<String>,
    /// The value replayed, as TOML (`None`: removed, the service's default).
    pub replayed: Option<String>,
}

impl fmt::Display for ParameterChange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let show = |v: &Option<String>| v.clone().unwrap_or_else(|| "its default".to_owned());
        write!(
            f,
            "{} = {} (recorded: {})",
            self.parameter,
            show(&self.replayed),
            show(&self.recorded)
        )
    }
}

/// One injected fault and the broker's reactions.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FaultReport {
    /// The SPEC.
    pub spec: String,
    /// The provider that failed.
    pub provider: String,
    /// How.
    pub kind: FaultKind,
    /// When it started.
    pub at_ns: i64,
    /// When it ended, if it did.
    pub until_ns: Option<i64>,
    /// The broker's decisions about the provider while the fault lasted, in order.
    pub reactions: Vec<Reaction>,
    /// Clients moved to another provider.
    pub takeovers: Vec<Takeover>,
}

/// One decision of the broker after a fault.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Reaction {
    /// When.
    pub at_ns: i64,
    /// How long after the fault started.
    pub latency_ns: i64,
    /// What it decided.
    pub action: String,
    /// Why.
    pub reason: String,
}

/// A provider the replay's broker failed or degraded.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Failure {
    /// When, from the start of the recording.
    pub at_ns: i64,
    /// The provider.
    pub service: String,
    /// Failed for good, or degraded (still serving, moved from where it can be); its word
    /// on `/lewis/broker` in the JSON.
    #[serde(serialize_with = "action_word")]
    pub action: BrokerAction,
    /// Why, as the broker said it.
    pub reason: String,
}

// serde's `serialize_with` hands the field by reference.
#[allow(clippy::trivially_copy_pass_by_ref)]
fn action_word<S: serde::Serializer>(action: &BrokerAction, out: S) -> Result<S::Ok, S::Error> {
    out.serialize_str(action.as_str())
}

impl Failure {
    /// The failure a decision published on `/lewis/broker` says, if it is one (its time
    /// absolute, as decided).
    #[must_use]
    pub fn of(message: &lewis_interfaces::msg::Broker) -> Option<Self> {
        let action = BrokerAction::parse(&message.action).filter(|a| {
            matches!(
                a,
                BrokerAction::ServiceFailed | BrokerAction::ServiceDegraded
            )
        })?;
        Some(Self {
            at_ns: message.at_ns,
            service: message.service.clone(),
            action,
            reason: message.reason.clone(),
        })
    }
}

/// A client moved to another provider after a fault.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Takeover {
    /// The client.
    pub client: String,
    /// The interface.
    pub interface: String,
    /// The provider that took over.
    pub provider: String,
    /// When.
    pub at_ns: i64,
    /// How long after the fault started.
    pub latency_ns: i64,
}

/// What the check compared with the recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Compared {
    /// The re-simulated outputs (no mission lived again).
    Outputs,
    /// The mission lived again: its states in order and its outcome, not the outputs, which
    /// the closed loop moves by the noise of live timing.
    MissionOnly,
    /// The mission lived again, and the re-simulated outputs too (`--check-outputs`).
    MissionAndOutputs,
}

/// The outcome of the comparison with the recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CheckOutcome {
    /// What was compared.
    pub compared: Compared,
    /// The absolute tolerance on numbers.
    pub tolerance: f64,
    /// Whether everything compared matched: the mission's course and outcome, and every
    /// output channel compared within the tolerance.
    pub passed: bool,
    /// The output channels beyond the tolerance (none when the outputs were not compared).
    pub failing: Vec<String>,
    /// How the replayed mission went otherwise than the recorded one, if it did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mission: Option<String>,
}

impl CheckOutcome {
    /// The outcome for these divergences, the outputs alone compared.
    #[must_use]
    pub fn of(tolerance: f64, divergence: &[ChannelDivergence]) -> Self {
        let failing: Vec<String> = divergence
            .iter()
            .filter(|d| d.differing > 0)
            .map(|d| d.channel.clone())
            .collect();
        Self {
            compared: Compared::Outputs,
            tolerance,
            passed: failing.is_empty(),
            failing,
            mission: None,
        }
    }

    /// The outcome of a mission lived again: `course` is how its course and outcome
    /// compare with the recorded ones; the outputs count only when `with_outputs`.
    #[must_use]
    pub fn of_mission(self, course: Result<(), String>, with_outputs: bool) -> Self {
        let outputs = if with_outputs {
            self
        } else {
            Self {
                passed: true,
                failing: Vec::new(),
                ..self
            }
        };
        Self {
            compared: if with_outputs {
                Compared::MissionAndOutputs
            } else {
                Compared::MissionOnly
            },
            passed: outputs.passed && course.is_ok(),
            mission: course.err(),
            ..outputs
        }
    }

    /// The check's line of the report: what was compared, then how it went.
    fn line(&self) -> String {
        let outputs = if self.failing.is_empty() {
            format!(
                "outputs match the recording (tolerance {:e})",
                self.tolerance
            )
        } else {
            format!(
                "outputs differ from the recording beyond {:e} on {}",
                self.tolerance,
                self.failing.join(", ")
            )
        };
        let mission = self.mission.clone().unwrap_or_else(|| {
            "the mission went as recorded (the same states in the same order, the same \
             outcome)"
                .to_owned()
        });
        match self.compared {
            // The line `lewis replay --check` has always printed: the outputs are all there is.
            Compared::Outputs => format!("check: {outputs}"),
            Compared::MissionOnly => format!(
                "check (the mission's states and outcome only; --check-outputs compares the \
                 outputs too): {mission}"
            ),
            Compared::MissionAndOutputs => format!(
                "check (the mission's states and outcome, and the outputs): {mission}; {outputs}"
            ),
        }
    }
}

/// Watches the broker's decisions for the reactions to one fault, as they are taken (so
/// that nothing grows with the recording's length: at most [`MAX_REACTIONS`] reactions and
/// [`MAX_TAKEOVERS`] takeovers are kept).
#[derive(Debug, Clone)]
pub struct FaultWatch {
    fault: Fault,
    /// The services the fault strikes: its provider, or every service of a host lost.
    providers: Vec<String>,
    reactions: Vec<Reaction>,
    takeovers: Vec<Takeover>,
    /// Clients unbound from the faulty provider and not yet bound again.
    unbound: Vec<(String, String)>,
}

impl FaultWatch {
    /// Starts watching for the reactions to `fault` on `robot`.
    #[must_use]
    pub fn new(fault: Fault, robot: &Robot) -> Self {
        let providers = if fault.kind == FaultKind::HostLost {
            robot
                .services_on(&fault.provider)
                .map(|s| s.name.clone())
                .collect()
        } else {
            vec![fault.provider.clone()]
        };
        Self {
            fault,
            providers,
            reactions: Vec::new(),
            takeovers: Vec::new(),
            unbound: Vec::new(),
        }
    }

    /// A decision of the broker, in the order they are taken.
    pub fn decision(&mut self, decision: &Decision) {
        let fault = &self.fault;
        if decision.at_ns < fault.at_ns || fault.until_ns.is_some_and(|end| decision.at_ns >= end) {
            return;
        }
        let struck = |service: &str| self.providers.iter().any(|p| p == service);
        let mut took_over = None;
        let concerns = match &decision.action {
            Action::Start { service }
            | Action::Stop { service }
            | Action::RestartScheduled { service, .. }
            | Action::ServiceFailed { service }
            | Action::ServiceDegraded { service }
            | Action::ServiceWaiting { service, .. }
            | Action::ServiceResumed { service } => struck(service),
            Action::Rebind {
                client,
                interface,
                from,
                to,
            } => {
                if struck(from) {
                    took_over = Some((client, interface, to));
                }
                struck(from)
            }
            Action::Unbind {
                client,
                interface,
                service,
            } => {
                let struck = struck(service);
                if struck && self.unbound.len() < MAX_TAKEOVERS {
                    self.unbound.push((client.clone(), interface.clone()));
                }
                struck
            }
            Action::Bind {
                client,
                interface,
                service,
            } => {
                let back = self
                    .unbound
                    .iter()
                    .position(|(c, i)| c == client && i == interface);
                if let Some(i) = back
                    && !struck(service)
                {
                    self.unbound.remove(i);
                    took_over = Some((client, interface, service));
                    true
                } else {
                    false
                }
            }
            Action::AskForHelp { .. } => true,
            Action::Reject { .. } => false,
        };
        if let Some((client, interface, to)) = took_over
            && self.takeovers.len() < MAX_TAKEOVERS
        {
            self.takeovers.push(Takeover {
                client: client.clone(),
                interface: interface.clone(),
                provider: to.clone(),
                at_ns: decision.at_ns,
                latency_ns: decision.at_ns - fault.at_ns,
            });
        }
        if concerns && self.reactions.len() < MAX_REACTIONS {
            self.reactions.push(Reaction {
                at_ns: decision.at_ns,
                latency_ns: decision.at_ns - fault.at_ns,
                action: decision.action.to_string(),
                reason: decision.reason.clone(),
            });
        }
    }

    /// The report of the fault, times relative to `start_ns`.
    #[must_use]
    pub fn report(self, start_ns: i64) -> FaultReport {
        let Self {
            fault,
            mut reactions,
            mut takeovers,
            ..
        } = self;
        for r in &mut reactions {
            r.at_ns -= start_ns;
        }
        for t in &mut takeovers {
            t.at_ns -= start_ns;
        }
        FaultReport {
            spec: fault.spec,
            provider: fault.provider,
            kind: fault.kind,
            at_ns: fault.at_ns - start_ns,
            until_ns: fault.until_ns.map(|u| u - start_ns),
            reactions,
            takeovers,
        }
    }
}

fn ms(ns: i64) -> String {
    // For display only.
    let ms = ns as f64 / 1e6;
    format!("{ms:.1} ms")
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "replayed {} ({}, robot {}) into {}",
            self.inputs.join(", "),
            format_seconds(self.duration_ns),
            self.robot,
            self.output
        )?;
        if self.robot_description != "recorded" {
            writeln!(
                f,
                "robot description: {} (instead of the recorded one)",
                self.robot_description
            )?;
        }
        for change in &self.parameter_changes {
            writeln!(f, "changed: {change}")?;
        }
        writeln!(f, "re-simulated: {}", list(&self.resimulated))?;
        writeln!(
            f,
            "following the recording (ticked when they ticked live, fed what they had): {}",
            list(&self.followed)
        )?;
        writeln!(f, "fed from the recording: {}", list(&self.fed))?;
        writeln!(
            f,
            "messages: {} read, {} written; {} broker decisions; {} inputs delivered, {} ticks",
            self.messages_read,
            self.messages_written,
            self.decisions,
            self.harness.inputs_delivered,
            self.harness.ticks
        )?;
        let h = &self.harness;
        if h.inputs_after_stop > 0 {
            writeln!(
                f,
                "not delivered: {} inputs recorded after their client had stopped live",
                h.inputs_after_stop
            )?;
        }
        if h.calls_between_resimulated
            + h.calls_answered_from_log
            + h.calls_defaulted
            + h.calls_failed
            > 0
        {
            writeln!(
                f,
                "calls: {} between re-simulated services, {} answered from the recording, {} answered with a default reply (not in the recording), {} failed",
                h.calls_between_resimulated,
                h.calls_answered_from_log,
                h.calls_defaulted,
                h.calls_failed
            )?;
        }
        if h.external_commands_fed > 0 {
            writeln!(
                f,
                "commands from outside fed again: {}",
                h.external_commands_fed
            )?;
        }
        for fault in &self.faults {
            let window = fault
                .until_ns
                .map(|u| format!(" until {}", format_seconds(u)))
                .unwrap_or_default();
            writeln!(
                f,
                "fault {}: {} {} at {}{window}",
                fault.spec,
                fault.provider,
                fault.kind,
                format_seconds(fault.at_ns)
            )?;
            if fault.reactions.is_empty() {
                writeln!(f, "  the broker did not react")?;
            }
            for r in &fault.reactions {
                writeln!(f, "  +{}: {} ({})", ms(r.latency_ns), r.action, r.reason)?;
            }
            for t in &fault.takeovers {
                writeln!(
                    f,
                    "  {} took over {} for {} after {}",
                    t.provider,
                    t.interface,
                    t.client,
                    ms(t.latency_ns)
                )?;
            }
        }
        for failure in &self.failures {
            writeln!(
                f,
                "broker: {} {} at {}: {}",
                failure.service,
                if failure.action == BrokerAction::ServiceDegraded {
                    "degraded"
                } else {
                    "failed"
                },
                format_seconds(failure.at_ns),
                failure.reason
            )?;
        }
        for feed in &self.feeds {
            writeln!(
                f,
                "input: {} got {} from {}: {} samples, {} to {}",
                feed.client,
                feed.interface,
                feed.provider,
                feed.samples,
                format_seconds(feed.first_ns),
                format_seconds(feed.last_ns)
            )?;
        }
        if let Some(gap) = &self.longest_gap {
            writeln!(
                f,
                "longest gap: {} had no {} for {} (from {} to {})",
                gap.client,
                gap.interface,
                ms(gap.gap_ns),
                format_seconds(gap.from_ns),
                format_seconds(gap.to_ns)
            )?;
        }
        if self.divergence.is_empty() {
            writeln!(f, "no output channel to compare")?;
        }
        for d in &self.divergence {
            write_divergence(f, d)?;
        }
        if let Some(mission) = &self.mission {
            write!(f, "{mission}")?;
        }
        write!(f, "{}", self.check.line())
    }
}

/// One output channel's divergence: a line, and what the re-simulated messages used.
fn write_divergence(f: &mut fmt::Formatter<'_>, d: &ChannelDivergence) -> fmt::Result {
    let first = d
        .first_divergence_ns
        .map(|t| format!(", first at {}", format_seconds(t)))
        .unwrap_or_default();
    let field = d
        .max_difference_field
        .as_ref()
        .map(|field| format!(" (in {field})"))
        .unwrap_or_default();
    writeln!(
        f,
        "{}: {} recorded, {} re-simulated, {} differ{first}, max difference {:.6}{field}",
        d.channel, d.recorded, d.resimulated, d.differing, d.max_numeric_difference
    )?;
    if !d.resimulated_inputs.is_empty() {
        let inputs: Vec<String> = d
            .resimulated_inputs
            .iter()
            .map(|i| {
                format!(
                    "{} ({} from {} to {})",
                    i.channel,
                    i.messages,
                    format_seconds(i.first_ns),
                    format_seconds(i.last_ns)
                )
            })
            .collect();
        writeln!(f, "  re-simulated from: {}", inputs.join(", "))?;
    }
    Ok(())
}

fn list(names: &[String]) -> String {
    if names.is_empty() {
        "none".to_owned()
    } else {
        names.join(", ")
    }
}
