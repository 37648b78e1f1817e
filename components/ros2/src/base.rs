//! `ros2-base`: a ROS 2 base as Lewis's Synchrodrive.
//!
//! `set_velocity` and `stop` become `geometry_msgs/msg/Twist` (or `TwistStamped`, the robot
//! file's `command_type`) on the command topic, sent at `rate_hz`, the pace a ROS 2 base
//! expects (the Create 3 stops by itself when `/cmd_vel` pauses); a change of the velocity
//! commanded goes out at once and stands for that period's twist. The base never drives on
//! a stale command:
//!
//! - `stop`, and `set_brake` on, send a zero twist at once;
//! - no `set_velocity` for `command_timeout_ms` (a client that died, stalled or was moved
//!   away) and the twist sent is zero;
//! - when the service stops (`lewis up` ends, the broker stops it) it sends a zero twist
//!   and waits for the robot to acknowledge it; a gateway killed outright sends nothing,
//!   but its restarted process holds the robot still (a zero twist the robot acknowledges,
//!   then `start_hold_ms` of zero twists whatever is commanded), and the base's own timeout
//!   stops it meanwhile.
//!
//! After motion ends, zero twists go on for `idle_zero_ms`, then the gateway says nothing,
//! so that a person's teleop can drive the robot while Lewis does not.
//!
//! Synchrodrive's publication, at `rate_hz`: the commanded velocities, the measured ones
//! when `odom_topic` is given (else the commanded ones), and the bumpers from the Create
//! 3's `HazardDetectionVector` (`hazard_topic`): one per `bumpers` frame, pressed while the
//! latest vector (no older than `hazard_timeout_ms`) has a BUMP in that frame.
//!
//! Health: out of service while nobody on the robot reads the command topic (no matched
//! reader: the base is not there, or in another domain or namespace).

use std::time::Duration;

use lewis_interfaces::Interface;
use lewis_interfaces::cdr;
use lewis_interfaces::dynamic::Value;
use lewis_interfaces::msg::{
    Synchrodrive, SynchrodriveCommand, SynchrodriveSetBrakeReply, SynchrodriveSetVelocityReply,
    SynchrodriveStopReply,
};
use lewis_interfaces::ros2::{ODOMETRY, TWIST, Twist};
use lewis_ros2_map::from_ros2;
use lewis_ros2_map::robot::{self, HAZARD_DETECTION_VECTOR, TWIST_STAMPED, TwistStamped};
use lewis_ros2_map::to_ros2::header;
use lewis_service::{
    BuildError, CommandError, Context, Health, IncomingCommand, Reply, Service, ServiceConfig,
};
use rustdds::no_key::DataWriter;
use rustdds::{DataWriterStatus, StatusEvented as _};
use serde::Deserialize;

use crate::dds::{RawAdapter, RawCdr};
use crate::gateway::{Gateway, Link, Millis, TopicSpec, declare};
use lewis_ros2_map::qos::QosProfile;

/// The kind name.
pub const KIND: &str = "ros2-base";

/// Which message the base takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CommandType {
    /// `geometry_msgs/msg/Twist` (Humble's `/cmd_vel`, the Create 3's).
    Twist,
    /// `geometry_msgs/msg/TwistStamped` (Jazzy's Nav2 and `ros2_control`).
    TwistStamped,
}

