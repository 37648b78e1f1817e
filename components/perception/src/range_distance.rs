//! `range_distance`: the Distance interface computed from whatever RangeFinder the broker
//! binds it to (the laser while it works, the sonar after a failover), for robots whose range
//! sensors publish no Distance of their own (an imported log's laser, a third-party driver).
//!
//! [`RangeToDistance`] is the computation, a plain struct: per angular sector the nearest
//! reading, over the whole circle or over a span of bearings (a laser's field of view), with
//! [`distance_from_range_finder`], the code the simulated and real drivers use. The service
//! publishes one Distance per RangeFinder sample, at once (provenance: that sample), and
//! answers `Distance.set_sector_count`.
//!
//! ```toml
//! [[services]]
//! name = "distance"
//! kind = "range_distance"
//! requires = ["RangeFinder"]
//! provides = [{ interface = "Distance", quality = 8, cost = 1 }]
//! [services.parameters]        # all optional
//! sector_count = 8             # 1 to 360
//! span_deg = [-90.25, 89.75]   # default: the whole circle, sector 0 centred behind
//! ```

use lewis_geometry::{SectorLayout, distance_from_range_finder};
use lewis_interfaces::msg::{Distance, DistanceCommand, DistanceSetSectorCountReply, RangeFinder};
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Input, Reply, Service, ServiceConfig,
    ServiceRegistry,
};
use serde::Deserialize;

/// The kind name in robot files.
pub const KIND: &str = "range_distance";

/// Registers the `range_distance` kind.
pub fn register(registry: &mut ServiceRegistry) {
    registry.register_with_parameters::<Params>(KIND, build);
}

/// The sector counts accepted.
pub const SECTOR_COUNTS: std::ops::RangeInclusive<usize> = 1..=360;

/// The parameters of `range_distance`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Sectors of each Distance reading.
    pub sector_count: usize,
    /// The bearings the sectors cover, from and to (counter-clockwise), in degrees; `None`:
    /// the whole circle.
    pub span_deg: Option<[f64; 2]>,
    /// Seed of the runtime's random source (unused; accepted so that every robot file may
    /// give one).
    pub seed: Option<u64>,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            sector_count: 8,
            span_deg: None,
            seed: None,
        }
    }
}

/// Turns RangeFinder readings into Distance readings (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct RangeToDistance {
    sector_count: usize,
    span_rad: Option<(f64, f64)>,
}

impl RangeToDistance {
    /// `sector_count` sectors over `span_rad` (from, to; `None`: the whole circle).
    ///
    /// # Errors
    /// The count is outside [`SECTOR_COUNTS`], or the span is not finite or not increasing.
    pub fn new(sector_count: usize, span_rad: Option<(f64, f64)>) -> Result<Self, String> {
        if let Some((from, to)) = span_rad
            && !(from.is_finite() && to.is_finite() && from < to)
        {
            return Err(format!(
                "the span from {:.3} to {:.3} degrees is not an increasing pair of finite bearings",
                from.to_degrees(),
                to.to_degrees()
            ));
        }
        let mut converter = Self {
            sector_count: 1,
            span_rad,
        };
        converter.set_sector_count(sector_count)?;
        Ok(converter)
    }

    /// The converter of a robot-file entry's parameters.
    ///
    /// # Errors
    /// As [`RangeToDistance::new`].
    pub fn from_params(params: &Params) -> Result<Self, String> {
        Self::new(
            params.sector_count,
            params
                .span_deg
                .map(|[from, to]| (from.to_radians(), to.to_radians())),
        )
    }

    /// Changes the number of sectors.
    ///
    /// # Errors
    /// The count is outside [`SECTOR_COUNTS`]; the old count is kept.
    pub fn set_sector_count(&mut self, sector_count: usize) -> Result<(), String> {
        if !SECTOR_COUNTS.contains(&sector_count) {
            return Err(format!(
                "{sector_count} sectors: give {} to {}",
                SECTOR_COUNTS.start(),
                SECTOR_COUNTS.end()
            ));
        }
        self.sector_count = sector_count;
        Ok(())
    }

    /// The sectors of each reading.
    #[must_use]
    pub fn sector_count(&self) -> usize {
        self.sector_count
    }

