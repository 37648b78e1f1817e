//! The companions of each message: their channels, the fixed frames before them, the
//! broker's bindings followed, and what is skipped. What each ROS 2 message holds is
//! `lewis_ros2_map::to_ros2`'s, tested there.

use lewis_interfaces::cdr;
use lewis_interfaces::dynamic::{Decoder, Value};
use lewis_interfaces::msg::{Blobs3D, Broker, Egomotion, ImageSource, Pose2D, RangeFinder, Signs};
use lewis_interfaces::ros2;

use super::*;

const ROBOT: &str = r#"
name = "test"
[[services]]
name = "camera"
[services.parameters]
mount = { x_m = 0.1, y_m = -0.2, heading_deg = 90.0, height_m = 1.2 }
"#;

fn spec(topic: &str, provider: &str, schema_name: &str) -> ChannelSpec {
    ChannelSpec {
        topic: topic.to_owned(),
        schema_name: schema_name.to_owned(),
        schema_text: String::new(),
        provider: provider.to_owned(),
        interface: String::new(),
        interface_version: String::new(),
        extra_metadata: BTreeMap::new(),
    }
}

fn convert<T: Struct>(
    companions: &mut Companions,
    topic: &str,
    provider: &str,
    message: &T,
) -> Vec<Companion> {
    let mut out = Vec::new();
    let channel = spec(topic, provider, T::SCHEMA_NAME);
    companions.convert(&channel, &cdr::to_vec(message), 7_000_000_123, &mut out);
    out
}

fn decoded(companion: &Companion) -> Value {
    let text = ros2::schema_text(companion.type_name).unwrap();
    Decoder::new(companion.type_name, &text)
        .unwrap()
        .decode(&companion.data)
        .unwrap()
}

fn f(value: &Value, path: &str) -> f64 {
    value
        .get(path)
        .and_then(Value::as_f64)
        .unwrap_or_else(|| panic!("{path} in {value:?}"))
}

