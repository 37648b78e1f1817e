//! One Lewis message to its ROS 2 message(s), as values of [`lewis_interfaces::ros2`]
//! that encode to ROS 2 CDR:
//!
//! - a uniform RangeFinder (a laser) to a `sensor_msgs/msg/LaserScan`, a non-uniform one
//!   (the sonar ring, each transducer at its own pose) to a `sensor_msgs/msg/PointCloud2`
//!   of where its beams end (fields x, y, z, range), both in the sensor's frame at its
//!   [`Mount`] ([`range_finder`]);
//! - an Egomotion to a `nav_msgs/msg/Odometry` and its pose as the [`ODOM_FRAME`] to
//!   [`BASE_FRAME`] transform ([`egomotion`]); the sensors' frames under [`BASE_FRAME`]
//!   as fixed transforms ([`static_transforms`]);
//! - an ImageSource (rgb8, bgr8, mono8) to a `sensor_msgs/msg/CompressedImage`, PNG or
//!   JPEG ([`compressed_image`]);
//! - Blobs3D, Signs and the broker's bindings to a `visualization_msgs/msg/MarkerArray`
//!   ([`blob_markers`], [`sign_markers`], [`binding_markers`]);
//! - a Synchrodrive velocity command to a `geometry_msgs/msg/Twist` ([`twist`]), what a
//!   ROS 2 base takes on `/cmd_vel`.
//!
//! Topics are the caller's: the recorder's companion channels name their own.

mod markers;

use std::io::Cursor;

use image::{DynamicImage, GrayImage, ImageFormat, RgbImage};
use lewis_interfaces::msg::{Egomotion, ImageSource, RangeFinder, SynchrodriveSetVelocity};
use lewis_interfaces::ros2::{
    CompressedImage, Header, LaserScan, Odometry, PointCloud, Pose, TfMessage, TransformStamped,
    Twist,
};

pub use markers::{binding_markers, blob_markers, sign_markers};

/// The odometry frame: where Egomotion's pose is.
pub const ODOM_FRAME: &str = "odom";
/// The robot's frame: the parent of every sensor's frame, the child of [`ODOM_FRAME`].
pub const BASE_FRAME: &str = "base_link";

/// A `std_msgs/Header` stamped `stamp_ns` in `frame`.
#[must_use]
pub fn header(stamp_ns: i64, frame: &str) -> Header {
    Header {
        stamp_ns,
        frame_id: frame.to_owned(),
    }
}

/// A sensor's frame in [`BASE_FRAME`]: planar position, height and heading.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Mount {
    /// Forward, in m.
    pub x: f64,
    /// Left, in m.
    pub y: f64,
    /// Up, in m.
    pub z: f64,
    /// Heading about z, in rad.
    pub yaw: f64,
}

impl Mount {
    /// A RangeFinder's frame: where its readings are measured from (its offsets), facing
    /// the robot's way, so that its bearings are the robot's.
    #[must_use]
    pub fn of_range_finder(rf: &RangeFinder) -> Self {
        Self {
            x: rf.x_offset,
            y: rf.y_offset,
            z: rf.z_offset,
            yaw: 0.0,
        }
    }
}

/// The sensors' frames as fixed transforms from [`BASE_FRAME`], each `(frame, mount)` in
/// the order given, stamped 0 (a static transform holds at every time): what ROS 2's
/// latched static broadcaster publishes on `/tf_static`.
#[must_use]
pub fn static_transforms<'a>(frames: impl IntoIterator<Item = (&'a str, &'a Mount)>) -> TfMessage {
    let transforms = frames
        .into_iter()
        .map(|(frame, m)| TransformStamped {
            header: header(0, BASE_FRAME),
            child_frame_id: frame.to_owned(),
            transform: Pose::planar(m.x, m.y, m.z, m.yaw),
        })
        .collect();
    TfMessage { transforms }
}

/// A RangeFinder's ROS 2 view: a scan or a cloud.
#[derive(Debug, Clone, PartialEq)]
pub enum RangeMessage {
    /// A uniform RangeFinder's (`sensor_msgs/msg/LaserScan`).
    Scan(LaserScan),
    /// A non-uniform RangeFinder's (`sensor_msgs/msg/PointCloud2`).
    Cloud(PointCloud),
}

/// A uniform RangeFinder as a LaserScan ([`laser_scan`]), a non-uniform one as a
/// PointCloud2 ([`point_cloud`]), under `header` (the sensor's frame) at `mount`.
#[must_use]
pub fn range_finder(rf: &RangeFinder, mount: &Mount, header: Header) -> RangeMessage {
    if rf.uniform {
        RangeMessage::Scan(laser_scan(rf, mount, header))
    } else {
        RangeMessage::Cloud(point_cloud(rf, mount, header))
    }
}

/// A uniform RangeFinder as a LaserScan in the frame at `mount`: its bearings are the
/// robot's (`theta_offset`) less the frame's heading; every range as it is, `range_max`
/// its `max_range`.
#[must_use]
pub fn laser_scan(rf: &RangeFinder, mount: &Mount, header: Header) -> LaserScan {
    let count = rf.ranges.len();
    let angle_min = rf.theta_offset - mount.yaw;
    let angle_max = angle_min + rf.theta_separation * count.saturating_sub(1) as f64;
    LaserScan {
        header,
        angle_min: angle_min as f32,
        angle_max: angle_max as f32,
        angle_increment: rf.theta_separation as f32,
        time_increment: 0.0,
        scan_time: 0.0,
        range_min: 0.0,
        range_max: rf.max_range as f32,
        ranges: rf.ranges.iter().map(|&r| r as f32).collect(),
        intensities: Vec::new(),
    }
}

