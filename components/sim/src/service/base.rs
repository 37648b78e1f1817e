//! `sim-base`: the simulated synchro-drive base, owner of the robot's true pose.
//!
//! At every tick it integrates the motion up to now (under the acceleration limits, stopped
//! by walls and objects) and publishes, for each interface the robot file lets it provide:
//! GroundTruth (the true pose, velocities, collisions: what the simulated sensors render
//! from), Synchrodrive (velocities and bumpers), Egomotion (odometry, which drifts) and,
//! at its own lower rate, Power (a battery that drains), and WorldState (where the world's
//! people are: the queue at the desk is served, people walk; see [`crate::scene`]). The
//! people move with the true pose and the time only, from the seed, and stand in the base's
//! own world too: the robot bumps into them. Commands are applied at the time they arrive:
//! the motion is integrated up to then first.
//!
//! ```toml
//! [services.parameters]
//! world = "robots/worlds/conference"
//! start = { x_m = 3.0, y_m = 12.5, heading_deg = 0.0 }
//! seed = 1
//! rate_hz = 50.0          # GroundTruth, Synchrodrive, Egomotion
//! power_rate_hz = 1.0     # Power
//! limits = { max_translation_velocity_mps = 1.0, max_rotation_velocity_radps = 1.5, translation_acceleration_mps2 = 0.6, rotation_acceleration_radps2 = 1.5 }
//! # body = { radius_m = 0.26, height_m = 1.2, bumper_count = 12, bumper_margin_m = 0.01 }
//! # odometry = { translation_variance_m2_per_m = 4e-4, rotation_variance_rad2_per_rad = 3e-4, rotation_variance_rad2_per_m = 1e-4, translation_scale = 1.0, rotation_scale = 1.0 }
//! # battery = { capacity_wh = 800.0, initial_charge_fraction = 1.0, ... }
//! ```

use std::path::PathBuf;

use lewis_geometry::Pose2;
use lewis_interfaces::msg::{
    Egomotion, EgomotionCommand, EgomotionResetOdometryReply, GroundTruth, Power, PowerCommand,
    PowerSetLowThresholdReply, Synchrodrive, SynchrodriveCommand, SynchrodriveSetBrakeReply,
    SynchrodriveSetVelocityReply, SynchrodriveStopReply, WorldState,
};
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Reply, Service, ServiceConfig,
};
use serde::Deserialize;

use super::{PoseParams, invalid, load_world, period_ns, provides, publish};
use crate::base::{BaseConfig, BatteryConfig, OdometryNoise, SimBase};
use crate::scene::Scene;
use crate::world::World;

/// The kind name in robot files.
pub const KIND: &str = "sim-base";

/// Longest time integrated at once, in ns: a process that was stopped for longer (a
/// debugger, a suspended machine) does not make the robot jump through walls in one call.
const MAX_CATCH_UP_NS: i64 = 1_000_000_000;

/// The parameters of `sim-base`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseParams {
    /// The world folder (`world.toml` and its map).
    pub world: PathBuf,
    /// Where the robot starts, in the world frame.
    pub start: PoseParams,
    /// Seed of the odometry and voltage noise.
    #[serde(default)]
    pub seed: Option<u64>,
    /// Rate of GroundTruth, Synchrodrive and Egomotion, in Hz.
    #[serde(default = "default_rate_hz")]
    pub rate_hz: f64,
    /// Rate of Power, in Hz.
    #[serde(default = "default_power_rate_hz")]
    pub power_rate_hz: f64,
    /// Speed and acceleration limits.
    #[serde(default)]
    pub limits: BaseLimits,
    /// The body: size, bumpers, integration step.
    #[serde(default)]
    pub body: BodyParams,
    /// Odometry noise.
    #[serde(default)]
    pub odometry: OdometryParams,
    /// The battery.
    #[serde(default)]
    pub battery: BatteryParams,
}

fn default_rate_hz() -> f64 {
    50.0
}

fn default_power_rate_hz() -> f64 {
    1.0
}

/// Speed and acceleration limits of the base.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BaseLimits {
    /// Largest translational speed, in m/s.
    pub max_translation_velocity_mps: f64,
    /// Largest rotational speed, in rad/s.
    pub max_rotation_velocity_radps: f64,
    /// Translational acceleration limit, in m/s^2.
    pub translation_acceleration_mps2: f64,
    /// Rotational acceleration limit, in rad/s^2.
    pub rotation_acceleration_radps2: f64,
}

