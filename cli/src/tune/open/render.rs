//! The frame the page shows: its pixels, those in a class tinted with the class's colour,
//! and its blobs boxed, as PNG.

use std::io::Cursor;

use image::{ImageFormat, RgbImage};
use lewis_perception::ColorConfig;
use lewis_perception::cmvision::{CmVision, Region};
use lewis_perception::sweep::HeldFrame;
use lewis_perception::tuning::draw_regions;

/// The frame with its classified pixels tinted and its regions boxed, as PNG bytes.
///
/// # Errors
/// When the configuration has too many classes or the PNG cannot be encoded.
pub fn overlay_png(
    config: &ColorConfig,
    frame: &HeldFrame,
    regions: &[Region],
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
    let mut png = Cursor::new(Vec::new());
    image.write_to(&mut png, ImageFormat::Png)?;
    Ok(png.into_inner())
}
