//! What video devices deliver, turned into the RGB8 frames ImageSource carries: YUYV (4:2:2,
//! the uncompressed format every UVC camera offers) and MJPEG (a JPEG per frame, which many
//! cameras need above 640x480 at 30 Hz).
//!
//! YUYV is converted by `lewis_images::yuv` (re-exported here), the one conversion the ROS 2
//! mappings' `yuv422` images share: the inverse of the BT.601 studio-swing integer
//! approximation that CMVision's thresholds are written in
//! (`lewis_perception::cmvision::rgb_to_yuv`), so a colour class tuned on recorded RGB frames
//! means the same on a camera's frames (up to one or two levels of rounding).
//!
//! MJPEG frames from UVC cameras usually omit the Huffman tables (the UVC specification
//! fixes them to those of the JPEG standard, Annex K.3): [`mjpeg_to_rgb`] inserts them when
//! the frame has none, as every MJPEG player does.

pub use lewis_images::yuv::{YuyvError, yuv_to_rgb, yuyv_to_rgb};

/// A pixel format of a video device, by its V4L2 four-character code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelFormat {
    /// `YUYV`: 2 bytes per pixel, Y0 U Y1 V for each pair of pixels.
    Yuyv,
    /// `MJPG`: one JPEG image per frame.
    Mjpeg,
}

impl PixelFormat {
    /// The V4L2 four-character code.
    #[must_use]
    pub fn fourcc(self) -> u32 {
        match self {
            Self::Yuyv => fourcc(*b"YUYV"),
            Self::Mjpeg => fourcc(*b"MJPG"),
        }
    }

    /// The format of a four-character code, if it is one this module converts.
    #[must_use]
    pub fn from_fourcc(code: u32) -> Option<Self> {
        [Self::Yuyv, Self::Mjpeg]
            .into_iter()
            .find(|f| f.fourcc() == code)
    }
}

/// A V4L2 four-character code (little-endian, as `v4l2_fourcc` builds it).
#[must_use]
pub fn fourcc(code: [u8; 4]) -> u32 {
    u32::from_le_bytes(code)
}

/// The four characters of a code, for messages (`?` for bytes that are not printable).
#[must_use]
pub fn fourcc_name(code: u32) -> String {
    code.to_le_bytes()
        .iter()
        .map(|&b| {
            if b.is_ascii_graphic() || b == b' ' {
                char::from(b)
            } else {
                '?'
            }
        })
        .collect()
}

/// Why a frame cannot be converted.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConvertError {
    /// A YUYV frame's size or length is wrong.
    #[error(transparent)]
    Yuyv(#[from] YuyvError),
    /// The JPEG decoder refused the frame.
    #[error("the MJPEG frame does not decode: {0}")]
    Jpeg(String),
}

/// Decodes an MJPEG frame to RGB8; returns (width, height, pixels). Frames without Huffman
/// tables get the standard ones first.
///
/// # Errors
/// When the frame is not a JPEG image the decoder reads.
pub fn mjpeg_to_rgb(frame: &[u8]) -> Result<(u32, u32, Vec<u8>), ConvertError> {
    let with_tables;
    let jpeg = if needs_huffman_tables(frame) {
        with_tables = insert_huffman_tables(frame);
        with_tables.as_slice()
    } else {
        frame
    };
    let image = image::load_from_memory_with_format(jpeg, image::ImageFormat::Jpeg)
        .map_err(|e| ConvertError::Jpeg(e.to_string()))?
        .to_rgb8();
    let (width, height) = image.dimensions();
    Ok((width, height, image.into_raw()))
}

/// JPEG markers this module looks for.
const SOI: u8 = 0xD8;
const DHT: u8 = 0xC4;
const SOS: u8 = 0xDA;

/// Whether a JPEG stream reaches its first scan without a Huffman table segment. A stream
/// that is not JPEG at all (no start-of-image) is left to the decoder to refuse.
fn needs_huffman_tables(jpeg: &[u8]) -> bool {
    if jpeg.get(..2) != Some(&[0xFF, SOI]) {
        return false;
    }
    let mut at = 2;
    // Marker segments: FF, marker, two bytes of length (which counts itself), payload.
    while let Some(&[0xFF, marker, hi, lo]) = jpeg.get(at..at + 4).and_then(|s| s.as_array()) {
        match marker {
            DHT => return false,
            SOS => return true,
            // Fill bytes before a marker.
            0xFF => at += 1,
            _ => at += 2 + usize::from(u16::from_be_bytes([hi, lo])),
        }
    }
    false
}

/// The stream with the standard Huffman tables inserted right after the start-of-image.
fn insert_huffman_tables(jpeg: &[u8]) -> Vec<u8> {
    let tables = standard_huffman_segment();
    let mut out = Vec::with_capacity(jpeg.len() + tables.len());
    out.extend_from_slice(&jpeg[..2]);
    out.extend_from_slice(&tables);
    out.extend_from_slice(&jpeg[2..]);
    out
}

