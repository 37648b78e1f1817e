//! One decoded ROS 2 message to a Lewis message, per type: `sensor_msgs/LaserScan` to a
//! RangeFinder, `nav_msgs/Odometry` (or a `tf2_msgs/TFMessage`'s odom to base transform)
//! to an Egomotion pose, `sensor_msgs/Image` and `sensor_msgs/CompressedImage` to an
//! ImageSource in rgb8. The messages were decoded by the schema-driven decoder
//! ([`lewis_interfaces::dynamic`]) with their own schema texts (a bag's, a live topic's);
//! this module reads fields of its value trees. Headers are left to the caller
//! ([`stamp_ns`] reads one's stamp).
//!
//! **Ranges.** A reading is kept unchanged (widened from `float32`) when it lies within the
//! scan's `[range_min, range_max]`; any other reading (NaN, infinite, below the minimum or
//! beyond the maximum: REP 117's "no return" and errors) becomes `max_range`, the
//! convention of the simulator's laser, ObstacleAvoider and Distance ("free up to there").

use image::ImageFormat;
use lewis_interfaces::dynamic::Value;
use lewis_interfaces::msg::{ImageSource, Pose2D, Pose3D, RangeFinder};

/// The pixel encodings of `sensor_msgs/Image` that [`image()`] converts.
pub const IMAGE_ENCODINGS: &[&str] = &["rgb8", "bgr8", "mono8", "yuv422", "yuv422_yuy2"];

/// A number at `path`, of whatever width the schema gave it.
pub fn number(value: &Value, path: &str) -> Result<f64, String> {
    match value.get(path) {
        Some(Value::Float(x)) => Ok(*x),
        // Integers of messages are far below 2^53.
        Some(Value::Int(x)) => Ok(*x as f64),
        Some(Value::UInt(x)) => Ok(*x as f64),
        Some(_) => Err(format!("`{path}` is not a number")),
        None => Err(format!("`{path}` is missing")),
    }
}

fn text<'v>(value: &'v Value, path: &str) -> Result<&'v str, String> {
    value
        .get(path)
        .and_then(Value::as_str)
        .ok_or_else(|| format!("`{path}` is missing or not a string"))
}

fn bytes<'v>(value: &'v Value, path: &str) -> Result<&'v [u8], String> {
    value
        .get(path)
        .and_then(Value::as_bytes)
        .ok_or_else(|| format!("`{path}` is missing or not bytes"))
}

fn unsigned(value: &Value, path: &str) -> Result<u32, String> {
    value
        .get(path)
        .and_then(Value::as_u64)
        .and_then(|v| u32::try_from(v).ok())
        .ok_or_else(|| format!("`{path}` is missing or not a 32-bit count"))
}

/// The `header.stamp` of a message, in ns (`None` when it has no header).
#[must_use]
pub fn stamp_ns(value: &Value) -> Option<i64> {
    stamp_at(value, "header.stamp")
}

fn stamp_at(value: &Value, path: &str) -> Option<i64> {
    let stamp = value.get(path)?;
    let sec = stamp.field("sec")?.as_i64()?;
    let nanosec = stamp.field("nanosec")?.as_i64()?;
    sec.checked_mul(1_000_000_000)?.checked_add(nanosec)
}

/// A LaserScan's beams and limits.
#[derive(Debug, Clone, PartialEq)]
pub struct Scan {
    /// The readings, in m, as logged.
    pub ranges_m: Vec<f64>,
    /// Bearing of the first beam, in rad.
    pub angle_min_rad: f64,
    /// Angle from one beam to the next, in rad.
    pub angle_increment_rad: f64,
    /// The shortest valid reading, in m.
    pub range_min_m: f64,
    /// The longest valid reading, in m.
    pub range_max_m: f64,
}