impl Default for BaseLimits {
    fn default() -> Self {
        let c = BaseConfig::default();
        Self {
            max_translation_velocity_mps: c.max_translation_velocity_mps,
            max_rotation_velocity_radps: c.max_rotation_velocity_radps,
            translation_acceleration_mps2: c.translation_acceleration_mps2,
            rotation_acceleration_radps2: c.rotation_acceleration_radps2,
        }
    }
}

/// The body of the base.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BodyParams {
    /// Radius of the round body, in m.
    pub radius_m: f64,
    /// Height of the body, in m: objects mounted higher do not stop it.
    pub height_m: f64,
    /// Bumper segments around the body, the first centred straight ahead.
    pub bumper_count: usize,
    /// An obstacle closer than the radius plus this presses a bumper, in m.
    pub bumper_margin_m: f64,
    /// The fixed integration step, in ms.
    pub integration_step_ms: f64,
}

impl Default for BodyParams {
    fn default() -> Self {
        let c = BaseConfig::default();
        // a step of a few ms
        let integration_step_ms = c.integration_step_ns as f64 * 1e-6;
        Self {
            radius_m: c.radius_m,
            height_m: c.height_m,
            bumper_count: c.bumper_count,
            bumper_margin_m: c.bumper_margin_m,
            integration_step_ms,
        }
    }
}

/// Odometry noise (see [`OdometryNoise`]).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OdometryParams {
    /// Variance of the measured distance per metre driven, in m^2/m.
    pub translation_variance_m2_per_m: f64,
    /// Variance of the measured turn per radian turned, in rad^2/rad.
    pub rotation_variance_rad2_per_rad: f64,
    /// Variance of the measured turn per metre driven, in rad^2/m.
    pub rotation_variance_rad2_per_m: f64,
    /// Systematic scale of measured distances.
    pub translation_scale: f64,
    /// Systematic scale of measured turns.
    pub rotation_scale: f64,
}

impl Default for OdometryParams {
    fn default() -> Self {
        let n = OdometryNoise::default();
        Self {
            translation_variance_m2_per_m: n.translation_variance_m2_per_m,
            rotation_variance_rad2_per_rad: n.rotation_variance_rad2_per_rad,
            rotation_variance_rad2_per_m: n.rotation_variance_rad2_per_m,
            translation_scale: n.translation_scale,
            rotation_scale: n.rotation_scale,
        }
    }
}

/// The battery (see [`BatteryConfig`]).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BatteryParams {
    /// Energy when full, in Wh.
    pub capacity_wh: f64,
    /// Charge at the start, 0 to 1.
    pub initial_charge_fraction: f64,
    /// Voltage when full, in V.
    pub full_voltage_v: f64,
    /// Voltage when empty, in V.
    pub empty_voltage_v: f64,
    /// Constant load, in W.
    pub idle_power_w: f64,
    /// Load of the drive per m/s, in W/(m/s).
    pub translation_power_w_per_mps: f64,
    /// Load of the steering per rad/s, in W/(rad/s).
    pub rotation_power_w_per_radps: f64,
    /// Charge below which Power says `low`, 0 to 1 (Power's `set_low_threshold` changes it).
    pub low_threshold_fraction: f64,
    /// Standard deviation of the voltage reading, in V.
    pub voltage_noise_v: f64,
}

impl Default for BatteryParams {
    fn default() -> Self {
        let b = BatteryConfig::default();
        Self {
            capacity_wh: b.capacity_wh,
            initial_charge_fraction: b.initial_charge_fraction,
            full_voltage_v: b.full_voltage_v,
            empty_voltage_v: b.empty_voltage_v,
            idle_power_w: b.idle_power_w,
            translation_power_w_per_mps: b.translation_power_w_per_mps,
            rotation_power_w_per_radps: b.rotation_power_w_per_radps,
            low_threshold_fraction: b.low_threshold_fraction,
            voltage_noise_v: b.voltage_noise_v,
        }
    }
}

