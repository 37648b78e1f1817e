//! The colours of the state lanes, by what the values mean, so that a failover reads at a
//! glance: a binding changes colour when it moves to another provider (the first provider
//! blue, the next orange, ...; unbound red), health and services are green when well, amber
//! when struggling, red when failed; the sequencer's states take the palette in the order
//! the mission visits them, `stop` green, asking amber, aborted red.
//!
//! Rerun colours a lane's values by their hash otherwise, so `sonar` could be as green as
//! `laser`, and a service's name as red as a failure. A [`StateConfiguration`] per lane, for
//! all times, fixes them once every value is known.

use lewis_interfaces::msg::{HealthState, MoverStatus, SequencerKind};
use rerun::{EntityPath, StateConfiguration};

use crate::ViewError;
use crate::rows::{ChunkSink, Rows};

const GOOD: u32 = 0x2E7D_32FF;
const WARN: u32 = 0xF9A8_25FF;
const BAD: u32 = 0xC628_28FF;
const IDLE: u32 = 0x6161_61FF;
/// For values that name something (providers, mission states), in order of appearance.
const PALETTE: [u32; 6] = [
    0x1E88_E5FF,
    0xEF6C_00FF,
    0x8E24_AAFF,
    0x0089_7BFF,
    0x6D4C_41FF,
    0xD813_60FF,
];

/// The values with a fixed meaning, per kind of lane (the path part that names it). Health,
/// the Mover's status and the end of a mission are words of the interfaces; the binding
/// and service states, `stop`, `asking the supervisor` and `no fault` are the viewer's own
/// words for what it reads from broker decisions, sequencer records and faults
/// (`events.rs`, `sequencer.rs`).
const MEANINGS: &[(&str, &str, u32)] = &[
    ("bindings", UNBOUND, BAD),
    ("health", HealthState::Ok.as_str(), GOOD),
    ("health", HealthState::Degraded.as_str(), WARN),
    ("health", HealthState::Stalled.as_str(), BAD),
    ("services", STARTED, GOOD),
    ("services", RESTARTING, WARN),
    ("services", FAILED, BAD),
    ("services", STOPPED, IDLE),
    ("sequencer", STOP, GOOD),
    ("sequencer", ASKING, WARN),
    ("sequencer", SequencerKind::Aborted.as_str(), BAD),
    ("faults", NO_FAULT, IDLE),
    ("mover", MoverStatus::Arrived.as_str(), GOOD),
    ("mover", MoverStatus::Blocked.as_str(), WARN),
    ("mover", MoverStatus::Failed.as_str(), BAD),
    ("mover", MoverStatus::Idle.as_str(), IDLE),
];

/// A binding's lane when the client has no provider.
pub(super) const UNBOUND: &str = "unbound";
/// A fault lane when the fault has ended.
pub(super) const NO_FAULT: &str = "no fault";
/// A service's lane after a `start` decision.
pub(super) const STARTED: &str = "started";
/// A service's lane after a `restart-scheduled` record.
pub(super) const RESTARTING: &str = "restarting";
/// A service's lane after a `service-failed` record.
pub(super) const FAILED: &str = "failed";
/// A service's lane after a `stop` decision.
pub(super) const STOPPED: &str = "stopped";
/// The sequencer's lane when the mission has finished: the script's `stop` state.
pub(super) const STOP: &str = "stop";
/// The sequencer's lane while the supervisor is asked where to resume.
pub(super) const ASKING: &str = "asking the supervisor";

/// Kinds of lane whose other values are all bad news (any health but ok or degraded,
/// any fault).
const OTHERWISE_BAD: &[&str] = &["health", "faults"];

/// The colour of `value`, the `index`th value of the lane at `path` to appear.
fn colour(path: &str, value: &str, index: usize) -> u32 {
    let kind = path
        .split('/')
        .find(|part| MEANINGS.iter().any(|(k, _, _)| k == part))
        .unwrap_or("");
    if let Some((_, _, colour)) = MEANINGS.iter().find(|(k, v, _)| *k == kind && *v == value) {
        return *colour;
    }
    if OTHERWISE_BAD.contains(&kind) {
        return BAD;
    }
    PALETTE[index % PALETTE.len()]
}

/// The colour of the sequencer's lane value `value` (0xRRGGBB as bytes) when the values
/// `earlier` appeared before it, in order: what the lane shows, for pictures drawn
/// elsewhere (`picture.rs`).
pub(crate) fn state_colour(value: &str, earlier: &[&str]) -> [u8; 3] {
    const PATH: &str = "status/sequencer";
    let mut named = 0;
    for earlier in earlier {
        if colour(PATH, earlier, named) == PALETTE[named % PALETTE.len()] {
            named += 1;
        }
    }
    let [r, g, b, _] = colour(PATH, value, named).to_be_bytes();
    [r, g, b]
}

/// Logs the colours of every lane of `rows`, for all times.
pub(super) fn configure(rows: &mut Rows, sink: &mut dyn ChunkSink) -> Result<(), ViewError> {
    for (path, values) in rows.take_lanes() {
        let text = path.to_string();
        // Names (providers, states) take the palette in their own order; the fixed
        // meanings do not use it up.
        let mut named = 0;
        let colours: Vec<u32> = values
            .iter()
            .map(|value| {
                let colour = colour(&text, value, named);
                if colour == PALETTE[named % PALETTE.len()] {
                    named += 1;
                }
                colour
            })
            .collect();
        configure_lane(rows, sink, &path, &values, &colours)?;
    }
    Ok(())
}

fn configure_lane(
    rows: &mut Rows,
    sink: &mut dyn ChunkSink,
    path: &EntityPath,
    values: &[String],
    colours: &[u32],
) -> Result<(), ViewError> {
    rows.log_static(
        sink,
        path,
        &StateConfiguration::new()
            .with_values(values.iter().cloned())
            .with_colors(colours.iter().copied()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_binding_moved_to_another_provider_changes_colour_and_unbound_is_red() {
        let path = "/status/bindings/obstacle_avoider/RangeFinder";
        assert_eq!(colour(path, "laser", 0), PALETTE[0]);
        assert_eq!(colour(path, "sonar", 1), PALETTE[1]);
        assert_eq!(colour(path, "unbound", 2), BAD);
        assert_eq!(colour("/status/replay/bindings/a/B", "unbound", 0), BAD);
    }

    #[test]
    fn health_services_and_the_sequencer_read_as_well_struggling_or_failed() {
        assert_eq!(colour("/status/health/laser", "ok", 0), GOOD);
        assert_eq!(colour("/status/health/laser", "degraded", 0), WARN);
        assert_eq!(colour("/status/health/laser", "out-of-service", 0), BAD);
        assert_eq!(colour("/status/services/laser", "restarting", 0), WARN);
        assert_eq!(colour("/status/services/laser", "failed", 0), BAD);
        assert_eq!(colour("/status/sequencer", "door", 0), PALETTE[0]);
        assert_eq!(
            colour("/status/sequencer", "asking the supervisor", 1),
            WARN
        );
        assert_eq!(colour("/status/sequencer", "stop", 1), GOOD);
        assert_eq!(
            colour("/status/replay/faults/laser", "fault: stall", 0),
            BAD
        );
        assert_eq!(colour("/status/replay/faults/laser", "no fault", 0), IDLE);
    }
}
