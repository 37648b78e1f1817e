//! The sensor kinds: one ROS 2 topic (or a few of one sensor) in, one Lewis interface out,
//! one process each, so that one silent topic fails over alone.
//!
//! | kind | ROS 2 | Lewis |
//! |---|---|---|
//! | `ros2-laser` | `sensor_msgs/msg/LaserScan` | RangeFinder (uniform) |
//! | `ros2-ir` | `irobot_create_msgs/msg/IrIntensityVector` | RangeFinder (one reading per IR sensor, [`crate::ir`]'s model) |
//! | `ros2-range` | `sensor_msgs/msg/Range`, one topic per sensor | RangeFinder (one reading per topic) |
//! | `ros2-odometry` | `nav_msgs/msg/Odometry` | Egomotion |
//! | `ros2-battery` | `sensor_msgs/msg/BatteryState` | Power |
//! | `ros2-camera` | `sensor_msgs/msg/Image` or `CompressedImage` | ImageSource (rgb8) |
//!
//! Each waits in `on_start` (at most `first_sample_ms`) for its topic's first good sample,
//! so that the broker's rate check starts on a flowing topic; from then on it publishes
//! one Lewis message per good sample, stamped with Lewis's clock, and is out of service
//! while no good sample has come for `silence_ms` (the broker moves its clients; with
//! `fail_back` they come back when it is healthy again).

use lewis_interfaces::Interface;
use lewis_interfaces::dynamic::Value;
use lewis_interfaces::msg::{
    Egomotion, EgomotionCommand, EgomotionResetOdometryReply, ImageSource, ImageSourceCommand,
    ImageSourceSetRateReply, Pose2D, Pose3D, Power, PowerCommand, PowerSetLowThresholdReply,
    RangeFinder, RangeFinderCommand, RangeFinderGetGeometryReply,
};
use lewis_interfaces::ros2::{COMPRESSED_IMAGE, LASER_SCAN, ODOMETRY, TF_MESSAGE};
use lewis_ros2_map::from_ros2::{self, RangeCounts};
use lewis_ros2_map::robot::{self, BATTERY_STATE, IMAGE, IR_INTENSITY_VECTOR, RANGE};
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Reply, Service, ServiceConfig,
};
use serde::Deserialize;

use crate::gateway::{Freshness, Gateway, Link, Millis, TopicSpec, declare};
use crate::ir::IrModel;
use lewis_ros2_map::qos::QosProfile;

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
    fn pose(&self, bearing_rad: f64) -> Pose3D {
        Pose3D {
            x: self.x_m,
            y: self.y_m,
            z: self.height_m,
            theta: self.heading_deg.to_radians() + bearing_rad,
            ..Pose3D::default()
        }
    }
}

/// The keys every sensor kind takes besides its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Timing {
    /// No good sample for this long is out of service, in ms.
    pub silence_ms: Millis,
    /// How long the start waits for a first good sample, in ms (the robot file's startup
    /// deadline must be longer).
    pub first_sample_ms: Millis,
}

impl Default for Timing {
    fn default() -> Self {
        Self {
            silence_ms: Millis(500),
            first_sample_ms: Millis(5_000),
        }
    }
}

fn invalid(config: &ServiceConfig<'_>, reason: impl Into<String>) -> BuildError {
    BuildError::Parameters {
        service: config.name().to_owned(),
        reason: reason.into(),
    }
}

/// What one kind makes of its samples and commands.
trait Kind {
    /// The interface it publishes.
    const INTERFACE: &'static str;

    /// A good sample of reader `reader`: publish what it means. `Err` counts it as
    /// unusable (a field out of its limits).
    fn sample(&mut self, ctx: &mut Context<'_>, reader: usize, value: &Value)
    -> Result<(), String>;

    /// Whether reader `reader`'s samples are the sensor's data (what keeps it healthy), not
    /// something beside it (`/tf_static`).
    fn is_data(&self, reader: usize) -> bool {
        let _ = reader;
        true
    }

    /// A command of its interface.
    fn command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError>;
}

/// A sensor kind as a service: the gateway, its health, the kind.
struct Sensor<K> {
    link: Link,
    topics: Vec<TopicSpec>,
    timing: Timing,
    gateway: Option<Gateway>,
    freshness: Freshness,
    flood: Option<Flood>,
    kind: K,
}

/// A topic published much faster than the robot file says: samples beyond
/// [`Flood::FACTOR`] times the declared rate over the last second are dropped (counted, said
/// once), so a flooding publisher cannot drown the gateway or its clients; a burst within
/// that is taken.
#[derive(Debug, Clone)]
struct Flood {
    per_second: usize,
    taken_ns: std::collections::VecDeque<i64>,
}

impl Flood {
    /// How much faster than declared a topic may go.
    const FACTOR: f64 = 3.0;

    fn new(declared_hz: f64) -> Option<Self> {
        (declared_hz.is_finite() && declared_hz > 0.0).then(|| Self {
            // At most a few thousand: a count, not a rate.
            per_second: (declared_hz * Self::FACTOR).ceil().max(1.0) as usize,
            taken_ns: std::collections::VecDeque::new(),
        })
    }

    /// Whether a sample at `now_ns` is within the rate (and so taken).
    fn admit(&mut self, now_ns: i64) -> bool {
        while self
            .taken_ns
            .front()
            .is_some_and(|&at| now_ns - at >= 1_000_000_000)
        {
            self.taken_ns.pop_front();
        }
        if self.taken_ns.len() >= self.per_second {
            return false;
        }
        self.taken_ns.push_back(now_ns);
        true
    }
}

impl<K: Kind> Sensor<K> {
    fn new(link: Link, topics: Vec<TopicSpec>, timing: Timing, kind: K) -> Self {
        Self {
            link,
            topics,
            timing,
            gateway: None,
            freshness: Freshness::new(timing.silence_ms.duration()),
            flood: None,
            kind,
        }
    }

    /// Samples of the first topic beyond three times `config`'s declared rate (its
    /// `data_rate_hz`, if any) are dropped.
    fn with_rate_of(mut self, config: &ServiceConfig<'_>) -> Self {
        self.flood = config
            .spec
            .provision(K::INTERFACE)
            .and_then(|p| p.data_rate_hz)
            .and_then(Flood::new);
        self
    }

