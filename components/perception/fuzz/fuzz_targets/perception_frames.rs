//! Frames of any declared size and content (0 width, 1 pixel, huge sides with few bytes,
//! odd steps, unknown encodings) through everything that reads camera frames: CMVision, the
//! sign detector, blobfinder3d on the blobs found, and the tuner. Errors are fine; panics,
//! unbounded allocations and non-finite positions are not.
#![no_main]

use lewis_interfaces::msg::{ImageSource, RangeFinder};
use lewis_perception::blobfinder3d::{BlobLocator, Scan};
use lewis_perception::camera_model::CameraMounts;
use lewis_perception::sign_detector::{Params, SignDetector};
use lewis_perception::signs::default_sign_colors;
use lewis_perception::tuning::Tuner;
use libfuzzer_sys::fuzz_target;

const ENCODINGS: [&str; 7] = ["rgb8", "bgr8", "rgba8", "bgra8", "mono8", "yuv422", ""];

fn signed(bytes: [u8; 4]) -> i32 {
    i32::from_le_bytes(bytes)
}

fuzz_target!(|data: &[u8]| {
    let Some((header, pixels)) = data.split_first_chunk::<13>() else {
        return;
    };
    // Small sides most of the time (the interesting edge cases), any i32 sometimes.
    let side = |b: [u8; 4]| {
        if b[3] & 0x80 != 0 {
            signed(b)
        } else {
            i32::from(b[0] % 64)
        }
    };
    let width = side([header[0], header[1], header[2], header[3]]);
    let height = side([header[4], header[5], header[6], header[7]]);
    let encoding = ENCODINGS[usize::from(header[8]) % ENCODINGS.len()];
    let padding = i32::from(header[9] % 8);
    let bytes_per_px = match encoding {
        "rgba8" | "bgra8" => 4,
        "mono8" => 1,
        _ => 3,
    };
    let step = if header[10] & 1 == 0 {
        width.saturating_mul(bytes_per_px).saturating_add(padding)
    } else {
        signed([header[11], header[12], header[10], 0])
    };
    let image = ImageSource {
        width,
        height,
        encoding: encoding.to_owned(),
        step,
        data: pixels.to_vec(),
        ..ImageSource::default()
    };

    let mut tuner = Tuner::new(&default_sign_colors()).expect("two classes");
    let Ok(tuned) = tuner.frame(&image) else {
        return;
    };
    let area: u64 = tuned.regions.iter().map(|r| u64::from(r.area_px)).sum();
    assert!(area <= u64::try_from(width).unwrap_or(0) * u64::try_from(height).unwrap_or(0));
    let _ = tuner.annotate(&image, &tuned).expect("the frame was read once");

    let params = Params::default();
    let mut detector = SignDetector::new(
        params.finder().expect("the default sign colours"),
        params.mounts(),
        params.horizontal_fov_deg.to_radians(),
    );
    let signs = detector.detect(&image).expect("the frame was read once");
    for sign in &signs.signs {
        assert!(sign.position.x.is_finite() && sign.position.y.is_finite());
    }

    // The blobs placed with a scan made of the same bytes.
    let ranges: Vec<f64> = pixels.iter().take(361).map(|&b| f64::from(b) / 16.0).collect();
    let scan_message = RangeFinder {
        range_count: i32::try_from(ranges.len()).unwrap_or(0),
        ranges,
        max_range: 8.0,
        uniform: true,
        theta_offset: -std::f64::consts::FRAC_PI_2,
        theta_separation: std::f64::consts::PI / 360.0,
        ..RangeFinder::default()
    };
    let scan = Scan::from_range_finder(&scan_message);
    let locator = BlobLocator::new(0.85, CameraMounts::default(), 8.0);
    let placed = locator.locate(&tuned.blobs, Some(&scan));
    for blob in placed.blobs.iter().filter(|b| b.range_valid) {
        assert!(blob.position.x.is_finite() && blob.position.z.is_finite());
        assert!(blob.width.is_finite() && blob.height.is_finite());
    }
});
