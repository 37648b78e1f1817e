//! Text logs and state lanes: broker decisions, bindings, health, services' output lines,
//! commands and the Mover's status, each under its [`Side`] (recorded or re-simulated).

use std::collections::BTreeMap;

use lewis_interfaces::dynamic::Value;
use lewis_interfaces::msg::{
    Broker, BrokerAction, CommandLog, CommandLogStatus, Health, HealthState, LogLine, LogLineLevel,
    Mover, MoverStatus,
};
use rerun::TextLog;

use super::lanes::{FAILED, RESTARTING, STARTED, STOPPED, UNBOUND};
use super::{Side, topic_entity};
use crate::ViewError;
use crate::rows::{ChunkSink, Rows, Stamp};

/// Generic messages are shown with at most this many items of each array.
const MAX_ITEMS_SHOWN: usize = 8;

/// What was last shown, so that heartbeats and repeated statuses log only their changes.
#[derive(Debug, Default)]
pub(super) struct EventState {
    health: BTreeMap<(Side, String), (String, String)>,
    mover_status: BTreeMap<(Side, String), String>,
}

impl EventState {
    /// A heartbeat: logged only when the declared health changes.
    pub(super) fn health(
        &mut self,
        rows: &mut Rows,
        sink: &mut dyn ChunkSink,
        side: Side,
        stamp: Stamp,
        health: &Health,
    ) -> Result<(), ViewError> {
        let service = health.header.provider.clone();
        let now = (health.state.clone(), health.reason.clone());
        let key = (side, service.clone());
        if self.health.get(&key) == Some(&now) {
            return Ok(());
        }
        self.health.insert(key, now);
        rows.lane(
            sink,
            &side.entity("status", &["health", &service]),
            stamp,
            &health.state,
        )?;
        let level = match HealthState::parse(&health.state) {
            Some(HealthState::Ok) => "INFO",
            Some(HealthState::Degraded) => "WARN",
            Some(HealthState::OutOfService | HealthState::Stalled) | None => "ERROR",
        };
        let reason = if health.reason.is_empty() {
            String::new()
        } else {
            format!(": {}", health.reason)
        };
        rows.log(
            sink,
            &side.entity("events", &["health"]),
            stamp,
            &TextLog::new(format!("{service} is {}{reason}", health.state)).with_level(level),
            128,
        )
    }

    /// The Mover's status, when it changes.
    pub(super) fn mover(
        &mut self,
        rows: &mut Rows,
        sink: &mut dyn ChunkSink,
        side: Side,
        topic: &str,
        stamp: Stamp,
        mover: &Mover,
    ) -> Result<(), ViewError> {
        let shown = format!("{} goal {}", mover.status, mover.goal_id);
        let key = (side, topic.to_owned());
        if self.mover_status.get(&key) == Some(&shown) {
            return Ok(());
        }
        self.mover_status.insert(key, shown);
        rows.lane(
            sink,
            &side.topic_entity("status", &["mover"], topic),
            stamp,
            &mover.status,
        )?;
        let level = match MoverStatus::parse(&mover.status) {
            Some(MoverStatus::Blocked) => "WARN",
            Some(MoverStatus::Failed) => "ERROR",
            _ => "INFO",
        };
        rows.log(
            sink,
            &side.topic_entity("events", &["mover"], topic),
            stamp,
            &TextLog::new(format!(
                "{} goal {} at ({:.2}, {:.2}), {:.2} m to go",
                mover.status, mover.goal_id, mover.goal.x, mover.goal.y, mover.distance_to_goal
            ))
            .with_level(level),
            128,
        )
    }
}

