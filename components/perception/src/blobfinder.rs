//! `blobfinder`: CMVision over every image of an ImageSource, published as Blobs.
//!
//! [`BlobFinder`] is the algorithm (a [`CmVision`] and a frame buffer); the service only
//! adapts it to the runtime: it requires ImageSource, provides Blobs, and answers
//! `Blobs.set_min_area`.
//!
//! ```toml
//! [[services]]
//! name = "blobfinder"
//! kind = "blobfinder"
//! requires = ["ImageSource"]
//! provides = [{ interface = "Blobs", quality = 10, cost = 3 }]
//! [services.parameters]
//! colors = "robots/colors/conference.txt"  # Player format, or TOML when it ends in .toml
//! min_area_px = 30                         # optional: overrides the file's minimum area
//! max_blobs_per_color = 64                 # optional: the largest blobs of each colour
//! ```
//!
//! A relative `colors` path is taken from the service's working directory (where `lewis up`
//! runs).

use std::path::PathBuf;

use lewis_interfaces::msg::{Blob, Blobs, BlobsCommand, BlobsSetMinAreaReply, ImageSource};
use lewis_service::Health;
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Input, Reply, Service, ServiceConfig,
};
use serde::Deserialize;

use super::cmvision::{CmVision, ColorClass, ColorConfig, ConfigError, Region};
use super::image_view::{FrameScratch, ImageError};

/// The kind name in robot files.
pub const KIND: &str = "blobfinder";

/// The parameters of `blobfinder`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// The colour file (Player's format, or TOML when the name ends in `.toml`).
    pub colors: PathBuf,
    /// Overrides the colour file's minimum blob area, in px.
    #[serde(default)]
    pub min_area_px: Option<u32>,
    /// At most this many blobs of each colour are published (the largest).
    #[serde(default = "default_max_blobs")]
    pub max_blobs_per_color: u32,
}

/// At most this many blobs of each colour, unless the parameters say otherwise.
pub const DEFAULT_MAX_BLOBS_PER_COLOR: u32 = 64;

fn default_max_blobs() -> u32 {
    DEFAULT_MAX_BLOBS_PER_COLOR
}

/// The message of one region: colour id, name and drawing colour from its class.
#[must_use]
pub fn blob_of(region: &Region, class: Option<&ColorClass>) -> Blob {
    let to_i32 = |v: u32| i32::try_from(v).unwrap_or(i32::MAX);
    let (name, rgb) = class.map_or((String::new(), [255; 3]), |c| {
        (c.name.clone(), c.display_rgb)
    });
    Blob {
        colour_index: i32::from(region.color),
        colour_name: name,
        colour_rgb: u32::from_be_bytes([0, rgb[0], rgb[1], rgb[2]]),
        area: to_i32(region.area_px),
        centroid_x: region.centroid_x_px,
        centroid_y: region.centroid_y_px,
        left: to_i32(region.left_px),
        top: to_i32(region.top_px),
        right: to_i32(region.right_px),
        bottom: to_i32(region.bottom_px),
    }
}

/// CMVision over ImageSource messages.
pub struct BlobFinder {
    cmvision: CmVision,
    scratch: FrameScratch,
    max_blobs_per_color: usize,
}

impl BlobFinder {
    /// A blob finder for the classes of `config`, publishing at most `max_blobs_per_color`
    /// blobs of each colour.
    ///
    /// # Errors
    /// When the configuration has more classes than CMVision handles.
    pub fn new(config: &ColorConfig, max_blobs_per_color: u32) -> Result<Self, ConfigError> {
        Ok(Self {
            cmvision: CmVision::new(config)?,
            scratch: FrameScratch::default(),
            max_blobs_per_color: max_blobs_per_color as usize,
        })
    }

    /// The CMVision instance (its classes, its minimum area).
    #[must_use]
    pub fn cmvision(&self) -> &CmVision {
        &self.cmvision
    }

    /// Changes the minimum blob area, in px.
    pub fn set_min_area_px(&mut self, min_area_px: u32) {
        self.cmvision.set_min_area_px(min_area_px);
    }

    /// The regions of one image (as [`CmVision::process`] orders them).
    ///
    /// # Errors
    /// When the image cannot be read.
    pub fn regions(&mut self, image: &ImageSource) -> Result<&[Region], ImageError> {
        let frame = self.scratch.rgb_frame(image)?;
        Ok(self.cmvision.process(frame))
    }

    /// The Blobs publication of one image (header left to the publisher): by colour id, each
    /// colour's blobs largest first.
    ///
    /// # Errors
    /// When the image cannot be read.
    pub fn find(&mut self, image: &ImageSource) -> Result<Blobs, ImageError> {
        let max = self.max_blobs_per_color;
        let frame = self.scratch.rgb_frame(image)?;
        self.cmvision.process(frame);
        let colors = self.cmvision.colors();
        let mut blobs = Vec::new();
        for (id, class) in (0..=u8::MAX).zip(colors) {
            let regions = self.cmvision.regions_of_color(id);
            blobs.extend(regions.iter().take(max).map(|r| blob_of(r, Some(class))));
        }
        Ok(Blobs {
            image_width: image.width,
            image_height: image.height,
            blob_count: i32::try_from(blobs.len()).unwrap_or(i32::MAX),
            blobs,
            ..Blobs::default()
        })
    }
}

/// Builds a `blobfinder` service from its robot-file entry.
///
/// # Errors
/// When the parameters are wrong or the colour file cannot be used.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: Params = config.parameters()?;
    let invalid = |reason: String| BuildError::Parameters {
        service: config.name().to_owned(),
        reason,
    };
    let mut colors = ColorConfig::load(&params.colors).map_err(|e| invalid(e.to_string()))?;
    if let Some(min_area_px) = params.min_area_px {
        colors.min_area_px = min_area_px;
    }
    let finder =
        BlobFinder::new(&colors, params.max_blobs_per_color).map_err(|e| invalid(e.to_string()))?;
    Ok(Box::new(BlobFinderService { finder }))
}

/// The `blobfinder` service.
struct BlobFinderService {
    finder: BlobFinder,
}

impl Service for BlobFinderService {
    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        if input.interface != "ImageSource" {
            return;
        }
        let result = input
            .decode::<ImageSource>()
            .map_err(|e| e.to_string())
            .and_then(|image| self.finder.find(&image).map_err(|e| e.to_string()));
        match result {
            Ok(mut blobs) => {
                ctx.set_health(Health::Ok);
                if let Err(e) = ctx.publish(&mut blobs) {
                    ctx.warn(&format!("cannot publish Blobs: {e}"));
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
        match command.decode::<Blobs>()? {
            BlobsCommand::SetMinArea(set) => {
                let min_area_px = u32::try_from(set.min_area).map_err(|_| {
                    CommandError::new(format!(
                        "min_area {} is negative: give a number of pixels, 0 or more",
                        set.min_area
                    ))
                })?;
                self.finder.set_min_area_px(min_area_px);
                Ok(ctx.reply(BlobsSetMinAreaReply::default()))
            }
        }
    }
}
