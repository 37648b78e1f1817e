//! Offline tuning of colour classes, behind `lewis tune`: the blobs of a frame drawn into it,
//! per-colour statistics over many frames, and a threshold line made from a patch of
//! pixels.

use std::f64::consts::FRAC_PI_2;
use std::fmt;
use std::path::Path;

use image::RgbImage;
use lewis_interfaces::msg::ImageSource;

use super::cmvision::{
    ChannelRange, CmVision, ColorClass, ColorConfig, ConfigError, Region, rgb_to_yuv,
};
use super::image_view::{FrameScratch, ImageError, ImageIntrinsics, image_message};
use crate::camera::sequence::{SequenceError, load_rgb};

/// Re-runs CMVision over frames with a colour configuration, keeping per-colour statistics
/// and drawing the blobs into the frames.
pub struct Tuner {
    cmvision: CmVision,
    scratch: FrameScratch,
    statistics: Statistics,
}

/// One frame as the tuner saw it.
#[derive(Debug, Clone, PartialEq)]
pub struct TunedFrame {
    /// Its regions, as [`CmVision::process`] orders them.
    pub regions: Vec<Region>,
    /// The frame with the regions drawn in.
    pub annotated: RgbImage,
}

impl TunedFrame {
    /// Writes the annotated frame as a PNG file.
    ///
    /// # Errors
    /// When the file cannot be written.
    pub fn save_png(&self, path: &Path) -> Result<(), image::ImageError> {
        self.annotated
            .save_with_format(path, image::ImageFormat::Png)
    }
}

impl Tuner {
    /// A tuner for the classes of `config`.
    ///
    /// # Errors
    /// When the configuration has more classes than CMVision handles.
    pub fn new(config: &ColorConfig) -> Result<Self, ConfigError> {
        Ok(Self {
            cmvision: CmVision::new(config)?,
            scratch: FrameScratch::default(),
            statistics: Statistics::new(&config.colors),
        })
    }

    /// Segments one frame, counts its blobs and draws them.
    ///
    /// # Errors
    /// When the image cannot be read (the frame is then not counted).
    pub fn frame(&mut self, image: &ImageSource) -> Result<TunedFrame, ImageError> {
        let frame = self.scratch.rgb_frame(image)?;
        let mut annotated =
            RgbImage::from_raw(frame.width_px(), frame.height_px(), frame.data().to_vec())
                .unwrap_or_default();
        let regions = self.cmvision.process(frame).to_vec();
        self.statistics.add_frame(&regions);
        draw_regions(&mut annotated, &regions, self.cmvision.colors());
        Ok(TunedFrame { regions, annotated })
    }

    /// Reads a PNG or JPEG file as an ImageSource frame (rgb8, no intrinsics).
    ///
    /// # Errors
    /// When the file cannot be read or decoded.
    pub fn read_image(path: &Path) -> Result<ImageSource, SequenceError> {
        let image = load_rgb(path)?;
        Ok(image_message(
            image.width_px,
            image.height_px,
            image.rgb,
            ImageIntrinsics::from_fov(image.width_px, image.height_px, FRAC_PI_2),
        ))
    }

    /// The statistics of the frames so far.
    #[must_use]
    pub fn statistics(&self) -> &Statistics {
        &self.statistics
    }
}

/// Draws each region's bounding box (2 px wide, in its class's display colour, or white)
/// and a cross at its centroid into `image`.
pub fn draw_regions(image: &mut RgbImage, regions: &[Region], colors: &[ColorClass]) {
    let (width, height) = image.dimensions();
    if width == 0 || height == 0 {
        return;
    }
    for region in regions {
        let rgb = colors
            .get(usize::from(region.color))
            .map_or([255; 3], |c| c.display_rgb);
        // A box drawn in the class's colour over that colour would vanish: outline it dark.
        let outline = [rgb[0] / 4, rgb[1] / 4, rgb[2] / 4];
        let mut put = |x: i64, y: i64, c: [u8; 3]| {
            if let (Ok(x), Ok(y)) = (u32::try_from(x), u32::try_from(y))
                && x < width
                && y < height
            {
                image.put_pixel(x, y, image::Rgb(c));
            }
        };
        let (l, t) = (i64::from(region.left_px), i64::from(region.top_px));
        let (r, b) = (i64::from(region.right_px), i64::from(region.bottom_px));
        for (offset, colour) in [(-2, outline), (-1, rgb), (0, rgb)] {
            let (l, t, r, b) = (l + offset, t + offset, r - offset, b - offset);
            for x in l..=r {
                put(x, t - 1, colour);
                put(x, b + 1, colour);
            }
            for y in t..=b {
                put(l - 1, y, colour);
                put(r + 1, y, colour);
            }
        }
        #[allow(clippy::cast_possible_truncation)] // centroids lie inside the image
        let (cx, cy) = (
            region.centroid_x_px.round() as i64,
            region.centroid_y_px.round() as i64,
        );
        for d in -3..=3 {
            put(cx + d, cy, outline);
            put(cx, cy + d, outline);
        }
    }
}