/// The parameters of `ros2-base`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseParams {
    /// The command topic.
    #[serde(default = "defaults::command_topic")]
    pub command_topic: String,
    /// Twist or TwistStamped.
    #[serde(default = "defaults::command_type")]
    pub command_type: CommandType,
    /// The frame of a TwistStamped.
    #[serde(default = "defaults::frame")]
    pub frame: String,
    /// The command topic's QoS (default: reliable, as `ros2 topic pub` and Nav2 send).
    #[serde(default = "defaults::command_qos")]
    pub qos: QosProfile,
    /// How to reach the robot.
    #[serde(default)]
    pub dds: Link,
    /// Twists, and Synchrodrive publications, per second.
    #[serde(default = "defaults::rate_hz")]
    pub rate_hz: f64,
    /// No `set_velocity` for this long and the twist is zero, in ms.
    #[serde(default = "defaults::command_timeout_ms")]
    pub command_timeout_ms: Millis,
    /// Zero twists go on this long after motion ends, in ms.
    #[serde(default = "defaults::idle_zero_ms")]
    pub idle_zero_ms: u64,
    /// The fastest forward or backward velocity sent, in m/s (faster commands are cut).
    #[serde(default = "defaults::max_translation_m_s")]
    pub max_translation_m_s: f64,
    /// The fastest turn sent, in rad/s.
    #[serde(default = "defaults::max_rotation_rad_s")]
    pub max_rotation_rad_s: f64,
    /// The Create 3's HazardDetectionVector topic, for the bumpers (absent: no bumpers).
    pub hazard_topic: Option<String>,
    /// The bump frames, in the order of Synchrodrive's `bumpers`.
    #[serde(default = "defaults::bumpers")]
    pub bumpers: Vec<String>,
    /// A hazard vector older than this presses no bumper, in ms.
    #[serde(default = "defaults::hazard_timeout_ms")]
    pub hazard_timeout_ms: Millis,
    /// An Odometry topic for the measured velocities (absent: the commanded ones).
    pub odom_topic: Option<String>,
    /// How long the start waits for the robot's reader of the command topic, in ms.
    #[serde(default = "defaults::match_wait_ms")]
    pub match_wait_ms: Millis,
    /// After the start (also a restart after a kill), the robot is held still this long,
    /// zero twists sent whatever is commanded, in ms.
    #[serde(default = "defaults::start_hold_ms")]
    pub start_hold_ms: Millis,
    /// Accepted so that every robot file may give one.
    pub seed: Option<u64>,
}

mod defaults {
    use crate::gateway::Millis;
    use lewis_ros2_map::qos::QosProfile;

    use super::CommandType;

    pub(super) fn match_wait_ms() -> Millis {
        Millis(5_000)
    }
    /// Long enough for the robot's side of discovery: the writer learns of the robot's
    /// reader first, and the reader may learn of the writer a second later on a loaded
    /// machine (seen: 0.5 s on 2 busy cores), dropping what was sent before. rustdds's
    /// acknowledgement wait does not cover that gap (it returns at once while the
    /// writer's own bookkeeping of the reader lags its match), so the hold does.
    pub(super) fn start_hold_ms() -> Millis {
        Millis(1_500)
    }

    pub(super) fn command_topic() -> String {
        "/cmd_vel".to_owned()
    }
    pub(super) fn command_type() -> CommandType {
        CommandType::Twist
    }
    pub(super) fn frame() -> String {
        "base_link".to_owned()
    }
    pub(super) fn command_qos() -> QosProfile {
        QosProfile::DEFAULT
    }
    pub(super) fn rate_hz() -> f64 {
        20.0
    }
    pub(super) fn command_timeout_ms() -> Millis {
        Millis(500)
    }
    pub(super) fn idle_zero_ms() -> u64 {
        1_000
    }
    pub(super) fn max_translation_m_s() -> f64 {
        0.3
    }
    pub(super) fn max_rotation_rad_s() -> f64 {
        1.9
    }
    pub(super) fn bumpers() -> Vec<String> {
        [
            "bump_left",
            "bump_front_left",
            "bump_front_center",
            "bump_front_right",
            "bump_right",
        ]
        .map(str::to_owned)
        .to_vec()
    }
    pub(super) fn hazard_timeout_ms() -> Millis {
        Millis(500)
    }
}

/// What the base sends, decided from commands and time alone (no I/O): the rules of the
/// module's documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct Commander {
    timeout_ns: i64,
    idle_zero_ns: i64,
    max_translation: f64,
    max_rotation: f64,
    /// The velocity commanded and when, while one is live.
    commanded: Option<(f64, f64, i64)>,
    /// When the twist became zero (`None`: never moved, or still moving).
    zero_since_ns: Option<i64>,
    brake: bool,
}

