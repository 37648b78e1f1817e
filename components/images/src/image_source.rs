//! The ImageSource message as a camera publishes it: the pinhole intrinsics that travel with
//! an image, and the message built from RGB8 pixels.

use lewis_interfaces::msg::ImageSource;

/// Pinhole intrinsics that travel with an image, in px.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageIntrinsics {
    /// Focal length along the rows, in px.
    pub focal_length_x_px: f64,
    /// Focal length along the columns, in px.
    pub focal_length_y_px: f64,
    /// Principal point, column.
    pub principal_x_px: f64,
    /// Principal point, row.
    pub principal_y_px: f64,
}

impl ImageIntrinsics {
    /// Intrinsics of a camera `width_px` wide with horizontal field of view
    /// `horizontal_fov_rad`, square pixels and the principal point at the image centre (pixel
    /// centres at integer coordinates, as ROS has them).
    #[must_use]
    pub fn from_fov(width_px: u32, height_px: u32, horizontal_fov_rad: f64) -> Self {
        let focal = (f64::from(width_px) / 2.0) / (horizontal_fov_rad / 2.0).tan();
        Self {
            focal_length_x_px: focal,
            focal_length_y_px: focal,
            principal_x_px: (f64::from(width_px) - 1.0) / 2.0,
            principal_y_px: (f64::from(height_px) - 1.0) / 2.0,
        }
    }

    /// The intrinsics an ImageSource message carries, when its focal lengths are usable
    /// (finite and positive).
    #[must_use]
    pub fn of_image(image: &ImageSource) -> Option<Self> {
        let usable = |f: f64| f.is_finite() && f > 0.0;
        (usable(image.focal_length_x)
            && usable(image.focal_length_y)
            && image.principal_point_x.is_finite()
            && image.principal_point_y.is_finite())
        .then_some(Self {
            focal_length_x_px: image.focal_length_x,
            focal_length_y_px: image.focal_length_y,
            principal_x_px: image.principal_point_x,
            principal_y_px: image.principal_point_y,
        })
    }
}

/// An ImageSource message (rgb8, tightly packed; header left to the publisher) from RGB8
/// pixels.
#[must_use]
pub fn image_message(
    width_px: u32,
    height_px: u32,
    rgb: Vec<u8>,
    intrinsics: ImageIntrinsics,
) -> ImageSource {
    let width = i32::try_from(width_px).unwrap_or(i32::MAX);
    ImageSource {
        width,
        height: i32::try_from(height_px).unwrap_or(i32::MAX),
        encoding: "rgb8".to_owned(),
        step: width.saturating_mul(3),
        data: rgb,
        focal_length_x: intrinsics.focal_length_x_px,
        focal_length_y: intrinsics.focal_length_y_px,
        principal_point_x: intrinsics.principal_x_px,
        principal_point_y: intrinsics.principal_y_px,
        ..ImageSource::default()
    }
}
