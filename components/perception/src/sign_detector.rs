//! `sign_detector`: direction signs in every image of an ImageSource, published as Signs
//! (see [`super::signs`] for how they are found and read).
//!
//! ```toml
//! [[services]]
//! name = "signs"
//! kind = "sign_detector"
//! requires = ["ImageSource"]
//! provides = [{ interface = "Signs", quality = 10, cost = 3 }]
//! [services.parameters]
//! # All optional; the values shown are the defaults.
//! # colors = "robots/colors/signs.txt"   # default: built-in grey-white and grey-black classes
//! board_color = "White"                  # class names in the colour file
//! arrow_color = "Black"
//! board_height_m = 0.45
//! board_aspect = 1.3333                  # width over height
//! min_board_area_px = 150
//! min_confidence = 0.2
//! horizontal_fov_deg = 48.8              # only for images that carry no intrinsics
//! camera = { x_m = 0.1, y_m = 0.0, z_m = 1.2, pan_rad = 0.0, tilt_rad = 0.0 }
//! # Optional: other cameras the images may come from, by service name (each image's header
//! # names its provider); `camera` is for any other.
//! cameras = { camera2 = { x_m = 0.1, y_m = -0.12, z_m = 1.2, pan_rad = 0.0, tilt_rad = 0.0 } }
//! ```

use std::collections::BTreeMap;
use std::path::PathBuf;

use lewis_images::ImageIntrinsics;
use lewis_interfaces::msg::{ImageSource, Signs, SignsCommand, SignsSetEnabledReply};
use lewis_service::Health;
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Input, Reply, Service, ServiceConfig,
};
use serde::Deserialize;

use super::camera_model::{CameraMount, CameraMounts, PinholeCamera};
use super::cmvision::ColorConfig;
use super::image_view::{FrameScratch, ImageError};
use super::signs::{SignFinder, SignModel, default_sign_colors};

/// The kind name in robot files.
pub const KIND: &str = "sign_detector";

/// The parameters of `sign_detector`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// A colour file with the board's and the arrow's classes (default: built in).
    pub colors: Option<PathBuf>,
    /// The board's class name.
    pub board_color: String,
    /// The arrow's class name.
    pub arrow_color: String,
    /// The board's height, in m.
    pub board_height_m: f64,
    /// The board's width over its height.
    pub board_aspect: f64,
    /// Smaller white regions are not boards, in px.
    pub min_board_area_px: u32,
    /// Signs read with less confidence are not published.
    pub min_confidence: f64,
    /// The camera's horizontal field of view, for images without intrinsics, in degrees.
    pub horizontal_fov_deg: f64,
    /// Where the camera sits on the robot.
    pub camera: CameraMount,
    /// Where each other camera sits, by its service's name, for its images (the broker may
    /// move the detector to another camera).
    pub cameras: BTreeMap<String, CameraMount>,
}

impl Default for Params {
    fn default() -> Self {
        let model = SignModel::default();
        Self {
            colors: None,
            board_color: "White".to_owned(),
            arrow_color: "Black".to_owned(),
            board_height_m: model.board_height_m,
            board_aspect: model.board_aspect,
            min_board_area_px: model.min_board_area_px,
            min_confidence: model.min_confidence,
            horizontal_fov_deg: 48.8,
            camera: CameraMount::default(),
            cameras: BTreeMap::new(),
        }
    }
}

/// Why sign detector parameters cannot work.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SignParamsError {
    /// The colour file cannot be used.
    #[error("{0}")]
    Colors(String),
    /// A class name the colour file does not have.
    #[error("colour class `{name}` is not in the colour file (it has {known}): set {parameter}")]
    UnknownClass {
        /// The name asked for.
        name: String,
        /// Which parameter names it.
        parameter: &'static str,
        /// The file's class names.
        known: String,
    },
    /// A number out of range.
    #[error("{0}")]
    OutOfRange(&'static str),
}

impl Params {
    /// Where the cameras the images may come from sit.
    #[must_use]
    pub fn mounts(&self) -> CameraMounts {
        CameraMounts::new(self.camera, self.cameras.clone())
    }

    /// The sign finder these parameters describe.
    ///
    /// # Errors
    /// When the colour file cannot be read, lacks a class, or a number is out of range.
    pub fn finder(&self) -> Result<SignFinder, SignParamsError> {
        let colors = match &self.colors {
            Some(path) => {
                ColorConfig::load(path).map_err(|e| SignParamsError::Colors(e.to_string()))?
            }
            None => default_sign_colors(),
        };
        self.finder_with(&colors)
    }

