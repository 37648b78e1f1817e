//! `sim-camera`: a forward pan-tilt-zoom camera rendering the world (a ray-cast 2.5D view)
//! from the latest GroundTruth pose. Publishes ImageSource (rgb8) at its rate, and
//! CameraControl (zoom, pan, tilt, exposure) at its first frame and after every command
//! that changes it.
//!
//! Where there is no simulator to publish GroundTruth (the B21r's device emulators), the same
//! camera renders from a pose its builder hands it ([`TruePoseSource`],
//! [`SimCameraService::with_true_pose`]): `lewis-emulators`' `emulated-camera` reads the pose
//! that the base's emulator shares.
//!
//! Commands: CameraControl `set_zoom` (clamped to 1..=`max_zoom`, the reply says what was
//! set), `set_pan_tilt` (clamped to the mount's limits), `set_focus` and `set_exposure`
//! (the rendering is a pinhole with unlimited depth of field and fixed exposure: they are
//! kept and reported, nothing more); ImageSource `set_rate` (frames are dropped to slow
//! down; the rate cannot go above `rate_hz`, the reply says the rate set).
//!
//! ```toml
//! [services.parameters]
//! world = "robots/worlds/conference"
//! seed = 4
//! rate_hz = 10.0
//! width_px = 640
//! height_px = 480
//! horizontal_fov_deg = 48.8
//! max_zoom = 12.0
//! max_pan_deg = 100.0
//! max_tilt_deg = 25.0
//! max_range_m = 50.0
//! pixel_noise_std = 2.0
//! mount = { x_m = 0.1, y_m = 0.0, heading_deg = 0.0, height_m = 1.2 }
//! ```

use std::path::PathBuf;

use lewis_interfaces::msg::{
    CameraControl, CameraControlCommand, CameraControlSetExposureReply, CameraControlSetFocusReply,
    CameraControlSetPanTiltReply, CameraControlSetZoomReply, ImageSource, ImageSourceBulkLens,
    ImageSourceCommand, ImageSourceSetRateReply,
};
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Input, Reply, Service, ServiceConfig,
};
use serde::Deserialize;

use super::{MountParams, TruthFollower, invalid, load_world, period_ns, provides, publish};
use crate::camera::{CameraConfig, SimCamera};
use crate::world::World;

/// The kind name in robot files.
pub const KIND: &str = "sim-camera";

/// The parameters of `sim-camera`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraParams {
    /// The world folder (`world.toml` and its map).
    pub world: PathBuf,
    /// Seed of the pixel noise.
    #[serde(default)]
    pub seed: Option<u64>,
    /// Frames per second (the most `set_rate` allows).
    #[serde(default = "defaults::rate_hz")]
    pub rate_hz: f64,
    /// Image width, in px.
    #[serde(default = "defaults::width_px")]
    pub width_px: u32,
    /// Image height, in px.
    #[serde(default = "defaults::height_px")]
    pub height_px: u32,
    /// Horizontal field of view at zoom 1, in degrees.
    #[serde(default = "defaults::horizontal_fov_deg")]
    pub horizontal_fov_deg: f64,
    /// Largest zoom (1 is the widest).
    #[serde(default = "defaults::max_zoom")]
    pub max_zoom: f64,
    /// Largest pan either way, in degrees.
    #[serde(default = "defaults::max_pan_deg")]
    pub max_pan_deg: f64,
    /// Largest tilt either way, in degrees.
    #[serde(default = "defaults::max_tilt_deg")]
    pub max_tilt_deg: f64,
    /// How far the camera sees, in m.
    #[serde(default = "defaults::max_range_m")]
    pub max_range_m: f64,
    /// Standard deviation of each pixel channel's noise, in levels of 255.
    #[serde(default = "defaults::pixel_noise_std")]
    pub pixel_noise_std: f64,
    /// Where the camera sits on the robot (its heading is the pan's zero).
    #[serde(default = "defaults::mount")]
    pub mount: MountParams,
}

mod defaults {
    use super::{CameraConfig, MountParams};

    pub(super) fn rate_hz() -> f64 {
        CameraConfig::default().rate_hz
    }
    pub(super) fn width_px() -> u32 {
        CameraConfig::default().width_px
    }
    pub(super) fn height_px() -> u32 {
        CameraConfig::default().height_px
    }
    pub(super) fn horizontal_fov_deg() -> f64 {
        CameraConfig::default().horizontal_fov_rad.to_degrees()
    }
    pub(super) fn max_zoom() -> f64 {
        CameraConfig::default().max_zoom
    }
    pub(super) fn max_pan_deg() -> f64 {
        CameraConfig::default().max_pan_rad.to_degrees()
    }
    pub(super) fn max_tilt_deg() -> f64 {
        CameraConfig::default().max_tilt_rad.to_degrees()
    }
    pub(super) fn max_range_m() -> f64 {
        CameraConfig::default().max_range_m
    }
    pub(super) fn pixel_noise_std() -> f64 {
        CameraConfig::default().pixel_noise_std
    }
    pub(super) fn mount() -> MountParams {
        MountParams::from_mount(CameraConfig::default().mount)
    }
}