    /// The Distance reading of `scan` (header left empty).
    #[must_use]
    pub fn distance(&self, scan: &RangeFinder) -> Distance {
        let layout = match self.span_rad {
            Some((from, to)) => SectorLayout::spanning(from, to, self.sector_count),
            None => SectorLayout::full_circle(self.sector_count),
        };
        distance_from_range_finder(scan, layout)
    }
}

/// The `range_distance` service.
#[derive(Debug)]
pub struct RangeDistanceService {
    converter: RangeToDistance,
    /// The last decoding problem logged, so that a stream of bad samples logs once.
    last_problem: Option<String>,
}

/// Builds a `range_distance` service from its robot-file entry.
///
/// # Errors
/// When a parameter is unknown or out of range, or the service does not require RangeFinder.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: Params = config.parameters()?;
    let invalid = |reason: String| BuildError::Parameters {
        service: config.name().to_owned(),
        reason,
    };
    if !config.spec.requires.iter().any(|r| r == "RangeFinder") {
        return Err(invalid(
            "a range_distance computes Distance from a RangeFinder: add \"RangeFinder\" to `requires`"
                .to_owned(),
        ));
    }
    let converter = RangeToDistance::from_params(&params).map_err(invalid)?;
    Ok(Box::new(RangeDistanceService {
        converter,
        last_problem: None,
    }))
}

impl Service for RangeDistanceService {
    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        if input.interface != "RangeFinder" {
            return;
        }
        match input.decode::<RangeFinder>() {
            Ok(scan) => {
                self.last_problem = None;
                let mut distance = self.converter.distance(&scan);
                if let Err(e) = ctx.publish(&mut distance) {
                    ctx.warn(&format!("cannot publish Distance: {e}"));
                }
            }
            Err(e) => {
                let text = format!("RangeFinder sample from {} ignored: {e}", input.provider);
                if self.last_problem.as_deref() != Some(text.as_str()) {
                    ctx.warn(&text);
                    self.last_problem = Some(text);
                }
            }
        }
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        if command.interface != "Distance" {
            return Err(CommandError::new(format!(
                "{KIND} serves Distance, not {}",
                command.interface
            )));
        }
        match command.decode::<Distance>()? {
            DistanceCommand::SetSectorCount(c) => {
                let count = usize::try_from(c.sector_count).unwrap_or(0);
                self.converter
                    .set_sector_count(count)
                    .map_err(|e| CommandError::new(format!("set_sector_count: {e}")))?;
                Ok(ctx.reply(DistanceSetSectorCountReply {
                    sector_count: c.sector_count,
                    ..DistanceSetSectorCountReply::default()
                }))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

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

    fn check(converter: &RangeToDistance, ranges: [f64; 3], sectors: &[f64], min: f64) {
        let d = converter.distance(&scan(ranges));
        assert_eq!(d.sector_distances, sectors);
        assert_eq!(d.min_distance, min);
        assert_eq!(usize::try_from(d.sector_count).unwrap(), sectors.len());
    }

    #[test]
    fn the_whole_circle_starts_behind_the_robot() {
        // Sectors centred behind, on the right, ahead and on the left.
        let converter = RangeToDistance::new(4, None).unwrap();
        check(&converter, [1.0, 2.0, 3.0], &[5.0, 1.0, 2.0, 3.0], 1.0);
    }

    #[test]
    fn a_span_puts_every_sector_in_the_field_of_view() {
        let converter =
            RangeToDistance::new(2, Some((-100f64.to_radians(), 100f64.to_radians()))).unwrap();
        check(&converter, [1.5, 5.0, 4.0], &[1.5, 4.0], 1.5);
    }

    #[test]
    fn bad_counts_and_spans_are_refused_with_the_reason() {
        let error = RangeToDistance::new(0, None).unwrap_err();
        assert!(error.contains("0 sectors: give 1 to 360"), "{error}");
        let error = RangeToDistance::new(8, Some((1.0, -1.0))).unwrap_err();
        assert!(error.contains("not an increasing pair"), "{error}");
        let mut converter = RangeToDistance::new(8, None).unwrap();
        assert!(converter.set_sector_count(361).is_err());
        assert_eq!(converter.sector_count(), 8);
    }
}
