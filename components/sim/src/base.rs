//! The B21r's synchro-drive base: commanded translational and rotational velocities reached
//! under acceleration limits and integrated with a fixed step, the true pose, odometry that
//! drifts, a battery that drains, bumpers and a collision counter.

use lewis_interfaces::msg::{Egomotion, Power, Synchrodrive};

use super::world::World;
use lewis_geometry::{Pose2, Vec2, wrap_angle};
use lewis_service::Rng;

/// Odometry noise: variances grow with the motion, so that the drift after a path does not
/// depend on the integration step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryNoise {
    /// Variance of the measured distance per metre driven, in m^2/m.
    pub translation_variance_m2_per_m: f64,
    /// Variance of the measured turn per radian turned, in rad^2/rad.
    pub rotation_variance_rad2_per_rad: f64,
    /// Variance of the measured turn per metre driven, in rad^2/m.
    pub rotation_variance_rad2_per_m: f64,
    /// Systematic scale of measured distances (1 is exact; a worn tyre is not).
    pub translation_scale: f64,
    /// Systematic scale of measured turns.
    pub rotation_scale: f64,
}

impl OdometryNoise {
    /// Exact odometry.
    pub const NONE: Self = Self {
        translation_variance_m2_per_m: 0.0,
        rotation_variance_rad2_per_rad: 0.0,
        rotation_variance_rad2_per_m: 0.0,
        translation_scale: 1.0,
        rotation_scale: 1.0,
    };
}

impl Default for OdometryNoise {
    /// About 2 cm of spread after 1 m, and 1 degree per radian turned.
    fn default() -> Self {
        Self {
            translation_variance_m2_per_m: 4e-4,
            rotation_variance_rad2_per_rad: 3e-4,
            rotation_variance_rad2_per_m: 1e-4,
            translation_scale: 1.0,
            rotation_scale: 1.0,
        }
    }
}

/// The battery: a charge drained by a constant load plus the motors' load.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BatteryConfig {
    /// Energy when full, in Wh.
    pub capacity_wh: f64,
    /// Charge when the simulation starts, 0 to 1.
    pub initial_charge_fraction: f64,
    /// Voltage when full, in V.
    pub full_voltage_v: f64,
    /// Voltage when empty, in V.
    pub empty_voltage_v: f64,
    /// Constant load (computers, sensors), in W.
    pub idle_power_w: f64,
    /// Load of the drive per m/s of translation, in W/(m/s).
    pub translation_power_w_per_mps: f64,
    /// Load of the steering per rad/s of rotation, in W/(rad/s).
    pub rotation_power_w_per_radps: f64,
    /// Charge below which Power says `low`, 0 to 1.
    pub low_threshold_fraction: f64,
    /// Standard deviation of the voltage reading, in V.
    pub voltage_noise_v: f64,
}

impl Default for BatteryConfig {
    /// A 24 V lead-acid pack of about 800 Wh (unverified for the B21r: a plausible size).
    fn default() -> Self {
        Self {
            capacity_wh: 800.0,
            initial_charge_fraction: 1.0,
            full_voltage_v: 26.4,
            empty_voltage_v: 22.8,
            idle_power_w: 90.0,
            translation_power_w_per_mps: 120.0,
            rotation_power_w_per_radps: 40.0,
            low_threshold_fraction: 0.2,
            voltage_noise_v: 0.02,
        }
    }
}

/// The base's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaseConfig {
    /// Radius of the round body, in m (B21r: 0.26).
    pub radius_m: f64,
    /// Height of the body, in m: objects mounted higher (signs) do not stop it.
    pub height_m: f64,
    /// Largest translational speed, in m/s.
    pub max_translation_velocity_mps: f64,
    /// Largest rotational speed, in rad/s.
    pub max_rotation_velocity_radps: f64,
    /// Translational acceleration limit, in m/s^2.
    pub translation_acceleration_mps2: f64,
    /// Rotational acceleration limit, in rad/s^2.
    pub rotation_acceleration_radps2: f64,
    /// The fixed integration step, in ns.
    pub integration_step_ns: i64,
    /// Number of bumper segments around the body, the first centred straight ahead, the
    /// others counter-clockwise.
    pub bumper_count: usize,
    /// An obstacle closer than the radius plus this presses a bumper, in m.
    pub bumper_margin_m: f64,
    /// Odometry noise.
    pub odometry: OdometryNoise,
    /// The battery.
    pub battery: BatteryConfig,
}