impl BaseParams {
    /// The model's configuration.
    #[must_use]
    pub fn base_config(&self) -> BaseConfig {
        let (l, body, o, b) = (self.limits, self.body, self.odometry, self.battery);
        // A non-finite or huge step is caught by the model's validation (it reads as 0).
        let integration_step_ns = if body.integration_step_ms.is_finite() {
            (body.integration_step_ms * 1e6).round() as i64
        } else {
            0
        };
        BaseConfig {
            radius_m: body.radius_m,
            height_m: body.height_m,
            max_translation_velocity_mps: l.max_translation_velocity_mps,
            max_rotation_velocity_radps: l.max_rotation_velocity_radps,
            translation_acceleration_mps2: l.translation_acceleration_mps2,
            rotation_acceleration_radps2: l.rotation_acceleration_radps2,
            integration_step_ns,
            bumper_count: body.bumper_count,
            bumper_margin_m: body.bumper_margin_m,
            odometry: OdometryNoise {
                translation_variance_m2_per_m: o.translation_variance_m2_per_m,
                rotation_variance_rad2_per_rad: o.rotation_variance_rad2_per_rad,
                rotation_variance_rad2_per_m: o.rotation_variance_rad2_per_m,
                translation_scale: o.translation_scale,
                rotation_scale: o.rotation_scale,
            },
            battery: BatteryConfig {
                capacity_wh: b.capacity_wh,
                initial_charge_fraction: b.initial_charge_fraction,
                full_voltage_v: b.full_voltage_v,
                empty_voltage_v: b.empty_voltage_v,
                idle_power_w: b.idle_power_w,
                translation_power_w_per_mps: b.translation_power_w_per_mps,
                rotation_power_w_per_radps: b.rotation_power_w_per_radps,
                low_threshold_fraction: b.low_threshold_fraction,
                voltage_noise_v: b.voltage_noise_v,
            },
        }
    }
}

/// Which interfaces the robot file lets the base publish.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Outputs {
    ground_truth: bool,
    synchrodrive: bool,
    egomotion: bool,
    power: bool,
    world_state: bool,
}

/// The `sim-base` service.
#[derive(Debug)]
pub struct SimBaseService {
    world: World,
    scene: Scene,
    base: SimBase,
    outputs: Outputs,
    period_ns: i64,
    power_period_ns: i64,
    low_threshold_fraction: f64,
    /// The time up to which the motion is integrated; `None` before the first event.
    simulated_to_ns: Option<i64>,
    next_power_ns: i64,
    reported_collisions: u64,
}

/// Builds a `sim-base` service from its robot-file entry.
///
/// # Errors
/// When a parameter is missing, unknown or cannot work, the world does not load, or the
/// start pose is inside a wall or an object.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: BaseParams = config.parameters()?;
    let power_period_ns = period_ns(config, "power_rate_hz", params.power_rate_hz)?;
    let period_ns = period_ns(config, "rate_hz", params.rate_hz)?;
    let world = load_world(config, &params.world)?;
    let start = params.start.to_pose();
    let base = SimBase::new(params.base_config(), start, config.seed())
        .map_err(|e| invalid(config, e.to_string()))?;
    let body = base.config();
    if !(start.x_m.is_finite() && start.y_m.is_finite() && start.heading_rad.is_finite()) {
        return Err(invalid(
            config,
            "`start` has a coordinate that is not a number",
        ));
    }
    if world.circle_collides(start.position(), body.radius_m, body.height_m) {
        return Err(invalid(
            config,
            format!(
                "`start` ({}, {}) puts the robot inside a wall or an object of world `{}`: choose a free place",
                params.start.x_m,
                params.start.y_m,
                world.name()
            ),
        ));
    }
    Ok(Box::new(SimBaseService {
        scene: Scene::new(&world, config.seed()),
        world,
        base,
        outputs: Outputs {
            ground_truth: provides::<GroundTruth>(config),
            synchrodrive: provides::<Synchrodrive>(config),
            egomotion: provides::<Egomotion>(config),
            power: provides::<Power>(config),
            world_state: provides::<WorldState>(config),
        },
        period_ns,
        power_period_ns,
        low_threshold_fraction: params.battery.low_threshold_fraction,
        simulated_to_ns: None,
        next_power_ns: 0,
        reported_collisions: 0,
    }))
}

impl SimBaseService {
    /// The simulated base (tests and tools read the true pose from it).
    #[must_use]
    pub fn base(&self) -> &SimBase {
        &self.base
    }