/// The DHT segment of the four tables of the JPEG standard, Annex K.3 (luminance and
/// chrominance, DC and AC), which UVC's MJPEG payload format assumes.
fn standard_huffman_segment() -> Vec<u8> {
    // (class << 4 | id, code counts per length 1..=16, symbols)
    let tables: [(u8, [u8; 16], &[u8]); 4] = [
        (0x00, DC_LUMINANCE_BITS, &DC_SYMBOLS),
        (0x01, DC_CHROMINANCE_BITS, &DC_SYMBOLS),
        (0x10, AC_LUMINANCE_BITS, &AC_LUMINANCE_SYMBOLS),
        (0x11, AC_CHROMINANCE_BITS, &AC_CHROMINANCE_SYMBOLS),
    ];
    let mut payload = Vec::new();
    for (class_id, bits, symbols) in tables {
        payload.push(class_id);
        payload.extend_from_slice(&bits);
        payload.extend_from_slice(symbols);
    }
    let length = u16::try_from(payload.len() + 2).unwrap_or(u16::MAX);
    let mut segment = vec![0xFF, DHT];
    segment.extend_from_slice(&length.to_be_bytes());
    segment.extend_from_slice(&payload);
    segment
}

const DC_LUMINANCE_BITS: [u8; 16] = [0, 1, 5, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0];
const DC_CHROMINANCE_BITS: [u8; 16] = [0, 3, 1, 1, 1, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0];
const DC_SYMBOLS: [u8; 12] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11];
const AC_LUMINANCE_BITS: [u8; 16] = [0, 2, 1, 3, 3, 2, 4, 3, 5, 5, 4, 4, 0, 0, 1, 0x7d];
const AC_CHROMINANCE_BITS: [u8; 16] = [0, 2, 1, 2, 4, 4, 3, 4, 7, 5, 4, 4, 0, 1, 2, 0x77];
#[rustfmt::skip]
const AC_LUMINANCE_SYMBOLS: [u8; 162] = [
    0x01, 0x02, 0x03, 0x00, 0x04, 0x11, 0x05, 0x12, 0x21, 0x31, 0x41, 0x06, 0x13, 0x51, 0x61, 0x07,
    0x22, 0x71, 0x14, 0x32, 0x81, 0x91, 0xa1, 0x08, 0x23, 0x42, 0xb1, 0xc1, 0x15, 0x52, 0xd1, 0xf0,
    0x24, 0x33, 0x62, 0x72, 0x82, 0x09, 0x0a, 0x16, 0x17, 0x18, 0x19, 0x1a, 0x25, 0x26, 0x27, 0x28,
    0x29, 0x2a, 0x34, 0x35, 0x36, 0x37, 0x38, 0x39, 0x3a, 0x43, 0x44, 0x45, 0x46, 0x47, 0x48, 0x49,
    0x4a, 0x53, 0x54, 0x55, 0x56, 0x57, 0x58, 0x59, 0x5a, 0x63, 0x64, 0x65, 0x66, 0x67, 0x68, 0x69,
    0x6a, 0x73, 0x74, 0x75, 0x76, 0x77, 0x78, 0x79, 0x7a, 0x83, 0x84, 0x85, 0x86, 0x87, 0x88, 0x89,
    0x8a, 0x92, 0x93, 0x94, 0x95, 0x96, 0x97, 0x98, 0x99, 0x9a, 0xa2, 0xa3, 0xa4, 0xa5, 0xa6, 0xa7,
    0xa8, 0xa9, 0xaa, 0xb2, 0xb3, 0xb4, 0xb5, 0xb6, 0xb7, 0xb8, 0xb9, 0xba, 0xc2, 0xc3, 0xc4, 0xc5,
    0xc6, 0xc7, 0xc8, 0xc9, 0xca, 0xd2, 0xd3, 0xd4, 0xd5, 0xd6, 0xd7, 0xd8, 0xd9, 0xda, 0xe1, 0xe2,
    0xe3, 0xe4, 0xe5, 0xe6, 0xe7, 0xe8, 0xe9, 0xea, 0xf1, 0xf2, 0xf3, 0xf4, 0xf5, 0xf6, 0xf7, 0xf8,
    0xf9, 0xfa,
];
#[rustfmt::skip]
const AC_CHROMINANCE_SYMBOLS: [u8; 162] = [
    0x00, 0x01, 0x02, 0x03, 0x11, 0x04, 0x05, 0x21, 0x31, 0x06, 0x12, 0x41, 0x51, 0x07, 0x61, 0x71,
    0x13, 0x22, 0x32, 0x81, 0x08, 0x14, 0x42, 0x91, 0xa1, 0xb1, 0xc1, 0x09, 0x23, 0x33, 0x52, 0xf0,
    0x15, 0x62, 0x72, 0xd1, 0x0a, 0x16, 0x24, 0x34, 0xe1, 0x25, 0xf1, 0x17, 0x18, 0x19, 0x1a, 0x26,
    0x27, 0x28, 0x29, 0x2a, 0x35, 0x36, 0x37, 0x38, 0x39, 0x3a, 0x43, 0x44, 0x45, 0x46, 0x47, 0x48,
    0x49, 0x4a, 0x53, 0x54, 0x55, 0x56, 0x57, 0x58, 0x59, 0x5a, 0x63, 0x64, 0x65, 0x66, 0x67, 0x68,
    0x69, 0x6a, 0x73, 0x74, 0x75, 0x76, 0x77, 0x78, 0x79, 0x7a, 0x82, 0x83, 0x84, 0x85, 0x86, 0x87,
    0x88, 0x89, 0x8a, 0x92, 0x93, 0x94, 0x95, 0x96, 0x97, 0x98, 0x99, 0x9a, 0xa2, 0xa3, 0xa4, 0xa5,
    0xa6, 0xa7, 0xa8, 0xa9, 0xaa, 0xb2, 0xb3, 0xb4, 0xb5, 0xb6, 0xb7, 0xb8, 0xb9, 0xba, 0xc2, 0xc3,
    0xc4, 0xc5, 0xc6, 0xc7, 0xc8, 0xc9, 0xca, 0xd2, 0xd3, 0xd4, 0xd5, 0xd6, 0xd7, 0xd8, 0xd9, 0xda,
    0xe2, 0xe3, 0xe4, 0xe5, 0xe6, 0xe7, 0xe8, 0xe9, 0xea, 0xf2, 0xf3, 0xf4, 0xf5, 0xf6, 0xf7, 0xf8,
    0xf9, 0xfa,
];

