//! Pixel classification: CMVision's three per-channel tables, fed by a branch-free RGB to
//! YUV conversion.
//!
//! The classification is CMVision's: `y_class[y] & u_class[u] & v_class[v]` gives the class
//! mask (bit k set when colour k's box contains the pixel), and a pixel's colour is the lowest
//! set bit. The conversion of [`super::yuv`] is done with three table lookups and two 64-bit
//! additions instead of nine multiplications: each YUV channel is a sum of one term per RGB
//! component, so `PARTIALS[0][r] + PARTIALS[1][g] + PARTIALS[2][b]` holds `Y * 256 + f`,
//! `U * 256 + f` and `V * 256 + f` in three 16-bit fields (bits 0, 16 and 32; `f < 256`),
//! with the constants and the signs folded into biases that keep every term and every field
//! sum within 0..65536, so that no field carries into the next.

use super::config::{ChannelRange, ColorClass, MAX_COLORS};

/// Colour code of a pixel in no class: codes 0..32 are colour ids (the lowest set bit).
pub(super) const NO_COLOR: u8 = 32;

/// Per-component terms of the packed YUV sum (see the module documentation).
static PARTIALS: [[u64; 256]; 3] = partials();

const fn partials() -> [[u64; 256]; 3] {
    // Bias per field: 128 (rounding) + 256 * offset (16 for Y, 128 for U and V), spread so
    // that each term is non-negative: the negative coefficients get `-c * 255` added back.
    const U_REST: i64 = 128 + 128 * 256 - 38 * 255 - 74 * 255;
    const V_REST: i64 = 128 + 128 * 256 - 94 * 255 - 18 * 255;
    let mut tables = [[0u64; 256]; 3];
    let mut i = 0;
    while i < 256 {
        let c = i as i64;
        let fields = [
            [
                66 * c + 128 + 16 * 256,
                -38 * c + 38 * 255 + U_REST,
                112 * c + V_REST,
            ],
            [129 * c, -74 * c + 74 * 255, -94 * c + 94 * 255],
            [25 * c, 112 * c, -18 * c + 18 * 255],
        ];
        let mut component = 0;
        while component < 3 {
            let [y, u, v] = fields[component];
            tables[component][i] = (y as u64) | ((u as u64) << 16) | ((v as u64) << 32);
            component += 1;
        }
        i += 1;
    }
    tables
}

/// The packed YUV sum of an RGB pixel: Y in bits 8..16, U in 24..32, V in 40..48.
#[inline(always)]
fn packed_yuv([r, g, b]: [u8; 3]) -> u64 {
    PARTIALS[0][usize::from(r)] + PARTIALS[1][usize::from(g)] + PARTIALS[2][usize::from(b)]
}

/// The class tables of a set of colours.
pub(super) struct Classifier {
    y_class: [u32; 256],
    u_class: [u32; 256],
    v_class: [u32; 256],
}

impl Classifier {
    /// Builds the tables of the first [`MAX_COLORS`] classes.
    pub(super) fn new(colors: &[ColorClass]) -> Self {
        let mut classifier = Self {
            y_class: [0; 256],
            u_class: [0; 256],
            v_class: [0; 256],
        };
        for (k, class) in colors.iter().take(MAX_COLORS).enumerate() {
            set_bits(&mut classifier.y_class, class.y, 1 << k);
            set_bits(&mut classifier.u_class, class.u, 1 << k);
            set_bits(&mut classifier.v_class, class.v, 1 << k);
        }
        classifier
    }

    /// The class mask of a YUV pixel: CMVision's two ANDs.
    #[inline(always)]
    pub(super) fn mask_yuv(&self, [y, u, v]: [u8; 3]) -> u32 {
        self.y_class[usize::from(y)] & self.u_class[usize::from(u)] & self.v_class[usize::from(v)]
    }

    /// The class mask of an RGB pixel.
    #[inline(always)]
    pub(super) fn mask_rgb(&self, rgb: [u8; 3]) -> u32 {
        let packed = packed_yuv(rgb);
        // Truncating to u8 takes the integer part of each field.
        self.mask_yuv([
            (packed >> 8) as u8,
            (packed >> 24) as u8,
            (packed >> 40) as u8,
        ])
    }

    /// The colour code of an RGB pixel: its colour id, or [`NO_COLOR`].
    #[inline(always)]
    pub(super) fn code_rgb(&self, rgb: [u8; 3]) -> u8 {
        // trailing_zeros is 32 for an empty mask: NO_COLOR. At most 32: the cast is exact.
        self.mask_rgb(rgb).trailing_zeros() as u8
    }
}

/// CMVision's table filling: set `bit` for every value of the range.
fn set_bits(table: &mut [u32; 256], range: ChannelRange, bit: u32) {
    if range.lo <= range.hi {
        for entry in &mut table[usize::from(range.lo)..=usize::from(range.hi)] {
            *entry |= bit;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmvision::yuv::rgb_to_yuv;

    #[test]
    fn the_packed_sum_gives_the_yuv_of_every_rgb_value() {
        for r in 0..=255u8 {
            for g in 0..=255u8 {
                for b in (0..=255u8).step_by(5) {
                    let packed = packed_yuv([r, g, b]);
                    let yuv = [
                        (packed >> 8) as u8,
                        (packed >> 24) as u8,
                        (packed >> 40) as u8,
                    ];
                    assert_eq!(yuv, rgb_to_yuv(r, g, b), "rgb {r} {g} {b}");
                    // Every field stays below 2^16: nothing carries into the next field.
                    assert_eq!(packed >> 48, 0);
                }
            }
        }
    }
}
