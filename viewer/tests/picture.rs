//! `lewis_viewer::write_png`: the picture of a mission, from recordings made with the
//! recorder and from the reference recording of a goal drive.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use lewis_testkit::repository_root;
use lewis_viewer::{MapStatus, write_png};

/// The picture's pixel at world `(x, y)` m: the conference map is 800 x 500 px at 0.05 m,
/// drawn twice as large.
fn pixel(picture: &image::RgbImage, x: f64, y: f64) -> [u8; 3] {
    let px = (x / 0.05 * 2.0).round() as u32;
    let py = 1000 - (y / 0.05 * 2.0).round() as u32;
    picture.get_pixel(px, py).0
}

#[test]
fn the_path_is_coloured_by_state_with_the_signs_and_the_laser_s_death() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::corridor_run(dir.path());
    let out = dir.path().join("run.png");
    let report = write_png(&run, &out).unwrap();
    assert_eq!(report.pose_source, Some("GroundTruth"));
    assert_eq!(report.poses, 231);
    assert!(
        matches!(&report.map, Some(MapStatus::Drawn { width_px: 800, .. })),
        "{report}"
    );
    let states: Vec<&str> = report.states.iter().map(|(s, _)| s.as_str()).collect();
    assert_eq!(states, ["door", "sign", "stop"], "{report}");
    assert_eq!(report.signs.len(), 2, "{report}");
    for ((word, at), expected) in report.signs.iter().zip(common::CORRIDOR_SIGNS) {
        assert!(
            (at[0] - expected[0]).hypot(at[1] - expected[1]) < 0.05,
            "{word} at {at:?}, not {expected:?}"
        );
    }
    assert_eq!(report.signs[0].0, "right");
    let [(service, Some(at))] = report.failures.as_slice() else {
        panic!("one failure with a place: {report}");
    };
    assert_eq!(service, "laser");
    assert!((at[0] - common::LASER_DIES_AT[0]).abs() < 0.11, "{at:?}");
    assert!(
        report
            .to_string()
            .contains("laser failed at (16.0, 12.5) m"),
        "{report}"
    );

    let picture = image::open(&out).unwrap().into_rgb8();
    assert_eq!(picture.dimensions(), (1600, 1000));
    let (door, sign) = (report.states[0].1, report.states[1].1);
    assert_ne!(door, sign);
    assert_eq!(pixel(&picture, 6.0, 12.5), door);
    assert_eq!(pixel(&picture, 24.0, 12.5), sign);
    // The cross is red; the sign's board white with a black border.
    let near_cross = [[0.0, 0.0], [0.1, 0.1], [-0.1, 0.1]]
        .iter()
        .map(|[dx, dy]| pixel(&picture, 16.0 + dx, 12.5 + dy))
        .collect::<Vec<_>>();
    assert!(near_cross.contains(&[198, 40, 40]), "{near_cross:?}");
    let [sx, sy] = report.signs[1].1;
    assert_eq!(pixel(&picture, sx + 0.1, sy + 0.1), [255, 255, 255]);
    keep(&out);
}

#[test]
fn the_reference_goal_drive_is_drawn_on_its_map() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("goal.png");
    let report = write_png(
        &repository_root().join("tests/data/reference/sim-goal.mcap"),
        &out,
    )
    .unwrap();
    assert_eq!(report.pose_source, Some("GroundTruth"), "{report}");
    assert!(report.poses > 100, "{report}");
    assert!(
        matches!(&report.map, Some(MapStatus::Drawn { .. })),
        "{report}"
    );
    assert!(
        report.states.is_empty(),
        "a goal drive has no mission: {report}"
    );
    assert!(out.is_file());
    keep(&out);
}

/// Copies the picture into the folder `LEWIS_KEEP_PICTURES` names, to look at it.
fn keep(picture: &std::path::Path) {
    if let Some(folder) = std::env::var_os("LEWIS_KEEP_PICTURES") {
        let name = picture.file_name().unwrap();
        std::fs::copy(picture, std::path::Path::new(&folder).join(name)).unwrap();
    }
}
