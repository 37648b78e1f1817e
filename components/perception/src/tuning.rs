//! Offline tuning of colour classes, behind `lewis tune`: CMVision (and the sign detector)
//! re-run over frames with new classes, per-colour statistics over many frames, the blobs
//! drawn into a frame, and the YUV ranges of a patch of pixels as a colour-file entry.

use std::f64::consts::FRAC_PI_2;
use std::fmt;
use std::path::Path;

use image::RgbImage;
use lewis_images::sequence::{SequenceError, load_rgb};
use lewis_images::{ImageIntrinsics, image_message};
use lewis_interfaces::msg::{Blobs, ImageSource, Signs};

use super::blobfinder::blob_of;
use super::cmvision::{
    ChannelRange, CmVision, ColorClass, ColorConfig, ConfigError, Region, rgb_to_yuv,
};
use super::image_view::{FrameScratch, ImageError};
use super::sign_detector::SignDetector;

/// Re-runs CMVision (and, when given one, a sign detector) over frames with a colour
/// configuration, keeping per-colour statistics.
pub struct Tuner {
    cmvision: CmVision,
    scratch: FrameScratch,
    statistics: Statistics,
    signs: Option<SignDetector>,
}

/// One frame as the tuner saw it.
#[derive(Debug, Clone, PartialEq)]
pub struct TunedFrame {
    /// Its regions, as [`CmVision::process`] orders them.
    pub regions: Vec<Region>,
    /// The regions as the blobfinder service would publish them (every one; header
    /// left to the writer).
    pub blobs: Blobs,
    /// The signs found, when the tuner has a sign detector (header left to the writer).
    pub signs: Option<Signs>,
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
            signs: None,
        })
    }

    /// Also runs `detector` over every frame.
    #[must_use]
    pub fn with_signs(mut self, detector: SignDetector) -> Self {
        self.signs = Some(detector);
        self
    }

    /// Segments one frame (and finds its signs) and counts its blobs.
    ///
    /// # Errors
    /// When the image cannot be read (the frame is then not counted).
    pub fn frame(&mut self, image: &ImageSource) -> Result<TunedFrame, ImageError> {
        let frame = self.scratch.rgb_frame(image)?;
        let regions = self.cmvision.process(frame).to_vec();
        self.statistics.add_frame(&regions);
        let colors = self.cmvision.colors();
        let blobs: Vec<_> = regions
            .iter()
            .map(|r| blob_of(r, colors.get(usize::from(r.color))))
            .collect();
        let blobs = Blobs {
            image_width: image.width,
            image_height: image.height,
            blob_count: i32::try_from(blobs.len()).unwrap_or(i32::MAX),
            blobs,
            ..Blobs::default()
        };
        let signs = self
            .signs
            .as_mut()
            .map(|detector| detector.detect(image))
            .transpose()?;
        Ok(TunedFrame {
            regions,
            blobs,
            signs,
        })
    }

    /// The frame with `tuned`'s regions drawn in (and its signs' boards, in white).
    ///
    /// # Errors
    /// When the image cannot be read.
    pub fn annotate(
        &mut self,
        image: &ImageSource,
        tuned: &TunedFrame,
    ) -> Result<RgbImage, ImageError> {
        let frame = self.scratch.rgb_frame(image)?;
        let mut annotated =
            RgbImage::from_raw(frame.width_px(), frame.height_px(), frame.data().to_vec())
                .unwrap_or_default();
        draw_regions(&mut annotated, &tuned.regions, self.cmvision.colors());
        if let Some(signs) = &tuned.signs {
            let boards: Vec<Region> = signs
                .signs
                .iter()
                .map(|s| Region {
                    color: u8::MAX,
                    area_px: 0,
                    left_px: u32::try_from(s.board.left).unwrap_or(0),
                    top_px: u32::try_from(s.board.top).unwrap_or(0),
                    right_px: u32::try_from(s.board.right).unwrap_or(0),
                    bottom_px: u32::try_from(s.board.bottom).unwrap_or(0),
                    centroid_x_px: s.board.centroid_x,
                    centroid_y_px: s.board.centroid_y,
                })
                .collect();
            draw_regions(&mut annotated, &boards, &[]);
        }
        Ok(annotated)
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

/// Writes an image as a PNG file.
///
/// # Errors
/// When the file cannot be written.
pub fn save_png(image: &RgbImage, path: &Path) -> Result<(), image::ImageError> {
    image.save_with_format(path, image::ImageFormat::Png)
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
        // centroids lie inside the image
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
        // counts far below 2^52
        self.areas_px.len() as f64 / self.frames as f64
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

/// Which pixels to pick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Patch {
    /// The pixels within `radius_px` of (`x`, `y`).
    Disc {
        /// Column of the centre.
        x: u32,
        /// Row of the centre.
        y: u32,
        /// Radius, in px.
        radius_px: u32,
    },
    /// A rectangle: its top-left pixel and its size.
    Rect {
        /// Column of the left edge.
        x: u32,
        /// Row of the top edge.
        y: u32,
        /// Width, in px.
        width: u32,
        /// Height, in px.
        height: u32,
    },
}

impl fmt::Display for Patch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Disc { x, y, radius_px } => {
                write!(f, "the disc of radius {radius_px} px at {x},{y}")
            }
            Self::Rect {
                x,
                y,
                width,
                height,
            } => write!(f, "the {width}x{height} rectangle at {x},{y}"),
        }
    }
}