impl Commander {
    /// A base at rest.
    #[must_use]
    pub fn new(
        timeout: Duration,
        idle_zero: Duration,
        max_translation: f64,
        max_rotation: f64,
    ) -> Self {
        Self {
            timeout_ns: i64::try_from(timeout.as_nanos()).unwrap_or(i64::MAX),
            idle_zero_ns: i64::try_from(idle_zero.as_nanos()).unwrap_or(i64::MAX),
            max_translation,
            max_rotation,
            commanded: None,
            zero_since_ns: Some(0),
            brake: false,
        }
    }

    /// A `set_velocity` at `now_ns` (cut to the limits); refused while the brake is on.
    ///
    /// # Errors
    /// A velocity that is not a number, or the brake.
    pub fn set_velocity(
        &mut self,
        now_ns: i64,
        translation: f64,
        rotation: f64,
    ) -> Result<(), String> {
        if !(translation.is_finite() && rotation.is_finite()) {
            return Err("set_velocity: a velocity is not a number".to_owned());
        }
        if self.brake && (translation != 0.0 || rotation != 0.0) {
            return Err("set_velocity: the brake is on".to_owned());
        }
        let v = translation.clamp(-self.max_translation, self.max_translation);
        let w = rotation.clamp(-self.max_rotation, self.max_rotation);
        if v == 0.0 && w == 0.0 {
            self.stop(now_ns);
        } else {
            self.commanded = Some((v, w, now_ns));
            self.zero_since_ns = None;
        }
        Ok(())
    }

    /// A `stop` at `now_ns`.
    pub fn stop(&mut self, now_ns: i64) {
        if self.commanded.take().is_some() || self.zero_since_ns.is_none() {
            self.zero_since_ns = Some(now_ns);
        }
    }

    /// The brake on (a stop) or off.
    pub fn set_brake(&mut self, now_ns: i64, on: bool) {
        self.brake = on;
        if on {
            self.stop(now_ns);
        }
    }

    /// The velocity to send at `now_ns` (`None`: nothing, the base is left alone), after
    /// applying the command timeout.
    pub fn due(&mut self, now_ns: i64) -> Option<(f64, f64)> {
        if let Some((v, w, at)) = self.commanded {
            if now_ns - at <= self.timeout_ns {
                return Some((v, w));
            }
            self.commanded = None;
            self.zero_since_ns = Some(now_ns);
        }
        match self.zero_since_ns {
            Some(since) if now_ns - since <= self.idle_zero_ns => Some((0.0, 0.0)),
            _ => None,
        }
    }

    /// The velocity commanded now (zero when none is live).
    #[must_use]
    pub fn commanded(&self) -> (f64, f64) {
        self.commanded.map_or((0.0, 0.0), |(v, w, _)| (v, w))
    }

    /// Whether the brake is on.
    #[must_use]
    pub fn brake(&self) -> bool {
        self.brake
    }
}

struct Base {
    params: BaseParams,
    commander: Commander,
    // Fields drop in order: the writer before the gateway's participant.
    writer: Option<DataWriter<RawCdr, RawAdapter>>,
    gateway: Option<Gateway>,
    hazard_reader: Option<usize>,
    odom_reader: Option<usize>,
    pressed: Vec<bool>,
    hazard_at_ns: Option<i64>,
    measured: Option<(f64, f64)>,
    sent: u64,
    /// When the last twist was sent.
    last_sent_ns: Option<i64>,
    /// Until when the robot is held still after the start. An instant of the machine's
    /// clock, not the service's: the service's time stands still through `on_start` (it is
    /// the start event's), and the hold must outlast the waits for the robot in it.
    hold_until: Option<std::time::Instant>,
    /// Readers of the command topic on the robot, as DDS matched them.
    readers: i32,
}

