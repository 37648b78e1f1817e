//! Each Lewis message's ROS 2 messages, encoded and decoded again with their own ros2msg
//! texts: what a ROS 2 reader sees.

use std::collections::BTreeMap;

use lewis_interfaces::cdr::{self, Encode};
use lewis_interfaces::dynamic::{Decoder, Value};
use lewis_interfaces::msg::{
    Blob, Blob3D, Blobs3D, Egomotion, ImageSource, Point3D, Pose2D, Pose3D, RangeFinder, Sign,
    Signs, SynchrodriveSetVelocity,
};
use lewis_interfaces::ros2;

use super::*;

/// `message` encoded, then decoded as a `type_name` by the text ROS 2 readers get.
fn decoded<T: Encode>(type_name: &str, message: &T) -> Value {
    let text = ros2::schema_text(type_name).unwrap();
    Decoder::new(type_name, &text)
        .unwrap()
        .decode(&cdr::to_vec(message))
        .unwrap()
}

fn f(value: &Value, path: &str) -> f64 {
    value
        .get(path)
        .and_then(Value::as_f64)
        .unwrap_or_else(|| panic!("{path} in {value:?}"))
}

fn laser() -> RangeFinder {
    RangeFinder {
        ranges: vec![1.0, 2.5, 8.0],
        range_count: 3,
        max_range: 8.0,
        uniform: true,
        x_offset: 0.12,
        z_offset: 0.38,
        theta_offset: -0.5,
        theta_separation: 0.5,
        ..RangeFinder::default()
    }
}

#[test]
fn a_laser_is_a_scan_with_its_ranges_and_bearings_in_its_frame() {
    let rf = laser();
    let mount = Mount::of_range_finder(&rf);
    assert_eq!((mount.x, mount.z, mount.yaw), (0.12, 0.38, 0.0));
    let RangeMessage::Scan(scan) = range_finder(&rf, &mount, header(7_000_000_123, "laser")) else {
        panic!("a uniform RangeFinder is a scan");
    };
    let scan = decoded(ros2::LASER_SCAN, &scan);
    assert_eq!(
        scan.get("header.frame_id").and_then(Value::as_str),
        Some("laser")
    );
    assert_eq!(
        scan.get("header.stamp.sec").and_then(Value::as_i64),
        Some(7)
    );
    assert_eq!(
        scan.get("header.stamp.nanosec").and_then(Value::as_u64),
        Some(123)
    );
    assert_eq!(f(&scan, "angle_min"), -0.5);
    assert_eq!(f(&scan, "angle_max"), 0.5);
    assert_eq!(f(&scan, "range_max"), 8.0);
    let ranges: Vec<f64> = scan
        .get("ranges")
        .and_then(Value::as_array)
        .unwrap()
        .iter()
        .filter_map(Value::as_f64)
        .collect();
    assert_eq!(ranges, [1.0, 2.5, 8.0]);
    // A frame turned left sees the same beams further right.
    let turned = Mount { yaw: 0.25, ..mount };
    let scan = laser_scan(&rf, &turned, header(0, "laser"));
    assert_eq!((scan.angle_min, scan.angle_max), (-0.75, 0.25));
}

#[test]
fn a_sonar_ring_is_a_cloud_of_where_its_beams_end_in_its_frame() {
    let sonar = RangeFinder {
        ranges: vec![1.0, 2.0],
        range_count: 2,
        uniform: false,
        x_offset: 0.1,
        sensor_positions: vec![
            Pose3D {
                x: 0.2,
                y: 0.0,
                z: 0.3,
                theta: 0.0,
                ..Pose3D::default()
            },
            Pose3D {
                x: 0.0,
                y: 0.2,
                z: 0.3,
                theta: std::f64::consts::FRAC_PI_2,
                ..Pose3D::default()
            },
        ],
        ..RangeFinder::default()
    };
    let mount = Mount::of_range_finder(&sonar);
    let RangeMessage::Cloud(cloud) = range_finder(&sonar, &mount, header(0, "sonar")) else {
        panic!("a non-uniform RangeFinder is a cloud");
    };
    let value = decoded(ros2::POINT_CLOUD2, &cloud);
    assert_eq!(value.get("width").and_then(Value::as_u64), Some(2));
    let data = value.get("data").and_then(Value::as_bytes).unwrap();
    let floats: Vec<f32> = data
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let want = [1.1, 0.0, 0.3, 1.0, -0.1, 2.2, 0.3, 2.0];
    for (got, want) in floats.iter().zip(want) {
        assert!((f64::from(*got) - want).abs() < 1e-6, "{floats:?}");
    }
}