/// Per-colour statistics over frames.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ColorStats {
    /// The class's name.
    pub name: String,
    /// Frames seen.
    pub frames: u64,
    /// Frames where the colour had no blob.
    pub frames_without: u64,
    /// Areas of every blob, in px.
    pub areas_px: Vec<u32>,
}

impl ColorStats {
    /// Blobs per frame, on average.
    #[must_use]
    pub fn blobs_per_frame(&self) -> f64 {
        if self.frames == 0 {
            return 0.0;
        }
        #[allow(clippy::cast_precision_loss)] // counts far below 2^52
        let ratio = self.areas_px.len() as f64 / self.frames as f64;
        ratio
    }

    /// The `q` quantile (0 to 1, nearest rank) of the blob areas, in px.
    #[must_use]
    pub fn area_quantile(&self, q: f64) -> Option<u32> {
        let mut sorted = self.areas_px.clone();
        sorted.sort_unstable();
        quantile(&sorted, q)
    }
}

fn quantile<T: Copy>(sorted: &[T], q: f64) -> Option<T> {
    if sorted.is_empty() {
        return None;
    }
    #[allow(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        clippy::cast_precision_loss
    )] // a rank within the slice
    let rank = ((sorted.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize;
    sorted.get(rank).copied()
}

impl fmt::Display for ColorStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: {:.2} blobs/frame, {} of {} frames without",
            self.name,
            self.blobs_per_frame(),
            self.frames_without,
            self.frames
        )?;
        match (
            self.area_quantile(0.0),
            self.area_quantile(0.5),
            self.area_quantile(0.9),
            self.area_quantile(1.0),
        ) {
            (Some(min), Some(median), Some(p90), Some(max)) => {
                write!(f, "; area px min {min} median {median} p90 {p90} max {max}")
            }
            _ => Ok(()),
        }
    }
}

/// Statistics of every colour class over the frames given to [`Statistics::add_frame`].
#[derive(Debug, Clone, PartialEq)]
pub struct Statistics {
    colors: Vec<ColorStats>,
}

impl Statistics {
    /// Empty statistics for `colors`.
    #[must_use]
    pub fn new(colors: &[ColorClass]) -> Self {
        Self {
            colors: colors
                .iter()
                .map(|c| ColorStats {
                    name: c.name.clone(),
                    ..ColorStats::default()
                })
                .collect(),
        }
    }

    /// Adds the regions of one frame.
    pub fn add_frame(&mut self, regions: &[Region]) {
        for (id, stats) in self.colors.iter_mut().enumerate() {
            let before = stats.areas_px.len();
            stats.areas_px.extend(
                regions
                    .iter()
                    .filter(|r| usize::from(r.color) == id)
                    .map(|r| r.area_px),
            );
            stats.frames += 1;
            if stats.areas_px.len() == before {
                stats.frames_without += 1;
            }
        }
    }

    /// Per colour, in colour id order.
    #[must_use]
    pub fn colors(&self) -> &[ColorStats] {
        &self.colors
    }
}

/// The YUV ranges of a patch of pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pick {
    /// Pixels in the patch.
    pub pixels: usize,
    /// Range of Y.
    pub y: ChannelRange,
    /// Range of U.
    pub u: ChannelRange,
    /// Range of V.
    pub v: ChannelRange,
}

impl Pick {
    /// The threshold line of Player's colour file format: `(Ylo:Yhi,Ulo:Uhi,Vlo:Vhi)`.
    #[must_use]
    pub fn threshold_line(&self) -> String {
        format!(
            "({:3}:{:3},{:3}:{:3},{:3}:{:3})",
            self.y.lo, self.y.hi, self.u.lo, self.u.hi, self.v.lo, self.v.hi
        )
    }
}

/// Why a patch cannot be picked.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PickError {
    /// The centre is outside the image.
    #[error("pixel {x},{y} is outside the {width}x{height} image")]
    Outside {
        /// Column asked for.
        x: u32,
        /// Row asked for.
        y: u32,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
    },
}

