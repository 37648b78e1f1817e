//! The drivers as services: `sick` (the SICK laser: RangeFinder and Distance) and `rflex`
//! (the B21r's base: Synchrodrive, Egomotion, Power, and the sonar ring as RangeFinder and
//! Distance).
//!
//! Each owns its driver and gives the live harness the port's descriptor
//! ([`Service::device`](lewis_service::Service::device)), so that it wakes when bytes
//! arrive; a tick runs the parts that depend on time (health, reconnection, the base's
//! watchdog). Device trouble never ends the process: the service declares itself out of
//! service with the driver's reason (the broker fails its clients over), keeps retrying the
//! port, and declares itself healthy again when data flows. A port that cannot be opened at
//! start is the same trouble, so a robot comes up with a device unplugged and picks it up
//! when it is plugged in.
//!
//! In replay neither runs: their recorded publications are fed instead.

pub mod rflex;
pub mod sick;

use lewis_geometry::{Pose2, SensorMount};
use lewis_interfaces::Interface;
use lewis_service::Health;
use lewis_service::{BuildError, Context, Role, ServiceConfig, ServiceRegistry};
use serde::Deserialize;

use super::io::DriverHealth;

/// Registers `sick` and `rflex`, devices (a replay feeds them from the recording).
pub fn register(registry: &mut ServiceRegistry) {
    registry.register_with_parameters::<sick::SickParams>(sick::KIND, sick::build);
    registry.register_with_parameters::<rflex::RflexParams>(rflex::KIND, rflex::build);
    registry.set_role(sick::KIND, Role::Device);
    registry.set_role(rflex::KIND, Role::Device);
}

/// A parameter error of service `config`.
fn invalid(config: &ServiceConfig<'_>, reason: impl Into<String>) -> BuildError {
    BuildError::Parameters {
        service: config.name().to_owned(),
        reason: reason.into(),
    }
}

/// Whether the robot file lets the service provide `T`.
fn provides<T: Interface>(config: &ServiceConfig<'_>) -> bool {
    config.spec.provision(T::NAME).is_some()
}

/// Publishes `message`, logging (not failing) when the channel refuses it.
fn publish<T: Interface>(ctx: &mut Context<'_>, message: &mut T) {
    if let Err(e) = ctx.publish(message) {
        ctx.warn(&format!("cannot publish {}: {e}", T::NAME));
    }
}

/// The runtime's health for a driver's view of its device: anything but fine is out of
/// service, with the driver's reason.
#[must_use]
pub fn health_of(driver: &DriverHealth) -> Health {
    match driver.reason() {
        None => Health::Ok,
        Some(reason) => Health::OutOfService(reason),
    }
}

/// Declares `health` when it differs from what the context holds, logging the change.
fn declare(ctx: &mut Context<'_>, health: Health) {
    if *ctx.health() == health {
        return;
    }
    match &health {
        Health::Ok => ctx.info("device healthy"),
        Health::Degraded(why) => ctx.warn(&format!("degraded: {why}")),
        Health::OutOfService(why) => ctx.warn(&format!("out of service: {why}")),
    }
    ctx.set_health(health);
}

/// A duration parameter in milliseconds, checked to be positive and at most an hour.
fn millis(
    config: &ServiceConfig<'_>,
    field: &str,
    value_ms: u64,
) -> Result<std::time::Duration, BuildError> {
    if value_ms == 0 || value_ms > 3_600_000 {
        return Err(invalid(
            config,
            format!("`{field}` is {value_ms}: give 1 to 3600000 ms"),
        ));
    }
    Ok(std::time::Duration::from_millis(value_ms))
}

/// Sectors of a Distance publication, 1 to 360.
fn sector_count(config: &ServiceConfig<'_>, count: i64) -> Result<usize, BuildError> {
    usize::try_from(count)
        .ok()
        .filter(|n| (1..=360).contains(n))
        .ok_or_else(|| {
            invalid(
                config,
                format!("`distance_sectors` is {count}: give 1 to 360"),
            )
        })
}

/// Where a sensor sits on the robot, as robot files write it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Mount {
    /// Forward of the robot's centre, in m.
    pub x_m: f64,
    /// Left of the robot's centre, in m.
    pub y_m: f64,
    /// Where it looks, counter-clockwise from straight ahead, in degrees.
    pub heading_deg: f64,
    /// Above the floor, in m.
    pub height_m: f64,
}

impl Mount {
    /// As the simulator's mount (which the Distance computation shares).
    #[must_use]
    pub fn to_sensor_mount(self) -> SensorMount {
        SensorMount {
            pose: Pose2::new(self.x_m, self.y_m, self.heading_deg.to_radians()),
            height_m: self.height_m,
        }
    }
}
