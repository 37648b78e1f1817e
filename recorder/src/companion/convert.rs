//! One Lewis message to its ROS 2 companions.

use std::collections::BTreeMap;
use std::io::Cursor;

use image::{DynamicImage, GrayImage, ImageFormat, RgbImage};
use lewis_interfaces::msg::{Blob, Blobs3D, Egomotion, ImageSource, RangeFinder, Signs};
use lewis_interfaces::ros2::{
    self, Color, CompressedImage, Header, LaserScan, Marker, MarkerArray, MarkerKind, Odometry,
    PointCloud, Pose, TfMessage, TransformStamped,
};

use super::{
    BASE_FRAME, Companion, ImageCodec, Mount, ODOM_FRAME, TF_TOPIC, companion, sibling_topic,
};

fn header(stamp_ns: i64, frame: &str) -> Header {
    Header {
        stamp_ns,
        frame_id: frame.to_owned(),
    }
}

/// A uniform RangeFinder as a LaserScan, a non-uniform one as a PointCloud2, in the
/// sensor's frame `frame` at `mount`.
pub(super) fn range_finder(
    topic: &str,
    frame: &str,
    stamp_ns: i64,
    rf: &RangeFinder,
    mount: &Mount,
) -> Companion {
    let header = header(stamp_ns, frame);
    if rf.uniform {
        let scan = laser_scan(rf, mount, header);
        companion(
            &sibling_topic(topic, "scan"),
            ros2::LASER_SCAN,
            Some(topic),
            &scan,
        )
    } else {
        let cloud = point_cloud(rf, mount, header);
        companion(
            &sibling_topic(topic, "points"),
            ros2::POINT_CLOUD2,
            Some(topic),
            &cloud,
        )
    }
}

