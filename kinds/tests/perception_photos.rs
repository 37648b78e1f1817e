//! The camera service over real photos, and the blob finder service over what it
//! publishes, both driven through the `Service` trait.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use lewis_interfaces::msg::{
    Blobs, BlobsSetMinArea, ImageSource, ImageSourceSetRate, ImageSourceSetRateReply, InputRef,
};
use lewis_service::Health;
use lewis_testkit::{Harness, repository_path as repository, shared_data};
use support::{build, robot};

const MS: i64 = 1_000_000;

/// A temporary folder holding copies of shared photos, under the names given.
fn photo_folder(photos: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::Builder::new()
        .prefix("lewis-camera-")
        .tempdir()
        .unwrap();
    for (name, photo) in photos {
        std::fs::copy(shared_data(photo), dir.path().join(name)).unwrap();
    }
    dir
}

fn camera(parameters: &str) -> Harness {
    let mut camera = build(
        &robot("camera", &[], &["ImageSource"], parameters),
        "under-test",
    )
    .expect("camera builds");
    camera.start(0).unwrap();
    camera
}

#[test]
fn the_camera_plays_a_folder_in_name_order_at_its_rate_and_loops() {
    let dir = photo_folder(&[
        ("b.png", "images/smarties.png"),
        ("a.jpg", "images/apple.jpg"),
    ]);
    let mut camera = camera(&format!(
        "images = {:?}\nrate_hz = 10.0\nmax_rate_hz = 20.0",
        dir.path()
    ));
    // Ticks at the highest rate (every 50 ms): a frame every other tick at 10 Hz.
    let mut sizes = Vec::new();
    for tick in 0..8 {
        camera.tick(tick * 50 * MS);
        sizes.push(
            camera
                .take::<ImageSource>()
                .iter()
                .map(|i| (i.width, i.height))
                .collect::<Vec<_>>(),
        );
    }
    let apple = image::image_dimensions(shared_data("images/apple.jpg")).unwrap();
    let smarties = image::image_dimensions(shared_data("images/smarties.png")).unwrap();
    let size = |(w, h): (u32, u32)| vec![(w as i32, h as i32)];
    assert_eq!(
        sizes,
        [
            size(apple),
            vec![],
            size(smarties),
            vec![],
            size(apple),
            vec![],
            size(smarties),
            vec![]
        ]
    );
    // Faster: every tick; beyond the highest rate, clamped to it.
    let reply: ImageSourceSetRateReply = camera
        .command(
            7 * 50 * MS,
            &ImageSourceSetRate {
                rate: 50.0,
                ..Default::default()
            },
        )
        .unwrap();
    assert_eq!(reply.rate, 20.0);
    let mut count = 0;
    for tick in 8..12 {
        camera.tick(tick * 50 * MS);
        count += camera.take::<ImageSource>().len();
    }
    assert_eq!(count, 4);
    let refused = camera.command(
        11 * 50 * MS,
        &ImageSourceSetRate {
            rate: -1.0,
            ..Default::default()
        },
    );
    assert!(refused.unwrap_err().0.contains("positive"));
}

#[test]
fn frames_carry_rgb_pixels_and_the_intrinsics_of_the_field_of_view() {
    let dir = photo_folder(&[("s.png", "images/smarties.png")]);
    let mut camera = camera(&format!(
        "images = \"{}/*.png\"\nhorizontal_fov_deg = 90.0",
        dir.path().display()
    ));
    camera.tick(0);
    let frames = camera.take::<ImageSource>();
    let frame = &frames[0];
    let photo = image::open(shared_data("images/smarties.png"))
        .unwrap()
        .to_rgb8();
    assert_eq!(frame.encoding, "rgb8");
    assert_eq!(frame.step, frame.width * 3);
    assert_eq!(frame.data, photo.as_raw().as_slice());
    // 90 degrees wide: the focal length is half the width.
    assert!((frame.focal_length_x - f64::from(frame.width) / 2.0).abs() < 1e-9);
    assert_eq!(frame.header.seq, 1);
}

