//! The camera driver's YUYV conversion against CMVision's: a colour class tuned on recorded
//! RGB frames must mean the same on a camera's frames.

#![allow(clippy::unwrap_used)]

use lewis_drivers::camera::pixel_format::yuyv_to_rgb;
use lewis_perception::cmvision::rgb_to_yuv;

#[test]
fn yuyv_round_trips_rgb_within_two_levels() {
    for rgb in [
        [255, 0, 0],
        [0, 255, 0],
        [0, 0, 255],
        [210, 25, 25],
        [240, 150, 180],
        [128, 128, 128],
        [30, 60, 200],
    ] {
        let [y, u, v] = rgb_to_yuv(rgb[0], rgb[1], rgb[2]);
        let mut out = Vec::new();
        yuyv_to_rgb(2, 1, 4, &[y, u, y, v], &mut out).unwrap();
        for (a, b) in out[..3].iter().zip(rgb) {
            assert!(a.abs_diff(b) <= 2, "{rgb:?} -> {:?}", &out[..3]);
        }
    }
}
