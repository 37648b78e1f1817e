//! A borrowed RGB8 frame whose size has been checked against its buffer.

/// The largest width or height CMVision accepts, in pixels: every coordinate, run index and
/// area then fits a `u32` with room to spare.
pub const MAX_SIDE_PX: u32 = 1 << 15;

/// A borrowed, tightly packed RGB8 image (`width * height * 3` bytes, rows top to bottom).
///
/// Built only through [`RgbFrame::new`], so a frame always has a non-zero size that its
/// buffer backs exactly.
#[derive(Debug, Clone, Copy)]
pub struct RgbFrame<'a> {
    width_px: u32,
    height_px: u32,
    data: &'a [u8],
}

/// Why bytes cannot be used as an RGB8 frame.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// Width or height is zero.
    #[error("empty frame {width_px}x{height_px}: width and height must be at least 1")]
    Empty {
        /// Declared width.
        width_px: u32,
        /// Declared height.
        height_px: u32,
    },
    /// Width or height above [`MAX_SIDE_PX`].
    #[error("frame {width_px}x{height_px} is too large: at most {MAX_SIDE_PX} pixels a side")]
    TooLarge {
        /// Declared width.
        width_px: u32,
        /// Declared height.
        height_px: u32,
    },
    /// The buffer length is not `width * height * 3`.
    #[error(
        "frame {width_px}x{height_px} RGB8 needs {expected_len} bytes but the buffer has {actual_len}"
    )]
    WrongLength {
        /// Declared width.
        width_px: u32,
        /// Declared height.
        height_px: u32,
        /// `width * height * 3`.
        expected_len: usize,
        /// Length of the buffer given.
        actual_len: usize,
    },
}

impl<'a> RgbFrame<'a> {
    /// Checks that `data` holds exactly `width_px * height_px` RGB8 pixels.
    ///
    /// # Errors
    /// [`FrameError`] when a side is 0 or above [`MAX_SIDE_PX`], or the length is wrong.
    pub fn new(width_px: u32, height_px: u32, data: &'a [u8]) -> Result<Self, FrameError> {
        if width_px == 0 || height_px == 0 {
            return Err(FrameError::Empty {
                width_px,
                height_px,
            });
        }
        if width_px > MAX_SIDE_PX || height_px > MAX_SIDE_PX {
            return Err(FrameError::TooLarge {
                width_px,
                height_px,
            });
        }
        // Both sides are at most 2^15: the product times 3 fits in 2^32 and in usize.
        let expected_len = width_px as usize * height_px as usize * 3;
        if data.len() != expected_len {
            return Err(FrameError::WrongLength {
                width_px,
                height_px,
                expected_len,
                actual_len: data.len(),
            });
        }
        Ok(Self {
            width_px,
            height_px,
            data,
        })
    }

    /// Width in pixels (at least 1).
    #[must_use]
    pub fn width_px(&self) -> u32 {
        self.width_px
    }

    /// Height in pixels (at least 1).
    #[must_use]
    pub fn height_px(&self) -> u32 {
        self.height_px
    }

    /// The pixels, `width * height * 3` bytes, R G B per pixel, rows top to bottom.
    #[must_use]
    pub fn data(&self) -> &'a [u8] {
        self.data
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(width_px: u32, height_px: u32, len: usize, expected: &Result<(), FrameError>) {
        let data = vec![0u8; len];
        assert_eq!(
            &RgbFrame::new(width_px, height_px, &data).map(|_| ()),
            expected
        );
    }

    #[test]
    fn sizes_are_checked_against_the_buffer() {
        check(1, 1, 3, &Ok(()));
        check(640, 480, 640 * 480 * 3, &Ok(()));
        check(
            0,
            10,
            0,
            &Err(FrameError::Empty {
                width_px: 0,
                height_px: 10,
            }),
        );
        check(
            10,
            0,
            0,
            &Err(FrameError::Empty {
                width_px: 10,
                height_px: 0,
            }),
        );
        check(
            2,
            2,
            11,
            &Err(FrameError::WrongLength {
                width_px: 2,
                height_px: 2,
                expected_len: 12,
                actual_len: 11,
            }),
        );
        check(
            u32::MAX,
            u32::MAX,
            3,
            &Err(FrameError::TooLarge {
                width_px: u32::MAX,
                height_px: u32::MAX,
            }),
        );
        check(
            MAX_SIDE_PX + 1,
            1,
            3,
            &Err(FrameError::TooLarge {
                width_px: MAX_SIDE_PX + 1,
                height_px: 1,
            }),
        );
    }
}
