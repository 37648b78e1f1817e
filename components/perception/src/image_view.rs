//! ImageSource messages as the RGB8 frames CMVision reads (the way back, a message from
//! pixels, is `lewis_images::image_message`).
//!
//! A camera may publish rows with padding (`step` above `width * 3`) or another pixel layout
//! (`bgr8`, `rgba8`, `bgra8`, `mono8`); [`FrameScratch::rgb_frame`] borrows the message's bytes
//! when they already are tightly packed `rgb8` and otherwise converts into its own buffer,
//! which it keeps from frame to frame.

use lewis_interfaces::msg::ImageSource;

use super::cmvision::{FrameError, MAX_SIDE_PX, RgbFrame};

/// Why an ImageSource message cannot be read as an image.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ImageError {
    /// A pixel layout this crate does not read.
    #[error("image encoding `{0}` is not supported: use rgb8, bgr8, rgba8, bgra8 or mono8")]
    UnsupportedEncoding(String),
    /// Width, height or step is negative, or the step is shorter than a row.
    #[error("image {width_px}x{height_px} with step {step_bytes} bytes is not a valid layout")]
    BadLayout {
        /// Declared width.
        width_px: i32,
        /// Declared height.
        height_px: i32,
        /// Declared bytes per row.
        step_bytes: i32,
    },
    /// Fewer bytes than `step * height`.
    #[error("image {width_px}x{height_px} needs {expected_len} bytes but has {actual_len}")]
    ShortData {
        /// Declared width.
        width_px: i32,
        /// Declared height.
        height_px: i32,
        /// `step * (height - 1) + width * bytes per pixel`.
        expected_len: usize,
        /// Bytes in the message.
        actual_len: usize,
    },
    /// The size is empty or too large for CMVision.
    #[error(transparent)]
    Frame(#[from] FrameError),
}

/// Turns the bytes of one pixel into RGB.
type ToRgb = fn(&[u8]) -> [u8; 3];

/// Bytes per pixel of an encoding, and how to turn one pixel into RGB.
fn layout(encoding: &str) -> Option<(usize, ToRgb)> {
    fn rgb(p: &[u8]) -> [u8; 3] {
        [p[0], p[1], p[2]]
    }
    fn bgr(p: &[u8]) -> [u8; 3] {
        [p[2], p[1], p[0]]
    }
    fn mono(p: &[u8]) -> [u8; 3] {
        [p[0]; 3]
    }
    match encoding {
        "rgb8" => Some((3, rgb)),
        "bgr8" => Some((3, bgr)),
        "rgba8" => Some((4, rgb)),
        "bgra8" => Some((4, bgr)),
        "mono8" => Some((1, mono)),
        _ => None,
    }
}

/// The buffer a converted frame lives in, kept between frames.
#[derive(Debug, Default, Clone)]
pub struct FrameScratch {
    rgb: Vec<u8>,
}