#[test]
fn a_sequence_that_does_not_loop_goes_out_of_service_at_its_end() {
    let dir = photo_folder(&[
        ("a.jpg", "images/apple.jpg"),
        ("b.jpg", "images/orange.jpg"),
    ]);
    let mut camera = camera(&format!(
        "images = {:?}\nloop = false\nrate_hz = 1.0",
        dir.path()
    ));
    for second in 0..3 {
        camera.tick(second * 1000 * MS);
    }
    assert_eq!(camera.take::<ImageSource>().len(), 2);
    assert_eq!(
        camera.backend.health,
        [Health::OutOfService(
            "the image sequence ended after its 2 images (loop = false)".into()
        )]
    );
}

#[test]
fn a_camera_without_its_source_says_why_it_is_out_of_service() {
    fn check(parameters: &str, expected: &str) {
        let mut camera = camera(parameters);
        camera.tick(0);
        assert!(camera.take::<ImageSource>().is_empty());
        match camera.backend.health.as_slice() {
            [Health::OutOfService(why)] => assert!(why.contains(expected), "{why}"),
            other => panic!("{parameters}: {other:?}"),
        }
    }
    if cfg!(feature = "v4l2") {
        check(
            "device = \"/dev/lewis-no-such-video\"",
            "cannot open video device /dev/lewis-no-such-video: No such file or directory",
        );
        // A file that exists but is no camera: the kernel refuses the first ioctl.
        check(
            "device = \"/dev/null\"",
            "video device /dev/null: VIDIOC_QUERYCAP failed: ENOTTY",
        );
        check("device = \"/dev/null\"", ": it is not a V4L2 device");
    } else {
        check(
            "device = \"/dev/lewis-no-such-video\"",
            "no video device at /dev/lewis-no-such-video",
        );
        check("device = \"/dev/null\"", "built without V4L2");
    }
    let empty = tempfile::tempdir().unwrap();
    check(
        &format!("images = {:?}", empty.path()),
        "no PNG or JPEG image",
    );
    check(
        "images = \"/nonexistent/lewis/*.png\"",
        "no PNG or JPEG image",
    );
    check("images = \"[\"", "not a valid glob");
}

#[test]
fn camera_parameters_that_cannot_work_are_refused() {
    for (parameters, expected) in [
        ("rate_hz = 5.0", "exactly one of `images`"),
        (
            "images = \"x\"\ndevice = \"/dev/video0\"",
            "exactly one of `images`",
        ),
        ("images = \"x\"\nrate_hz = 0.0", "rate_hz"),
        (
            "images = \"x\"\nrate_hz = 10.0\nmax_rate_hz = 5.0",
            "rate_hz",
        ),
        ("images = \"x\"\nframes = 3", "unknown field"),
    ] {
        let got = build(
            &robot("camera", &[], &["ImageSource"], parameters),
            "under-test",
        );
        let err = got.err().unwrap_or_default();
        assert!(err.contains(expected), "{parameters}: {err}");
    }
}

/// (colour, centre x, centre y) of each candy of smarties.png, located by eye (the same
/// list as the CMVision test's).
const CANDIES: &[(&str, f64, f64)] = &[
    ("Red", 33.0, 228.0),
    ("Red", 98.0, 259.0),
    ("Red", 288.0, 213.0),
    ("Red", 219.0, 305.0),
    ("Orange", 205.0, 211.0),
    ("Orange", 134.0, 327.0),
    ("Green", 268.0, 117.0),
    ("Green", 386.0, 170.0),
    ("Green", 14.0, 344.0),
    ("Blue", 377.0, 80.0),
    ("Blue", 347.0, 237.0),
    ("Blue", 294.0, 320.0),
];

fn blobfinder(parameters: &str) -> Harness {
    let mut finder = build(
        &robot("blobfinder", &["ImageSource"], &["Blobs"], parameters),
        "under-test",
    )
    .expect("blobfinder builds");
    finder.start(0).unwrap();
    finder
}