/// A broker decision: a text line, and the binding or service state lanes it changes.
pub(super) fn broker(
    rows: &mut Rows,
    sink: &mut dyn ChunkSink,
    side: Side,
    stamp: Stamp,
    d: &Broker,
) -> Result<(), ViewError> {
    let (text, level) = broker_line(d);
    rows.log(
        sink,
        &side.entity("events", &["broker"]),
        stamp,
        &TextLog::new(text).with_level(level),
        128,
    )?;
    let action = BrokerAction::parse(&d.action);
    let binding = match action {
        Some(BrokerAction::Bind) => Some(d.service.clone()),
        Some(BrokerAction::Rebind) => Some(d.to_service.clone()),
        Some(BrokerAction::Unbind) => Some(UNBOUND.to_owned()),
        _ => None,
    };
    if let Some(service) = binding
        && !d.client.is_empty()
        && !d.interface.is_empty()
    {
        rows.lane(
            sink,
            &side.entity("status", &["bindings", &d.client, &d.interface]),
            stamp,
            &service,
        )?;
    }
    // The viewer's own words for a service's state: the IDL has none (the broker's
    // status reply is text for people).
    let service_state = match action {
        Some(BrokerAction::Start) => Some(STARTED),
        Some(BrokerAction::Stop) => Some(STOPPED),
        Some(BrokerAction::ServiceFailed) => Some(FAILED),
        Some(BrokerAction::RestartScheduled) => Some(RESTARTING),
        _ => None,
    };
    if let Some(state) = service_state
        && !d.service.is_empty()
    {
        rows.lane(
            sink,
            &side.entity("status", &["services", &d.service]),
            stamp,
            state,
        )?;
    }
    Ok(())
}

/// The text of a broker decision, and its level.
fn broker_line(d: &Broker) -> (String, &'static str) {
    let why = if d.reason.is_empty() {
        String::new()
    } else {
        format!(": {}", d.reason)
    };
    let action = BrokerAction::parse(&d.action);
    let text = match action {
        Some(BrokerAction::Rebind) => format!(
            "rebind {} {}: {} -> {}{why}",
            d.client, d.interface, d.from_service, d.to_service
        ),
        Some(BrokerAction::Bind | BrokerAction::Unbind) => format!(
            "{} {} {}: {}{why}",
            d.action, d.client, d.interface, d.service
        ),
        _ => {
            let about: Vec<&str> = [d.service.as_str(), d.client.as_str(), d.interface.as_str()]
                .into_iter()
                .filter(|s| !s.is_empty())
                .collect();
            format!("{} {}{why}", d.action, about.join(" "))
        }
    };
    let level = match action {
        Some(BrokerAction::ServiceFailed | BrokerAction::AskForHelp) => "ERROR",
        Some(BrokerAction::Rebind | BrokerAction::Reject | BrokerAction::RestartScheduled) => {
            "WARN"
        }
        _ => "INFO",
    };
    (text, level)
}

/// A line a service wrote.
pub(super) fn log_line(
    rows: &mut Rows,
    sink: &mut dyn ChunkSink,
    side: Side,
    stamp: Stamp,
    line: &LogLine,
) -> Result<(), ViewError> {
    let mut log = TextLog::new(line.text.clone());
    let level = LogLineLevel::parse(&line.level).map(|level| match level {
        LogLineLevel::Error => "ERROR",
        LogLineLevel::Warn => "WARN",
        LogLineLevel::Info => "INFO",
        LogLineLevel::Debug => "DEBUG",
        LogLineLevel::Trace => "TRACE",
    });
    if let Some(level) = level {
        log = log.with_level(level);
    }
    let service = if line.service.is_empty() {
        line.header.provider.as_str()
    } else {
        line.service.as_str()
    };
    rows.log(
        sink,
        &side.entity("events", &["log", service]),
        stamp,
        &log,
        line.text.len() + 32,
    )
}

/// A command a service carried out or refused.
pub(super) fn command(
    rows: &mut Rows,
    sink: &mut dyn ChunkSink,
    side: Side,
    stamp: Stamp,
    command: &CommandLog,
) -> Result<(), ViewError> {
    let service = command.header.provider.as_str();
    let (text, level) = if command.status == CommandLogStatus::Ok {
        (
            format!("{}.{} ok", command.interface, command.command),
            "INFO",
        )
    } else {
        (
            format!(
                "{}.{} {}: {}",
                command.interface, command.command, command.status, command.error
            ),
            "WARN",
        )
    };
    rows.log(
        sink,
        &side.entity("events", &["commands", service]),
        stamp,
        &TextLog::new(text).with_level(level),
        128,
    )
}

/// Any other message, as one line of text.
pub(super) fn generic_text(
    rows: &mut Rows,
    sink: &mut dyn ChunkSink,
    topic: &str,
    stamp: Stamp,
    value: &Value,
) -> Result<(), ViewError> {
    let text = value.display_limited(MAX_ITEMS_SHOWN).to_string();
    let bytes = text.len();
    rows.log(
        sink,
        &topic_entity(&["topics"], topic, &[]),
        stamp,
        &TextLog::new(text),
        bytes,
    )
}