    fn handle(&mut self, ctx: &mut Context<'_>, values: Vec<(usize, Value)>) {
        let now = ctx.now();
        for (reader, value) in values {
            if reader == 0
                && let Some(flood) = &mut self.flood
                && !flood.admit(now)
            {
                if let Some(intake) = self.gateway.as_mut().and_then(|g| g.intakes.first_mut()) {
                    let detail = format!(
                        "faster than {} times the robot file's data_rate_hz",
                        Flood::FACTOR
                    );
                    intake.bad(ctx, "flooding", &detail);
                }
                continue;
            }
            match self.kind.sample(ctx, reader, &value) {
                Ok(()) if self.kind.is_data(reader) => self.freshness.good(ctx.now()),
                Ok(()) => {}
                Err(why) => {
                    if let Some(intake) = self
                        .gateway
                        .as_mut()
                        .and_then(|g| g.intakes.get_mut(reader))
                    {
                        intake.bad(ctx, "unusable", &why);
                    }
                }
            }
        }
        self.check(ctx);
    }

    fn check(&mut self, ctx: &mut Context<'_>) {
        if let Some(intake) = self.gateway.as_ref().and_then(|g| g.intakes.first()) {
            let health = self.freshness.health(ctx.now(), intake);
            declare(ctx, health);
        }
    }
}

impl<K: Kind> Service for Sensor<K> {
    fn tick_period_ns(&self) -> Option<i64> {
        // A quarter of the silence allowed: silence is seen within 125% of it.
        Some(i64::try_from(self.timing.silence_ms.get()).unwrap_or(500) * 250_000)
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        let mut gateway = Gateway::open(&self.link, &self.topics)?;
        let names: Vec<&str> = self.topics.iter().map(|t| t.topic.as_str()).collect();
        ctx.info(&format!(
            "reading {} in DDS domain {} as {}",
            names.join(", "),
            self.link.domain()?,
            K::INTERFACE
        ));
        let limit = self.timing.first_sample_ms.duration();
        let (taken, arrived) = gateway.wait_first(ctx, 0, limit);
        self.gateway = Some(gateway);
        if !arrived {
            ctx.warn(&format!(
                "no {} within {} ms of the start: is the robot on, in this domain and namespace?",
                names.first().copied().unwrap_or_default(),
                self.timing.first_sample_ms.get()
            ));
        }
        self.handle(ctx, taken);
        Ok(())
    }

    fn device(&self) -> Option<std::os::fd::BorrowedFd<'_>> {
        self.gateway.as_ref().map(Gateway::fd)
    }

    fn on_device(&mut self, ctx: &mut Context<'_>) {
        let values = match self.gateway.as_mut() {
            Some(gateway) => gateway.take(ctx),
            None => return,
        };
        self.handle(ctx, values);
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        // Whatever a missed wake-up left behind, then the health.
        self.on_device(ctx);
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        if command.interface != K::INTERFACE {
            return Err(CommandError::new(format!(
                "this service serves {}, not {}",
                K::INTERFACE,
                command.interface
            )));
        }
        self.kind.command(ctx, command)
    }
}

fn publish<T: Interface>(ctx: &mut Context<'_>, message: &mut T) {
    if let Err(e) = ctx.publish(message) {
        ctx.warn(&format!("cannot publish {}: {e}", T::NAME));
    }
}

fn geometry_reply(
    ctx: &mut Context<'_>,
    command: &IncomingCommand<'_>,
    range_count: usize,
    max_range: f64,
    rate_hz: f64,
) -> Result<Reply, CommandError> {
    match command.decode::<RangeFinder>()? {
        RangeFinderCommand::GetGeometry(_) => Ok(ctx.reply(RangeFinderGetGeometryReply {
            range_count: i32::try_from(range_count).unwrap_or(i32::MAX),
            max_range,
            rate: rate_hz,
            ..RangeFinderGetGeometryReply::default()
        })),
    }
}

// ---- ros2-laser ---------------------------------------------------------------------

/// The kind name of the laser.
pub const LASER: &str = "ros2-laser";

/// The parameters of `ros2-laser`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaserParams {
    /// The LaserScan topic.
    #[serde(default = "defaults::scan")]
    pub topic: String,
    /// Its QoS (default: ROS 2's sensor data, best effort).
    #[serde(default = "defaults::sensor_qos")]
    pub qos: QosProfile,
    /// How to reach the robot.
    #[serde(default)]
    pub dds: Link,
    /// Where the laser sits on the robot.
    #[serde(default)]
    pub mount: Mount,
    /// Scans per second, for the geometry clients ask for.
    #[serde(default = "defaults::laser_rate_hz")]
    pub rate_hz: f64,
    /// The robot's static transforms, against which `mount` is checked once both the
    /// scan's frame and a chain from `base_frame` to it are known ("": no check).
    #[serde(default = "defaults::tf_static")]
    pub tf_static_topic: String,
    /// The robot's frame, whose origin `mount` is given from.
    #[serde(default = "defaults::base_frame")]
    pub base_frame: String,
    /// Silence and start.
    #[serde(default)]
    pub timing: Timing,
    /// Accepted so that every robot file may give one.
    pub seed: Option<u64>,
}

mod defaults {
    pub(super) fn tf_static() -> String {
        "/tf_static".to_owned()
    }
    pub(super) fn base_frame() -> String {
        "base_link".to_owned()
    }
    use lewis_ros2_map::qos::QosProfile;

    pub(super) fn scan() -> String {
        "/scan".to_owned()
    }
    pub(super) fn ir() -> String {
        "/ir_intensity".to_owned()
    }
    pub(super) fn odom() -> String {
        "/odom".to_owned()
    }
    pub(super) fn battery() -> String {
        "/battery_state".to_owned()
    }
    pub(super) fn sensor_qos() -> QosProfile {
        QosProfile::SENSOR_DATA
    }
    pub(super) fn laser_rate_hz() -> f64 {
        10.0
    }
    pub(super) fn ir_rate_hz() -> f64 {
        62.0
    }
    pub(super) fn low_charge_fraction() -> f64 {
        0.2
    }
    pub(super) fn image_type() -> super::ImageType {
        super::ImageType::Image
    }
}

struct Laser {
    mount: Mount,
    rate_hz: f64,
    counts: RangeCounts,
    last: (usize, f64),
    mount_check: MountCheck,
}

/// The robot file's mount of a sensor against the robot's `/tf_static`, said once.
#[derive(Debug, Clone, Default)]
struct MountCheck {
    base_frame: String,
    frame: Option<String>,
    transforms: Vec<robot::PlanarTransform>,
    done: bool,
}