impl CameraParams {
    /// The model's configuration.
    #[must_use]
    pub fn camera_config(&self) -> CameraConfig {
        CameraConfig {
            width_px: self.width_px,
            height_px: self.height_px,
            horizontal_fov_rad: self.horizontal_fov_deg.to_radians(),
            max_zoom: self.max_zoom,
            mount: self.mount.to_mount(),
            max_range_m: self.max_range_m,
            pixel_noise_std: self.pixel_noise_std,
            max_pan_rad: self.max_pan_deg.to_radians(),
            max_tilt_rad: self.max_tilt_deg.to_radians(),
            rate_hz: self.rate_hz,
        }
    }
}

/// What `set_focus` and `set_exposure` set: reported, not rendered.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Optics {
    focus_m: f64,
    iris: f64,
    shutter_s: f64,
    gain_db: f64,
}

/// Where a camera without GroundTruth learns the robot's true pose in the world: an
/// emulator's, never a real robot's (a real camera has no such thing).
pub trait TruePoseSource: std::fmt::Debug + Send {
    /// The robot's true pose in the world frame now; `Ok(None)` before there is one.
    ///
    /// # Errors
    /// Why the pose cannot be had, for a log line (the camera renders nothing meanwhile).
    fn true_pose(&mut self) -> Result<Option<lewis_geometry::Pose2>, String>;
}

/// Where the camera's renderings are seen from.
#[derive(Debug)]
enum Truth {
    /// The latest GroundTruth sample (and WorldState's people), named as provenance.
    Published(TruthFollower),
    /// A pose handed over by the service's builder.
    Given {
        source: Box<dyn TruePoseSource>,
        /// Whether the last failure was logged (once per run of failures).
        warned: bool,
    },
}

impl Truth {
    /// The pose to render from now, if any.
    fn pose(&mut self, ctx: &mut Context<'_>, world: &mut World) -> Option<lewis_geometry::Pose2> {
        match self {
            Self::Published(follower) => follower.pose_for_rendering(ctx, world),
            Self::Given { source, warned } => match source.true_pose() {
                Ok(pose) => {
                    *warned = false;
                    pose
                }
                Err(e) => {
                    if !*warned {
                        ctx.warn(&format!("no true pose to render from: {e}"));
                        *warned = true;
                    }
                    None
                }
            },
        }
    }
}

/// The `sim-camera` service.
#[derive(Debug)]
pub struct SimCameraService {
    world: World,
    camera: SimCamera,
    truth: Truth,
    period_ns: i64,
    max_rate_hz: f64,
    /// The period `set_rate` asked for, in ns (no shorter than `period_ns`).
    frame_period_ns: i64,
    next_frame_ns: Option<i64>,
    optics: Optics,
    control_changed: bool,
    publish_image: bool,
    publish_control: bool,
}

/// Builds a `sim-camera` service from its robot-file entry.
///
/// # Errors
/// When a parameter is missing, unknown or cannot work, or the world does not load.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: CameraParams = config.parameters()?;
    let service = SimCameraService::new(
        config,
        &params,
        Truth::Published(TruthFollower::for_sensor()),
    )?;
    Ok(Box::new(service))
}

impl SimCameraService {
    /// The camera of service `config` with `params`, rendering from the poses `source`
    /// gives rather than from GroundTruth (its inputs, if any, are ignored): for a robot
    /// whose devices are emulated outside the simulator.
    ///
    /// # Errors
    /// When a parameter cannot work, or the world does not load.
    pub fn with_true_pose(
        config: &ServiceConfig<'_>,
        params: &CameraParams,
        source: Box<dyn TruePoseSource>,
    ) -> Result<Self, BuildError> {
        Self::new(
            config,
            params,
            Truth::Given {
                source,
                warned: false,
            },
        )
    }

    fn new(
        config: &ServiceConfig<'_>,
        params: &CameraParams,
        truth: Truth,
    ) -> Result<Self, BuildError> {
        let period_ns = period_ns(config, "rate_hz", params.rate_hz)?;
        let camera = SimCamera::new(params.camera_config(), config.seed())
            .map_err(|e| invalid(config, e.to_string()))?;
        let world = load_world(config, &params.world)?;
        let control = camera.camera_control();
        Ok(SimCameraService {
            world,
            camera,
            truth,
            period_ns,
            max_rate_hz: params.rate_hz,
            frame_period_ns: period_ns,
            next_frame_ns: None,
            optics: Optics {
                focus_m: control.focus,
                iris: control.iris,
                shutter_s: control.shutter,
                gain_db: control.gain,
            },
            control_changed: true,
            publish_image: provides::<ImageSource>(config),
            publish_control: provides::<CameraControl>(config),
        })
    }

