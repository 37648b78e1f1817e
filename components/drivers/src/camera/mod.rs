//! `camera`: an ImageSource from an image sequence (a folder or a glob of PNG and JPEG
//! files, at a rate, once or in a loop) or from a video device.
//!
//! ```toml
//! [[services]]
//! name = "camera"
//! kind = "camera"
//! provides = [{ interface = "ImageSource", quality = 5, cost = 2, data_rate_hz = 10.0 }]
//! [services.parameters]
//! images = "/work/shared/data/images"  # a folder, or a glob such as "frames/*.png"
//! rate_hz = 10.0
//! max_rate_hz = 30.0                   # optional: how fast set_rate may go (default rate_hz)
//! loop = true                          # default true; false: out of service after the last
//! horizontal_fov_deg = 48.8            # gives the focal length published with each image
//! # device = "/dev/video0"             # instead of images: a V4L2 device, and then
//! # width_px = 640                      # the size asked of it (the driver may give another)
//! # height_px = 480
//! # max_zoom = 4.0                      # the magnification at its largest zoom value
//! ```
//!
//! Frames come on the service's ticks: the harness ticks it at `max_rate_hz`, and it sends a
//! frame whenever one is due at the current rate, so `ImageSource.set_rate` can change the
//! rate (up to `max_rate_hz`; the reply gives the rate set) without touching the harness.
//! Images are decoded when they are sent (a folder of any size costs no memory up front);
//! a file that cannot be decoded is skipped with a warning and the camera says it is
//! degraded.
//!
//! Video devices (cargo feature `v4l2`, on by default: it needs no system library): frames
//! are captured by memory-mapped streaming ([`v4l2`]), in YUYV or MJPEG, converted to RGB8
//! ([`pixel_format`]) and published as they come (dropped to keep `rate_hz`); the service
//! also provides CameraControl where the device has the controls (see `device.rs`). A
//! device that is missing, is not a V4L2 capture device or fails declares the service out
//! of service with the reason, and the broker moves its clients to another ImageSource; a
//! build without the feature says so the same way. A sequence that has ended does the same.

#[cfg(feature = "v4l2")]
mod device;
pub mod pixel_format;
#[cfg(feature = "v4l2")]
pub mod v4l2;

use std::path::PathBuf;

use lewis_interfaces::Interface;
use lewis_interfaces::msg::{
    CameraControl, ImageSource, ImageSourceCommand, ImageSourceSetRateReply,
};
use lewis_service::Health;
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Reply, Role, Service, ServiceConfig,
    ServiceRegistry,
};
use serde::Deserialize;

use lewis_images::sequence::{ImageSequence, load_rgb, resolve};
use lewis_images::{ImageIntrinsics, image_message};

/// The kind name in robot files.
pub const KIND: &str = "camera";

/// Registers the `camera` kind, a device (a replay feeds it from the recording).
pub fn register(registry: &mut ServiceRegistry) {
    registry.register_with_parameters::<Params>(KIND, build);
    registry.set_role(KIND, Role::Device);
}

/// The parameters of `camera`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// A folder of PNG and JPEG files, or a glob pattern.
    pub images: Option<String>,
    /// A V4L2 device (`/dev/video0`).
    pub device: Option<PathBuf>,
    /// Frames per second.
    pub rate_hz: f64,
    /// The highest rate `set_rate` may ask for (default: `rate_hz`).
    pub max_rate_hz: Option<f64>,
    /// Start again after the last image.
    #[serde(rename = "loop")]
    pub looping: bool,
    /// The camera's horizontal field of view, in degrees (for the published intrinsics).
    pub horizontal_fov_deg: f64,
    /// The frame width asked of a video device, in px.
    pub width_px: u32,
    /// The frame height asked of a video device, in px.
    pub height_px: u32,
    /// The magnification of a video device at its largest zoom value.
    pub max_zoom: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            images: None,
            device: None,
            rate_hz: 10.0,
            max_rate_hz: None,
            looping: true,
            horizontal_fov_deg: 48.8,
            width_px: 640,
            height_px: 480,
            max_zoom: 4.0,
        }
    }
}