#[test]
fn the_blob_finder_finds_every_candy_of_the_camera_frames() {
    let dir = photo_folder(&[("s.png", "images/smarties.png")]);
    let mut camera = camera(&format!("images = {:?}", dir.path()));
    let colors = repository("robots/colors/smarties.txt");
    // The file's own minimum area (700 px, its [Options]) keeps the specks out.
    let mut finder = blobfinder(&format!("colors = {colors:?}"));
    camera.tick(0);
    let frame = camera.take::<ImageSource>().remove(0);
    finder.send(0, "camera", &frame);
    let blobs = finder.take::<Blobs>();
    let blobs = &blobs[0];
    assert_eq!(
        (blobs.image_width, blobs.image_height),
        (frame.width, frame.height)
    );
    assert_eq!(blobs.blob_count as usize, blobs.blobs.len());
    assert_eq!(blobs.blobs.len(), CANDIES.len(), "{:#?}", blobs.blobs);
    for &(colour, x, y) in CANDIES {
        let found = blobs.blobs.iter().any(|b| {
            b.colour_name == colour
                && (b.centroid_x - x).hypot(b.centroid_y - y) < 6.0
                && (f64::from(b.left)..=f64::from(b.right)).contains(&x)
                && (f64::from(b.top)..=f64::from(b.bottom)).contains(&y)
        });
        assert!(found, "no {colour} blob at ({x}, {y}): {:#?}", blobs.blobs);
    }
    // Blobs come by colour, largest first, with the class's drawing colour.
    let red: Vec<_> = blobs
        .blobs
        .iter()
        .filter(|b| b.colour_name == "Red")
        .collect();
    assert!(red.windows(2).all(|w| w[0].area >= w[1].area));
    assert_eq!(red[0].colour_rgb, 0xFF0000);
    // The blobs name the frame they were found in, as the live harness hands it over (the
    // old harness gave no provenance, and this compared two empty lists).
    assert_eq!(
        blobs.header.inputs,
        [InputRef {
            channel: "/camera/ImageSource".into(),
            seq: frame.header.seq,
        }]
    );

    // A lower minimum area lets the specks through: more blobs.
    finder
        .command(
            0,
            &BlobsSetMinArea {
                min_area: 5,
                ..Default::default()
            },
        )
        .unwrap();
    finder.send(0, "camera", &frame);
    assert!(finder.take::<Blobs>()[0].blobs.len() > CANDIES.len());
    let refused = finder.command(
        0,
        &BlobsSetMinArea {
            min_area: -1,
            ..Default::default()
        },
    );
    assert!(refused.unwrap_err().0.contains("negative"));
}

#[test]
fn an_image_that_cannot_be_read_degrades_the_blob_finder_and_publishes_nothing() {
    let colors = repository("robots/colors/smarties.txt");
    let mut finder = blobfinder(&format!("colors = {colors:?}"));
    let broken = ImageSource {
        width: 4,
        height: 4,
        encoding: "yuv422".into(),
        step: 8,
        data: vec![0; 32],
        ..ImageSource::default()
    };
    finder.send(0, "camera", &broken);
    assert!(finder.take::<Blobs>().is_empty());
    match finder.backend.health.as_slice() {
        [Health::Degraded(why)] => assert!(why.contains("yuv422"), "{why}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_blob_finder_with_a_broken_colour_file_is_refused_with_the_place() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.txt");
    std::fs::write(
        &path,
        "[Colors]\n(255,0,0) 0.0 Red\n[Thresholds]\n(1:2,3:4)\n",
    )
    .unwrap();
    let got = build(
        &robot(
            "blobfinder",
            &["ImageSource"],
            &["Blobs"],
            &format!("colors = {path:?}"),
        ),
        "under-test",
    );
    let err = got.err().unwrap_or_default();
    assert!(err.contains("bad.txt:4:"), "{err}");
    let missing = build(
        &robot(
            "blobfinder",
            &["ImageSource"],
            &["Blobs"],
            "colors = \"/nonexistent.txt\"",
        ),
        "under-test",
    );
    assert!(
        missing
            .err()
            .unwrap_or_default()
            .contains("/nonexistent.txt")
    );
}
