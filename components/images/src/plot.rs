//! What every plot Lewis draws with plotters shares: the bundled font, registered once,
//! and the encoding of a pixel buffer as PNG. No system font is read and no C font library
//! linked (plotters reads the font through ab_glyph), so the same picture gives the same
//! bytes on every machine.

use std::sync::OnceLock;

use image::ImageEncoder as _;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use plotters::style::{FontStyle, register_font};

/// DejaVu Sans (`components/images/assets/DejaVuSans-LICENSE.txt` has its licence).
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// The family every text of a picture asks for; plotters' own defaults (tick labels) ask
/// for it too.
pub const FAMILY: &str = "sans-serif";

/// Registers the bundled font under [`FAMILY`] (once per process).
///
/// # Errors
/// When the bundled font cannot be read.
pub fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let registered =
        *REGISTERED.get_or_init(|| register_font(FAMILY, FontStyle::Normal, FONT).is_ok());
    if registered {
        Ok(())
    } else {
        Err("the bundled font DejaVuSans.ttf cannot be read".to_owned())
    }
}

/// `pixels`, three bytes a pixel as plotters' bitmap backend draws them, as PNG bytes.
///
/// # Errors
/// When the buffer does not hold `width` x `height` pixels.
pub fn rgb_png(pixels: &[u8], width: u32, height: u32) -> Result<Vec<u8>, image::ImageError> {
    let mut png = Vec::new();
    // Best compression: plots are flat colours, this keeps them to tens of KB.
    PngEncoder::new_with_quality(&mut png, CompressionType::Best, FilterType::Adaptive)
        .write_image(pixels, width, height, image::ExtendedColorType::Rgb8)?;
    Ok(png)
}