/// The beams of a `sensor_msgs/LaserScan`.
///
/// # Errors
/// A field is missing or of another type, or the limits are not usable.
pub fn laser_scan(value: &Value) -> Result<Scan, String> {
    let ranges = value
        .get("ranges")
        .and_then(Value::as_array)
        .ok_or("`ranges` is missing or not an array")?;
    let ranges_m = ranges
        .iter()
        .map(|r| r.as_f64().ok_or("`ranges` holds a non-number"))
        .collect::<Result<Vec<f64>, _>>()?;
    let scan = Scan {
        ranges_m,
        angle_min_rad: number(value, "angle_min")?,
        angle_increment_rad: number(value, "angle_increment")?,
        range_min_m: number(value, "range_min")?,
        range_max_m: number(value, "range_max")?,
    };
    if !(scan.range_max_m.is_finite() && scan.range_max_m > 0.0) {
        return Err(format!(
            "range_max is {}: a scan needs a positive finite maximum",
            scan.range_max_m
        ));
    }
    if !(scan.angle_min_rad.is_finite() && scan.angle_increment_rad.is_finite()) {
        return Err("angle_min or angle_increment is not finite".to_owned());
    }
    Ok(scan)
}

/// Readings converted, by kind, over many scans (an import's, a gateway's).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RangeCounts {
    /// Readings kept as logged.
    pub kept: u64,
    /// Readings outside `[range_min, range_max]` or not finite, published as max range.
    pub out_of_limits: u64,
}

/// The RangeFinder reading of a scan (the laser taken at the robot's centre, facing
/// forward: the static transforms of `/tf_static` are not applied).
#[must_use]
pub fn range_finder(scan: &Scan, counts: &mut RangeCounts) -> RangeFinder {
    let max = scan.range_max_m;
    let ranges: Vec<f64> = scan
        .ranges_m
        .iter()
        .map(|&r| {
            if r.is_finite() && r >= scan.range_min_m && r <= max {
                counts.kept += 1;
                r
            } else {
                counts.out_of_limits += 1;
                max
            }
        })
        .collect();
    let sensor_positions = (0..ranges.len())
        .map(|i| Pose3D {
            theta: scan.angle_min_rad + scan.angle_increment_rad * i as f64,
            ..Pose3D::default()
        })
        .collect();
    RangeFinder {
        range_count: i32::try_from(ranges.len()).unwrap_or(i32::MAX),
        ranges,
        max_range: max,
        uniform: true,
        sensor_positions,
        theta_offset: scan.angle_min_rad,
        theta_separation: scan.angle_increment_rad,
        ..RangeFinder::default()
    }
}

/// The heading of the quaternion at `path`, about z, in rad.
///
/// # Errors
/// A component is missing or not a number.
pub fn yaw(value: &Value, path: &str) -> Result<f64, String> {
    let q = |c: &str| number(value, &format!("{path}.{c}"));
    let (x, y, z, w) = (q("x")?, q("y")?, q("z")?, q("w")?);
    Ok((2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z)))
}

/// An odometry reading: the planar pose and velocities.
#[derive(Debug, Clone, PartialEq)]
pub struct Odometry {
    /// Pose in the odometry frame.
    pub pose: Pose2D,
    /// Forward velocity, in m/s.
    pub translation_mps: f64,
    /// Turn rate, in rad/s.
    pub rotation_radps: f64,
}

/// The planar pose and velocities of a `nav_msgs/Odometry`.
///
/// # Errors
/// A field is missing or of another type.
pub fn odometry(value: &Value) -> Result<Odometry, String> {
    Ok(Odometry {
        pose: Pose2D {
            x: number(value, "pose.pose.position.x")?,
            y: number(value, "pose.pose.position.y")?,
            theta: yaw(value, "pose.pose.orientation")?,
        },
        translation_mps: number(value, "twist.twist.linear.x")?,
        rotation_radps: number(value, "twist.twist.angular.z")?,
    })
}

/// The frames an odometry transform goes from and to.
pub const ODOM_FRAMES: &[(&str, &str)] = &[("odom", "base_link"), ("odom", "base_footprint")];