impl MountCheck {
    /// Distance and angle within which the two agree.
    const TOLERANCE_M: f64 = 0.02;
    const TOLERANCE_DEG: f64 = 2.0;

    fn frame(&mut self, ctx: &mut Context<'_>, frame: &str, mount: &Mount) {
        if self.frame.as_deref() != Some(frame) {
            self.frame = Some(frame.trim_start_matches('/').to_owned());
            self.check(ctx, mount);
        }
    }

    fn transforms(
        &mut self,
        ctx: &mut Context<'_>,
        value: &Value,
        mount: &Mount,
    ) -> Result<(), String> {
        for t in robot::transforms(value)? {
            self.transforms.retain(|known| known.child != t.child);
            self.transforms.push(t);
        }
        self.check(ctx, mount);
        Ok(())
    }

    fn check(&mut self, ctx: &mut Context<'_>, mount: &Mount) {
        let Some(frame) = &self.frame else { return };
        if self.done {
            return;
        }
        let Some(tf) = robot::frame_in(&self.transforms, &self.base_frame, frame) else {
            return;
        };
        self.done = true;
        let heading = tf.yaw.to_degrees();
        let turn = (heading - mount.heading_deg + 180.0).rem_euclid(360.0) - 180.0;
        let agree = (tf.x - mount.x_m).abs() <= Self::TOLERANCE_M
            && (tf.y - mount.y_m).abs() <= Self::TOLERANCE_M
            && (tf.z - mount.height_m).abs() <= Self::TOLERANCE_M
            && turn.abs() <= Self::TOLERANCE_DEG;
        let tf_text = format!(
            "x {:.3} m, y {:.3} m, height {:.3} m, heading {heading:.1} deg",
            tf.x, tf.y, tf.z
        );
        if agree {
            ctx.info(&format!(
                "mount agrees with /tf_static's {} -> {frame} ({tf_text})",
                self.base_frame
            ));
        } else {
            ctx.warn(&format!(
                "mount mismatch: the robot file puts {frame} at x {:.3} m, y {:.3} m, height {:.3} m, heading {:.1} deg; /tf_static's {} -> {frame} is {tf_text} (the robot file's is used)",
                mount.x_m, mount.y_m, mount.height_m, mount.heading_deg, self.base_frame
            ));
        }
    }
}

impl Kind for Laser {
    const INTERFACE: &'static str = RangeFinder::NAME;

    fn is_data(&self, reader: usize) -> bool {
        reader == 0
    }

    fn sample(
        &mut self,
        ctx: &mut Context<'_>,
        reader: usize,
        value: &Value,
    ) -> Result<(), String> {
        if reader == 1 {
            return self.mount_check.transforms(ctx, value, &self.mount);
        }
        let scan = from_ros2::laser_scan(value)?;
        if let Some(frame) = value.get("header.frame_id").and_then(Value::as_str) {
            self.mount_check.frame(ctx, frame, &self.mount);
        }
        let mut reading = from_ros2::range_finder(&scan, &mut self.counts);
        reading.sensor_positions = (0..reading.ranges.len())
            .map(|i| {
                self.mount
                    .pose(scan.angle_min_rad + scan.angle_increment_rad * i as f64)
            })
            .collect();
        reading.x_offset = self.mount.x_m;
        reading.y_offset = self.mount.y_m;
        reading.z_offset = self.mount.height_m;
        reading.theta_offset = self.mount.heading_deg.to_radians() + scan.angle_min_rad;
        self.last = (reading.ranges.len(), reading.max_range);
        publish(ctx, &mut reading);
        Ok(())
    }

    fn command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        geometry_reply(ctx, command, self.last.0, self.last.1, self.rate_hz)
    }
}

fn build_laser(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: LaserParams = config.parameters()?;
    let mut topics = vec![TopicSpec {
        topic: params.topic,
        type_name: LASER_SCAN,
        qos: params.qos,
    }];
    if !params.tf_static_topic.is_empty() {
        topics.push(TopicSpec {
            topic: params.tf_static_topic,
            type_name: TF_MESSAGE,
            qos: crate::dds::TF_STATIC_READER,
        });
    }
    Ok(Box::new(
        Sensor::new(
            params.dds,
            topics,
            params.timing,
            Laser {
                mount: params.mount,
                rate_hz: params.rate_hz,
                counts: RangeCounts::default(),
                last: (0, 0.0),
                mount_check: MountCheck {
                    base_frame: params.base_frame,
                    ..MountCheck::default()
                },
            },
        )
        .with_rate_of(config),
    ))
}

// ---- ros2-ir ------------------------------------------------------------------------

/// The kind name of the Create 3's IR ring.
pub const IR: &str = "ros2-ir";

/// One IR sensor: its frame in the IrIntensityVector and where it looks.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IrSensor {
    /// Its `header.frame_id` in the vector (`ir_intensity_front_left`).
    pub frame: String,
    /// Forward of the robot's centre, in m.
    #[serde(default)]
    pub x_m: f64,
    /// Left of the robot's centre, in m.
    #[serde(default)]
    pub y_m: f64,
    /// Where it looks, counter-clockwise from straight ahead, in degrees.
    #[serde(default)]
    pub heading_deg: f64,
    /// Above the floor, in m.
    #[serde(default)]
    pub height_m: f64,
}

/// The parameters of `ros2-ir`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IrParams {
    /// The IrIntensityVector topic.
    #[serde(default = "defaults::ir")]
    pub topic: String,
    /// Its QoS (default: sensor data).
    #[serde(default = "defaults::sensor_qos")]
    pub qos: QosProfile,
    /// How to reach the robot.
    #[serde(default)]
    pub dds: Link,
    /// The sensors, in the order of the RangeFinder's readings.
    pub sensors: Vec<IrSensor>,
    /// Intensity to distance.
    #[serde(default)]
    pub model: IrModel,
    /// Vectors per second, for the geometry clients ask for.
    #[serde(default = "defaults::ir_rate_hz")]
    pub rate_hz: f64,
    /// The robot's static transforms, against which each sensor's pose is checked ("": no
    /// check).
    #[serde(default = "defaults::tf_static")]
    pub tf_static_topic: String,
    /// The robot's frame, whose origin the sensors' poses are given from.
    #[serde(default = "defaults::base_frame")]
    pub base_frame: String,
    /// Silence and start.
    #[serde(default)]
    pub timing: Timing,
    /// Accepted so that every robot file may give one.
    pub seed: Option<u64>,
}

