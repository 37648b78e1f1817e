//! Images as the camera drivers and perception share them: image files (PNG, JPEG) decoded to
//! RGB8 and played as sequences ([`sequence`]), the pinhole intrinsics that travel with an
//! image, the ImageSource message built from RGB8 pixels ([`image_source`]), and YUV 4:2:2
//! pixels to RGB8 ([`yuv`]); and what every plot shares, the bundled font and the PNG
//! encoding of plotters' pixels ([`plot`]: the sweep's, the chaos run's, a rebuilt world's
//! check).
//!
//! The `camera` service (in `lewis-drivers`) publishes image files with these; perception's
//! offline tuning (`lewis tune`) reads the same files the same way. Neither may depend on the
//! other, so this sits below both; so does the YUYV conversion, which the camera's V4L2
//! frames and the ROS 2 mappings (`lewis-ros2-map`: `yuv422` images) share. It owns no
//! service, no device and no image processing: what video devices deliver (V4L2 formats,
//! MJPEG) is the drivers', colour segmentation is perception's.

pub mod image_source;
#[cfg(feature = "plot")]
pub mod plot;
pub mod sequence;
pub mod yuv;

pub use image_source::{ImageIntrinsics, image_message};
pub use sequence::{ImageSequence, RgbImageData, SequenceError, is_image_file, load_rgb, resolve};