impl Default for BaseConfig {
    /// A B21r.
    fn default() -> Self {
        Self {
            radius_m: 0.26,
            height_m: 1.2,
            max_translation_velocity_mps: 1.0,
            max_rotation_velocity_radps: 1.5,
            translation_acceleration_mps2: 0.6,
            rotation_acceleration_radps2: 1.5,
            integration_step_ns: 5_000_000,
            bumper_count: 12,
            bumper_margin_m: 0.01,
            odometry: OdometryNoise::default(),
            battery: BatteryConfig::default(),
        }
    }
}

/// A base parameter that cannot work.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("base parameter `{field}` is {value}: {expected}")]
pub struct BaseConfigError {
    /// The parameter.
    pub field: &'static str,
    /// Its value.
    pub value: f64,
    /// What it must be.
    pub expected: &'static str,
}

impl BaseConfig {
    /// Checks that every parameter can work.
    ///
    /// # Errors
    /// The first parameter that cannot.
    pub fn validate(&self) -> Result<(), BaseConfigError> {
        let positive = [
            ("radius_m", self.radius_m),
            ("height_m", self.height_m),
            (
                "max_translation_velocity_mps",
                self.max_translation_velocity_mps,
            ),
            (
                "max_rotation_velocity_radps",
                self.max_rotation_velocity_radps,
            ),
            (
                "translation_acceleration_mps2",
                self.translation_acceleration_mps2,
            ),
            (
                "rotation_acceleration_radps2",
                self.rotation_acceleration_radps2,
            ),
            ("battery.capacity_wh", self.battery.capacity_wh),
        ];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(BaseConfigError {
                    field,
                    value,
                    expected: "a positive number",
                });
            }
        }
        let non_negative = [
            ("bumper_margin_m", self.bumper_margin_m),
            (
                "odometry.translation_variance_m2_per_m",
                self.odometry.translation_variance_m2_per_m,
            ),
            (
                "odometry.rotation_variance_rad2_per_rad",
                self.odometry.rotation_variance_rad2_per_rad,
            ),
            (
                "odometry.rotation_variance_rad2_per_m",
                self.odometry.rotation_variance_rad2_per_m,
            ),
            ("battery.idle_power_w", self.battery.idle_power_w),
            (
                "battery.translation_power_w_per_mps",
                self.battery.translation_power_w_per_mps,
            ),
            (
                "battery.rotation_power_w_per_radps",
                self.battery.rotation_power_w_per_radps,
            ),
            ("battery.voltage_noise_v", self.battery.voltage_noise_v),
        ];
        for (field, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(BaseConfigError {
                    field,
                    value,
                    expected: "zero or more",
                });
            }
        }
        let fractions = [
            (
                "battery.initial_charge_fraction",
                self.battery.initial_charge_fraction,
            ),
            (
                "battery.low_threshold_fraction",
                self.battery.low_threshold_fraction,
            ),
        ];
        for (field, value) in fractions {
            if !(0.0..=1.0).contains(&value) {
                return Err(BaseConfigError {
                    field,
                    value,
                    expected: "between 0 and 1",
                });
            }
        }
        if self.integration_step_ns <= 0 {
            return Err(BaseConfigError {
                field: "integration_step_ns",
                value: self.integration_step_ns as f64,
                expected: "a positive number of nanoseconds",
            });
        }
        Ok(())
    }
}