    /// The people of the world, where they are now.
    #[must_use]
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Integrates the motion up to the context's now.
    fn advance(&mut self, ctx: &mut Context<'_>) {
        let now = ctx.now();
        let from = *self.simulated_to_ns.get_or_insert(now);
        let dt = now.saturating_sub(from);
        if dt > MAX_CATCH_UP_NS {
            ctx.warn(&format!(
                "{} ms passed since the last step: integrating only {} ms",
                dt / 1_000_000,
                MAX_CATCH_UP_NS / 1_000_000
            ));
        }
        self.base.step(&self.world, dt.min(MAX_CATCH_UP_NS));
        self.simulated_to_ns = Some(now.max(from));
        self.scene
            .step(now.max(from), self.base.true_pose().position());
        self.scene.apply_to(&mut self.world);
        let collisions = self.base.collision_count();
        if collisions > self.reported_collisions {
            self.reported_collisions = collisions;
            let pose = self.base.true_pose();
            ctx.warn(&format!(
                "collision {collisions}: the robot ran into something at ({:.2}, {:.2}) heading {:.0} deg",
                pose.x_m,
                pose.y_m,
                pose.heading_rad.to_degrees()
            ));
        }
    }

    /// The GroundTruth publication (header left to the context).
    #[must_use]
    pub fn ground_truth(&self) -> GroundTruth {
        let (v, w) = self.base.velocity();
        GroundTruth {
            pose: self.base.true_pose().to_msg(),
            translation_velocity: v,
            rotation_velocity: w,
            collisions: i32::try_from(self.base.collision_count()).unwrap_or(i32::MAX),
            bumped: self.base.is_blocked() || self.base.bumpers().iter().any(|&b| b),
            ..GroundTruth::default()
        }
    }

    fn power(&mut self) -> Power {
        let mut power = self.base.power();
        power.low = power.charge_fraction < self.low_threshold_fraction;
        power
    }

    fn publish_state(&mut self, ctx: &mut Context<'_>) {
        if self.outputs.ground_truth {
            publish(ctx, &mut self.ground_truth());
        }
        if self.outputs.synchrodrive {
            publish(ctx, &mut self.base.synchrodrive());
        }
        if self.outputs.egomotion {
            publish(ctx, &mut self.base.egomotion());
        }
        if self.outputs.world_state {
            publish(ctx, &mut self.scene.world_state());
        }
        if self.outputs.power && ctx.now() >= self.next_power_ns {
            self.next_power_ns = ctx.now().saturating_add(self.power_period_ns);
            let mut power = self.power();
            publish(ctx, &mut power);
        }
    }
}

impl Service for SimBaseService {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(self.period_ns)
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        self.simulated_to_ns = Some(ctx.now());
        let pose = self.base.true_pose();
        ctx.info(&format!(
            "world `{}`, robot at ({:.2}, {:.2}) heading {:.0} deg",
            self.world.name(),
            pose.x_m,
            pose.y_m,
            pose.heading_rad.to_degrees()
        ));
        // The sensors need a true pose before the first tick.
        self.publish_state(ctx);
        Ok(())
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        self.advance(ctx);
        self.publish_state(ctx);
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        self.advance(ctx);
        match command.interface {
            "Synchrodrive" => match command.decode::<Synchrodrive>()? {
                SynchrodriveCommand::SetVelocity(c) => {
                    self.base
                        .set_velocity(c.translation_velocity, c.rotation_velocity);
                    Ok(ctx.reply(SynchrodriveSetVelocityReply::default()))
                }
                SynchrodriveCommand::Stop(_) => {
                    self.base.stop();
                    Ok(ctx.reply(SynchrodriveStopReply::default()))
                }
                SynchrodriveCommand::SetBrake(c) => {
                    self.base.set_brake(c.on);
                    Ok(ctx.reply(SynchrodriveSetBrakeReply::default()))
                }
            },
            "Egomotion" => match command.decode::<Egomotion>()? {
                EgomotionCommand::ResetOdometry(c) => {
                    let pose = Pose2::from_msg(&c.pose);
                    if !(pose.x_m.is_finite()
                        && pose.y_m.is_finite()
                        && pose.heading_rad.is_finite())
                    {
                        return Err(CommandError::new(
                            "reset_odometry: the pose has a coordinate that is not a number",
                        ));
                    }
                    self.base.reset_odometry(pose);
                    Ok(ctx.reply(EgomotionResetOdometryReply::default()))
                }
            },
            "Power" => match command.decode::<Power>()? {
                PowerCommand::SetLowThreshold(c) => {
                    if !(0.0..=1.0).contains(&c.charge_fraction) {
                        return Err(CommandError::new(format!(
                            "set_low_threshold: charge_fraction is {}, expected between 0 and 1",
                            c.charge_fraction
                        )));
                    }
                    self.low_threshold_fraction = c.charge_fraction;
                    Ok(ctx.reply(PowerSetLowThresholdReply::default()))
                }
            },
            other => Err(CommandError::new(format!("{KIND} does not serve {other}"))),
        }
    }
}