struct IrRing {
    sensors: Vec<IrSensor>,
    model: IrModel,
    rate_hz: f64,
    missing_said: bool,
    /// One per sensor, its frame known from the robot file.
    mount_checks: Vec<MountCheck>,
}

impl IrSensor {
    fn mount(&self) -> Mount {
        Mount {
            x_m: self.x_m,
            y_m: self.y_m,
            heading_deg: self.heading_deg,
            height_m: self.height_m,
        }
    }
}

impl Kind for IrRing {
    const INTERFACE: &'static str = RangeFinder::NAME;

    fn is_data(&self, reader: usize) -> bool {
        reader == 0
    }

    fn sample(
        &mut self,
        ctx: &mut Context<'_>,
        reader: usize,
        value: &Value,
    ) -> Result<(), String> {
        if reader == 1 {
            for (check, sensor) in self.mount_checks.iter_mut().zip(&self.sensors) {
                check.transforms(ctx, value, &sensor.mount())?;
            }
            return Ok(());
        }
        let readings = robot::ir_intensities(value)?;
        let mut ranges = Vec::with_capacity(self.sensors.len());
        let mut missing = Vec::new();
        for sensor in &self.sensors {
            match readings.iter().find(|r| r.frame_id == sensor.frame) {
                // Raw intensities are int16: exact in f64.
                Some(r) => ranges.push(self.model.distance_m(r.value as f64)),
                None => {
                    missing.push(sensor.frame.as_str());
                    ranges.push(self.model.max_range_m);
                }
            }
        }
        if missing.len() == self.sensors.len() {
            return Err(format!(
                "none of the robot file's IR frames is in the vector (it has {})",
                readings
                    .iter()
                    .map(|r| r.frame_id.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        if !missing.is_empty() && !self.missing_said {
            self.missing_said = true;
            ctx.warn(&format!(
                "IR frames missing from the vector, read as nothing seen: {} (said once)",
                missing.join(", ")
            ));
        }
        let mut reading = RangeFinder {
            range_count: i32::try_from(ranges.len()).unwrap_or(i32::MAX),
            ranges,
            max_range: self.model.max_range_m,
            uniform: false,
            sensor_positions: self
                .sensors
                .iter()
                .map(|s| Pose3D {
                    x: s.x_m,
                    y: s.y_m,
                    z: s.height_m,
                    theta: s.heading_deg.to_radians(),
                    ..Pose3D::default()
                })
                .collect(),
            ..RangeFinder::default()
        };
        publish(ctx, &mut reading);
        Ok(())
    }

    fn command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        geometry_reply(
            ctx,
            command,
            self.sensors.len(),
            self.model.max_range_m,
            self.rate_hz,
        )
    }
}

fn build_ir(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: IrParams = config.parameters()?;
    if params.sensors.is_empty() {
        return Err(invalid(config, "`sensors` is empty: name the IR frames"));
    }
    let mut topics = vec![TopicSpec {
        topic: params.topic,
        type_name: IR_INTENSITY_VECTOR,
        qos: params.qos,
    }];
    if !params.tf_static_topic.is_empty() {
        topics.push(TopicSpec {
            topic: params.tf_static_topic,
            type_name: TF_MESSAGE,
            qos: crate::dds::TF_STATIC_READER,
        });
    }
    let mount_checks = params
        .sensors
        .iter()
        .map(|sensor| MountCheck {
            base_frame: params.base_frame.clone(),
            frame: Some(sensor.frame.trim_start_matches('/').to_owned()),
            ..MountCheck::default()
        })
        .collect();
    Ok(Box::new(
        Sensor::new(
            params.dds,
            topics,
            params.timing,
            IrRing {
                sensors: params.sensors,
                model: params.model,
                rate_hz: params.rate_hz,
                missing_said: false,
                mount_checks,
            },
        )
        .with_rate_of(config),
    ))
}

// ---- ros2-range ---------------------------------------------------------------------

/// The kind name of `sensor_msgs/msg/Range` sensors.
pub const RANGE_KIND: &str = "ros2-range";

/// One Range topic and where its sensor sits.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RangeTopic {
    /// The topic.
    pub topic: String,
    /// Where the sensor sits.
    #[serde(default)]
    pub mount: Mount,
}

/// The parameters of `ros2-range`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RangeParams {
    /// The sensors, one topic each, in the order of the RangeFinder's readings.
    pub topics: Vec<RangeTopic>,
    /// Their QoS (default: sensor data).
    #[serde(default = "defaults::sensor_qos")]
    pub qos: QosProfile,
    /// How to reach the robot.
    #[serde(default)]
    pub dds: Link,
    /// The farthest reading, in m, until each sensor said its own.
    pub max_range_m: f64,
    /// Readings per second of each sensor, for the geometry clients ask for.
    #[serde(default = "defaults::laser_rate_hz")]
    pub rate_hz: f64,
    /// Silence (of the first topic) and start.
    #[serde(default)]
    pub timing: Timing,
    /// Accepted so that every robot file may give one.
    pub seed: Option<u64>,
}

struct Ranges {
    mounts: Vec<Mount>,
    latest: Vec<f64>,
    max_range_m: f64,
    rate_hz: f64,
}

impl Kind for Ranges {
    const INTERFACE: &'static str = RangeFinder::NAME;

    fn sample(
        &mut self,
        ctx: &mut Context<'_>,
        reader: usize,
        value: &Value,
    ) -> Result<(), String> {
        let reading = robot::range(value)?;
        if let Some(slot) = self.latest.get_mut(reader) {
            *slot = reading.distance_m();
        }
        self.max_range_m = self.max_range_m.max(reading.max_range_m);
        let mut message = RangeFinder {
            range_count: i32::try_from(self.latest.len()).unwrap_or(i32::MAX),
            ranges: self.latest.clone(),
            max_range: self.max_range_m,
            uniform: false,
            sensor_positions: self.mounts.iter().map(|m| m.pose(0.0)).collect(),
            ..RangeFinder::default()
        };
        publish(ctx, &mut message);
        Ok(())
    }

    fn command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        geometry_reply(
            ctx,
            command,
            self.latest.len(),
            self.max_range_m,
            self.rate_hz,
        )
    }
}

