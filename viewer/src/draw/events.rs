//! Text logs and state lanes: broker decisions, bindings, health, services' output lines,
//! commands and the Mover's status, each under its [`Side`] (recorded or re-simulated).

use std::collections::BTreeMap;

use lewis_interfaces::dynamic::Value;
use lewis_interfaces::msg::{Broker, CommandLog, Health, LogLine, Mover};
use rerun::TextLog;

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
        let level = match health.state.as_str() {
            "ok" => "INFO",
            "degraded" => "WARN",
            _ => "ERROR",
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
        let level = match mover.status.as_str() {
            "blocked" => "WARN",
            "failed" => "ERROR",
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
    let binding = match d.action.as_str() {
        "bind" => Some(d.service.clone()),
        "rebind" => Some(d.to_service.clone()),
        "unbind" => Some("unbound".to_owned()),
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
    let service_state = match d.action.as_str() {
        "start" => Some("started"),
        "stop" => Some("stopped"),
        "service-failed" => Some("failed"),
        "restart-scheduled" => Some("restarting"),
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
    let text = match d.action.as_str() {
        "rebind" => format!(
            "rebind {} {}: {} -> {}{why}",
            d.client, d.interface, d.from_service, d.to_service
        ),
        "bind" | "unbind" => format!(
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
    let level = match d.action.as_str() {
        "service-failed" | "ask-for-help" => "ERROR",
        "rebind" | "reject" | "restart-scheduled" => "WARN",
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
    let level = match line.level.as_str() {
        "error" => Some("ERROR"),
        "warn" => Some("WARN"),
        "info" => Some("INFO"),
        "debug" => Some("DEBUG"),
        "trace" => Some("TRACE"),
        _ => None,
    };
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
    let (text, level) = if command.status == "ok" {
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
