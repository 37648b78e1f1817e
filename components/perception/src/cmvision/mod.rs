//! CMVision colour segmentation (Bruce, Balch and Veloso, IROS 2000), as PROTOCOLS.md
//! describes it: classify every pixel into up to 32 colour classes with three per-channel
//! tables, run-length encode each row, merge 4-connected runs of the same colour with
//! union-find, and build regions (colour, area, bounding box, centroid) from the runs.
//!
//! [`CmVision`] owns all its scratch space: after the first frames of a given kind, processing
//! a frame allocates nothing.
//!
//! Colour of a pixel: the lowest set bit of its class mask (colour 0 wins over colour 1 where
//! their boxes overlap). Runs are stored with that colour, so two adjacent runs whose masks
//! differ but share the lowest bit belong to one region: "merge runs of the same colour".

mod classifier;
mod config;
mod frame;
pub mod player_format;
mod regions;
pub mod toml_format;
mod yuv;

pub use config::{
    ChannelRange, ColorClass, ColorConfig, ColorFileError, ColorFileProblem, MAX_COLORS,
};
pub use frame::{FrameError, MAX_SIDE_PX, RgbFrame};
pub use regions::Region;
pub use yuv::rgb_to_yuv;

use classifier::{Classifier, NO_COLOR};
use regions::{RegionBuilder, Run};

/// Why a colour configuration cannot be used.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConfigError {
    /// More classes than the class mask has bits.
    #[error("{0} colour classes: CMVision classifies at most {MAX_COLORS} at once")]
    TooManyColors(usize),
}

/// The CMVision blob finder: colour tables plus the scratch space of one frame.
pub struct CmVision {
    colors: Vec<ColorClass>,
    min_area_px: u32,
    classifier: Classifier,
    /// Non-background runs of the frame, row after row, left to right.
    runs: Vec<Run>,
    /// Index in `runs` of the first run of each row, plus one past the last run.
    row_starts: Vec<u32>,
    regions: RegionBuilder,
}

impl CmVision {
    /// Builds the class tables of `config`.
    ///
    /// # Errors
    /// [`ConfigError::TooManyColors`] beyond [`MAX_COLORS`] classes.
    pub fn new(config: &ColorConfig) -> Result<Self, ConfigError> {
        if config.colors.len() > MAX_COLORS {
            return Err(ConfigError::TooManyColors(config.colors.len()));
        }
        Ok(Self {
            colors: config.colors.clone(),
            min_area_px: config.min_area_px,
            classifier: Classifier::new(&config.colors),
            runs: Vec::new(),
            row_starts: Vec::new(),
            regions: RegionBuilder::default(),
        })
    }

    /// The colour classes, in colour id order.
    #[must_use]
    pub fn colors(&self) -> &[ColorClass] {
        &self.colors
    }

    /// Regions smaller than this are dropped.
    #[must_use]
    pub fn min_area_px(&self) -> u32 {
        self.min_area_px
    }

    /// Changes the minimum region area (takes effect from the next frame).
    pub fn set_min_area_px(&mut self, min_area_px: u32) {
        self.min_area_px = min_area_px;
    }

    /// The colour id of an RGB pixel (the lowest class containing it), or `None`.
    #[must_use]
    pub fn color_of_rgb(&self, rgb: [u8; 3]) -> Option<u8> {
        let code = self.classifier.code_rgb(rgb);
        (code != NO_COLOR).then_some(code)
    }

    /// The class mask of a YUV pixel (bit k: colour k contains it).
    #[must_use]
    pub fn class_mask_yuv(&self, yuv: [u8; 3]) -> u32 {
        self.classifier.mask_yuv(yuv)
    }

    /// Segments one frame. Returns its regions, grouped by colour id (ascending), each
    /// colour's regions by area (descending; ties: the region whose first pixel in raster
    /// order comes first), each at least [`Self::min_area_px`] pixels, merged by density
    /// where the colour's `merge_density` is above 0. The slice lives until the next call.
    pub fn process(&mut self, frame: RgbFrame<'_>) -> &[Region] {
        self.encode_runs(frame);
        self.regions
            .build(&self.runs, &self.row_starts, &self.colors, self.min_area_px);
        self.regions.regions()
    }

    /// The regions of one colour id from the last [`Self::process`] (empty for unknown ids).
    #[must_use]
    pub fn regions_of_color(&self, color: u8) -> &[Region] {
        self.regions.regions_of_color(color)
    }

    /// Number of (non-background) runs in the last frame.
    #[must_use]
    pub fn run_count(&self) -> usize {
        self.runs.len()
    }

    /// Classification and run-length encoding in one pass over each row.
    fn encode_runs(&mut self, frame: RgbFrame<'_>) {
        let width = frame.width_px() as usize;
        self.runs.clear();
        self.row_starts.clear();
        // RgbFrame guarantees data.len() == width * height * 3 with both at least 1.
        let (pixels, _) = frame.data().as_chunks::<3>();
        for row in pixels.chunks_exact(width) {
            // Runs are fewer than 2^30 (pixels are at most 2^30): the casts are exact.
            self.row_starts.push(self.runs.len() as u32);
            self.runs.reserve(width);
            encode_row(&self.classifier, row, &mut self.runs);
        }
        self.row_starts.push(self.runs.len() as u32);
    }
}

/// Appends the non-background runs of one row to `runs`.
#[inline(always)]
fn encode_row(classifier: &Classifier, row: &[[u8; 3]], runs: &mut Vec<Run>) {
    let Some((&first, rest)) = row.split_first() else {
        return;
    };
    let mut run_code = classifier.code_rgb(first);
    let mut run_start = 0u32;
    let mut x = 1u32;
    for &pixel in rest {
        let code = classifier.code_rgb(pixel);
        if code != run_code {
            if run_code != NO_COLOR {
                runs.push(Run {
                    start: run_start,
                    end: x - 1,
                    code: run_code,
                });
            }
            run_code = code;
            run_start = x;
        }
        x += 1;
    }
    if run_code != NO_COLOR {
        runs.push(Run {
            start: run_start,
            end: x - 1,
            code: run_code,
        });
    }
}