/// Where frames come from.
#[derive(Debug, Clone, PartialEq)]
enum Source {
    Images(String),
    Device(PathBuf),
}

/// Builds a `camera` service from its robot-file entry.
///
/// # Errors
/// When the parameters are wrong (both or neither source, rates out of range).
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: Params = config.parameters()?;
    let invalid = |reason: &str| BuildError::Parameters {
        service: config.name().to_owned(),
        reason: reason.to_owned(),
    };
    let source = match (params.images, params.device) {
        (Some(images), None) => Source::Images(images),
        (None, Some(device)) => Source::Device(device),
        _ => {
            return Err(invalid(
                "give exactly one of `images` (folder or glob) and `device`",
            ));
        }
    };
    let rate_ok = |r: f64| r.is_finite() && (1e-3..=1000.0).contains(&r);
    let max_rate_hz = params.max_rate_hz.unwrap_or(params.rate_hz);
    if !rate_ok(params.rate_hz) || !rate_ok(max_rate_hz) || params.rate_hz > max_rate_hz {
        return Err(invalid(
            "rate_hz and max_rate_hz must be in [0.001, 1000], rate_hz at most max_rate_hz",
        ));
    }
    if !(params.horizontal_fov_deg > 0.0 && params.horizontal_fov_deg < 180.0) {
        return Err(invalid("horizontal_fov_deg must be between 0 and 180"));
    }
    if params.width_px == 0 || params.height_px == 0 {
        return Err(invalid("width_px and height_px must be at least 1"));
    }
    if !(params.max_zoom.is_finite() && params.max_zoom >= 1.0) {
        return Err(invalid("max_zoom must be 1 or more"));
    }
    Ok(Box::new(Camera {
        source,
        looping: params.looping,
        horizontal_fov_rad: params.horizontal_fov_deg.to_radians(),
        tick_period_ns: period_ns(max_rate_hz),
        max_rate_hz,
        rate_hz: params.rate_hz,
        sequence: None,
        next_frame_ns: None,
        request: (params.width_px, params.height_px, params.max_zoom),
        #[cfg(feature = "v4l2")]
        device: None,
        rgb: Vec::new(),
        publish_control: config.spec.provision(CameraControl::NAME).is_some(),
    }))
}

/// The period of a rate in [0.001, 1000] Hz, in ns.
fn period_ns(rate_hz: f64) -> i64 {
    // At most 1e12 ns: the cast is exact enough and cannot overflow.
    (1e9 / rate_hz).round() as i64
}

/// The `camera` service.
struct Camera {
    source: Source,
    looping: bool,
    horizontal_fov_rad: f64,
    tick_period_ns: i64,
    max_rate_hz: f64,
    rate_hz: f64,
    sequence: Option<ImageSequence>,
    next_frame_ns: Option<i64>,
    /// Width, height and largest zoom for a video device.
    request: (u32, u32, f64),
    /// The video device, while it works.
    #[cfg(feature = "v4l2")]
    device: Option<device::DeviceSource>,
    /// The last frame from the video device, RGB8 (its buffer is reused).
    #[cfg_attr(
        not(feature = "v4l2"),
        expect(dead_code, reason = "read by V4L2 capture only")
    )]
    rgb: Vec<u8>,
    /// Whether the robot file says this service provides CameraControl.
    #[cfg_attr(
        not(feature = "v4l2"),
        expect(dead_code, reason = "read by V4L2 capture only")
    )]
    publish_control: bool,
}

