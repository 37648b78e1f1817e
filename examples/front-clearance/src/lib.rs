//! `front-clearance`: a service kind written in a crate of its own, outside Lewis, as a
//! team would write theirs (the user guide's "Add your own service kind" follows it).
//!
//! It turns whatever RangeFinder the broker binds it to into a one-sector Distance: the
//! nearest reading within a cone ahead of the robot, for an application that only asks "how
//! far can I go straight on?". [`FrontClearance`] is the computation, a plain struct with
//! unit tests; [`FrontClearanceService`] only adapts it to inputs and outputs.
//!
//! ```toml
//! [[services]]
//! name = "front"
//! kind = "front-clearance"
//! requires = ["RangeFinder"]
//! provides = [{ interface = "Distance", quality = 5, cost = 1 }]
//! [services.parameters]
//! half_angle_deg = 30.0   # the cone: 30 degrees either side of straight ahead
//! ```

use lewis_interfaces::msg::{Distance, DistanceCommand, DistanceSetSectorCountReply, RangeFinder};
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Input, Reply, Service, ServiceConfig,
    ServiceRegistry,
};
use serde::Deserialize;

/// The kind's name in robot files.
pub const KIND: &str = "front-clearance";

/// Registers `front-clearance`, its parameters checked when a robot file is loaded. An
/// algorithm (the default role): a replay runs it again on the recorded scans.
pub fn register(registry: &mut ServiceRegistry) {
    registry.register_with_parameters::<Params>(KIND, build);
}

/// `[services.parameters]` of a `front-clearance` service: `deny_unknown_fields`, so that a
/// misspelt key stops `lewis up` when the robot file is loaded.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Half the cone's width, in degrees (more than 0, at most 180).
    pub half_angle_deg: f64,
    /// Accepted so that every robot file may give one; the kind draws nothing at random.
    pub seed: Option<u64>,
}

/// The nearest reading within a cone ahead, as a one-sector Distance.
#[derive(Debug, Clone, PartialEq)]
pub struct FrontClearance {
    half_angle_rad: f64,
}

impl FrontClearance {
    /// A cone of `half_angle_deg` either side of straight ahead.
    ///
    /// # Errors
    /// When the angle is not in (0, 180] degrees; the error is the sentence to show.
    pub fn new(half_angle_deg: f64) -> Result<Self, String> {
        if !(half_angle_deg > 0.0 && half_angle_deg <= 180.0) {
            return Err(format!(
                "half_angle_deg = {half_angle_deg}: give an angle above 0 and at most 180"
            ));
        }
        Ok(Self {
            half_angle_rad: half_angle_deg.to_radians(),
        })
    }

    /// The clearance ahead in `scan`: the nearest reading whose beam points into the cone,
    /// `max_range` when none does.
    #[must_use]
    pub fn distance(&self, scan: &RangeFinder) -> Distance {
        let mut nearest = (scan.max_range, 0.0);
        for (index, &range) in scan.ranges.iter().enumerate() {
            let bearing = bearing_of(scan, index);
            let in_cone = wrap(bearing).abs() <= self.half_angle_rad;
            if in_cone && range.is_finite() && range < nearest.0 {
                nearest = (range, wrap(bearing));
            }
        }
        Distance {
            sector_count: 1,
            sector_distances: vec![nearest.0],
            first_sector_angle: 0.0,
            sector_width: 2.0 * self.half_angle_rad,
            max_range: scan.max_range,
            min_distance: nearest.0,
            min_bearing: nearest.1,
            ..Distance::default()
        }
    }
}

/// The bearing of beam `index` in the robot frame: evenly spaced from `theta_offset` for a
/// uniform scan (a laser), each transducer's own heading otherwise (a sonar ring).
fn bearing_of(scan: &RangeFinder, index: usize) -> f64 {
    if scan.uniform {
        // Beam counts are far below 2^53.
        #[allow(clippy::cast_precision_loss)]
        let index = index as f64;
        scan.theta_offset + index * scan.theta_separation
    } else {
        scan.sensor_positions
            .get(index)
            .map_or(f64::INFINITY, |pose| pose.theta)
    }
}

/// An angle in (-pi, pi].
fn wrap(angle: f64) -> f64 {
    let wrapped = angle.rem_euclid(std::f64::consts::TAU);
    if wrapped > std::f64::consts::PI {
        wrapped - std::f64::consts::TAU
    } else {
        wrapped
    }
}

/// The `front-clearance` service.
#[derive(Debug)]
pub struct FrontClearanceService {
    clearance: FrontClearance,
}

fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: Params = config.parameters()?;
    let clearance =
        FrontClearance::new(params.half_angle_deg).map_err(|reason| BuildError::Parameters {
            service: config.name().to_owned(),
            reason,
        })?;
    Ok(Box::new(FrontClearanceService { clearance }))
}

impl Service for FrontClearanceService {
    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        if input.interface != "RangeFinder" {
            return;
        }
        match input.decode::<RangeFinder>() {
            Ok(scan) => {
                let mut distance = self.clearance.distance(&scan);
                if let Err(e) = ctx.publish(&mut distance) {
                    ctx.warn(&format!("cannot publish Distance: {e}"));
                }
            }
            Err(e) => ctx.warn(&format!("a RangeFinder sample ignored: {e}")),
        }
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        match command.decode::<Distance>()? {
            // One sector is all this kind computes: it says so rather than pretend.
            DistanceCommand::SetSectorCount(c) if c.sector_count == 1 => {
                Ok(ctx.reply(DistanceSetSectorCountReply {
                    sector_count: 1,
                    ..DistanceSetSectorCountReply::default()
                }))
            }
            DistanceCommand::SetSectorCount(c) => Err(CommandError::new(format!(
                "{KIND} computes one sector ahead, not {}",
                c.sector_count
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::FRAC_PI_2;

    use super::*;

    /// Three beams at -90, 0 and +90 degrees.
    fn scan(ranges: [f64; 3]) -> RangeFinder {
        RangeFinder {
            range_count: 3,
            ranges: ranges.to_vec(),
            max_range: 5.0,
            uniform: true,
            theta_offset: -FRAC_PI_2,
            theta_separation: FRAC_PI_2,
            ..RangeFinder::default()
        }
    }

    #[test]
    fn only_the_beams_in_the_cone_count() -> Result<(), String> {
        let ahead = FrontClearance::new(30.0)?.distance(&scan([1.0, 3.0, 2.0]));
        assert_eq!(ahead.sector_distances, [3.0]);
        assert_eq!(ahead.min_bearing, 0.0);
        let wide = FrontClearance::new(90.0)?.distance(&scan([1.0, 3.0, 2.0]));
        assert_eq!(wide.min_distance, 1.0);
        assert!((wide.min_bearing + FRAC_PI_2).abs() < 1e-12);
        Ok(())
    }

    #[test]
    fn nothing_in_the_cone_is_clear_to_the_maximum_range() -> Result<(), String> {
        let d = FrontClearance::new(30.0)?.distance(&scan([1.0, f64::NAN, 2.0]));
        assert_eq!(d.sector_distances, [5.0]);
        Ok(())
    }

    #[test]
    fn a_cone_that_is_no_angle_is_refused() {
        assert!(FrontClearance::new(0.0).is_err());
        assert!(FrontClearance::new(f64::NAN).is_err());
        assert!(FrontClearance::new(181.0).is_err());
    }
}