impl Patch {
    /// Whether the patch's anchor (a disc's centre, a rectangle's top-left pixel) lies
    /// in a `width` x `height` image and the patch is not empty.
    fn check(self, width: u32, height: u32) -> Result<(), PickError> {
        let (x, y, empty) = match self {
            Self::Disc { x, y, .. } => (x, y, false),
            Self::Rect {
                x,
                y,
                width,
                height,
            } => (x, y, width == 0 || height == 0),
        };
        if empty {
            return Err(PickError::Empty { patch: self });
        }
        if x >= width || y >= height {
            return Err(PickError::Outside {
                patch: self,
                width,
                height,
            });
        }
        Ok(())
    }

    /// Its pixels inside a `width` x `height` image, row by row.
    fn pixels(self, width: u32, height: u32) -> Vec<(u32, u32)> {
        let mut inside = Vec::new();
        match self {
            Self::Disc { x, y, radius_px } => {
                let r = i64::from(radius_px);
                for dy in -r..=r {
                    for dx in -r..=r {
                        if dx * dx + dy * dy > r * r {
                            continue;
                        }
                        if let (Ok(px), Ok(py)) = (
                            u32::try_from(i64::from(x) + dx),
                            u32::try_from(i64::from(y) + dy),
                        ) && px < width
                            && py < height
                        {
                            inside.push((px, py));
                        }
                    }
                }
            }
            Self::Rect {
                x,
                y,
                width: w,
                height: h,
            } => {
                let right = x.saturating_add(w).min(width);
                let bottom = y.saturating_add(h).min(height);
                for py in y..bottom {
                    inside.extend((x..right).map(|px| (px, py)));
                }
            }
        }
        inside
    }
}

/// The YUV ranges of a patch of pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pick {
    /// Pixels in the patch (inside the image).
    pub pixels: usize,
    /// Range of Y.
    pub y: ChannelRange,
    /// Range of U.
    pub u: ChannelRange,
    /// Range of V.
    pub v: ChannelRange,
    /// The patch's median colour, to draw the class's blobs with.
    pub median_rgb: [u8; 3],
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

    /// The class's line of a Player colour file's `[Colors]` section: the patch's median
    /// colour, no density merging, `name`.
    #[must_use]
    pub fn color_line(&self, name: &str) -> String {
        let [r, g, b] = self.median_rgb;
        format!("({r:3},{g:3},{b:3}) 0.000000 1 {name}")
    }
}

/// Why a patch cannot be picked.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PickError {
    /// The patch's anchor is outside the image.
    #[error("{patch} is outside the {width}x{height} image")]
    Outside {
        /// The patch asked for.
        patch: Patch,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
    },
    /// The patch has no pixels.
    #[error("{patch} has no pixels: give a width and a height of at least 1")]
    Empty {
        /// The patch asked for.
        patch: Patch,
    },
}