fn build_range(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: RangeParams = config.parameters()?;
    if params.topics.is_empty() {
        return Err(invalid(config, "`topics` is empty: name the Range topics"));
    }
    if !(params.max_range_m.is_finite() && params.max_range_m > 0.0) {
        return Err(invalid(
            config,
            format!(
                "`max_range_m` is {}: give a positive number",
                params.max_range_m
            ),
        ));
    }
    let topics = params
        .topics
        .iter()
        .map(|t| TopicSpec {
            topic: t.topic.clone(),
            type_name: RANGE,
            qos: params.qos,
        })
        .collect();
    Ok(Box::new(
        Sensor::new(
            params.dds,
            topics,
            params.timing,
            Ranges {
                latest: vec![params.max_range_m; params.topics.len()],
                mounts: params.topics.iter().map(|t| t.mount).collect(),
                max_range_m: params.max_range_m,
                rate_hz: params.rate_hz,
            },
        )
        .with_rate_of(config),
    ))
}

// ---- ros2-odometry ------------------------------------------------------------------

/// The kind name of odometry.
pub const ODOMETRY_KIND: &str = "ros2-odometry";

/// The parameters of `ros2-odometry`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdometryParams {
    /// The Odometry topic.
    #[serde(default = "defaults::odom")]
    pub topic: String,
    /// Its QoS (default: sensor data; a reader of best effort matches reliable writers too).
    #[serde(default = "defaults::sensor_qos")]
    pub qos: QosProfile,
    /// How to reach the robot.
    #[serde(default)]
    pub dds: Link,
    /// Silence and start.
    #[serde(default)]
    pub timing: Timing,
    /// Accepted so that every robot file may give one.
    pub seed: Option<u64>,
}

/// The planar transform `a` then `b`.
fn compose(a: &Pose2D, b: &Pose2D) -> Pose2D {
    let (s, c) = a.theta.sin_cos();
    Pose2D {
        x: a.x + c * b.x - s * b.y,
        y: a.y + s * b.x + c * b.y,
        theta: wrap(a.theta + b.theta),
    }
}

fn inverse(a: &Pose2D) -> Pose2D {
    let (s, c) = a.theta.sin_cos();
    Pose2D {
        x: -c * a.x - s * a.y,
        y: s * a.x - c * a.y,
        theta: wrap(-a.theta),
    }
}

/// Into [-pi, pi), Lewis's one angle convention.
fn wrap(angle: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    (angle + std::f64::consts::PI).rem_euclid(two_pi) - std::f64::consts::PI
}

struct Odometry {
    /// Published pose = `offset` then the robot's pose (after `reset_odometry`).
    offset: Pose2D,
    last_raw: Option<Pose2D>,
    travelled_m: f64,
}

impl Kind for Odometry {
    const INTERFACE: &'static str = Egomotion::NAME;

    fn sample(&mut self, ctx: &mut Context<'_>, _: usize, value: &Value) -> Result<(), String> {
        let odometry = from_ros2::odometry(value)?;
        let raw = odometry.pose;
        if let Some(last) = &self.last_raw {
            self.travelled_m += (raw.x - last.x).hypot(raw.y - last.y);
        }
        let pose = compose(&self.offset, &raw);
        self.last_raw = Some(raw);
        let mut message = Egomotion {
            pose,
            translation_velocity: odometry.translation_mps,
            rotation_velocity: odometry.rotation_radps,
            distance_travelled: self.travelled_m,
            ..Egomotion::default()
        };
        publish(ctx, &mut message);
        Ok(())
    }

    fn command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        match command.decode::<Egomotion>()? {
            EgomotionCommand::ResetOdometry(c) => {
                let pose = c.pose;
                if !(pose.x.is_finite() && pose.y.is_finite() && pose.theta.is_finite()) {
                    return Err(CommandError::new(
                        "reset_odometry: the pose has a coordinate that is not a number",
                    ));
                }
                // The robot's odometry is its own: Lewis's pose is shifted so that the
                // robot's present pose reads `pose`.
                let raw = self.last_raw.clone().unwrap_or_default();
                self.offset = compose(&pose, &inverse(&raw));
                Ok(ctx.reply(EgomotionResetOdometryReply::default()))
            }
        }
    }
}

fn build_odometry(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: OdometryParams = config.parameters()?;
    let topics = vec![TopicSpec {
        topic: params.topic,
        type_name: ODOMETRY,
        qos: params.qos,
    }];
    Ok(Box::new(
        Sensor::new(
            params.dds,
            topics,
            params.timing,
            Odometry {
                offset: Pose2D::default(),
                last_raw: None,
                travelled_m: 0.0,
            },
        )
        .with_rate_of(config),
    ))
}

// ---- ros2-battery -------------------------------------------------------------------

/// The kind name of the battery.
pub const BATTERY: &str = "ros2-battery";

/// The parameters of `ros2-battery`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BatteryParams {
    /// The BatteryState topic.
    #[serde(default = "defaults::battery")]
    pub topic: String,
    /// Its QoS (default: sensor data).
    #[serde(default = "defaults::sensor_qos")]
    pub qos: QosProfile,
    /// How to reach the robot.
    #[serde(default)]
    pub dds: Link,
    /// Below this charge fraction, Power says low.
    #[serde(default = "defaults::low_charge_fraction")]
    pub low_charge_fraction: f64,
    /// Silence and start (a battery speaks seldom: give a long silence).
    #[serde(default)]
    pub timing: Timing,
    /// Accepted so that every robot file may give one.
    pub seed: Option<u64>,
}

struct Battery {
    low_charge_fraction: f64,
}

impl Kind for Battery {
    const INTERFACE: &'static str = Power::NAME;

    fn sample(&mut self, ctx: &mut Context<'_>, _: usize, value: &Value) -> Result<(), String> {
        let battery = robot::battery(value)?;
        if !(battery.voltage_v.is_finite() && battery.charge_fraction.is_finite()) {
            return Err(format!(
                "voltage {} V, percentage {}: not numbers Power can carry",
                battery.voltage_v, battery.charge_fraction
            ));
        }
        let mut power = Power {
            voltage: battery.voltage_v,
            charge_fraction: battery.charge_fraction,
            charging: battery.charging,
            low: battery.charge_fraction < self.low_charge_fraction,
            ..Power::default()
        };
        publish(ctx, &mut power);
        Ok(())
    }

