//! RGB to YUV: the one conversion every colour threshold of this crate is written in.
//!
//! CMVision classifies in YUV because the thresholds of a colour are then a box that
//! brightness changes move mostly along one axis. Player's CMVision read YUV straight from
//! the camera; our frames are RGB8, so we convert with the standard integer approximation of
//! ITU-R BT.601 (studio swing, as in Microsoft's "YUV video subtypes" and most camera
//! firmware):
//!
//! ```text
//! Y = ((  66 R + 129 G +  25 B + 128) >> 8) +  16     Y in 16..=235
//! U = (( -38 R -  74 G + 112 B + 128) >> 8) + 128     U in 16..=240
//! V = (( 112 R -  94 G -  18 B + 128) >> 8) + 128     V in 16..=240
//! ```
//!
//! `>>` is an arithmetic shift (floor division by 256), so each channel is a non-decreasing
//! function of every input with a positive coefficient and a non-increasing function of every
//! input with a negative one; the classifier's cell table relies on that.

/// Converts one RGB pixel to YUV with the BT.601 integer approximation above.
#[inline(always)]
#[must_use]
pub fn rgb_to_yuv(r: u8, g: u8, b: u8) -> [u8; 3] {
    let (r, g, b) = (i32::from(r), i32::from(g), i32::from(b));
    let y = ((66 * r + 129 * g + 25 * b + 128) >> 8) + 16;
    let u = ((-38 * r - 74 * g + 112 * b + 128) >> 8) + 128;
    let v = ((112 * r - 94 * g - 18 * b + 128) >> 8) + 128;
    // The ranges above (16..=240 at most) fit a byte for every input: the casts cannot wrap.
    [y as u8, u as u8, v as u8]
}

#[cfg(test)]
mod tests {
    use super::rgb_to_yuv;

    fn check(rgb: [u8; 3], expected_yuv: [u8; 3]) {
        assert_eq!(
            rgb_to_yuv(rgb[0], rgb[1], rgb[2]),
            expected_yuv,
            "rgb {rgb:?}"
        );
    }

    #[test]
    fn primaries_and_greys_map_to_the_bt601_studio_swing_values() {
        check([0, 0, 0], [16, 128, 128]);
        check([255, 255, 255], [235, 128, 128]);
        check([255, 0, 0], [82, 90, 240]);
        check([0, 255, 0], [144, 54, 34]);
        check([0, 0, 255], [41, 240, 110]);
        check([128, 128, 128], [126, 128, 128]);
    }

    #[test]
    fn every_rgb_value_stays_inside_the_studio_swing_ranges() {
        for r in (0..=255u8).step_by(5) {
            for g in (0..=255u8).step_by(5) {
                for b in (0..=255u8).step_by(5) {
                    let [y, u, v] = rgb_to_yuv(r, g, b);
                    assert!((16..=235).contains(&y), "{r} {g} {b} -> y {y}");
                    assert!((16..=240).contains(&u), "{r} {g} {b} -> u {u}");
                    assert!((16..=240).contains(&v), "{r} {g} {b} -> v {v}");
                }
            }
        }
    }
}