impl Base {
    fn send(&mut self, ctx: &mut Context<'_>, v: f64, w: f64) {
        let Some(writer) = &self.writer else { return };
        let (v, w) = if self
            .hold_until
            .is_some_and(|until| std::time::Instant::now() < until)
        {
            (0.0, 0.0)
        } else {
            (v, w)
        };
        let twist = Twist {
            linear: [v, 0.0, 0.0],
            angular: [0.0, 0.0, w],
        };
        let bytes = match self.params.command_type {
            CommandType::Twist => cdr::to_vec(&twist),
            CommandType::TwistStamped => cdr::to_vec(&TwistStamped {
                header: header(ctx.now(), &self.params.frame),
                twist,
            }),
        };
        match writer.write(RawCdr(bytes), None) {
            Ok(()) => {
                self.sent += 1;
                self.last_sent_ns = Some(ctx.now());
            }
            Err(e) => ctx.warn(&format!("cannot send {}: {e}", self.params.command_topic)),
        }
    }

    fn publish_state(&mut self, ctx: &mut Context<'_>) {
        let now = ctx.now();
        let stale = self.hazard_at_ns.is_none_or(|at| {
            now - at > i64::try_from(self.params.hazard_timeout_ms.get()).unwrap_or(500) * 1_000_000
        });
        if stale {
            self.pressed.iter_mut().for_each(|p| *p = false);
        }
        let (cv, cw) = self.commander.commanded();
        let (v, w) = self.measured.unwrap_or((cv, cw));
        let mut state = Synchrodrive {
            translation_velocity: v,
            rotation_velocity: w,
            commanded_translation_velocity: cv,
            commanded_rotation_velocity: cw,
            brake_on: self.commander.brake(),
            bumper_count: i32::try_from(self.pressed.len()).unwrap_or(i32::MAX),
            bumpers: self.pressed.clone(),
            ..Synchrodrive::default()
        };
        if let Err(e) = ctx.publish(&mut state) {
            ctx.warn(&format!("cannot publish Synchrodrive: {e}"));
        }
    }

    fn matched(&mut self) -> Health {
        if let Some(writer) = &self.writer {
            while let Some(status) = writer.try_recv_status() {
                if let DataWriterStatus::PublicationMatched { current, .. } = status {
                    self.readers = current.count();
                }
            }
        }
        match &self.writer {
            Some(_) if self.readers > 0 => Health::Ok,
            _ => Health::OutOfService(format!(
                "nobody on the robot reads {} (is the base on, in this domain and namespace?)",
                self.params.command_topic
            )),
        }
    }

    fn sample(&mut self, ctx: &mut Context<'_>, reader: usize, value: &Value) {
        let now = ctx.now();
        if Some(reader) == self.hazard_reader {
            match robot::bumps(value) {
                Ok(frames) => {
                    self.hazard_at_ns = Some(now);
                    let before = self.pressed.clone();
                    for (pressed, frame) in self.pressed.iter_mut().zip(&self.params.bumpers) {
                        *pressed = frames.contains(frame);
                    }
                    if before != self.pressed {
                        self.publish_state(ctx);
                    }
                }
                Err(why) => self.unusable(ctx, reader, &why),
            }
        } else if Some(reader) == self.odom_reader {
            match from_ros2::odometry(value) {
                Ok(odometry) => {
                    self.measured = Some((odometry.translation_mps, odometry.rotation_radps));
                }
                Err(why) => self.unusable(ctx, reader, &why),
            }
        }
    }

    fn unusable(&mut self, ctx: &mut Context<'_>, reader: usize, why: &str) {
        if let Some(intake) = self
            .gateway
            .as_mut()
            .and_then(|g| g.intakes.get_mut(reader))
        {
            intake.bad(ctx, "unusable", why);
        }
    }
}