/// A RangeFinder as a PointCloud2 (fields x, y, z, range): one point per reading, where
/// its beam ends, moved from the robot's frame into the one at `mount`.
#[must_use]
pub fn point_cloud(rf: &RangeFinder, mount: &Mount, header: Header) -> PointCloud {
    let (sin, cos) = (-mount.yaw).sin_cos();
    let mut values = Vec::with_capacity(rf.ranges.len() * 4);
    for (range, at) in rf.ranges.iter().zip(&rf.sensor_positions) {
        let bx = at.x + range * at.theta.cos() - mount.x;
        let by = at.y + range * at.theta.sin() - mount.y;
        let x = cos * bx - sin * by;
        let y = sin * bx + cos * by;
        values.extend([x as f32, y as f32, (at.z - mount.z) as f32, *range as f32]);
    }
    PointCloud {
        header,
        fields: vec!["x", "y", "z", "range"],
        values,
    }
}

/// An Egomotion as an Odometry (in [`ODOM_FRAME`], child [`BASE_FRAME`], the velocities
/// in the robot's frame), and the same pose as the [`ODOM_FRAME`] to [`BASE_FRAME`]
/// transform (for `/tf`), both stamped `stamp_ns`.
#[must_use]
pub fn egomotion(ego: &Egomotion, stamp_ns: i64) -> (Odometry, TfMessage) {
    let header = header(stamp_ns, ODOM_FRAME);
    let pose = Pose::planar(ego.pose.x, ego.pose.y, 0.0, ego.pose.theta);
    let odometry = Odometry {
        header: header.clone(),
        child_frame_id: BASE_FRAME.to_owned(),
        pose,
        linear: [ego.translation_velocity, 0.0, 0.0],
        angular: [0.0, 0.0, ego.rotation_velocity],
    };
    let tf = TfMessage {
        transforms: vec![TransformStamped {
            header,
            child_frame_id: BASE_FRAME.to_owned(),
            transform: pose,
        }],
    };
    (odometry, tf)
}

/// A Synchrodrive velocity command as a Twist: forward velocity along x, turn rate about z
/// (ROS 2's REP 103 axes are Lewis's: x forward, z up, counter-clockwise positive).
#[must_use]
pub fn twist(command: &SynchrodriveSetVelocity) -> Twist {
    Twist {
        linear: [command.translation_velocity, 0.0, 0.0],
        angular: [0.0, 0.0, command.rotation_velocity],
    }
}

/// How images are compressed for a CompressedImage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageCodec {
    /// Lossless.
    Png,
    /// Lossy, smaller.
    Jpeg,
}

impl ImageCodec {
    /// `CompressedImage`'s `format`: `png` or `jpeg`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Png => "png",
            Self::Jpeg => "jpeg",
        }
    }
}

/// An rgb8, bgr8 or mono8 image compressed with `codec`, under `header` (the camera's
/// frame).
///
/// # Errors
/// Another encoding, a size its data does not hold, or the encoder's refusal: the reason,
/// in words.
pub fn compressed_image(
    image: &ImageSource,
    header: Header,
    codec: ImageCodec,
) -> Result<CompressedImage, String> {
    let picture = picture(image)?;
    let format = match codec {
        ImageCodec::Png => ImageFormat::Png,
        ImageCodec::Jpeg => ImageFormat::Jpeg,
    };
    let mut data = Cursor::new(Vec::new());
    picture
        .write_to(&mut data, format)
        .map_err(|e| format!("cannot compress: {e}"))?;
    Ok(CompressedImage {
        header,
        format: codec.name().to_owned(),
        data: data.into_inner(),
    })
}

/// The pixels of an ImageSource, rows without their padding.
fn picture(image: &ImageSource) -> Result<DynamicImage, String> {
    let channels = match image.encoding.as_str() {
        "rgb8" | "bgr8" => 3,
        "mono8" => 1,
        other => {
            return Err(format!(
                "encoding `{other}` is not compressed (rgb8, bgr8, mono8 are)"
            ));
        }
    };
    let size = |n: i32, what: &str| u32::try_from(n).map_err(|_| format!("{what} {n}"));
    let (width, height) = (size(image.width, "width")?, size(image.height, "height")?);
    let step = usize::try_from(image.step).map_err(|_| format!("step {}", image.step))?;
    let row = width as usize * channels;
    let needed = step.saturating_mul(height as usize);
    if step < row || image.data.len() < needed {
        return Err(format!(
            "{width}x{height} {} with step {step} needs {needed} bytes, it has {}",
            image.encoding,
            image.data.len()
        ));
    }
    let mut pixels = Vec::with_capacity(row * height as usize);
    for y in 0..height as usize {
        let line = &image.data[y * step..y * step + row];
        if image.encoding == "bgr8" {
            pixels.extend(line.chunks_exact(3).flat_map(|p| [p[2], p[1], p[0]]));
        } else {
            pixels.extend_from_slice(line);
        }
    }
    let wrong = || "pixels do not fit the size".to_owned();
    Ok(if channels == 3 {
        DynamicImage::ImageRgb8(RgbImage::from_raw(width, height, pixels).ok_or_else(wrong)?)
    } else {
        DynamicImage::ImageLuma8(GrayImage::from_raw(width, height, pixels).ok_or_else(wrong)?)
    })
}

#[cfg(test)]
mod tests;