#[cfg(test)]
mod tests {
    use super::*;

    /// A small JPEG made by the `image` crate's encoder (which uses the standard tables).
    fn jpeg_of(width: u32, height: u32, rgb: &[u8]) -> Vec<u8> {
        let mut jpeg = Vec::new();
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 95)
            .encode(rgb, width, height, image::ExtendedColorType::Rgb8)
            .unwrap();
        jpeg
    }

    /// The stream without its DHT segments, as UVC cameras send it.
    fn without_huffman_tables(jpeg: &[u8]) -> Vec<u8> {
        let mut out = jpeg[..2].to_vec();
        let mut at = 2;
        loop {
            let marker = jpeg[at + 1];
            if marker == SOS {
                out.extend_from_slice(&jpeg[at..]);
                return out;
            }
            let length = usize::from(u16::from_be_bytes([jpeg[at + 2], jpeg[at + 3]]));
            if marker != DHT {
                out.extend_from_slice(&jpeg[at..at + 2 + length]);
            }
            at += 2 + length;
        }
    }

    #[test]
    fn mjpeg_frames_decode_with_or_without_their_huffman_tables() {
        let (width, height) = (16, 8);
        let rgb: Vec<u8> = (0..width * height)
            .flat_map(|i| {
                if i % 16 < 8 {
                    [200, 30, 30]
                } else {
                    [30, 30, 200]
                }
            })
            .collect();
        let jpeg = jpeg_of(width, height, &rgb);
        let (w, h, with_tables) = mjpeg_to_rgb(&jpeg).unwrap();
        assert_eq!((w, h), (width, height));
        for (got, want) in with_tables.iter().zip(&rgb) {
            assert!(got.abs_diff(*want) <= 12, "{got} vs {want}");
        }
        let bare = without_huffman_tables(&jpeg);
        assert!(bare.len() < jpeg.len() && needs_huffman_tables(&bare));
        assert!(!needs_huffman_tables(&jpeg));
        assert_eq!(mjpeg_to_rgb(&bare).unwrap(), (w, h, with_tables));
    }

    #[test]
    fn broken_mjpeg_frames_are_errors() {
        for frame in [
            &[][..],
            &[0xFF, 0xD8],
            &[0xFF, 0xD8, 0xFF, 0xDA, 0, 2],
            b"not a jpeg",
        ] {
            assert!(
                matches!(mjpeg_to_rgb(frame), Err(ConvertError::Jpeg(_))),
                "{frame:?}"
            );
        }
    }

    #[test]
    fn fourcc_codes_are_little_endian_character_codes() {
        assert_eq!(PixelFormat::Yuyv.fourcc(), 0x5659_5559);
        assert_eq!(
            PixelFormat::from_fourcc(fourcc(*b"MJPG")),
            Some(PixelFormat::Mjpeg)
        );
        assert_eq!(PixelFormat::from_fourcc(fourcc(*b"RGB3")), None);
        assert_eq!(fourcc_name(fourcc(*b"H264")), "H264");
        assert_eq!(fourcc_name(0x0000_3141), "A1??");
    }
}