impl Service for Base {
    fn tick_period_ns(&self) -> Option<i64> {
        Some((1e9 / self.params.rate_hz) as i64)
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        let mut topics = Vec::new();
        if let Some(topic) = &self.params.hazard_topic {
            self.hazard_reader = Some(topics.len());
            topics.push(TopicSpec {
                topic: topic.clone(),
                type_name: HAZARD_DETECTION_VECTOR,
                qos: QosProfile::SENSOR_DATA,
            });
        }
        if let Some(topic) = &self.params.odom_topic {
            self.odom_reader = Some(topics.len());
            topics.push(TopicSpec {
                topic: topic.clone(),
                type_name: ODOMETRY,
                qos: QosProfile::SENSOR_DATA,
            });
        }
        let gateway = Gateway::open(&self.params.dds, &topics)?;
        let (type_name, dds_type) = match self.params.command_type {
            CommandType::Twist => (TWIST, "geometry_msgs::msg::dds_::Twist_"),
            CommandType::TwistStamped => (TWIST_STAMPED, "geometry_msgs::msg::dds_::TwistStamped_"),
        };
        self.writer = Some(gateway.participant.writer(
            &gateway.dds_topic(&self.params.command_topic),
            dds_type,
            self.params.qos,
        )?);
        self.gateway = Some(gateway);
        // The first twist (zero) goes once the robot reads the topic: a sample written
        // before DDS matched the two sides is lost, and a base restarted after a kill must
        // be held still.
        let deadline = std::time::Instant::now() + self.params.match_wait_ms.duration();
        while self.matched() != Health::Ok && std::time::Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(10));
        }
        ctx.info(&format!(
            "driving {} ({type_name}) at {} Hz in DDS domain {}",
            self.params.command_topic,
            self.params.rate_hz,
            self.params.dds.domain()?
        ));
        // A fresh base (also one restarted after a kill) holds the robot still: a zero
        // twist, the wait for the robot's acknowledgement, then `start_hold_ms` of zero
        // twists whatever is commanded (a command queued for the process that died is one
        // of them). The hold counts from the wait's end, on the machine's clock: the robot's
        // reader may match this writer well after the writer matched it, and drops what
        // was sent before; zeros sent after it arrive.
        self.commander.stop(ctx.now());
        self.hold_until = None;
        self.send(ctx, 0.0, 0.0);
        if let Some(writer) = &self.writer {
            let _ = writer.wait_for_acknowledgments(self.params.match_wait_ms.duration());
        }
        self.hold_until = Some(std::time::Instant::now() + self.params.start_hold_ms.duration());
        self.on_tick(ctx);
        Ok(())
    }

    fn device(&self) -> Option<std::os::fd::BorrowedFd<'_>> {
        self.gateway.as_ref().map(Gateway::fd)
    }

    fn on_device(&mut self, ctx: &mut Context<'_>) {
        let values = match self.gateway.as_mut() {
            Some(g) => g.take(ctx),
            None => return,
        };
        for (reader, value) in values {
            self.sample(ctx, reader, &value);
        }
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        self.on_device(ctx);
        let now = ctx.now();
        if let Some((v, w)) = self.commander.due(now) {
            // A twist sent at once since the last tick stands for this one: the rate stays
            // the base's (a millisecond of slack for the timer's jitter).
            let period = self.tick_period_ns().unwrap_or(0);
            if self
                .last_sent_ns
                .is_none_or(|at| now - at >= period - 1_000_000)
            {
                self.send(ctx, v, w);
            }
        }
        self.publish_state(ctx);
        let health = self.matched();
        declare(ctx, health);
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        if command.interface != Synchrodrive::NAME {
            return Err(CommandError::new(format!(
                "{KIND} serves Synchrodrive, not {}",
                command.interface
            )));
        }
        let now = ctx.now();
        match command.decode::<Synchrodrive>()? {
            SynchrodriveCommand::SetVelocity(c) => {
                let before = self.commander.commanded();
                self.commander
                    .set_velocity(now, c.translation_velocity, c.rotation_velocity)
                    .map_err(CommandError::new)?;
                // A change goes out at once, not at the next tick.
                let after = self.commander.commanded();
                if after != before {
                    self.send(ctx, after.0, after.1);
                }
                Ok(ctx.reply(SynchrodriveSetVelocityReply::default()))
            }
            SynchrodriveCommand::Stop(_) => {
                self.commander.stop(now);
                self.send(ctx, 0.0, 0.0);
                Ok(ctx.reply(SynchrodriveStopReply::default()))
            }
            SynchrodriveCommand::SetBrake(c) => {
                self.commander.set_brake(now, c.on);
                if c.on {
                    self.send(ctx, 0.0, 0.0);
                }
                Ok(ctx.reply(SynchrodriveSetBrakeReply::default()))
            }
        }
    }

    fn on_stop(&mut self, ctx: &mut Context<'_>) {
        self.commander.stop(ctx.now());
        self.send(ctx, 0.0, 0.0);
        if let Some(writer) = &self.writer {
            // The last word is a zero twist: wait (briefly) until the robot has it.
            let _ = writer.wait_for_acknowledgments(Duration::from_millis(300));
        }
        ctx.info(&format!(
            "stopped: a zero twist sent on {} ({} twists in all)",
            self.params.command_topic, self.sent
        ));
    }
}