/// The YUV ranges of the pixels of `patch`: from the 5th to the 95th percentile of each
/// channel (so that a few stray pixels at the patch's edge do not widen the class),
/// widened by `margin` levels on each side. A patch that reaches past the image's edge is
/// cut there.
///
/// # Errors
/// When the patch is empty or starts outside the image.
pub fn pick(image: &RgbImage, patch: Patch, margin: u8) -> Result<Pick, PickError> {
    let (width, height) = image.dimensions();
    patch.check(width, height)?;
    let mut channels: [Vec<u8>; 3] = Default::default();
    let mut colours: [Vec<u8>; 3] = Default::default();
    for (px, py) in patch.pixels(width, height) {
        let rgb = image.get_pixel(px, py).0;
        for (channel, value) in channels.iter_mut().zip(rgb_to_yuv(rgb[0], rgb[1], rgb[2])) {
            channel.push(value);
        }
        for (channel, value) in colours.iter_mut().zip(rgb) {
            channel.push(value);
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
    let median = |values: &mut Vec<u8>| {
        values.sort_unstable();
        quantile(values, 0.5).unwrap_or(0)
    };
    let pixels = channels[0].len();
    let [mut ys, mut us, mut vs] = channels;
    let [mut rs, mut gs, mut bs] = colours;
    Ok(Pick {
        pixels,
        y: range(&mut ys),
        u: range(&mut us),
        v: range(&mut vs),
        median_rgb: [median(&mut rs), median(&mut gs), median(&mut bs)],
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
/// When the file cannot be read or the patch is not in it.
pub fn pick_in_file(path: &Path, patch: Patch, margin: u8) -> Result<Pick, PickFileError> {
    let data = load_rgb(path)?;
    let image = RgbImage::from_raw(data.width_px, data.height_px, data.rgb).unwrap_or_default();
    pick(&image, patch, margin).map_err(|source| PickFileError::Pick {
        path: path.display().to_string(),
        source,
    })
}

/// An ImageSource message as an RGB image (for [`pick`]).
///
/// # Errors
/// When the message's pixels cannot be read (encoding, size).
pub fn rgb_image(image: &ImageSource) -> Result<RgbImage, ImageError> {
    let mut scratch = FrameScratch::default();
    let frame = scratch.rgb_frame(image)?;
    Ok(
        RgbImage::from_raw(frame.width_px(), frame.height_px(), frame.data().to_vec())
            .unwrap_or_default(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_uniform_patch_gives_its_colour_widened_by_the_margin() {
        let image = RgbImage::from_pixel(20, 10, image::Rgb([255, 0, 0]));
        let disc = |x, y| Patch::Disc { x, y, radius_px: 3 };
        let got = pick(&image, disc(0, 0), 4).unwrap();
        // Red is Y 82, U 90, V 240 (BT.601 integer approximation).
        assert_eq!(got.threshold_line(), "( 78: 86, 86: 94,236:244)");
        assert_eq!(got.color_line("Red"), "(255,  0,  0) 0.000000 1 Red");
        assert_eq!(
            got.pixels, 11,
            "the quarter disc of radius 3 inside the image"
        );
        assert_eq!(
            pick(&image, disc(20, 0), 4),
            Err(PickError::Outside {
                patch: disc(20, 0),
                width: 20,
                height: 10
            })
        );
        assert_eq!(
            pick(&image, disc(20, 0), 4).unwrap_err().to_string(),
            "the disc of radius 3 px at 20,0 is outside the 20x10 image"
        );
    }

    #[test]
    fn a_rectangle_takes_its_pixels_cut_at_the_image_edge() {
        // Left half blue, right half green.
        let image = RgbImage::from_fn(20, 10, |x, _| {
            image::Rgb(if x < 10 { [0, 0, 255] } else { [0, 255, 0] })
        });
        let rect = |x, y, width, height| Patch::Rect {
            x,
            y,
            width,
            height,
        };
        let blue = pick(&image, rect(2, 2, 4, 3), 0).unwrap();
        assert_eq!(blue.pixels, 12);
        // Blue is Y 41, U 240, V 110.
        assert_eq!(blue.threshold_line(), "( 41: 41,240:240,110:110)");
        assert_eq!(blue.median_rgb, [0, 0, 255]);
        let cut = pick(&image, rect(15, 8, 100, 100), 0).unwrap();
        assert_eq!(cut.pixels, 10, "5 columns x 2 rows inside the image");
        assert_eq!(cut.median_rgb, [0, 255, 0]);
        // Half and half: the percentiles keep both colours in range.
        let both = pick(&image, rect(0, 0, 20, 10), 0).unwrap();
        assert_eq!(both.pixels, 200);
        assert_eq!(both.y, ChannelRange { lo: 41, hi: 144 });
        assert_eq!(
            pick(&image, rect(0, 0, 0, 5), 0).unwrap_err().to_string(),
            "the 0x5 rectangle at 0,0 has no pixels: give a width and a height of at least 1"
        );
        assert!(matches!(
            pick(&image, rect(20, 0, 5, 5), 0),
            Err(PickError::Outside { .. })
        ));
        assert!(matches!(
            pick(&image, rect(u32::MAX, u32::MAX, u32::MAX, u32::MAX), 0),
            Err(PickError::Outside { .. })
        ));
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