    /// The sign finder these parameters describe, with the classes of `colors` instead of
    /// [`Self::colors`]' (`lewis tune open` finds signs with the classes being tuned).
    ///
    /// # Errors
    /// As [`Self::finder`], but for the colour file's reading.
    pub fn finder_with(&self, colors: &ColorConfig) -> Result<SignFinder, SignParamsError> {
        let class = |name: &str, parameter| {
            colors
                .colors
                .iter()
                .position(|c| c.name == name)
                .and_then(|i| u8::try_from(i).ok())
                .ok_or_else(|| SignParamsError::UnknownClass {
                    name: name.to_owned(),
                    parameter,
                    known: colors
                        .colors
                        .iter()
                        .map(|c| c.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                })
        };
        let board = class(&self.board_color, "board_color")?;
        let arrow = class(&self.arrow_color, "arrow_color")?;
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !positive(self.board_height_m) {
            return Err(SignParamsError::OutOfRange(
                "board_height_m must be positive",
            ));
        }
        if !positive(self.board_aspect) {
            return Err(SignParamsError::OutOfRange("board_aspect must be positive"));
        }
        if !(self.horizontal_fov_deg > 0.0 && self.horizontal_fov_deg < 180.0) {
            return Err(SignParamsError::OutOfRange(
                "horizontal_fov_deg must be between 0 and 180",
            ));
        }
        let model = SignModel {
            board_height_m: self.board_height_m,
            board_aspect: self.board_aspect,
            min_board_area_px: self.min_board_area_px,
            min_confidence: self.min_confidence,
            ..SignModel::default()
        };
        SignFinder::new(colors, board, arrow, model)
            .map_err(|e| SignParamsError::Colors(e.to_string()))
    }
}

/// Signs in ImageSource messages.
pub struct SignDetector {
    finder: SignFinder,
    scratch: FrameScratch,
    mounts: CameraMounts,
    horizontal_fov_rad: f64,
}

impl SignDetector {
    /// A detector with `finder`, cameras at `mounts` whose field of view is
    /// `horizontal_fov_rad` when the images do not say.
    #[must_use]
    pub fn new(finder: SignFinder, mounts: CameraMounts, horizontal_fov_rad: f64) -> Self {
        Self {
            finder,
            scratch: FrameScratch::default(),
            mounts,
            horizontal_fov_rad,
        }
    }

    /// The Signs publication of one image (header left to the publisher).
    ///
    /// # Errors
    /// When the image cannot be read.
    pub fn detect(&mut self, image: &ImageSource) -> Result<Signs, ImageError> {
        let frame = self.scratch.rgb_frame(image)?;
        let intrinsics = ImageIntrinsics::of_image(image).unwrap_or_else(|| {
            ImageIntrinsics::from_fov(frame.width_px(), frame.height_px(), self.horizontal_fov_rad)
        });
        // The camera that took it: the provider its header names.
        let camera = PinholeCamera::new(intrinsics, self.mounts.of(&image.header.provider));
        let found = self.finder.find(frame);
        let signs: Vec<_> = found
            .iter()
            .map(|sign| self.finder.sign_message(sign, &camera))
            .collect();
        Ok(Signs {
            sign_count: i32::try_from(signs.len()).unwrap_or(i32::MAX),
            signs,
            ..Signs::default()
        })
    }
}

/// Builds a `sign_detector` service from its robot-file entry.
///
/// # Errors
/// When the parameters are wrong or the colour file cannot be used.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: Params = config.parameters()?;
    let finder = params.finder().map_err(|e| BuildError::Parameters {
        service: config.name().to_owned(),
        reason: e.to_string(),
    })?;
    Ok(Box::new(SignDetectorService {
        detector: SignDetector::new(
            finder,
            params.mounts(),
            params.horizontal_fov_deg.to_radians(),
        ),
        enabled: true,
    }))
}

/// The `sign_detector` service.
struct SignDetectorService {
    detector: SignDetector,
    enabled: bool,
}

impl Service for SignDetectorService {
    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        if input.interface != "ImageSource" || !self.enabled {
            return;
        }
        let result = input
            .decode::<ImageSource>()
            .map_err(|e| e.to_string())
            .and_then(|image| self.detector.detect(&image).map_err(|e| e.to_string()));
        match result {
            Ok(mut signs) => {
                ctx.set_health(Health::Ok);
                if let Err(e) = ctx.publish(&mut signs) {
                    ctx.warn(&format!("cannot publish Signs: {e}"));
                }
            }
            Err(why) => {
                ctx.warn(&format!("image from {} skipped: {why}", input.provider));
                ctx.set_health(Health::Degraded(format!("images cannot be read: {why}")));
            }
        }
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        match command.decode::<Signs>()? {
            SignsCommand::SetEnabled(set) => {
                self.enabled = set.enabled;
                Ok(ctx.reply(SignsSetEnabledReply::default()))
            }
        }
    }
}