fn invalid(config: &ServiceConfig<'_>, reason: impl Into<String>) -> BuildError {
    BuildError::Parameters {
        service: config.name().to_owned(),
        reason: reason.into(),
    }
}

fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: BaseParams = config.parameters()?;
    if !(params.rate_hz.is_finite() && (1.0..=200.0).contains(&params.rate_hz)) {
        return Err(invalid(
            config,
            format!("`rate_hz` is {}: give 1 to 200", params.rate_hz),
        ));
    }
    for (name, x) in [
        ("max_translation_m_s", params.max_translation_m_s),
        ("max_rotation_rad_s", params.max_rotation_rad_s),
    ] {
        if !(x.is_finite() && x > 0.0) {
            return Err(invalid(
                config,
                format!("`{name}` is {x}: give a positive number"),
            ));
        }
    }
    let commander = Commander::new(
        params.command_timeout_ms.duration(),
        Duration::from_millis(params.idle_zero_ms),
        params.max_translation_m_s,
        params.max_rotation_rad_s,
    );
    let bumpers = if params.hazard_topic.is_some() {
        params.bumpers.len()
    } else {
        0
    };
    Ok(Box::new(Base {
        commander,
        gateway: None,
        writer: None,
        hazard_reader: None,
        odom_reader: None,
        pressed: vec![false; bumpers],
        hazard_at_ns: None,
        measured: None,
        sent: 0,
        last_sent_ns: None,
        hold_until: None,
        readers: 0,
        params,
    }))
}