    /// The CameraControl publication (header left to the context).
    #[must_use]
    pub fn camera_control(&self) -> CameraControl {
        CameraControl {
            focus: self.optics.focus_m,
            iris: self.optics.iris,
            shutter: self.optics.shutter_s,
            gain: self.optics.gain_db,
            ..self.camera.camera_control()
        }
    }

    /// Renders the frame seen from `pose` straight into the channel's shared memory: a
    /// 640x480 frame is 900 KiB that would otherwise be rendered into a buffer and copied.
    fn publish_frame(&mut self, ctx: &mut Context<'_>, pose: lewis_geometry::Pose2) {
        let mut frame = self.camera.frame_fields();
        let lens = ImageSourceBulkLens {
            data: self.camera.frame_len(),
        };
        let (camera, world) = (&mut self.camera, &self.world);
        if let Err(e) = ctx.publish_in_place(&mut frame, &lens, |bulk| {
            camera.render_into(world, pose, bulk.data);
        }) {
            ctx.warn(&format!("cannot publish ImageSource: {e}"));
        }
    }
}

impl Service for SimCameraService {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(self.period_ns)
    }

    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        if let Truth::Published(follower) = &mut self.truth {
            follower.take(ctx, input);
        }
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        if self.control_changed && self.publish_control {
            self.control_changed = false;
            publish(ctx, &mut self.camera_control());
        }
        // A frame is due within half a tick of its time (the live clock jitters); due times
        // advance by whole frame periods, so a rate set below the tick's keeps its average.
        let now = ctx.now();
        let slack = self.period_ns / 2;
        if self
            .next_frame_ns
            .is_some_and(|due| now < due.saturating_sub(slack))
        {
            return;
        }
        let Some(pose) = self.truth.pose(ctx, &mut self.world) else {
            return;
        };
        let due = self.next_frame_ns.unwrap_or(now);
        let mut next = due.saturating_add(self.frame_period_ns);
        if next < now {
            next = now.saturating_add(self.frame_period_ns);
        }
        self.next_frame_ns = Some(next);
        if self.publish_image {
            self.publish_frame(ctx, pose);
        }
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        match command.interface {
            "CameraControl" => {
                let reply = match command.decode::<CameraControl>()? {
                    CameraControlCommand::SetZoom(c) => {
                        let zoom = self.camera.set_zoom(c.zoom);
                        ctx.reply(CameraControlSetZoomReply {
                            zoom,
                            ..CameraControlSetZoomReply::default()
                        })
                    }
                    CameraControlCommand::SetFocus(c) => {
                        if !(c.focus.is_finite() && c.focus > 0.0) {
                            return Err(CommandError::new(format!(
                                "set_focus: {} m, expected a positive distance",
                                c.focus
                            )));
                        }
                        self.optics.focus_m = c.focus;
                        ctx.reply(CameraControlSetFocusReply {
                            focus: c.focus,
                            ..CameraControlSetFocusReply::default()
                        })
                    }
                    CameraControlCommand::SetExposure(c) => {
                        let finite = [c.iris, c.shutter, c.gain].iter().all(|v| v.is_finite());
                        if !(finite && (0.0..=1.0).contains(&c.iris) && c.shutter > 0.0) {
                            return Err(CommandError::new(format!(
                                "set_exposure: iris {}, shutter {} s, gain {} dB: expected iris 0 to 1 and a positive shutter",
                                c.iris, c.shutter, c.gain
                            )));
                        }
                        self.optics = Optics {
                            iris: c.iris,
                            shutter_s: c.shutter,
                            gain_db: c.gain,
                            ..self.optics
                        };
                        ctx.reply(CameraControlSetExposureReply::default())
                    }
                    CameraControlCommand::SetPanTilt(c) => {
                        self.camera.set_pan_tilt(c.pan, c.tilt);
                        ctx.reply(CameraControlSetPanTiltReply::default())
                    }
                };
                self.control_changed = true;
                Ok(reply)
            }
            "ImageSource" => match command.decode::<ImageSource>()? {
                ImageSourceCommand::SetRate(c) => {
                    if !(c.rate.is_finite() && c.rate > 0.0) {
                        return Err(CommandError::new(format!(
                            "set_rate: {} Hz, expected a positive rate",
                            c.rate
                        )));
                    }
                    let rate = c.rate.min(self.max_rate_hz);
                    // A rate in (0, max] gives a period of at least `period_ns`.
                    let period = (1e9 / rate).round().min(1e12) as i64;
                    self.frame_period_ns = period.max(self.period_ns);
                    Ok(ctx.reply(ImageSourceSetRateReply {
                        rate,
                        ..ImageSourceSetRateReply::default()
                    }))
                }
            },
            other => Err(CommandError::new(format!("{KIND} does not serve {other}"))),
        }
    }
}
