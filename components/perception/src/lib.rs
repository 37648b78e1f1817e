//! Perception: what the robot makes of its sensors' data. Colour segmentation (CMVision) and
//! what is built on it, and Distance from any RangeFinder.
//!
//! - [`cmvision`]: the segmentation itself, colour files included.
//! - [`blobfinder`] (`blobfinder`): ImageSource in, Blobs out.
//! - [`blobfinder3d`] (`blobfinder3d`): Blobs and RangeFinder in, Blobs3D out, with the
//!   pinhole model of [`camera_model`].
//! - [`signs`] and [`sign_detector`] (`sign_detector`): ImageSource in, Signs out.
//! - [`range_distance`] (`range_distance`): RangeFinder in, Distance out.
//! - [`tuning`]: the offline tools behind `lewis tune` (annotated frames, per-colour
//!   statistics, a threshold line from a patch of pixels).
//! - [`labels`] and [`scoring`]: labelled frames (a box per true object and class) and the
//!   precision and recall of a colour file's blobs against them; [`fitting`], the ranges
//!   that score best on them.
//!
//! Every algorithm is a plain struct with methods; the services only adapt them to the
//! runtime. This crate knows no device and no simulator: its services take any provider of
//! their inputs, the image files it reads come through `lewis-images`, and Distance is
//! computed by `lewis-geometry`'s code, the same the drivers use.

pub mod blobfinder;
pub mod blobfinder3d;
pub mod camera_model;
pub mod cmvision;
pub mod fitting;
pub mod image_view;
pub mod labels;
pub mod range_distance;
pub mod scoring;
pub mod sign_detector;
pub mod signs;
pub mod sweep;
pub mod tuning;

use lewis_service::ServiceRegistry;

pub use cmvision::{
    ChannelRange, CmVision, ColorClass, ColorConfig, ColorFileError, ColorFileProblem, ConfigError,
    FrameError, Region, RgbFrame,
};

/// Registers the perception service kinds (`blobfinder`, `blobfinder3d`, `sign_detector`,
/// `range_distance`). The `camera` that feeds the first three is `lewis-drivers`'.
pub fn register(registry: &mut ServiceRegistry) {
    registry.register_with_parameters::<blobfinder::Params>(blobfinder::KIND, blobfinder::build);
    registry
        .register_with_parameters::<blobfinder3d::Params>(blobfinder3d::KIND, blobfinder3d::build);
    registry.register_with_parameters::<sign_detector::Params>(
        sign_detector::KIND,
        sign_detector::build,
    );
    range_distance::register(registry);
}
