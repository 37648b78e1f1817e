//! Arbitrary bytes as what a video device delivers (YUYV at any declared geometry, MJPEG
//! with or without Huffman tables) and arbitrary patches picked from the converted frame:
//! errors are fine, panics and huge allocations from a short buffer are not.
#![no_main]

use lewis_drivers::camera::pixel_format::{mjpeg_to_rgb, yuyv_to_rgb};
use lewis_perception::tuning::{Patch, pick};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((header, frame)) = data.split_first_chunk::<8>() else {
        return;
    };
    let width = u32::from(u16::from_le_bytes([header[0], header[1]]));
    let height = u32::from(u16::from_le_bytes([header[2], header[3]]));
    let stride = u32::from(u16::from_le_bytes([header[4], header[5]]));
    let mut rgb = Vec::new();
    if yuyv_to_rgb(width, height, stride, frame, &mut rgb).is_ok() {
        assert_eq!(rgb.len(), width as usize * height as usize * 3);
        let image = image::RgbImage::from_raw(width, height, rgb).expect("sized above");
        let patch = if header[6] & 1 == 0 {
            Patch::Disc {
                x: u32::from(header[6]),
                y: u32::from(header[7]),
                radius_px: u32::from(header[7] % 16),
            }
        } else {
            Patch::Rect {
                x: u32::from(header[7]),
                y: u32::from(header[6] / 2),
                width: u32::from(header[6]),
                height: u32::from(header[7]),
            }
        };
        if let Ok(got) = pick(&image, patch, header[5]) {
            assert!(got.pixels >= 1);
        }
    }
    if let Ok((width, height, pixels)) = mjpeg_to_rgb(frame) {
        assert_eq!(pixels.len(), width as usize * height as usize * 3);
    }
});