/// The simulated base.
#[derive(Debug, Clone)]
pub struct SimBase {
    config: BaseConfig,
    rng: Rng,
    true_pose: Pose2,
    odometry_pose: Pose2,
    distance_travelled_m: f64,
    translation_velocity_mps: f64,
    rotation_velocity_radps: f64,
    measured_translation_velocity_mps: f64,
    measured_rotation_velocity_radps: f64,
    commanded_translation_velocity_mps: f64,
    commanded_rotation_velocity_radps: f64,
    brake_on: bool,
    pending_ns: i64,
    elapsed_ns: i64,
    charge_fraction: f64,
    blocked: bool,
    touching: bool,
    collision_count: u64,
    bumpers: Vec<bool>,
}

impl SimBase {
    /// A base at rest at `true_pose`, with its odometry reading the zero pose and its own
    /// random generator seeded from `seed`.
    ///
    /// # Errors
    /// When a parameter cannot work.
    pub fn new(config: BaseConfig, true_pose: Pose2, seed: u64) -> Result<Self, BaseConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            rng: Rng::for_device(seed, "base"),
            true_pose,
            odometry_pose: Pose2::default(),
            distance_travelled_m: 0.0,
            translation_velocity_mps: 0.0,
            rotation_velocity_radps: 0.0,
            measured_translation_velocity_mps: 0.0,
            measured_rotation_velocity_radps: 0.0,
            commanded_translation_velocity_mps: 0.0,
            commanded_rotation_velocity_radps: 0.0,
            brake_on: false,
            pending_ns: 0,
            elapsed_ns: 0,
            charge_fraction: config.battery.initial_charge_fraction,
            blocked: false,
            touching: false,
            collision_count: 0,
            bumpers: vec![false; config.bumper_count],
        })
    }

    /// Its parameters.
    #[must_use]
    pub fn config(&self) -> &BaseConfig {
        &self.config
    }

    /// Commands the velocities to reach (clamped to the limits; non-finite values read as 0).
    pub fn set_velocity(&mut self, translation_mps: f64, rotation_radps: f64) {
        let clamp = |v: f64, max: f64| {
            if v.is_finite() {
                v.clamp(-max, max)
            } else {
                0.0
            }
        };
        self.commanded_translation_velocity_mps =
            clamp(translation_mps, self.config.max_translation_velocity_mps);
        self.commanded_rotation_velocity_radps =
            clamp(rotation_radps, self.config.max_rotation_velocity_radps);
    }

    /// Commands both velocities to zero (reached under the acceleration limits).
    pub fn stop(&mut self) {
        self.set_velocity(0.0, 0.0);
    }

    /// Sets the brake: while on, the base stands still at once and ignores velocities.
    pub fn set_brake(&mut self, on: bool) {
        self.brake_on = on;
        if on {
            self.translation_velocity_mps = 0.0;
            self.rotation_velocity_radps = 0.0;
        }
    }

    /// Sets the odometry's pose (the true pose does not move).
    pub fn reset_odometry(&mut self, pose: Pose2) {
        self.odometry_pose = pose;
    }

    /// Puts the robot somewhere else, at rest (tests, scenario set-up).
    pub fn teleport(&mut self, true_pose: Pose2) {
        self.true_pose = true_pose;
        self.translation_velocity_mps = 0.0;
        self.rotation_velocity_radps = 0.0;
        self.blocked = false;
        self.touching = false;
    }

    /// Advances the simulation by `dt_ns` (negative reads as 0), in fixed integration steps;
    /// time that does not fill a step is carried to the next call.
    pub fn step(&mut self, world: &World, dt_ns: i64) {
        self.pending_ns = self.pending_ns.saturating_add(dt_ns.max(0));
        let step_ns = self.config.integration_step_ns;
        let mut stepped = false;
        while self.pending_ns >= step_ns {
            self.pending_ns -= step_ns;
            self.elapsed_ns = self.elapsed_ns.saturating_add(step_ns);
            // steps are far below 2^52 ns
            self.integrate(world, step_ns as f64 * 1e-9);
            stepped = true;
        }
        if stepped {
            self.update_bumpers(world);
        }
    }

    fn integrate(&mut self, world: &World, dt_s: f64) {
        let (target_v, target_w) = if self.brake_on {
            (0.0, 0.0)
        } else {
            (
                self.commanded_translation_velocity_mps,
                self.commanded_rotation_velocity_radps,
            )
        };
        let (previous_v, previous_w) =
            (self.translation_velocity_mps, self.rotation_velocity_radps);
        let approach = |current: f64, target: f64, max_change: f64| {
            current + (target - current).clamp(-max_change, max_change)
        };
        self.translation_velocity_mps = approach(
            self.translation_velocity_mps,
            target_v,
            self.config.translation_acceleration_mps2 * dt_s,
        );
        self.rotation_velocity_radps = approach(
            self.rotation_velocity_radps,
            target_w,
            self.config.rotation_acceleration_radps2 * dt_s,
        );
        // Trapezoidal integration: exact while the acceleration is constant.
        let v = 0.5 * (previous_v + self.translation_velocity_mps);
        let w = 0.5 * (previous_w + self.rotation_velocity_radps);
        let d_theta = w * dt_s;
        let distance = v * dt_s;
        let moved = arc(self.true_pose, distance, d_theta);
        let radius = self.config.radius_m;
        let height = self.config.height_m;
        let blocked = distance != 0.0 && world.circle_collides(moved.position(), radius, height);
        let (distance, new_pose) = if blocked {
            // The body stops against the obstacle; a round body can still turn in place.
            self.translation_velocity_mps = 0.0;
            (0.0, arc(self.true_pose, 0.0, d_theta))
        } else {
            (distance, moved)
        };
        // One collision per contact: pushing on, or creeping back against, the same
        // obstacle does not count again until the body has left it.
        if blocked && !self.touching {
            self.collision_count += 1;
            self.touching = true;
        } else if self.touching
            && !blocked
            && !world.circle_collides(
                new_pose.position(),
                radius + self.config.bumper_margin_m,
                height,
            )
        {
            self.touching = false;
        }
        self.blocked = blocked;
        self.true_pose = new_pose;
        self.update_odometry(distance, d_theta, dt_s);
        // A base pushing against a wall still draws its motors' current.
        self.drain_battery(v.abs(), w.abs(), dt_s);
    }

    fn update_odometry(&mut self, distance: f64, d_theta: f64, dt_s: f64) {
        let noise = self.config.odometry;
        let d_std = (noise.translation_variance_m2_per_m * distance.abs()).sqrt();
        let t_std = (noise.rotation_variance_rad2_per_rad * d_theta.abs()
            + noise.rotation_variance_rad2_per_m * distance.abs())
        .sqrt();
        let (d_noise, t_noise) = if distance == 0.0 && d_theta == 0.0 {
            (0.0, 0.0)
        } else {
            (self.rng.normal(0.0, d_std), self.rng.normal(0.0, t_std))
        };
        let d = distance * noise.translation_scale + d_noise;
        let t = d_theta * noise.rotation_scale + t_noise;
        self.odometry_pose = arc(self.odometry_pose, d, t);
        self.distance_travelled_m += d.abs();
        self.measured_translation_velocity_mps = d / dt_s;
        self.measured_rotation_velocity_radps = t / dt_s;
    }

    fn drain_battery(&mut self, speed_mps: f64, turn_rate_radps: f64, dt_s: f64) {
        let b = &self.config.battery;
        let power_w = b.idle_power_w
            + b.translation_power_w_per_mps * speed_mps
            + b.rotation_power_w_per_radps * turn_rate_radps;
        let used = power_w * dt_s / (b.capacity_wh * 3600.0);
        self.charge_fraction = (self.charge_fraction - used).max(0.0);
    }

    fn update_bumpers(&mut self, world: &World) {
        let n = self.bumpers.len();
        self.bumpers.iter_mut().for_each(|b| *b = false);
        if n == 0 {
            return;
        }
        let pose = self.true_pose;
        let reach = self.config.radius_m + self.config.bumper_margin_m;
        let width = std::f64::consts::TAU / n as f64;
        let bumpers = &mut self.bumpers;
        world.for_each_obstacle_point_within(pose.position(), reach, self.config.height_m, |p| {
            let bearing = wrap_angle((p - pose.position()).angle() - pose.heading_rad);
            // Sector k is centred on bearing k * width.
            // in 0..=n
            let k = ((bearing + width / 2.0).rem_euclid(std::f64::consts::TAU) / width) as usize;
            bumpers[k.min(n - 1)] = true;
        });
    }

    /// Where the robot really is.
    #[must_use]
    pub fn true_pose(&self) -> Pose2 {
        self.true_pose
    }

    /// Where the odometry says it is.
    #[must_use]
    pub fn odometry_pose(&self) -> Pose2 {
        self.odometry_pose
    }

    /// The velocities being driven: (m/s, rad/s).
    #[must_use]
    pub fn velocity(&self) -> (f64, f64) {
        (self.translation_velocity_mps, self.rotation_velocity_radps)
    }

    /// How many times the robot ran into something (one count per contact, however long).
    #[must_use]
    pub fn collision_count(&self) -> u64 {
        self.collision_count
    }

    /// Whether the last integration step was stopped by an obstacle.
    #[must_use]
    pub fn is_blocked(&self) -> bool {
        self.blocked
    }

    /// Which bumpers are pressed.
    #[must_use]
    pub fn bumpers(&self) -> &[bool] {
        &self.bumpers
    }

    /// Simulated time integrated so far, in ns.
    #[must_use]
    pub fn elapsed_ns(&self) -> i64 {
        self.elapsed_ns
    }

    /// The battery's charge, 0 to 1.
    #[must_use]
    pub fn charge_fraction(&self) -> f64 {
        self.charge_fraction
    }

    /// The Egomotion publication (header left for the service to fill).
    #[must_use]
    pub fn egomotion(&self) -> Egomotion {
        Egomotion {
            pose: self.odometry_pose.to_msg(),
            translation_velocity: self.measured_translation_velocity_mps,
            rotation_velocity: self.measured_rotation_velocity_radps,
            distance_travelled: self.distance_travelled_m,
            ..Egomotion::default()
        }
    }

    /// The Synchrodrive publication (header left for the service to fill).
    #[must_use]
    pub fn synchrodrive(&self) -> Synchrodrive {
        Synchrodrive {
            translation_velocity: self.translation_velocity_mps,
            rotation_velocity: self.rotation_velocity_radps,
            commanded_translation_velocity: self.commanded_translation_velocity_mps,
            commanded_rotation_velocity: self.commanded_rotation_velocity_radps,
            brake_on: self.brake_on,
            bumper_count: i32::try_from(self.bumpers.len()).unwrap_or(i32::MAX),
            bumpers: self.bumpers.clone(),
            ..Synchrodrive::default()
        }
    }

    /// The Power publication (header left for the service to fill). Draws the voltage
    /// reading's noise.
    pub fn power(&mut self) -> Power {
        let b = self.config.battery;
        let voltage = b.empty_voltage_v
            + (b.full_voltage_v - b.empty_voltage_v) * self.charge_fraction
            + self.rng.normal(0.0, b.voltage_noise_v);
        Power {
            voltage,
            charge_fraction: self.charge_fraction,
            charging: false,
            low: self.charge_fraction < b.low_threshold_fraction,
            ..Power::default()
        }
    }
}

/// The pose after driving `distance` while turning by `d_theta` (a circular arc).
fn arc(pose: Pose2, distance: f64, d_theta: f64) -> Pose2 {
    let heading = pose.heading_rad;
    let delta = if d_theta.abs() < 1e-12 {
        Vec2::from_angle(heading) * distance
    } else {
        let radius = distance / d_theta;
        let next = heading + d_theta;
        Vec2::new(
            radius * (next.sin() - heading.sin()),
            -radius * (next.cos() - heading.cos()),
        )
    };
    Pose2::new(
        pose.x_m + delta.x,
        pose.y_m + delta.y,
        wrap_angle(heading + d_theta),
    )
}