fn topics(out: &[Companion]) -> Vec<&str> {
    out.iter().map(|c| c.topic.as_str()).collect()
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
fn a_laser_gives_its_frame_then_a_scan_stamped_in_it_on_a_companion_channel() {
    let mut companions = Companions::new(CompanionOptions::default(), None);
    let out = convert(&mut companions, "/laser/RangeFinder", "laser", &laser());
    assert_eq!(topics(&out), [TF_STATIC_TOPIC, "/laser/scan"]);
    assert_eq!(out[0].source, None);
    let tf = decoded(&out[0]);
    let transform = &tf.get("transforms").and_then(Value::as_array).unwrap()[0];
    assert_eq!(
        transform.get("child_frame_id").and_then(Value::as_str),
        Some("laser")
    );
    assert_eq!(f(transform, "transform.translation.x"), 0.12);
    assert_eq!(f(transform, "transform.translation.z"), 0.38);
    assert_eq!(out[1].type_name, ros2::LASER_SCAN);
    let scan = decoded(&out[1]);
    assert_eq!(
        scan.get("header.frame_id").and_then(Value::as_str),
        Some("laser")
    );
    assert_eq!(
        scan.get("header.stamp.nanosec").and_then(Value::as_u64),
        Some(123)
    );
    assert_eq!(out[1].source.as_deref(), Some("/laser/RangeFinder"));
    assert_eq!(
        out[1]
            .channel_spec()
            .extra_metadata
            .get("kind")
            .map(String::as_str),
        Some(COMPANION_KIND)
    );
}

#[test]
fn each_view_is_on_its_sources_sibling_topic() {
    let mut companions = Companions::new(CompanionOptions::default(), None);
    let sonar = RangeFinder {
        uniform: false,
        ..laser()
    };
    let out = convert(&mut companions, "/sonar/RangeFinder", "sonar", &sonar);
    assert_eq!(topics(&out), [TF_STATIC_TOPIC, "/sonar/points"]);
    assert_eq!(out[1].type_name, ros2::POINT_CLOUD2);
    let ego = Egomotion {
        pose: Pose2D {
            x: 1.5,
            y: -2.0,
            theta: 2.0,
        },
        ..Egomotion::default()
    };
    let out = convert(&mut companions, "/base/Egomotion", "base", &ego);
    assert_eq!(topics(&out), ["/base/odom", TF_TOPIC]);
    assert_eq!(out[1].source.as_deref(), Some("/base/Egomotion"));
    let blobs = convert(
        &mut companions,
        "/blobfinder3d/Blobs3D",
        "blobfinder3d",
        &Blobs3D::default(),
    );
    let signs = convert(
        &mut companions,
        "/sign_detector/Signs",
        "sign_detector",
        &Signs::default(),
    );
    assert_eq!(
        [topics(&blobs), topics(&signs)],
        [["/blobfinder3d/markers"], ["/sign_detector/markers"]]
    );
    assert_eq!(signs[0].type_name, ros2::MARKER_ARRAY);
}

#[test]
fn the_fixed_frames_are_written_again_only_for_a_new_frame_or_a_new_part() {
    let mut companions = Companions::new(CompanionOptions::default(), None);
    let statics = |out: &[Companion]| out.iter().filter(|c| c.topic == TF_STATIC_TOPIC).count();
    assert_eq!(
        statics(&convert(
            &mut companions,
            "/laser/RangeFinder",
            "laser",
            &laser()
        )),
        1
    );
    assert_eq!(
        statics(&convert(
            &mut companions,
            "/laser/RangeFinder",
            "laser",
            &laser()
        )),
        0
    );
    let sonar = RangeFinder {
        uniform: false,
        ..laser()
    };
    let out = convert(&mut companions, "/sonar/RangeFinder", "sonar", &sonar);
    assert_eq!(statics(&out), 1);
    let frames = decoded(&out[0]);
    assert_eq!(
        frames
            .get("transforms")
            .and_then(Value::as_array)
            .map(<[_]>::len),
        Some(2)
    );
    companions.part_started();
    assert_eq!(
        statics(&convert(
            &mut companions,
            "/laser/RangeFinder",
            "laser",
            &laser()
        )),
        1
    );
}

#[test]
fn the_markers_follow_the_brokers_bindings() {
    let mut companions = Companions::new(CompanionOptions::default(), None);
    let decision = |action: &str, service: &str, to: &str| Broker {
        action: action.to_owned(),
        client: "avoider".to_owned(),
        interface: "RangeFinder".to_owned(),
        service: service.to_owned(),
        to_service: to.to_owned(),
        ..Broker::default()
    };
    let text = |out: &[Companion]| {
        let value = decoded(&out[0]);
        let markers = value
            .get("markers")
            .and_then(Value::as_array)
            .unwrap()
            .to_vec();
        assert_eq!(markers[0].get("action").and_then(Value::as_i64), Some(3));
        markers[1]
            .get("text")
            .and_then(Value::as_str)
            .unwrap()
            .to_owned()
    };
    let out = convert(
        &mut companions,
        "/lewis/broker",
        "broker",
        &decision("bind", "laser", ""),
    );
    assert_eq!(out[0].topic, BINDINGS_TOPIC);
    assert_eq!(text(&out), "avoider: RangeFinder <- laser");
    let out = convert(
        &mut companions,
        "/lewis/broker",
        "broker",
        &decision("rebind", "", "sonar"),
    );
    assert_eq!(text(&out), "avoider: RangeFinder <- sonar");
    assert!(
        convert(
            &mut companions,
            "/lewis/broker",
            "broker",
            &decision("start", "laser", "")
        )
        .is_empty()
    );
    let out = convert(
        &mut companions,
        "/lewis/broker",
        "broker",
        &decision("unbind", "sonar", ""),
    );
    assert_eq!(text(&out), "");
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
fn images_only_when_asked_in_the_cameras_mounted_frame() {
    let bgr = picture("bgr8", vec![1, 2, 3, 4, 5, 6, 0, 0], 2, 8);
    let mut off = Companions::new(CompanionOptions::default(), Some(ROBOT));
    assert!(convert(&mut off, "/camera/ImageSource", "camera", &bgr).is_empty());
    let options = CompanionOptions {
        images: Some(ImageCodec::Png),
    };
    let mut on = Companions::new(options, Some(ROBOT));
    let out = convert(&mut on, "/camera/ImageSource", "camera", &bgr);
    let tf = decoded(&out[0]);
    let transform = &tf.get("transforms").and_then(Value::as_array).unwrap()[0];
    assert_eq!(f(transform, "transform.translation.y"), -0.2);
    assert_eq!(f(transform, "transform.translation.z"), 1.2);
    let image = decoded(&out[1]);
    assert_eq!(out[1].topic, "/camera/image/compressed");
    assert_eq!(image.get("format").and_then(Value::as_str), Some("png"));
    assert_eq!(
        image.get("header.frame_id").and_then(Value::as_str),
        Some("camera")
    );
}

#[test]
fn what_cannot_be_converted_is_counted_with_its_reason_and_nothing_is_written() {
    let options = CompanionOptions {
        images: Some(ImageCodec::Jpeg),
    };
    let mut companions = Companions::new(options, None);
    let yuv = picture("yuv422", vec![0; 4], 2, 4);
    assert!(convert(&mut companions, "/camera/ImageSource", "camera", &yuv).is_empty());
    let short = picture("rgb8", vec![0; 3], 2, 6);
    assert!(convert(&mut companions, "/camera/ImageSource", "camera", &short).is_empty());
    let mut out = Vec::new();
    let channel = spec("/laser/RangeFinder", "laser", RangeFinder::SCHEMA_NAME);
    companions.convert(&channel, &[1, 2, 3], 0, &mut out);
    assert!(out.is_empty());
    let skipped = companions.skipped();
    assert_eq!(skipped["/camera/ImageSource"].count, 2);
    assert!(
        skipped["/camera/ImageSource"].reason.contains("yuv422"),
        "{skipped:?}"
    );
    assert_eq!(skipped["/laser/RangeFinder"].count, 1);
    assert!(
        skipped["/laser/RangeFinder"]
            .reason
            .starts_with("does not decode")
    );
}