/// Registers `ros2-base`.
pub fn register(registry: &mut lewis_service::ServiceRegistry) {
    registry.register_with_parameters::<BaseParams>(KIND, build);
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use lewis_interfaces::cdr::{Encode, Sink};
    use lewis_interfaces::dynamic::Decoder;
    use lewis_interfaces::ros2::Header;
    use lewis_ros2_map::robot::schema_texts;
    use lewis_service::ContextState;
    use lewis_testkit::{RecordingBackend, decoded};

    use super::*;

    struct Hazards(Vec<(u8, &'static str)>);

    impl Encode for Hazards {
        fn encode<S: Sink>(&self, sink: &mut S) {
            let header = |frame: &str| Header {
                stamp_ns: 1,
                frame_id: frame.into(),
            };
            header("base_link").encode(sink);
            u32::try_from(self.0.len()).unwrap().encode(sink);
            for (kind, frame) in &self.0 {
                header(frame).encode(sink);
                kind.encode(sink);
            }
        }
    }

    fn hazards(list: Vec<(u8, &'static str)>) -> Value {
        Decoder::new(
            HAZARD_DETECTION_VECTOR,
            &schema_texts(HAZARD_DETECTION_VECTOR)[0],
        )
        .unwrap()
        .decode(&cdr::to_vec(&Hazards(list)))
        .unwrap()
    }

    /// A base as `build` makes it, never started (no DDS in unit tests).
    fn base() -> Base {
        let params: BaseParams = toml::from_str(r#"hazard_topic = "/hazard_detection""#).unwrap();
        let mut base = Base {
            commander: Commander::new(
                Duration::from_millis(500),
                Duration::from_millis(1000),
                0.3,
                1.9,
            ),
            writer: None,
            gateway: None,
            hazard_reader: Some(0),
            odom_reader: None,
            pressed: vec![false; params.bumpers.len()],
            hazard_at_ns: None,
            measured: None,
            sent: 0,
            last_sent_ns: None,
            hold_until: None,
            readers: 0,
            params,
        };
        base.commander.stop(0);
        base
    }

    #[test]
    fn bumps_press_their_bumpers_until_the_hazards_are_stale() {
        let mut base = base();
        let mut backend = RecordingBackend::default();
        let mut state = ContextState::new("base", 1);
        backend.now_ns = 1_000_000_000;
        let mut ctx = state.context(&mut backend);
        // A bump at the front centre and a cliff (not a bumper).
        base.sample(
            &mut ctx,
            0,
            &hazards(vec![(1, "bump_front_center"), (2, "cliff_front_left")]),
        );
        let drive = decoded::<Synchrodrive>(&backend.published);
        assert_eq!(
            drive.len(),
            1,
            "a change of the bumpers is published at once"
        );
        assert_eq!(drive[0].bumpers, [false, false, true, false, false]);
        // The same again: no extra publication; then hazards go stale and the bumper is released.
        backend.now_ns = 1_100_000_000;
        let mut ctx = state.context(&mut backend);
        base.sample(&mut ctx, 0, &hazards(vec![(1, "bump_front_center")]));
        assert_eq!(decoded::<Synchrodrive>(&backend.published).len(), 1);
        backend.now_ns = 1_700_000_000;
        let mut ctx = state.context(&mut backend);
        base.publish_state(&mut ctx);
        let last = decoded::<Synchrodrive>(&backend.published).pop().unwrap();
        assert_eq!(last.bumpers, [false; 5]);
        assert_eq!(last.bumper_count, 5);
    }

    const MS: i64 = 1_000_000;

    fn commander() -> Commander {
        Commander::new(
            Duration::from_millis(500),
            Duration::from_millis(1000),
            0.3,
            1.9,
        )
    }

    #[test]
    fn a_command_is_sent_until_it_is_stale_then_zeros_then_nothing() {
        let mut c = commander();
        // At rest from the start: zeros for the idle time, then silence.
        assert_eq!(c.due(0), Some((0.0, 0.0)));
        assert_eq!(c.due(1001 * MS), None);
        c.set_velocity(2000 * MS, 0.2, 0.5).unwrap();
        assert_eq!(c.due(2100 * MS), Some((0.2, 0.5)));
        assert_eq!(c.due(2500 * MS), Some((0.2, 0.5)));
        // 501 ms without a command: zero, never the stale velocity.
        assert_eq!(c.due(2501 * MS), Some((0.0, 0.0)));
        assert_eq!(c.commanded(), (0.0, 0.0));
        assert_eq!(c.due(3400 * MS), Some((0.0, 0.0)));
        assert_eq!(c.due(3600 * MS), None);
    }

    #[test]
    fn a_stop_is_zero_at_once_and_velocities_are_cut_to_the_limits() {
        let mut c = commander();
        c.set_velocity(0, 5.0, -9.0).unwrap();
        assert_eq!(c.due(MS), Some((0.3, -1.9)));
        c.stop(2 * MS);
        assert_eq!(c.due(3 * MS), Some((0.0, 0.0)));
        assert!(c.set_velocity(4 * MS, f64::NAN, 0.0).is_err());
        assert_eq!(c.due(5 * MS), Some((0.0, 0.0)));
    }

    #[test]
    fn the_brake_stops_and_refuses_motion() {
        let mut c = commander();
        c.set_velocity(0, 0.1, 0.0).unwrap();
        c.set_brake(MS, true);
        assert_eq!(c.due(2 * MS), Some((0.0, 0.0)));
        assert!(c.set_velocity(3 * MS, 0.1, 0.0).is_err());
        c.set_velocity(3 * MS, 0.0, 0.0).unwrap();
        c.set_brake(4 * MS, false);
        c.set_velocity(5 * MS, 0.1, 0.0).unwrap();
        assert_eq!(c.due(6 * MS), Some((0.1, 0.0)));
    }
}
