//! Perception: colour segmentation (CMVision) and what is built on it.
//!
//! - [`cmvision`]: the segmentation itself, colour files included.
//! - [`blobfinder`] (`blobfinder`): ImageSource in, Blobs out.
//! - [`blobfinder3d`] (`blobfinder3d`): Blobs and RangeFinder in, Blobs3D out, with the
//!   pinhole model of [`camera_model`].
//! - [`signs`] and [`sign_detector`] (`sign_detector`): ImageSource in, Signs out.
//! - [`tuning`]: the offline tools behind `lewis tune` (annotated frames, per-colour
//!   statistics, a threshold line from a patch of pixels).
//!
//! Every algorithm is a plain struct with methods; the services only adapt them to the
//! runtime.

pub mod blobfinder;
pub mod blobfinder3d;
pub mod camera_model;
pub mod cmvision;
pub mod image_view;
pub mod sign_detector;
pub mod signs;
pub mod tuning;

use lewis_runtime::service::ServiceRegistry;

pub use cmvision::{
    ChannelRange, CmVision, ColorClass, ColorConfig, ColorFileError, ColorFileProblem, ConfigError,
    FrameError, Region, RgbFrame,
};

/// Registers the perception service kinds (`blobfinder`, `blobfinder3d`, `sign_detector`)
/// and the `camera` that feeds them ([`crate::camera`]).
pub fn register(registry: &mut ServiceRegistry) {
    crate::camera::register(registry);
    registry.register_with_parameters::<blobfinder::Params>(blobfinder::KIND, blobfinder::build);
    registry
        .register_with_parameters::<blobfinder3d::Params>(blobfinder3d::KIND, blobfinder3d::build);
    registry.register_with_parameters::<sign_detector::Params>(
        sign_detector::KIND,
        sign_detector::build,
    );
}