    fn command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        match command.decode::<Power>()? {
            PowerCommand::SetLowThreshold(c) => {
                if !(0.0..=1.0).contains(&c.charge_fraction) {
                    return Err(CommandError::new(format!(
                        "set_low_threshold: charge_fraction is {}, expected between 0 and 1",
                        c.charge_fraction
                    )));
                }
                self.low_charge_fraction = c.charge_fraction;
                Ok(ctx.reply(PowerSetLowThresholdReply::default()))
            }
        }
    }
}

fn build_battery(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: BatteryParams = config.parameters()?;
    if !(0.0..=1.0).contains(&params.low_charge_fraction) {
        return Err(invalid(
            config,
            format!(
                "`low_charge_fraction` is {}: give 0 to 1",
                params.low_charge_fraction
            ),
        ));
    }
    let topics = vec![TopicSpec {
        topic: params.topic,
        type_name: BATTERY_STATE,
        qos: params.qos,
    }];
    Ok(Box::new(
        Sensor::new(
            params.dds,
            topics,
            params.timing,
            Battery {
                low_charge_fraction: params.low_charge_fraction,
            },
        )
        .with_rate_of(config),
    ))
}

// ---- ros2-camera --------------------------------------------------------------------

/// The kind name of a camera.
pub const CAMERA: &str = "ros2-camera";

/// Which message the camera's topic carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ImageType {
    /// `sensor_msgs/msg/Image` (rgb8, bgr8, mono8, yuv422, yuv422_yuy2).
    Image,
    /// `sensor_msgs/msg/CompressedImage` (JPEG or PNG).
    CompressedImage,
}

/// A pinhole camera's intrinsics, as `sensor_msgs/msg/CameraInfo`'s `k` gives them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Intrinsics {
    /// Focal length along the rows, in px (`k[0]`).
    pub fx: f64,
    /// Focal length along the columns, in px (`k[4]`).
    pub fy: f64,
    /// Principal point, column (`k[2]`).
    pub cx: f64,
    /// Principal point, row (`k[5]`).
    pub cy: f64,
}

/// The parameters of `ros2-camera`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraParams {
    /// The image topic.
    pub topic: String,
    /// Image or CompressedImage.
    #[serde(default = "defaults::image_type")]
    pub image_type: ImageType,
    /// Its QoS (default: sensor data).
    #[serde(default = "defaults::sensor_qos")]
    pub qos: QosProfile,
    /// How to reach the robot.
    #[serde(default)]
    pub dds: Link,
    /// The camera's intrinsics (absent: zeros, "unknown", as an import without CameraInfo).
    pub intrinsics: Option<Intrinsics>,
    /// Frames per second published at most (`ImageSource.set_rate` changes it; absent: every
    /// frame).
    pub max_rate_hz: Option<f64>,
    /// Silence and start.
    #[serde(default)]
    pub timing: Timing,
    /// Accepted so that every robot file may give one.
    pub seed: Option<u64>,
}

struct Camera {
    image_type: ImageType,
    intrinsics: Intrinsics,
    /// Frames per second published at most.
    max_rate_hz: Option<f64>,
    last_published_ns: Option<i64>,
}

impl Kind for Camera {
    const INTERFACE: &'static str = ImageSource::NAME;

    fn sample(&mut self, ctx: &mut Context<'_>, _: usize, value: &Value) -> Result<(), String> {
        let now = ctx.now();
        if let (Some(rate), Some(last)) = (self.max_rate_hz, self.last_published_ns)
            && ((now - last) as f64) < 1e9 / rate
        {
            // A good frame, not wanted now.
            return Ok(());
        }
        let (width, height, rgb) = match self.image_type {
            ImageType::Image => from_ros2::image(value),
            ImageType::CompressedImage => from_ros2::compressed_image(value),
        }
        .map_err(|e| e.to_string())?;
        let mut image = from_ros2::image_source(width, height, rgb);
        image.focal_length_x = self.intrinsics.fx;
        image.focal_length_y = self.intrinsics.fy;
        image.principal_point_x = self.intrinsics.cx;
        image.principal_point_y = self.intrinsics.cy;
        publish(ctx, &mut image);
        self.last_published_ns = Some(now);
        Ok(())
    }

    fn command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        match command.decode::<ImageSource>()? {
            ImageSourceCommand::SetRate(c) => {
                if !(c.rate.is_finite() && c.rate > 0.0) {
                    return Err(CommandError::new(format!(
                        "set_rate: {} Hz is not a rate",
                        c.rate
                    )));
                }
                // The robot's camera keeps its own rate: Lewis publishes at most this many.
                self.max_rate_hz = Some(c.rate);
                Ok(ctx.reply(ImageSourceSetRateReply {
                    rate: c.rate,
                    ..ImageSourceSetRateReply::default()
                }))
            }
        }
    }
}

fn build_camera(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: CameraParams = config.parameters()?;
    if let Some(rate) = params.max_rate_hz
        && !(rate.is_finite() && rate > 0.0)
    {
        return Err(invalid(
            config,
            format!("`max_rate_hz` is {rate}: give a positive rate"),
        ));
    }
    let type_name = match params.image_type {
        ImageType::Image => IMAGE,
        ImageType::CompressedImage => COMPRESSED_IMAGE,
    };
    let topics = vec![TopicSpec {
        topic: params.topic,
        type_name,
        qos: params.qos,
    }];
    Ok(Box::new(
        Sensor::new(
            params.dds,
            topics,
            params.timing,
            Camera {
                image_type: params.image_type,
                intrinsics: params.intrinsics.unwrap_or_default(),
                max_rate_hz: params.max_rate_hz,
                last_published_ns: None,
            },
        )
        .with_rate_of(config),
    ))
}

