//! Images as the camera drivers and perception share them: image files (PNG, JPEG) decoded to
//! RGB8 and played as sequences ([`sequence`]), the pinhole intrinsics that travel with an
//! image, and the ImageSource message built from RGB8 pixels ([`image_source`]).
//!
//! The `camera` service (in `lewis-drivers`) publishes image files with these; perception's
//! offline tuning (`lewis tune`) reads the same files the same way. Neither may depend on the
//! other, so this sits below both. It owns no service, no device and no image processing:
//! pixel formats of video devices are the drivers', colour segmentation is perception's.

pub mod image_source;
pub mod sequence;

pub use image_source::{ImageIntrinsics, image_message};
pub use sequence::{ImageSequence, RgbImageData, SequenceError, is_image_file, load_rgb, resolve};