/// The odom to base pose of a `tf2_msgs/TFMessage`, when it holds one, with its stamp.
///
/// # Errors
/// A field is missing or of another type.
pub fn tf_odometry(value: &Value) -> Result<Option<(Pose2D, Option<i64>)>, String> {
    let transforms = value
        .get("transforms")
        .and_then(Value::as_array)
        .ok_or("`transforms` is missing or not an array")?;
    for t in transforms {
        let parent = text(t, "header.frame_id")?.trim_start_matches('/');
        let child = text(t, "child_frame_id")?.trim_start_matches('/');
        if ODOM_FRAMES.contains(&(parent, child)) {
            let pose = Pose2D {
                x: number(t, "transform.translation.x")?,
                y: number(t, "transform.translation.y")?,
                theta: yaw(t, "transform.rotation")?,
            };
            return Ok(Some((pose, stamp_at(t, "header.stamp"))));
        }
    }
    Ok(None)
}

/// Why an image cannot be converted.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ImageError {
    /// Its encoding is none of [`IMAGE_ENCODINGS`] (or, compressed, neither JPEG nor PNG).
    UnknownEncoding(String),
    /// Anything else: a field, a size, undecodable bytes.
    Bad(String),
}

impl std::fmt::Display for ImageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::UnknownEncoding(encoding) => write!(
                f,
                "image encoding `{encoding}` is not converted (raw images: {}; compressed: jpeg, png)",
                IMAGE_ENCODINGS.join(", ")
            ),
            Self::Bad(reason) => f.write_str(reason),
        }
    }
}

impl From<String> for ImageError {
    fn from(reason: String) -> Self {
        Self::Bad(reason)
    }
}

/// The encoding of a `sensor_msgs/Image`, checked against [`IMAGE_ENCODINGS`] before its
/// pixels are read.
///
/// # Errors
/// [`ImageError::UnknownEncoding`], or the field is missing.
pub fn image_encoding(value: &Value) -> Result<&str, ImageError> {
    let encoding = text(value, "encoding")?;
    if IMAGE_ENCODINGS.contains(&encoding) {
        Ok(encoding)
    } else {
        Err(ImageError::UnknownEncoding(encoding.to_owned()))
    }
}

/// Width, height and RGB8 pixels of a `sensor_msgs/Image`.
///
/// # Errors
/// An unknown encoding, or a size the data does not hold.
pub fn image(value: &Value) -> Result<(u32, u32, Vec<u8>), ImageError> {
    let encoding = image_encoding(value)?;
    let width = unsigned(value, "width")?;
    let height = unsigned(value, "height")?;
    let step = unsigned(value, "step")? as usize;
    let data = bytes(value, "data")?;
    let (w, h) = (width as usize, height as usize);
    // A width of 0 needs no bytes whatever the height: 4 billion empty rows held the
    // gateway for seconds (a timeout of ros2-map/fuzz's ros2_samples).
    if w == 0 || h == 0 {
        return Err(ImageError::Bad(format!("{width}x{height}: no pixels")));
    }
    let bytes_per_pixel = match encoding {
        "mono8" => 1,
        "rgb8" | "bgr8" => 3,
        _ => 2,
    };
    let needed = h
        .checked_sub(1)
        .map_or(Some(0), |rows| {
            rows.checked_mul(step)?
                .checked_add(w.checked_mul(bytes_per_pixel)?)
        })
        .filter(|_| step >= w.saturating_mul(bytes_per_pixel))
        .ok_or_else(|| {
            ImageError::Bad(format!(
                "{width}x{height} with a step of {step} bytes is impossible"
            ))
        })?;
    if data.len() < needed {
        return Err(ImageError::Bad(format!(
            "{width}x{height} {encoding} with a step of {step} needs {needed} bytes, the message has {}",
            data.len()
        )));
    }
    let mut rgb = Vec::with_capacity(w * h * 3);
    if matches!(encoding, "yuv422" | "yuv422_yuy2") {
        // ROS's `yuv422` is UYVY; `yuv422_yuy2` is YUYV, the camera driver's order.
        let mut yuyv = Vec::with_capacity(needed);
        for row in 0..h {
            let line = data.get(row * step..row * step + w * 2).unwrap_or_default();
            if encoding == "yuv422" {
                for quad in line.chunks_exact(4) {
                    yuyv.extend_from_slice(&[quad[1], quad[0], quad[3], quad[2]]);
                }
            } else {
                yuyv.extend_from_slice(line);
            }
        }
        lewis_images::yuv::yuyv_to_rgb(width, height, width.div_ceil(2) * 4, &yuyv, &mut rgb)
            .map_err(|e| ImageError::Bad(e.to_string()))?;
        return Ok((width, height, rgb));
    }
    for row in 0..h {
        let line = data
            .get(row * step..row * step + w * bytes_per_pixel)
            .unwrap_or_default();
        match encoding {
            "rgb8" => rgb.extend_from_slice(line),
            "bgr8" => {
                for p in line.chunks_exact(3) {
                    rgb.extend_from_slice(&[p[2], p[1], p[0]]);
                }
            }
            _ => {
                for &g in line {
                    rgb.extend_from_slice(&[g, g, g]);
                }
            }
        }
    }
    Ok((width, height, rgb))
}