#[test]
fn odometry_and_the_odom_transform_carry_the_same_pose() {
    let ego = Egomotion {
        pose: Pose2D {
            x: 1.5,
            y: -2.0,
            theta: 2.0,
        },
        translation_velocity: 0.4,
        rotation_velocity: -0.1,
        ..Egomotion::default()
    };
    let (odometry, tf) = egomotion(&ego, 7_000_000_123);
    let odom = decoded(ros2::ODOMETRY, &odometry);
    assert_eq!(
        odom.get("header.frame_id").and_then(Value::as_str),
        Some(ODOM_FRAME)
    );
    assert_eq!(
        odom.get("child_frame_id").and_then(Value::as_str),
        Some(BASE_FRAME)
    );
    assert_eq!(f(&odom, "pose.pose.position.x"), 1.5);
    let (z, w) = (
        f(&odom, "pose.pose.orientation.z"),
        f(&odom, "pose.pose.orientation.w"),
    );
    assert!((2.0 * z.atan2(w) - 2.0).abs() < 1e-12);
    assert_eq!(f(&odom, "twist.twist.linear.x"), 0.4);
    assert_eq!(f(&odom, "twist.twist.angular.z"), -0.1);
    let tf = decoded(ros2::TF_MESSAGE, &tf);
    let transform = &tf.get("transforms").and_then(Value::as_array).unwrap()[0];
    assert_eq!(
        transform.get("header.frame_id").and_then(Value::as_str),
        Some(ODOM_FRAME)
    );
    assert_eq!(
        transform.get("child_frame_id").and_then(Value::as_str),
        Some(BASE_FRAME)
    );
    assert_eq!(f(transform, "transform.translation.y"), -2.0);
}

#[test]
fn the_sensors_frames_are_fixed_transforms_from_the_robots() {
    let laser = Mount {
        x: 0.12,
        z: 0.38,
        ..Mount::default()
    };
    let camera = Mount {
        x: 0.1,
        y: -0.2,
        z: 1.2,
        yaw: std::f64::consts::FRAC_PI_2,
    };
    let tf = static_transforms([("camera", &camera), ("laser", &laser)]);
    let value = decoded(ros2::TF_MESSAGE, &tf);
    let transforms = value.get("transforms").and_then(Value::as_array).unwrap();
    assert_eq!(transforms.len(), 2);
    let [camera, laser] = [&transforms[0], &transforms[1]];
    assert_eq!(
        camera.get("child_frame_id").and_then(Value::as_str),
        Some("camera")
    );
    assert_eq!(
        camera.get("header.frame_id").and_then(Value::as_str),
        Some(BASE_FRAME)
    );
    assert_eq!(
        camera.get("header.stamp.sec").and_then(Value::as_i64),
        Some(0)
    );
    assert_eq!(f(camera, "transform.translation.y"), -0.2);
    assert_eq!(f(camera, "transform.translation.z"), 1.2);
    assert!((f(camera, "transform.rotation.z") - 0.5f64.sqrt()).abs() < 1e-12);
    assert_eq!(f(laser, "transform.translation.x"), 0.12);
}

#[test]
fn a_velocity_command_is_a_twist_forward_and_about_z() {
    let command = SynchrodriveSetVelocity {
        translation_velocity: 0.5,
        rotation_velocity: -0.25,
        ..SynchrodriveSetVelocity::default()
    };
    let value = decoded(ros2::TWIST, &twist(&command));
    assert_eq!(f(&value, "linear.x"), 0.5);
    assert_eq!(f(&value, "angular.z"), -0.25);
    for path in ["linear.y", "linear.z", "angular.x", "angular.y"] {
        assert_eq!(f(&value, path), 0.0, "{path}");
    }
}

#[test]
fn the_markers_of_the_bindings_are_one_text_after_a_clear() {
    let text = |bindings: &BTreeMap<(String, String), String>| {
        let value = decoded(ros2::MARKER_ARRAY, &binding_markers(bindings, 5));
        let markers = value
            .get("markers")
            .and_then(Value::as_array)
            .unwrap()
            .to_vec();
        assert_eq!(markers[0].get("action").and_then(Value::as_i64), Some(3));
        assert_eq!(
            markers[1].get("header.frame_id").and_then(Value::as_str),
            Some(BASE_FRAME)
        );
        markers[1]
            .get("text")
            .and_then(Value::as_str)
            .unwrap()
            .to_owned()
    };
    let mut bindings = BTreeMap::new();
    assert_eq!(text(&bindings), "");
    bindings.insert(
        ("avoider".to_owned(), "RangeFinder".to_owned()),
        "laser".to_owned(),
    );
    bindings.insert(
        ("avoider".to_owned(), "Egomotion".to_owned()),
        "base".to_owned(),
    );
    assert_eq!(
        text(&bindings),
        "avoider: Egomotion <- base\navoider: RangeFinder <- laser"
    );
}