impl FrameScratch {
    /// The message's pixels as a tightly packed RGB8 frame: its own bytes when they already
    /// are, a converted copy in this scratch buffer otherwise.
    ///
    /// # Errors
    /// [`ImageError`] when the encoding is unknown or the sizes disagree with the bytes.
    pub fn rgb_frame<'a>(&'a mut self, image: &'a ImageSource) -> Result<RgbFrame<'a>, ImageError> {
        let (bytes_per_px, to_rgb) = layout(&image.encoding)
            .ok_or_else(|| ImageError::UnsupportedEncoding(image.encoding.clone()))?;
        let bad_layout = || ImageError::BadLayout {
            width_px: image.width,
            height_px: image.height,
            step_bytes: image.step,
        };
        let (Ok(width), Ok(height), Ok(step)) = (
            u32::try_from(image.width),
            u32::try_from(image.height),
            usize::try_from(image.step),
        ) else {
            return Err(bad_layout());
        };
        if width == 0 || height == 0 {
            return Err(FrameError::Empty {
                width_px: width,
                height_px: height,
            }
            .into());
        }
        // Checked before any product of the sides is formed.
        if width > MAX_SIDE_PX || height > MAX_SIDE_PX {
            return Err(FrameError::TooLarge {
                width_px: width,
                height_px: height,
            }
            .into());
        }
        let row_bytes = width as usize * bytes_per_px;
        if step < row_bytes {
            return Err(bad_layout());
        }
        let expected_len = step * (height as usize - 1) + row_bytes;
        if image.data.len() < expected_len {
            return Err(ImageError::ShortData {
                width_px: image.width,
                height_px: image.height,
                expected_len,
                actual_len: image.data.len(),
            });
        }
        if image.encoding == "rgb8" && step == row_bytes {
            return Ok(RgbFrame::new(width, height, &image.data[..expected_len])?);
        }
        self.rgb.clear();
        self.rgb.reserve(width as usize * height as usize * 3);
        for row in image.data.chunks(step).take(height as usize) {
            for pixel in row[..row_bytes].chunks_exact(bytes_per_px) {
                self.rgb.extend_from_slice(&to_rgb(pixel));
            }
        }
        Ok(RgbFrame::new(width, height, &self.rgb)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(width: i32, height: i32, encoding: &str, step: i32, data: Vec<u8>) -> ImageSource {
        ImageSource {
            width,
            height,
            encoding: encoding.to_owned(),
            step,
            data,
            ..ImageSource::default()
        }
    }

    fn check(message: &ImageSource, expected: &Result<Vec<u8>, ImageError>) {
        let mut scratch = FrameScratch::default();
        let got = scratch
            .rgb_frame(message)
            .map(|frame| frame.data().to_vec());
        assert_eq!(&got, expected, "{} {}", message.encoding, message.step);
    }

    #[test]
    fn layouts_are_converted_to_packed_rgb() {
        check(
            &image(2, 1, "rgb8", 6, vec![1, 2, 3, 4, 5, 6]),
            &Ok(vec![1, 2, 3, 4, 5, 6]),
        );
        check(
            &image(1, 2, "rgb8", 4, vec![1, 2, 3, 99, 4, 5, 6]),
            &Ok(vec![1, 2, 3, 4, 5, 6]),
        );
        check(&image(1, 1, "bgr8", 3, vec![1, 2, 3]), &Ok(vec![3, 2, 1]));
        check(
            &image(1, 1, "bgra8", 4, vec![1, 2, 3, 4]),
            &Ok(vec![3, 2, 1]),
        );
        check(
            &image(2, 1, "mono8", 2, vec![7, 9]),
            &Ok(vec![7, 7, 7, 9, 9, 9]),
        );
    }

    #[test]
    fn broken_layouts_are_refused_with_the_reason() {
        check(
            &image(1, 1, "yuv422", 2, vec![0; 4]),
            &Err(ImageError::UnsupportedEncoding("yuv422".into())),
        );
        check(
            &image(-1, 1, "rgb8", 3, vec![0; 3]),
            &Err(ImageError::BadLayout {
                width_px: -1,
                height_px: 1,
                step_bytes: 3,
            }),
        );
        check(
            &image(2, 1, "rgb8", 3, vec![0; 6]),
            &Err(ImageError::BadLayout {
                width_px: 2,
                height_px: 1,
                step_bytes: 3,
            }),
        );
        check(
            &image(2, 2, "rgb8", 6, vec![0; 7]),
            &Err(ImageError::ShortData {
                width_px: 2,
                height_px: 2,
                expected_len: 12,
                actual_len: 7,
            }),
        );
        check(
            &image(0, 5, "rgb8", 0, vec![]),
            &Err(ImageError::Frame(FrameError::Empty {
                width_px: 0,
                height_px: 5,
            })),
        );
        check(
            &image(i32::MAX, i32::MAX, "rgb8", i32::MAX, vec![]),
            &Err(ImageError::Frame(FrameError::TooLarge {
                width_px: i32::MAX as u32,
                height_px: i32::MAX as u32,
            })),
        );
    }
}