impl Camera {
    /// Whether a frame is due at `now_ns`; moves the schedule on when it is.
    fn frame_due(&mut self, now_ns: i64) -> bool {
        let period = period_ns(self.rate_hz);
        // Ticks jitter: a frame due within half a tick counts as due now.
        let slack = self.tick_period_ns / 2;
        match self.next_frame_ns {
            Some(due) if now_ns + slack < due => false,
            Some(due) => {
                let next = due + period;
                // After a stall, start afresh rather than send a burst.
                self.next_frame_ns = Some(if next + slack <= now_ns {
                    now_ns + period
                } else {
                    next
                });
                true
            }
            None => {
                self.next_frame_ns = Some(now_ns + period);
                true
            }
        }
    }

    fn send_next(&mut self, ctx: &mut Context<'_>) {
        let Some(sequence) = &mut self.sequence else {
            return;
        };
        // Skip undecodable files, but give up after one pass over the whole sequence.
        for _ in 0..sequence.files().len() {
            let Some(path) = sequence.next_file().map(std::path::Path::to_path_buf) else {
                let count = sequence.files().len();
                ctx.set_health(Health::OutOfService(format!(
                    "the image sequence ended after its {count} images (loop = false)"
                )));
                self.sequence = None;
                return;
            };
            match load_rgb(&path) {
                Ok(image) => {
                    let intrinsics = ImageIntrinsics::from_fov(
                        image.width_px,
                        image.height_px,
                        self.horizontal_fov_rad,
                    );
                    let mut message: ImageSource =
                        image_message(image.width_px, image.height_px, image.rgb, intrinsics);
                    if let Err(e) = ctx.publish(&mut message) {
                        ctx.warn(&format!("cannot publish ImageSource: {e}"));
                    }
                    if matches!(ctx.health(), Health::Degraded(_)) {
                        ctx.set_health(Health::Ok);
                    }
                    return;
                }
                Err(e) => {
                    ctx.warn(&format!("{e}: skipped"));
                    ctx.set_health(Health::Degraded(e.to_string()));
                }
            }
        }
    }
}

impl Camera {
    /// Opens the video device, or says why it cannot.
    #[cfg(feature = "v4l2")]
    fn open_device(&mut self, ctx: &mut Context<'_>, path: &std::path::Path) {
        let (width_px, height_px, max_zoom) = self.request;
        let request = v4l2::CaptureRequest {
            width_px,
            height_px,
            rate_hz: self.max_rate_hz,
        };
        match device::DeviceSource::open(path, request, max_zoom) {
            Ok(source) => {
                ctx.info(&format!(
                    "capturing from {}: {}",
                    path.display(),
                    source.describe()
                ));
                if self.publish_control {
                    let mut control = source.control();
                    if let Err(e) = ctx.publish(&mut control) {
                        ctx.warn(&format!("cannot publish CameraControl: {e}"));
                    }
                }
                self.device = Some(source);
            }
            Err(e) => ctx.set_health(Health::OutOfService(e.to_string())),
        }
    }

    /// Says that this build has no video capture.
    #[cfg(not(feature = "v4l2"))]
    fn open_device(&mut self, ctx: &mut Context<'_>, path: &std::path::Path) {
        let _ = self.request;
        let reason = if path.exists() {
            format!(
                "{} exists but this lewis was built without V4L2 capture (cargo feature \
                 `v4l2`): use an image sequence (`images`)",
                path.display()
            )
        } else {
            format!("no video device at {}", path.display())
        };
        ctx.set_health(Health::OutOfService(reason));
    }