/// Registers the sensor kinds with their parameters.
pub fn register(registry: &mut lewis_service::ServiceRegistry) {
    registry.register_with_parameters::<LaserParams>(LASER, build_laser);
    registry.register_with_parameters::<IrParams>(IR, build_ir);
    registry.register_with_parameters::<RangeParams>(RANGE_KIND, build_range);
    registry.register_with_parameters::<OdometryParams>(ODOMETRY_KIND, build_odometry);
    registry.register_with_parameters::<BatteryParams>(BATTERY, build_battery);
    registry.register_with_parameters::<CameraParams>(CAMERA, build_camera);
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use lewis_interfaces::cdr::{self, Encode, Sink};
    use lewis_interfaces::dynamic::Decoder;
    use lewis_interfaces::ros2::Header;
    use lewis_ros2_map::robot::schema_texts;
    use lewis_service::ContextState;
    use lewis_testkit::{RecordingBackend, decoded};

    use super::*;

    /// A message of `type_name` encoded by `encode`, as the gateway's decoder reads it.
    fn value(type_name: &str, message: &impl Encode) -> Value {
        Decoder::new(type_name, &schema_texts(type_name)[0])
            .unwrap()
            .decode(&cdr::to_vec(message))
            .unwrap()
    }

    struct IrVector(Vec<(&'static str, i16)>);

    impl Encode for IrVector {
        fn encode<S: Sink>(&self, sink: &mut S) {
            let header = |frame: &str| Header {
                stamp_ns: 1,
                frame_id: frame.into(),
            };
            header("base_link").encode(sink);
            u32::try_from(self.0.len()).unwrap().encode(sink);
            for (frame, value) in &self.0 {
                header(frame).encode(sink);
                value.encode(sink);
            }
        }
    }

    fn sensor(frame: &str, heading_deg: f64) -> IrSensor {
        IrSensor {
            frame: frame.into(),
            x_m: 0.1,
            y_m: 0.0,
            heading_deg,
            height_m: 0.05,
        }
    }

    #[test]
    fn ir_intensities_become_distances_where_the_sensors_look() {
        let mut ring = IrRing {
            sensors: vec![
                sensor("ir_left", 30.0),
                sensor("ir_front", 0.0),
                sensor("ir_gone", -30.0),
            ],
            model: IrModel::default(),
            rate_hz: 62.0,
            missing_said: false,
            mount_checks: Vec::new(),
        };
        let mut backend = RecordingBackend::default();
        let mut state = ContextState::new("ir", 1);
        let mut ctx = state.context(&mut backend);
        let vector = value(
            IR_INTENSITY_VECTOR,
            &IrVector(vec![("ir_front", 400), ("ir_left", 3)]),
        );
        ring.sample(&mut ctx, 0, &vector).unwrap();
        ring.sample(&mut ctx, 0, &vector).unwrap();
        let published = decoded::<RangeFinder>(&backend.published);
        assert_eq!(published.len(), 2);
        let reading = &published[0];
        assert!(!reading.uniform);
        assert_eq!(reading.ranges.len(), 3);
        assert_eq!(reading.ranges[0], 0.2, "below the floor: nothing seen");
        assert!((reading.ranges[1] - 0.05).abs() < 1e-12);
        assert_eq!(reading.ranges[2], 0.2, "missing: nothing seen");
        assert!((reading.sensor_positions[0].theta - 30f64.to_radians()).abs() < 1e-12);
        let missing = backend
            .logs
            .iter()
            .filter(|(_, t)| t.contains("ir_gone"))
            .count();
        assert_eq!(missing, 1, "a missing frame is said once");
        // A vector with none of the robot file's frames is unusable, not a reading.
        let strange = value(IR_INTENSITY_VECTOR, &IrVector(vec![("other", 5)]));
        let mut ctx = state.context(&mut backend);
        assert!(ring.sample(&mut ctx, 0, &strange).is_err());
    }

    struct Image {
        encoding: &'static str,
        width: u32,
        height: u32,
        step: u32,
        data: Vec<u8>,
    }

    impl Encode for Image {
        fn encode<S: Sink>(&self, sink: &mut S) {
            Header {
                stamp_ns: 1,
                frame_id: "oakd_rgb_camera_optical_frame".into(),
            }
            .encode(sink);
            self.height.encode(sink);
            self.width.encode(sink);
            self.encoding.to_owned().encode(sink);
            0u8.encode(sink);
            self.step.encode(sink);
            self.data.encode(sink);
        }
    }

    #[test]
    fn images_become_rgb8_with_their_intrinsics_at_most_at_the_rate_asked() {
        let mut camera = Camera {
            image_type: ImageType::Image,
            intrinsics: Intrinsics {
                fx: 200.0,
                fy: 201.0,
                cx: 1.0,
                cy: 0.5,
            },
            max_rate_hz: Some(10.0),
            last_published_ns: None,
        };
        let bgr = value(
            IMAGE,
            &Image {
                encoding: "bgr8",
                width: 2,
                height: 1,
                step: 6,
                data: vec![1, 2, 3, 4, 5, 6],
            },
        );
        let mut backend = RecordingBackend::default();
        let mut state = ContextState::new("camera", 1);
        for now_ns in [0, 50_000_000, 100_000_000] {
            backend.now_ns = now_ns;
            let mut ctx = state.context(&mut backend);
            camera.sample(&mut ctx, 0, &bgr).unwrap();
        }
        let images = decoded::<ImageSource>(&backend.published);
        assert_eq!(
            images.len(),
            2,
            "10 Hz at most: the frame 50 ms after is left out"
        );
        assert_eq!(images[0].data, [3, 2, 1, 6, 5, 4]);
        assert_eq!(
            (images[0].width, images[0].height, images[0].step),
            (2, 1, 6)
        );
        assert_eq!(images[0].focal_length_y, 201.0);
        let bayer = value(
            IMAGE,
            &Image {
                encoding: "bayer_rggb8",
                width: 2,
                height: 1,
                step: 2,
                data: vec![0; 2],
            },
        );
        backend.now_ns = 1_000_000_000;
        let mut ctx = state.context(&mut backend);
        assert!(camera.sample(&mut ctx, 0, &bayer).is_err());
    }

    fn tf_static(x: f64, yaw: f64) -> Value {
        use lewis_interfaces::ros2::{Pose, TfMessage, TransformStamped};
        value(
            TF_MESSAGE,
            &TfMessage {
                transforms: vec![TransformStamped {
                    header: Header {
                        stamp_ns: 1,
                        frame_id: "base_link".into(),
                    },
                    child_frame_id: "rplidar_link".into(),
                    transform: Pose::planar(x, 0.0, 0.193, yaw),
                }],
            },
        )
    }

    #[test]
    fn the_mount_is_checked_once_against_tf_static() {
        let mount = Mount {
            x_m: -0.04,
            y_m: 0.0,
            heading_deg: 90.0,
            height_m: 0.193,
        };
        for (x, yaw, said) in [
            (-0.04, std::f64::consts::FRAC_PI_2, "mount agrees"),
            (0.10, 0.0, "mount mismatch"),
        ] {
            let mut check = MountCheck {
                base_frame: "base_link".into(),
                ..MountCheck::default()
            };
            let mut backend = RecordingBackend::default();
            let mut state = ContextState::new("laser", 1);
            let mut ctx = state.context(&mut backend);
            // The frame first, the transforms later (or the other way): said once both are
            // known, and never again.
            check.frame(&mut ctx, "rplidar_link", &mount);
            assert!(!check.done);
            check
                .transforms(&mut ctx, &tf_static(x, yaw), &mount)
                .unwrap();
            check
                .transforms(&mut ctx, &tf_static(x, yaw), &mount)
                .unwrap();
            let lines: Vec<&String> = backend.logs.iter().map(|(_, t)| t).collect();
            assert_eq!(lines.len(), 1, "{lines:?}");
            assert!(lines[0].starts_with(said), "{lines:?}");
        }
    }

    #[test]
    fn each_ir_sensor_is_checked_against_tf_static() {
        use lewis_interfaces::ros2::{Pose, TfMessage, TransformStamped};
        let sensors = vec![sensor("ir_left", 30.0), sensor("ir_front", 0.0)];
        let mut ring = IrRing {
            mount_checks: sensors
                .iter()
                .map(|s| MountCheck {
                    base_frame: "base_link".into(),
                    frame: Some(s.frame.clone()),
                    ..MountCheck::default()
                })
                .collect(),
            sensors,
            model: IrModel::default(),
            rate_hz: 62.0,
            missing_said: false,
        };
        let transform = |frame: &str, yaw_deg: f64| TransformStamped {
            header: Header {
                stamp_ns: 1,
                frame_id: "base_link".into(),
            },
            child_frame_id: frame.into(),
            transform: Pose::planar(0.1, 0.0, 0.05, yaw_deg.to_radians()),
        };
        let tf = value(
            TF_MESSAGE,
            &TfMessage {
                transforms: vec![transform("ir_left", 30.0), transform("ir_front", 45.0)],
            },
        );
        let mut backend = RecordingBackend::default();
        let mut state = ContextState::new("ir", 1);
        let mut ctx = state.context(&mut backend);
        ring.sample(&mut ctx, 1, &tf).unwrap();
        assert!(backend.published.is_empty(), "transforms are no reading");
        let lines: Vec<&String> = backend.logs.iter().map(|(_, t)| t).collect();
        assert_eq!(lines.len(), 2, "{lines:?}");
        assert!(lines[0].starts_with("mount agrees") && lines[0].contains("ir_left"));
        assert!(lines[1].starts_with("mount mismatch") && lines[1].contains("ir_front"));
        assert!(!ring.is_data(1) && ring.is_data(0));
    }

    #[test]
    fn a_scan_is_a_range_finder_at_the_lasers_mount() {
        let mut laser = Laser {
            mount: Mount {
                x_m: -0.04,
                y_m: 0.0,
                heading_deg: 90.0,
                height_m: 0.19,
            },
            rate_hz: 7.7,
            counts: RangeCounts::default(),
            last: (0, 0.0),
            mount_check: MountCheck {
                base_frame: "base_link".into(),
                ..MountCheck::default()
            },
        };
        let scan = lewis_interfaces::ros2::LaserScan {
            header: Header {
                stamp_ns: 5,
                frame_id: "laser".into(),
            },
            angle_min: -0.5,
            angle_max: 0.5,
            angle_increment: 0.5,
            time_increment: 0.0,
            scan_time: 0.13,
            range_min: 0.15,
            range_max: 12.0,
            ranges: vec![1.0, f32::INFINITY, 0.05],
            intensities: vec![],
        };
        let mut backend = RecordingBackend::default();
        let mut state = ContextState::new("laser", 1);
        let mut ctx = state.context(&mut backend);
        laser
            .sample(&mut ctx, 0, &value(LASER_SCAN, &scan))
            .unwrap();
        let reading = &decoded::<RangeFinder>(&backend.published)[0];
        assert_eq!(reading.ranges, [1.0, 12.0, 12.0]);
        assert_eq!(reading.max_range, 12.0);
        assert!((reading.theta_offset - (90f64.to_radians() - 0.5)).abs() < 1e-6);
        assert!((reading.sensor_positions[2].theta - (90f64.to_radians() + 0.5)).abs() < 1e-6);
        assert_eq!(reading.x_offset, -0.04);
        assert_eq!(laser.counts.out_of_limits, 2);
    }

    #[test]
    fn numbers_out_of_range_are_refused_when_the_robot_file_is_read() {
        let timing: Result<Timing, _> = toml::from_str("silence_ms = 0");
        assert!(
            timing
                .unwrap_err()
                .to_string()
                .contains("give 1 to 600000 ms")
        );
        let laser: Result<LaserParams, _> = toml::from_str("dds = { domain_id = 300 }");
        assert!(laser.unwrap_err().to_string().contains("232"));
        let ir: Result<IrParams, _> =
            toml::from_str("sensors = [{ frame = \"f\" }]\nmodel = { p = -1.0 }");
        assert!(ir.unwrap_err().to_string().contains("`p`"));
        let fine: Timing = toml::from_str("silence_ms = 250").unwrap();
        assert_eq!(fine.silence_ms.get(), 250);
    }

    #[test]
    fn a_flood_beyond_three_times_the_declared_rate_is_cut_and_bursts_are_taken() {
        let mut flood = Flood::new(10.0).unwrap();
        // A burst of 30 at once is within a second's 30.
        assert!((0..30).all(|_| flood.admit(0)));
        assert!(!flood.admit(1));
        assert!(flood.admit(1_000_000_000));
        // 100 Hz for two seconds: 30 a second taken.
        let mut flood = Flood::new(10.0).unwrap();
        let taken = (0..200).filter(|i| flood.admit(i * 10_000_000)).count();
        assert_eq!(taken, 60);
        assert!(Flood::new(0.0).is_none());
    }

    #[test]
    fn a_reset_makes_the_present_pose_read_the_given_one() {
        let raw = Pose2D {
            x: 2.0,
            y: -1.0,
            theta: 0.7,
        };
        let want = Pose2D {
            x: 0.5,
            y: 0.25,
            theta: -1.0,
        };
        let offset = compose(&want, &inverse(&raw));
        let got = compose(&offset, &raw);
        assert!((got.x - want.x).abs() < 1e-12);
        assert!((got.y - want.y).abs() < 1e-12);
        assert!((got.theta - want.theta).abs() < 1e-12);
    }
}
