//! What perception found and what the broker decided, drawn as a
//! `visualization_msgs/msg/MarkerArray` in [`BASE_FRAME`]: each array begins with a marker
//! that removes the topic's earlier ones, so each message replaces the last.

use std::collections::BTreeMap;

use lewis_interfaces::msg::{Blob, Blobs3D, Signs};
use lewis_interfaces::ros2::{Color, Marker, MarkerArray, MarkerKind, Pose};

use super::{BASE_FRAME, header};

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
/// in its colour with its label above it, after a marker that clears the topic's last ones.
fn labelled_boxes(
    stamp: i64,
    ns: &str,
    boxes: impl Iterator<Item = ([f64; 3], [f64; 2], Color, String)>,
) -> MarkerArray {
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
    MarkerArray { markers }
}

/// Each placed blob (its range valid) as a box of its size in its colour, its colour's name
/// above, stamped `stamp_ns`.
#[must_use]
pub fn blob_markers(blobs: &Blobs3D, stamp_ns: i64) -> MarkerArray {
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
    labelled_boxes(stamp_ns, "blobs", placed)
}

/// The size of a sign's board, in m.
const BOARD: [f64; 2] = [0.4, 0.3];

/// Each sign as a white board with what it says (and the confidence) above it, stamped
/// `stamp_ns`.
#[must_use]
pub fn sign_markers(signs: &Signs, stamp_ns: i64) -> MarkerArray {
    let boards = signs.signs.iter().map(|s| {
        let at = [s.position.x, s.position.y, s.position.z];
        (
            at,
            BOARD,
            WHITE,
            format!("{} ({:.2})", s.arrow, s.confidence),
        )
    });
    labelled_boxes(stamp_ns, "signs", boards)
}

/// The broker's bindings, `(client, interface)` to provider, as one text above the robot,
/// a line each: `client: Interface <- provider`; stamped `stamp_ns`.
#[must_use]
pub fn binding_markers(
    bindings: &BTreeMap<(String, String), String>,
    stamp_ns: i64,
) -> MarkerArray {
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
    MarkerArray { markers }
}