    /// The video device's descriptor, while it is open.
    #[cfg(feature = "v4l2")]
    fn device_fd(&self) -> Option<std::os::fd::BorrowedFd<'_>> {
        self.device.as_ref().map(device::DeviceSource::fd)
    }

    /// No device without the feature.
    #[cfg(not(feature = "v4l2"))]
    #[allow(clippy::unused_self, reason = "the signature of the v4l2 build's")]
    fn device_fd(&self) -> Option<std::os::fd::BorrowedFd<'_>> {
        None
    }

    /// Nothing to read without the feature.
    #[cfg(not(feature = "v4l2"))]
    #[allow(clippy::unused_self, reason = "the signature of the v4l2 build's")]
    fn read_device(&mut self, _ctx: &mut Context<'_>) {}

    /// Publishes the frames the device has ready (those due at the current rate).
    #[cfg(feature = "v4l2")]
    fn read_device(&mut self, ctx: &mut Context<'_>) {
        let Some(mut source) = self.device.take() else {
            return;
        };
        loop {
            match source.read_frame(&mut self.rgb) {
                Ok(None) => break,
                Ok(Some(frame)) => {
                    if self.frame_due(ctx.now()) {
                        self.publish_frame(ctx, frame);
                    }
                }
                Err(e @ v4l2::DeviceError::Convert { .. }) => {
                    ctx.warn(&format!("{e}: frame skipped"));
                    ctx.set_health(Health::Degraded(e.to_string()));
                }
                Err(e) => {
                    // Unplugged, or the driver failed: nothing more will come.
                    ctx.set_health(Health::OutOfService(e.to_string()));
                    return;
                }
            }
        }
        self.device = Some(source);
    }

    /// Publishes the device's last frame (in `self.rgb`).
    #[cfg(feature = "v4l2")]
    fn publish_frame(&mut self, ctx: &mut Context<'_>, frame: v4l2::FrameInfo) {
        let intrinsics =
            ImageIntrinsics::from_fov(frame.width_px, frame.height_px, self.horizontal_fov_rad);
        let mut message = image_message(
            frame.width_px,
            frame.height_px,
            std::mem::take(&mut self.rgb),
            intrinsics,
        );
        if let Err(e) = ctx.publish(&mut message) {
            ctx.warn(&format!("cannot publish ImageSource: {e}"));
        }
        self.rgb = message.data;
        if matches!(ctx.health(), Health::Degraded(_)) {
            ctx.set_health(Health::Ok);
        }
    }
}

impl Service for Camera {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(self.tick_period_ns)
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        match &self.source {
            Source::Images(pattern) => match resolve(pattern) {
                Ok(files) => {
                    ctx.info(&format!("{} images from {pattern}", files.len()));
                    self.sequence = Some(ImageSequence::new(files, self.looping));
                }
                Err(e) => ctx.set_health(Health::OutOfService(e.to_string())),
            },
            Source::Device(path) => {
                let path = path.clone();
                self.open_device(ctx, &path);
            }
        }
        Ok(())
    }

    fn device(&self) -> Option<std::os::fd::BorrowedFd<'_>> {
        self.device_fd()
    }

    fn on_device(&mut self, ctx: &mut Context<'_>) {
        self.read_device(ctx);
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        if self.sequence.is_some() && self.frame_due(ctx.now()) {
            self.send_next(ctx);
        }
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        if command.interface == CameraControl::NAME {
            #[cfg(feature = "v4l2")]
            if let Some(device) = &mut self.device {
                let command = command.decode::<CameraControl>()?;
                let reply = device.command(ctx, command)?;
                let mut control = device.control();
                if let Err(e) = ctx.publish(&mut control) {
                    ctx.warn(&format!("cannot publish CameraControl: {e}"));
                }
                return Ok(reply);
            }
            return Err(CommandError::new(
                "this camera has no controls: it reads an image sequence, or its device is not open",
            ));
        }
        match command.decode::<ImageSource>()? {
            ImageSourceCommand::SetRate(set) => {
                if !(set.rate.is_finite() && set.rate > 0.0) {
                    return Err(CommandError::new(format!(
                        "rate {} must be a positive number of frames per second",
                        set.rate
                    )));
                }
                self.rate_hz = set.rate.clamp(1e-3, self.max_rate_hz);
                Ok(ctx.reply(ImageSourceSetRateReply {
                    rate: self.rate_hz,
                    ..ImageSourceSetRateReply::default()
                }))
            }
        }
    }
}
