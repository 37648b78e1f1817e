//! YUV 4:2:2 pixels to RGB8, for every source that carries them: the camera driver's YUYV
//! frames (V4L2) and the `yuv422` images of ROS 2 bags and topics. One conversion, so that a
//! colour class tuned on recorded RGB frames means the same whichever way the pixels came.
//!
//! The inverse of the BT.601 studio-swing integer approximation that CMVision's thresholds
//! are written in (`lewis_perception::cmvision::rgb_to_yuv`): a round trip is within one or
//! two levels of rounding.

/// Why a YUYV frame cannot be converted.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum YuyvError {
    /// The frame is shorter than its size says.
    #[error(
        "a {width}x{height} YUYV frame with {bytes_per_line} bytes per line needs {needed} bytes, the device gave {got}"
    )]
    ShortFrame {
        /// Width, in px.
        width: u32,
        /// Height, in px.
        height: u32,
        /// Bytes from one line to the next.
        bytes_per_line: u32,
        /// Bytes needed.
        needed: usize,
        /// Bytes given.
        got: usize,
    },
    /// Width or height is 0, or a line is shorter than its pixels.
    #[error("a {width}x{height} YUYV frame cannot have {bytes_per_line} bytes per line")]
    BadGeometry {
        /// Width, in px.
        width: u32,
        /// Height, in px.
        height: u32,
        /// Bytes from one line to the next.
        bytes_per_line: u32,
    },
}

/// One Y, U, V sample to RGB: the inverse of the BT.601 studio-swing integer approximation.
#[inline(always)]
#[must_use]
pub fn yuv_to_rgb(y: u8, u: u8, v: u8) -> [u8; 3] {
    let c = 298 * (i32::from(y) - 16);
    let d = i32::from(u) - 128;
    let e = i32::from(v) - 128;
    let clamp = |x: i32| (x >> 8).clamp(0, 255) as u8;
    [
        clamp(c + 409 * e + 128),
        clamp(c - 100 * d - 208 * e + 128),
        clamp(c + 516 * d + 128),
    ]
}

/// Converts a YUYV frame (Y0 U Y1 V for each pair of pixels) to RGB8 into `rgb` (resized to
/// `width * height * 3`). `bytes_per_line` is the line stride (at least `2 * width`,
/// rounded up to whole pixel pairs). An odd width takes its last pixel from the last pair.
///
/// # Errors
/// When the geometry is impossible or the frame is short.
pub fn yuyv_to_rgb(
    width: u32,
    height: u32,
    bytes_per_line: u32,
    frame: &[u8],
    rgb: &mut Vec<u8>,
) -> Result<(), YuyvError> {
    let pairs = width.div_ceil(2) as usize;
    let stride = bytes_per_line as usize;
    if width == 0 || height == 0 || stride < pairs * 4 {
        return Err(YuyvError::BadGeometry {
            width,
            height,
            bytes_per_line,
        });
    }
    // The last line needs only its pixels, not its padding.
    let needed = (height as usize - 1)
        .checked_mul(stride)
        .and_then(|n| n.checked_add(pairs * 4))
        .unwrap_or(usize::MAX);
    if frame.len() < needed {
        return Err(YuyvError::ShortFrame {
            width,
            height,
            bytes_per_line,
            needed,
            got: frame.len(),
        });
    }
    let width = width as usize;
    rgb.clear();
    rgb.resize(width * height as usize * 3, 0);
    for (line, out) in frame.chunks(stride).zip(rgb.chunks_exact_mut(width * 3)) {
        // Every line is at least `pairs * 4` long: the length was checked above.
        let (quads, _) = line.get(..pairs * 4).unwrap_or_default().as_chunks::<4>();
        let (pixels, _) = out.as_chunks_mut::<3>();
        for (pair, &[y0, u, y1, v]) in pixels.chunks_mut(2).zip(quads) {
            pair[0] = yuv_to_rgb(y0, u, v);
            if let Some(second) = pair.get_mut(1) {
                *second = yuv_to_rgb(y1, u, v);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yuyv_pairs_share_their_chroma_and_match_the_bt601_values() {
        fn check(width: u32, stride: u32, frame: &[u8], expected: &[[u8; 3]]) {
            let mut rgb = Vec::new();
            yuyv_to_rgb(width, 1, stride, frame, &mut rgb).unwrap();
            let (got, _) = rgb.as_chunks::<3>();
            assert_eq!(got, expected, "{frame:?}");
        }
        // Black, white, and pure red (Y 82, U 90, V 240, see cmvision's yuv.rs).
        check(2, 4, &[16, 128, 235, 128], &[[0, 0, 0], [255, 255, 255]]);
        // The integer inverse lands one level off in green.
        check(2, 4, &[82, 90, 82, 240], &[[255, 1, 0], [255, 1, 0]]);
        // An odd width takes the first pixel of its last pair; padding is skipped.
        check(
            3,
            12,
            &[16, 128, 235, 128, 235, 128, 16, 128, 9, 9, 9, 9],
            &[[0, 0, 0], [255, 255, 255], [255, 255, 255]],
        );
    }

    #[test]
    fn yuyv_refuses_short_frames_and_impossible_geometry() {
        let mut rgb = Vec::new();
        assert_eq!(
            yuyv_to_rgb(4, 2, 8, &[0; 15], &mut rgb),
            Err(YuyvError::ShortFrame {
                width: 4,
                height: 2,
                bytes_per_line: 8,
                needed: 16,
                got: 15
            })
        );
        for (width, height, stride) in [(0, 1, 4), (4, 0, 8), (4, 1, 6), (3, 1, 6)] {
            assert!(
                matches!(
                    yuyv_to_rgb(width, height, stride, &[0; 64], &mut rgb),
                    Err(YuyvError::BadGeometry { .. })
                ),
                "{width}x{height} stride {stride}"
            );
        }
        // Huge frames announced by a short buffer are refused without allocating.
        assert!(matches!(
            yuyv_to_rgb(60_000, 60_000, 120_000, &[0; 64], &mut rgb),
            Err(YuyvError::ShortFrame { .. })
        ));
        assert!(matches!(
            yuyv_to_rgb(u32::MAX, u32::MAX, u32::MAX, &[0; 64], &mut rgb),
            Err(YuyvError::BadGeometry { .. })
        ));
        assert!(rgb.is_empty());
    }
}