/// The bearings are the robot's (`theta_offset`) less the frame's heading.
fn laser_scan(rf: &RangeFinder, mount: &Mount, header: Header) -> LaserScan {
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

/// One point per reading, where its beam ends, moved from the robot's frame into the
/// sensor's.
fn point_cloud(rf: &RangeFinder, mount: &Mount, header: Header) -> PointCloud {
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

/// Odometry, and the same pose as `odom` to `base_link` on `/tf`.
pub(super) fn egomotion(topic: &str, stamp_ns: i64, ego: &Egomotion) -> [Companion; 2] {
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
    [
        companion(
            &sibling_topic(topic, "odom"),
            ros2::ODOMETRY,
            Some(topic),
            &odometry,
        ),
        companion(TF_TOPIC, ros2::TF_MESSAGE, Some(topic), &tf),
    ]
}

/// An rgb8, bgr8 or mono8 image compressed.
pub(super) fn image(
    topic: &str,
    frame: &str,
    stamp_ns: i64,
    image: &ImageSource,
    codec: ImageCodec,
) -> Result<Companion, String> {
    let picture = picture(image)?;
    let format = match codec {
        ImageCodec::Png => ImageFormat::Png,
        ImageCodec::Jpeg => ImageFormat::Jpeg,
    };
    let mut data = Cursor::new(Vec::new());
    picture
        .write_to(&mut data, format)
        .map_err(|e| format!("cannot compress: {e}"))?;
    let compressed = CompressedImage {
        header: header(stamp_ns, frame),
        format: codec.name().to_owned(),
        data: data.into_inner(),
    };
    Ok(companion(
        &sibling_topic(topic, "image/compressed"),
        ros2::COMPRESSED_IMAGE,
        Some(topic),
        &compressed,
    ))
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

/// A marker that removes the topic's earlier markers: each message replaces the last.
fn clear(stamp_ns: i64) -> Marker {
    Marker {
        header: header(stamp_ns, BASE_FRAME),
        ns: String::new(),
        id: 0,
        kind: MarkerKind::Cube,
        delete_all: true,
        pose: Pose::planar(0.0, 0.0, 0.0, 0.0),
        scale: [0.0; 3],
        color: Color {
            r: 0.0,
            g: 0.0,
            b: 0.0,
            a: 0.0,
        },
        text: String::new(),
    }
}

fn marker(
    stamp_ns: i64,
    ns: &str,
    id: usize,
    kind: MarkerKind,
    pose: Pose,
    scale: [f64; 3],
    color: Color,
) -> Marker {
    Marker {
        header: header(stamp_ns, BASE_FRAME),
        ns: ns.to_owned(),
        id: i32::try_from(id).unwrap_or(i32::MAX),
        kind,
        delete_all: false,
        pose,
        scale,
        color,
        text: String::new(),
    }
}

const WHITE: Color = Color {
    r: 1.0,
    g: 1.0,
    b: 1.0,
    a: 1.0,
};

/// A colour for a colour file's class name (CMVision's names are free text): the common
/// colour words, grey otherwise.
fn colour_of(name: &str) -> Color {
    let name = name.to_ascii_lowercase();
    let table: [(&str, [f32; 3]); 8] = [
        ("red", [0.9, 0.1, 0.1]),
        ("orange", [1.0, 0.55, 0.0]),
        ("yellow", [0.95, 0.9, 0.1]),
        ("green", [0.1, 0.8, 0.2]),
        ("blue", [0.1, 0.3, 0.95]),
        ("pink", [1.0, 0.4, 0.7]),
        ("purple", [0.6, 0.2, 0.8]),
        ("white", [1.0, 1.0, 1.0]),
    ];
    let [r, g, b] = table
        .iter()
        .find(|(word, _)| name.contains(word))
        .map_or([0.6, 0.6, 0.6], |(_, rgb)| *rgb);
    Color { r, g, b, a: 0.8 }
}

/// Labelled boxes, each a thin box facing the robot at `(x, y, z)` of `(width, height)`
/// in its colour with its label above it, as a MarkerArray replacing the topic's last one.
fn labelled_boxes(
    topic: &str,
    stamp: i64,
    ns: &str,
    boxes: impl Iterator<Item = ([f64; 3], [f64; 2], Color, String)>,
) -> Companion {
    let mut markers = vec![clear(stamp)];
    for (i, ([x, y, z], [width, height], color, label)) in boxes.enumerate() {
        let size = [0.02, width.max(0.01), height.max(0.01)];
        let centre = Pose::planar(x, y, z, 0.0);
        markers.push(marker(
            stamp,
            ns,
            2 * i,
            MarkerKind::Cube,
            centre,
            size,
            color,
        ));
        let above = Pose::planar(x, y, z + height / 2.0 + 0.1, 0.0);
        let text = marker(
            stamp,
            ns,
            2 * i + 1,
            MarkerKind::Text,
            above,
            [0.0, 0.0, 0.12],
            WHITE,
        );
        markers.push(Marker {
            text: label,
            ..text
        });
    }
    companion(
        &sibling_topic(topic, "markers"),
        ros2::MARKER_ARRAY,
        Some(topic),
        &MarkerArray { markers },
    )
}

/// Each placed blob as a box of its size in its colour, its colour's name above.
pub(super) fn blobs(topic: &str, stamp: i64, blobs: &Blobs3D) -> Companion {
    let placed = blobs.blobs.iter().filter(|b| b.range_valid).map(|b| {
        let Blob { colour_name, .. } = &b.blob;
        let at = [b.position.x, b.position.y, b.position.z];
        (
            at,
            [b.width, b.height],
            colour_of(colour_name),
            colour_name.clone(),
        )
    });
    labelled_boxes(topic, stamp, "blobs", placed)
}

/// The size of a sign's board, in m.
const BOARD: [f64; 2] = [0.4, 0.3];

/// Each sign as a white board with what it says above it.
pub(super) fn signs(topic: &str, stamp: i64, signs: &Signs) -> Companion {
    let boards = signs.signs.iter().map(|s| {
        let at = [s.position.x, s.position.y, s.position.z];
        (
            at,
            BOARD,
            WHITE,
            format!("{} ({:.2})", s.arrow, s.confidence),
        )
    });
    labelled_boxes(topic, stamp, "signs", boards)
}

/// The broker's bindings as one text above the robot, a line each:
/// `client: Interface <- provider`.
pub(super) fn bindings(
    topic: &str,
    stamp_ns: i64,
    bindings: &BTreeMap<(String, String), String>,
) -> Companion {
    let text = bindings
        .iter()
        .map(|((client, interface), provider)| format!("{client}: {interface} <- {provider}"))
        .collect::<Vec<_>>()
        .join("\n");
    let pose = Pose::planar(0.0, 0.0, 2.0, 0.0);
    let markers = vec![
        clear(stamp_ns),
        Marker {
            text,
            ..marker(
                stamp_ns,
                "bindings",
                0,
                MarkerKind::Text,
                pose,
                [0.0, 0.0, 0.1],
                WHITE,
            )
        },
    ];
    companion(
        &format!("{topic}/markers"),
        ros2::MARKER_ARRAY,
        Some(topic),
        &MarkerArray { markers },
    )
}