/// The YUV ranges of the pixels within `radius_px` of (`x`, `y`): from the 5th to the 95th
/// percentile of each channel (so that a few stray pixels at the patch's edge do not widen
/// the class), widened by `margin` levels on each side.
///
/// # Errors
/// When the centre is outside the image.
pub fn pick(
    image: &RgbImage,
    x: u32,
    y: u32,
    radius_px: u32,
    margin: u8,
) -> Result<Pick, PickError> {
    let (width, height) = image.dimensions();
    if x >= width || y >= height {
        return Err(PickError::Outside {
            x,
            y,
            width,
            height,
        });
    }
    let r = i64::from(radius_px);
    let mut channels: [Vec<u8>; 3] = Default::default();
    for dy in -r..=r {
        for dx in -r..=r {
            if dx * dx + dy * dy > r * r {
                continue;
            }
            let (Ok(px), Ok(py)) = (
                u32::try_from(i64::from(x) + dx),
                u32::try_from(i64::from(y) + dy),
            ) else {
                continue;
            };
            if px >= width || py >= height {
                continue;
            }
            let [red, green, blue] = image.get_pixel(px, py).0;
            for (channel, value) in channels.iter_mut().zip(rgb_to_yuv(red, green, blue)) {
                channel.push(value);
            }
        }
    }
    let range = |values: &mut Vec<u8>| {
        values.sort_unstable();
        let lo = quantile(values, 0.05).unwrap_or(0);
        let hi = quantile(values, 0.95).unwrap_or(255);
        ChannelRange {
            lo: lo.saturating_sub(margin),
            hi: hi.saturating_add(margin),
        }
    };
    let pixels = channels[0].len();
    let [mut ys, mut us, mut vs] = channels;
    Ok(Pick {
        pixels,
        y: range(&mut ys),
        u: range(&mut us),
        v: range(&mut vs),
    })
}

/// Why a patch of a file cannot be picked.
#[derive(Debug, thiserror::Error)]
pub enum PickFileError {
    /// The image cannot be read.
    #[error(transparent)]
    Read(#[from] SequenceError),
    /// The patch is not in the image.
    #[error("{path}: {source}")]
    Pick {
        /// The image file.
        path: String,
        /// Why.
        source: PickError,
    },
}

/// [`pick`] on a PNG or JPEG file.
///
/// # Errors
/// When the file cannot be read or the centre is outside it.
pub fn pick_in_file(
    path: &Path,
    x: u32,
    y: u32,
    radius_px: u32,
    margin: u8,
) -> Result<Pick, PickFileError> {
    let data = load_rgb(path)?;
    let image = RgbImage::from_raw(data.width_px, data.height_px, data.rgb).unwrap_or_default();
    pick(&image, x, y, radius_px, margin).map_err(|source| PickFileError::Pick {
        path: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_uniform_patch_gives_its_colour_widened_by_the_margin() {
        let image = RgbImage::from_pixel(20, 10, image::Rgb([255, 0, 0]));
        let got = pick(&image, 0, 0, 3, 4).unwrap();
        // Red is Y 82, U 90, V 240 (BT.601 integer approximation).
        assert_eq!(got.threshold_line(), "( 78: 86, 86: 94,236:244)");
        assert_eq!(
            got.pixels, 11,
            "the quarter disc of radius 3 inside the image"
        );
        assert_eq!(
            pick(&image, 20, 0, 3, 4),
            Err(PickError::Outside {
                x: 20,
                y: 0,
                width: 20,
                height: 10
            })
        );
    }

    #[test]
    fn statistics_count_blobs_frames_without_and_areas() {
        let class = ColorClass {
            name: "Red".into(),
            display_rgb: [255, 0, 0],
            merge_density: 0.0,
            expected_regions: 0,
            y: ChannelRange { lo: 0, hi: 255 },
            u: ChannelRange { lo: 0, hi: 255 },
            v: ChannelRange { lo: 0, hi: 255 },
        };
        let region = |area_px| Region {
            color: 0,
            area_px,
            left_px: 0,
            top_px: 0,
            right_px: 0,
            bottom_px: 0,
            centroid_x_px: 0.0,
            centroid_y_px: 0.0,
        };
        let mut stats = Statistics::new(&[class]);
        stats.add_frame(&[region(10), region(30)]);
        stats.add_frame(&[]);
        stats.add_frame(&[region(20)]);
        let red = &stats.colors()[0];
        assert_eq!(
            red.to_string(),
            "Red: 1.00 blobs/frame, 1 of 3 frames without; area px min 10 median 20 p90 30 max 30"
        );
    }
}