/// Width, height and RGB8 pixels of a `sensor_msgs/CompressedImage` (JPEG or PNG, by its
/// `format` field and its bytes).
///
/// # Errors
/// Another format, or bytes that do not decode.
pub fn compressed_image(value: &Value) -> Result<(u32, u32, Vec<u8>), ImageError> {
    let format = text(value, "format")?.to_ascii_lowercase();
    let kind = if format.contains("jpeg") || format.contains("jpg") {
        ImageFormat::Jpeg
    } else if format.contains("png") {
        ImageFormat::Png
    } else {
        return Err(ImageError::UnknownEncoding(format));
    };
    let data = bytes(value, "data")?;
    let decoded = image::load_from_memory_with_format(data, kind)
        .map_err(|e| ImageError::Bad(format!("the {format} image does not decode: {e}")))?
        .to_rgb8();
    let (width, height) = decoded.dimensions();
    Ok((width, height, decoded.into_raw()))
}

/// An ImageSource message (rgb8; no intrinsics: a CameraInfo is not read).
#[must_use]
pub fn image_source(width: u32, height: u32, rgb: Vec<u8>) -> ImageSource {
    let none = lewis_images::ImageIntrinsics {
        focal_length_x_px: 0.0,
        focal_length_y_px: 0.0,
        principal_x_px: 0.0,
        principal_y_px: 0.0,
    };
    lewis_images::image_message(width, height, rgb, none)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use std::sync::Arc;

    use image::ImageEncoder as _;

    use super::*;

    fn message(fields: Vec<(&str, Value)>) -> Value {
        Value::Struct(
            fields
                .into_iter()
                .map(|(name, value)| (Arc::from(name), value))
                .collect(),
        )
    }

    fn raw(encoding: &str, width: u64, height: u64, step: u64, data: Vec<u8>) -> Value {
        message(vec![
            ("height", Value::UInt(height)),
            ("width", Value::UInt(width)),
            ("encoding", Value::String(encoding.to_owned())),
            ("is_bigendian", Value::UInt(0)),
            ("step", Value::UInt(step)),
            ("data", Value::Bytes(data)),
        ])
    }

    #[test]
    fn raw_encodings_become_rgb8_rows_without_their_padding() {
        // Two pixels a row, one byte of padding per row.
        let bgr = raw("bgr8", 2, 1, 7, vec![1, 2, 3, 4, 5, 6, 99]);
        assert_eq!(image(&bgr).unwrap(), (2, 1, vec![3, 2, 1, 6, 5, 4]));
        let mono = raw("mono8", 2, 2, 3, vec![7, 8, 99, 9, 10]);
        assert_eq!(
            image(&mono).unwrap(),
            (2, 2, vec![7, 7, 7, 8, 8, 8, 9, 9, 9, 10, 10, 10])
        );
        // UYVY grey (Y 128, U = V = 128) is the camera driver's YUYV grey.
        let uyvy = raw("yuv422", 2, 1, 4, vec![128, 128, 128, 128]);
        let (_, _, rgb) = image(&uyvy).unwrap();
        assert_eq!(
            rgb,
            [lewis_images::yuv::yuv_to_rgb(128, 128, 128); 2].concat()
        );
    }

    #[test]
    fn an_unknown_encoding_or_a_short_image_is_refused() {
        let bayer = raw("bayer_rggb8", 2, 2, 2, vec![0; 4]);
        assert_eq!(
            image(&bayer),
            Err(ImageError::UnknownEncoding("bayer_rggb8".to_owned()))
        );
        let short = raw("rgb8", 2, 2, 6, vec![0; 11]);
        assert!(matches!(image(&short), Err(ImageError::Bad(r)) if r.contains("needs 12 bytes")));
        let impossible = raw("rgb8", 4, 2, 6, vec![0; 100]);
        assert!(matches!(image(&impossible), Err(ImageError::Bad(_))));
    }

    #[test]
    fn an_image_of_no_pixels_is_refused_at_once() {
        // The fuzzer's input: no width, 2^32 - 1 rows of no bytes, which took seconds.
        for encoding in ["mono8", "yuv422"] {
            let empty = raw(encoding, 0, u64::from(u32::MAX), 0, Vec::new());
            let started = std::time::Instant::now();
            assert!(matches!(image(&empty), Err(ImageError::Bad(r)) if r.contains("no pixels")));
            assert!(started.elapsed() < std::time::Duration::from_millis(100));
        }
        assert!(matches!(
            image(&raw("rgb8", 2, 0, 6, Vec::new())),
            Err(ImageError::Bad(_))
        ));
    }

    #[test]
    fn a_png_compressed_image_decodes_to_its_pixels() {
        let pixels = vec![1u8, 2, 3, 4, 5, 6];
        let mut png = Vec::new();
        image::codecs::png::PngEncoder::new(&mut png)
            .write_image(&pixels, 2, 1, image::ExtendedColorType::Rgb8)
            .unwrap();
        let compressed = message(vec![
            (
                "format",
                Value::String("rgb8; png compressed bgr8".to_owned()),
            ),
            ("data", Value::Bytes(png)),
        ]);
        assert_eq!(compressed_image(&compressed).unwrap(), (2, 1, pixels));
    }

    #[test]
    fn readings_outside_the_limits_become_max_range_and_the_rest_are_kept() {
        let scan = Scan {
            ranges_m: vec![0.05, 1.25, f64::NAN, 31.0, f64::INFINITY, 30.0],
            angle_min_rad: -1.0,
            angle_increment_rad: 0.5,
            range_min_m: 0.1,
            range_max_m: 30.0,
        };
        let mut counts = RangeCounts::default();
        let reading = range_finder(&scan, &mut counts);
        assert_eq!(reading.ranges, [30.0, 1.25, 30.0, 30.0, 30.0, 30.0]);
        assert_eq!((counts.kept, counts.out_of_limits), (2, 4));
        assert_eq!(reading.sensor_positions[2].theta, 0.0);
    }

    #[test]
    fn a_quaternion_about_z_gives_its_heading() {
        let q = |yaw: f64| {
            message(vec![(
                "q",
                message(vec![
                    ("x", Value::Float(0.0)),
                    ("y", Value::Float(0.0)),
                    ("z", Value::Float((yaw / 2.0).sin())),
                    ("w", Value::Float((yaw / 2.0).cos())),
                ]),
            )])
        };
        for yaw in [0.0, 0.5, -2.0, 3.0] {
            assert!((super::yaw(&q(yaw), "q").unwrap() - yaw).abs() < 1e-12);
        }
    }
}
