//! What `sim-laser` and `sim-sonar` share as services: render a scan from the latest true
//! pose at the sensor's rate, publish RangeFinder and Distance (each when the robot file lets
//! the service provide it), answer `get_geometry` and `set_sector_count`.

use lewis_geometry::Pose2;
use lewis_interfaces::msg::{
    Distance, DistanceCommand, DistanceSetSectorCountReply, RangeFinder, RangeFinderCommand,
    RangeFinderGetGeometryReply,
};
use lewis_service::{CommandError, Context, IncomingCommand, Input, Reply, Service, ServiceConfig};

use super::{TruthFollower, provides, publish, sector_count};
use crate::world::World;

/// A simulated range sensor: what differs between the laser and the sonar.
pub trait RangeSensor: Send + 'static {
    /// The kind name in robot files (for error messages).
    const KIND: &'static str;
    /// One scan of `world` from the robot at `pose`.
    fn scan(&mut self, world: &World, pose: Pose2) -> RangeFinder;
    /// The sensor's Distance: `sectors` sectors computed from `scan`.
    fn distance(&self, scan: &RangeFinder, sectors: usize) -> Distance;
    /// The answer to RangeFinder's `get_geometry`.
    fn geometry(&self) -> RangeFinderGetGeometryReply;
}

/// A simulated range sensor run as a service.
#[derive(Debug)]
pub struct RangeService<S> {
    world: World,
    sensor: S,
    truth: TruthFollower,
    period_ns: i64,
    sectors: usize,
    publish_range_finder: bool,
    publish_distance: bool,
}

impl<S: RangeSensor> RangeService<S> {
    /// `sensor` rendering `world` every `period_ns`, with `sectors` Distance sectors, for the
    /// interfaces `config` lets it provide.
    pub(super) fn new(
        config: &ServiceConfig,
        world: World,
        sensor: S,
        period_ns: i64,
        sectors: usize,
    ) -> Self {
        Self {
            world,
            sensor,
            truth: TruthFollower::for_sensor(),
            period_ns,
            sectors,
            publish_range_finder: provides::<RangeFinder>(config),
            publish_distance: provides::<Distance>(config),
        }
    }
}

impl<S: RangeSensor> Service for RangeService<S> {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(self.period_ns)
    }

    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        self.truth.take(ctx, input);
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        let Some(pose) = self.truth.pose_for_rendering(ctx, &mut self.world) else {
            return;
        };
        let mut scan = self.sensor.scan(&self.world, pose);
        if self.publish_distance {
            publish(ctx, &mut self.sensor.distance(&scan, self.sectors));
        }
        if self.publish_range_finder {
            publish(ctx, &mut scan);
        }
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        match command.interface {
            "RangeFinder" => match command.decode::<RangeFinder>()? {
                RangeFinderCommand::GetGeometry(_) => Ok(ctx.reply(self.sensor.geometry())),
            },
            "Distance" => match command.decode::<Distance>()? {
                DistanceCommand::SetSectorCount(c) => {
                    self.sectors = sector_count(c.sector_count.into()).ok_or_else(|| {
                        CommandError::new(format!(
                            "set_sector_count: {} sectors, expected 1 to 360",
                            c.sector_count
                        ))
                    })?;
                    Ok(ctx.reply(DistanceSetSectorCountReply {
                        sector_count: c.sector_count,
                        ..DistanceSetSectorCountReply::default()
                    }))
                }
            },
            other => Err(CommandError::new(format!(
                "{} does not serve {other}",
                S::KIND
            ))),
        }
    }
}