#[test]
fn blobs_and_signs_are_boxes_where_they_were_placed() {
    let blob = |valid: bool| Blob3D {
        blob: Blob {
            colour_name: "Red".into(),
            ..Blob::default()
        },
        range_valid: valid,
        position: Point3D {
            x: 2.0,
            y: 0.5,
            z: 0.4,
        },
        width: 0.2,
        height: 0.3,
    };
    let blobs = Blobs3D {
        blob_count: 2,
        blobs: vec![blob(true), blob(false)],
        ..Blobs3D::default()
    };
    let value = decoded(ros2::MARKER_ARRAY, &blob_markers(&blobs, 0));
    let markers = value.get("markers").and_then(Value::as_array).unwrap();
    assert_eq!(
        markers.len(),
        3,
        "a clear, then a box and a label for the placed blob only"
    );
    assert_eq!(f(&markers[1], "pose.position.x"), 2.0);
    assert_eq!(f(&markers[1], "color.r"), f64::from(0.9f32));
    assert_eq!(markers[2].get("text").and_then(Value::as_str), Some("Red"));
    let sign = Sign {
        position: Point3D {
            x: 3.0,
            y: 0.0,
            z: 1.0,
        },
        arrow: "left".into(),
        confidence: 0.9,
        ..Sign::default()
    };
    let signs = Signs {
        sign_count: 1,
        signs: vec![sign],
        ..Signs::default()
    };
    let value = decoded(ros2::MARKER_ARRAY, &sign_markers(&signs, 0));
    let markers = value.get("markers").and_then(Value::as_array).unwrap();
    assert_eq!(f(&markers[1], "pose.position.x"), 3.0);
    assert_eq!(
        markers[2].get("text").and_then(Value::as_str),
        Some("left (0.90)")
    );
}

fn picture(encoding: &str, data: Vec<u8>, width: i32, step: i32) -> ImageSource {
    ImageSource {
        width,
        height: 1,
        encoding: encoding.to_owned(),
        step,
        data,
        ..ImageSource::default()
    }
}

#[test]
fn an_image_is_compressed_with_its_pixels_in_rgb_order_without_padding() {
    let bgr = picture("bgr8", vec![1, 2, 3, 4, 5, 6, 0, 0], 2, 8);
    let compressed = compressed_image(&bgr, header(0, "camera"), ImageCodec::Png).unwrap();
    let image = decoded(ros2::COMPRESSED_IMAGE, &compressed);
    assert_eq!(image.get("format").and_then(Value::as_str), Some("png"));
    assert_eq!(
        image.get("header.frame_id").and_then(Value::as_str),
        Some("camera")
    );
    let png = image.get("data").and_then(Value::as_bytes).unwrap();
    let back = image::load_from_memory(png).unwrap().to_rgb8();
    assert_eq!(
        back.into_raw(),
        [3, 2, 1, 6, 5, 4],
        "bgr8 stored as rgb, the row's padding dropped"
    );
    let mono = picture("mono8", vec![9, 200], 2, 2);
    let jpeg = compressed_image(&mono, header(0, "camera"), ImageCodec::Jpeg).unwrap();
    assert_eq!(jpeg.format, "jpeg");
    let back = image::load_from_memory(&jpeg.data).unwrap();
    assert_eq!((back.width(), back.height()), (2, 1));
}

#[test]
fn an_image_of_another_encoding_or_too_short_is_refused_with_its_reason() {
    let yuv = picture("yuv422", vec![0; 4], 2, 4);
    let reason = compressed_image(&yuv, header(0, "camera"), ImageCodec::Png).unwrap_err();
    assert!(reason.contains("yuv422"), "{reason}");
    let short = picture("rgb8", vec![0; 3], 2, 6);
    let reason = compressed_image(&short, header(0, "camera"), ImageCodec::Png).unwrap_err();
    assert!(reason.contains("needs 6 bytes"), "{reason}");
}
