//! The frame the page shows: its pixels, those in a class tinted with the class's colour,
//! its blobs boxed (and with `--signs` the sign detector's boards, in white), as PNG.

use std::io::Cursor;

use image::{ImageFormat, RgbImage};
use lewis_images::{ImageIntrinsics, image_message};
use lewis_interfaces::msg::Signs;
use lewis_perception::ColorConfig;
use lewis_perception::cmvision::{CmVision, Region};
use lewis_perception::sign_detector::{self, SignDetector};
use lewis_perception::sweep::{HeldFrame, PIXELS_PER_HELD_PIXEL};
use lewis_perception::tuning::draw_regions;

/// The frame with its classified pixels tinted and its regions boxed, as PNG bytes.
///
/// # Errors
/// When the configuration has too many classes or the PNG cannot be encoded.
pub fn overlay_png(
    config: &ColorConfig,
    frame: &HeldFrame,
    regions: &[Region],
    boards: &[Region],
) -> anyhow::Result<Vec<u8>> {
    let cmvision = CmVision::new(config)?;
    let mut rgb = frame.rgb.clone();
    for pixel in rgb.chunks_exact_mut(3) {
        let Some(color) = cmvision.color_of_rgb([pixel[0], pixel[1], pixel[2]]) else {
            continue;
        };
        let Some(class) = config.colors.get(usize::from(color)) else {
            continue;
        };
        // Half the pixel, half the class's colour: the pixel still shows through.
        for (p, c) in pixel.iter_mut().zip(class.display_rgb) {
            *p = u8::try_from((u16::from(*p) + u16::from(c)) / 2).unwrap_or(u8::MAX);
        }
    }
    let mut image = RgbImage::from_raw(frame.width_px, frame.height_px, rgb)
        .ok_or_else(|| anyhow::anyhow!("frame {}: pixels do not fit its size", frame.name))?;
    draw_regions(&mut image, regions, &config.colors);
    draw_regions(&mut image, boards, &[]);
    let mut png = Cursor::new(Vec::new());
    image.write_to(&mut png, ImageFormat::Png)?;
    Ok(png.into_inner())
}

/// The signs the sign detector finds in a held frame with the classes being tuned (its
/// board and arrow classes are `White` and `Black`), in held pixels: the detector's
/// smallest board is scaled down by the decimation.
///
/// # Errors
/// When the classes lack `White` or `Black`, or the frame cannot be read.
pub fn signs(config: &ColorConfig, frame: &HeldFrame) -> anyhow::Result<Signs> {
    let defaults = sign_detector::Params::default();
    let params = sign_detector::Params {
        min_board_area_px: (defaults.min_board_area_px / PIXELS_PER_HELD_PIXEL).max(1),
        ..defaults
    };
    let fov_rad = params.horizontal_fov_deg.to_radians();
    let finder = params.finder_with(config)?;
    let mut detector = SignDetector::new(finder, params.mounts(), fov_rad);
    let image = image_message(
        frame.width_px,
        frame.height_px,
        frame.rgb.clone(),
        ImageIntrinsics::from_fov(frame.width_px, frame.height_px, fov_rad),
    );
    Ok(detector.detect(&image)?)
}

/// The signs' boards as regions, to be drawn in white.
pub fn sign_boards(signs: &Signs) -> Vec<Region> {
    signs
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
        .collect()
}
