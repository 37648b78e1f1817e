//! CMVision against a naive flood fill, on the smarties photo, on odd inputs and on the
//! colour files of the Player project.
#![allow(
    clippy::expect_used,
    reason = "test helpers fail loudly on broken fixtures"
)]

use std::path::{Path, PathBuf};

use lewis_perception::cmvision::{
    ChannelRange, CmVision, ColorClass, ColorConfig, ColorFileError, FrameError, MAX_SIDE_PX,
    Region, RgbFrame, rgb_to_yuv,
};
use lewis_testkit::shared_data;
use proptest::prelude::*;

fn robots_file(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../robots")
        .join(relative)
}

fn class(y: (u8, u8), u: (u8, u8), v: (u8, u8), merge_density: f64) -> ColorClass {
    ColorClass {
        name: String::new(),
        display_rgb: [0; 3],
        merge_density,
        expected_regions: 0,
        y: ChannelRange { lo: y.0, hi: y.1 },
        u: ChannelRange { lo: u.0, hi: u.1 },
        v: ChannelRange { lo: v.0, hi: v.1 },
    }
}

// ---------------------------------------------------------------------------------------
// The reference: classify each pixel straight from the ranges, flood fill 4-connected
// pixels of equal colour, then filter and sort as CMVision documents.

#[derive(Debug)]
struct Image {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
}

fn flood_fill_regions(image: &Image, config: &ColorConfig) -> Vec<Region> {
    let (w, h) = (image.width as usize, image.height as usize);
    let color: Vec<Option<u8>> = image
        .rgb
        .chunks_exact(3)
        .map(|p| {
            let mask = config.class_mask_yuv(rgb_to_yuv(p[0], p[1], p[2]));
            (mask != 0).then(|| mask.trailing_zeros() as u8)
        })
        .collect();
    let mut seen = vec![false; w * h];
    // (region, order of its first pixel, sums): the order is the raster index of that pixel.
    let mut found: Vec<(Region, usize)> = Vec::new();
    for start in 0..w * h {
        let Some(c) = color[start] else { continue };
        if seen[start] {
            continue;
        }
        seen[start] = true;
        let mut stack = vec![start];
        let (mut area, mut sum_x, mut sum_y) = (0u32, 0u64, 0u64);
        let (mut left, mut top, mut right, mut bottom) = (u32::MAX, u32::MAX, 0, 0);
        while let Some(i) = stack.pop() {
            let (x, y) = (i % w, i / w);
            area += 1;
            sum_x += x as u64;
            sum_y += y as u64;
            (left, right) = (left.min(x as u32), right.max(x as u32));
            (top, bottom) = (top.min(y as u32), bottom.max(y as u32));
            let mut visit = |j: usize| {
                if !seen[j] && color[j] == Some(c) {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - w);
            }
            if y + 1 < h {
                visit(i + w);
            }
        }
        let region = Region {
            color: c,
            area_px: area,
            left_px: left,
            top_px: top,
            right_px: right,
            bottom_px: bottom,
            centroid_x_px: sum_x as f64 / f64::from(area),
            centroid_y_px: sum_y as f64 / f64::from(area),
        };
        found.push((region, start));
    }
    found.retain(|(r, _)| r.area_px >= config.min_area_px);
    found.sort_by_key(|(r, order)| (r.color, std::cmp::Reverse(r.area_px), *order));
    found.into_iter().map(|(r, _)| r).collect()
}

fn cmvision_regions(image: &Image, config: &ColorConfig) -> Vec<Region> {
    let mut cmv = CmVision::new(config).expect("at most 32 colours");
    let frame = RgbFrame::new(image.width, image.height, &image.rgb).expect("valid frame");
    cmv.process(frame).to_vec()
}

/// Images of a few palette colours with per-pixel jitter (so that pixels straddle the
/// boundaries of the colour boxes), and classes centred on palette colours or anywhere.
fn image_and_config() -> impl Strategy<Value = (Image, ColorConfig)> {
    let palette = prop::collection::vec(any::<[u8; 3]>(), 1..6);
    (1u32..24, 1u32..24, palette, 0u8..24, 1u32..5).prop_flat_map(
        |(width, height, palette, jitter, min_area_px)| {
            let n = (width * height) as usize;
            let pixels = prop::collection::vec((0..palette.len(), any::<[u8; 3]>()), n);
            let classes = prop::collection::vec(
                (0..palette.len() + 2, any::<[u8; 3]>(), any::<[u8; 3]>()),
                1..6,
            );
            (pixels, classes).prop_map(move |(pixels, classes)| {
                let mut rgb = Vec::with_capacity(n * 3);
                for (index, noise) in pixels {
                    for k in 0..3 {
                        let offset = if jitter == 0 {
                            0
                        } else {
                            noise[k] % (jitter + 1)
                        };
                        rgb.push(palette[index][k].saturating_add(offset));
                    }
                }
                let colors = classes
                    .into_iter()
                    .map(|(centre, a, b)| {
                        // Centred on a palette colour (hits) or anywhere (mostly misses).
                        let yuv = palette
                            .get(centre)
                            .map_or(a, |p| rgb_to_yuv(p[0], p[1], p[2]));
                        let range = |k: usize| {
                            let (below, above) = (a[k] % 40, b[k] % 40);
                            (yuv[k].saturating_sub(below), yuv[k].saturating_add(above))
                        };
                        class(range(0), range(1), range(2), 0.0)
                    })
                    .collect();
                (
                    Image { width, height, rgb },
                    ColorConfig {
                        colors,
                        min_area_px,
                    },
                )
            })
        },
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn regions_equal_those_of_a_naive_flood_fill((image, config) in image_and_config()) {
        prop_assert_eq!(cmvision_regions(&image, &config), flood_fill_regions(&image, &config));
    }
}

#[test]
fn processing_reuses_buffers_and_gives_the_same_regions_every_time() {
    let config = ColorConfig {
        colors: vec![
            class((0, 255), (0, 127), (0, 255), 0.0),
            class((0, 255), (128, 255), (0, 255), 0.0),
        ],
        min_area_px: 1,
    };
    let mut cmv = CmVision::new(&config).expect("two colours");
    let big = Image {
        width: 64,
        height: 48,
        rgb: (0..64 * 48 * 3).map(|i| (i * 7 % 256) as u8).collect(),
    };
    let small = Image {
        width: 3,
        height: 2,
        rgb: vec![
            0, 0, 255, 255, 255, 0, 0, 0, 255, 9, 9, 9, 0, 0, 255, 0, 0, 255,
        ],
    };
    for image in [&big, &small, &big, &small] {
        let frame = RgbFrame::new(image.width, image.height, &image.rgb).expect("valid frame");
        let got = cmv.process(frame).to_vec();
        assert_eq!(got, flood_fill_regions(image, &config));
        for c in 0..2u8 {
            let of_color: Vec<Region> = got.iter().copied().filter(|r| r.color == c).collect();
            assert_eq!(cmv.regions_of_color(c), of_color.as_slice());
        }
        assert!(cmv.regions_of_color(7).is_empty());
    }
}

// ---------------------------------------------------------------------------------------
// Density merging.

/// Paints `rect` (left, top, right, bottom inclusive) of a white image blue.
fn paint(image: &mut Image, (left, top, right, bottom): (u32, u32, u32, u32)) {
    for y in top..=bottom {
        for x in left..=right {
            let i = ((y * image.width + x) * 3) as usize;
            image.rgb[i..i + 3].copy_from_slice(&[0, 0, 255]);
        }
    }
}

#[test]
fn two_halves_of_a_blob_split_by_a_line_merge_when_dense_enough() {
    let mut image = Image {
        width: 40,
        height: 30,
        rgb: vec![255; 40 * 30 * 3],
    };
    paint(&mut image, (5, 5, 14, 9));
    paint(&mut image, (5, 11, 14, 15));
    paint(&mut image, (30, 20, 35, 25));
    let blue = |merge_density| ColorConfig {
        colors: vec![class((0, 255), (200, 255), (0, 255), merge_density)],
        min_area_px: 1,
    };
    let summary = |regions: Vec<Region>| -> Vec<(u32, u32, u32, u32, u32)> {
        regions
            .iter()
            .map(|r| (r.area_px, r.left_px, r.top_px, r.right_px, r.bottom_px))
            .collect()
    };
    assert_eq!(
        summary(cmvision_regions(&image, &blue(0.0))),
        [(50, 5, 5, 14, 9), (50, 5, 11, 14, 15), (36, 30, 20, 35, 25)]
    );
    // 100 pixels in a 10x11 union box: density 0.91.
    assert_eq!(
        summary(cmvision_regions(&image, &blue(0.9))),
        [(100, 5, 5, 14, 15), (36, 30, 20, 35, 25)]
    );
    assert_eq!(summary(cmvision_regions(&image, &blue(0.95))).len(), 3);
    let merged = cmvision_regions(&image, &blue(0.9))[0];
    assert!(
        (merged.centroid_y_px - 10.0).abs() < 1e-9 && (merged.centroid_x_px - 9.5).abs() < 1e-9
    );
}

// ---------------------------------------------------------------------------------------
// The smarties photo, with the colour file written by hand for it.

/// A candy located by eye in smarties.png: colour name and centre.
struct Candy(&'static str, f64, f64);

/// The candies of smarties.png, located by looking at the photo (brown ones are not in the
/// colour file). The green one in the bottom-left corner is cut by the image border.
const CANDIES: &[Candy] = &[
    Candy("Red", 33.0, 228.0),
    Candy("Red", 98.0, 259.0),
    Candy("Red", 288.0, 213.0),
    Candy("Red", 219.0, 305.0),
    Candy("Orange", 205.0, 211.0),
    Candy("Orange", 134.0, 327.0),
    Candy("Green", 268.0, 117.0),
    Candy("Green", 386.0, 170.0),
    Candy("Green", 14.0, 344.0),
    Candy("Blue", 377.0, 80.0),
    Candy("Blue", 347.0, 237.0),
    Candy("Blue", 294.0, 320.0),
];

/// Candies have a radius of about 26 px; the smallest whole candy found has 1800 px and the
/// one cut by the border 770 px.
const CANDY_MIN_AREA_PX: u32 = 700;

#[test]
fn smarties_photo_gives_one_blob_per_candy_at_the_places_seen_in_the_photo() {
    let photo = image::open(shared_data("images/smarties.png"))
        .expect("smarties.png decodes")
        .to_rgb8();
    let config = ColorConfig::load(&robots_file("colors/smarties.txt")).expect("colour file loads");
    let names: Vec<&str> = config.colors.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["Red", "Orange", "Green", "Blue"]);
    assert_eq!(
        config.min_area_px, CANDY_MIN_AREA_PX,
        "the file's [Options] keep the specks out"
    );
    let mut cmv = CmVision::new(&config).expect("four colours");
    let (width, height) = photo.dimensions();
    let regions = cmv
        .process(RgbFrame::new(width, height, photo.as_raw()).expect("valid frame"))
        .to_vec();

    let out_dir = tempfile::Builder::new()
        .prefix("lewis-cmvision-smarties-")
        .tempdir()
        .expect("temp dir")
        .keep();
    let boxes_png = out_dir.join("boxes.png");
    draw_boxes(photo.clone(), &regions)
        .save(&boxes_png)
        .expect("boxes PNG written");
    println!("boxes drawn into {}", boxes_png.display());

    for (c, class) in config.colors.iter().enumerate() {
        let expected: Vec<&Candy> = CANDIES
            .iter()
            .filter(|candy| candy.0 == class.name)
            .collect();
        let found = cmv.regions_of_color(c as u8);
        assert_eq!(
            found.len(),
            expected.len(),
            "{} blobs: {found:?}",
            class.name
        );
        for candy in expected {
            let near = found.iter().find(|r| {
                let distance = (r.centroid_x_px - candy.1).hypot(r.centroid_y_px - candy.2);
                distance < 6.0
                    && (f64::from(r.left_px)..=f64::from(r.right_px)).contains(&candy.1)
                    && (f64::from(r.top_px)..=f64::from(r.bottom_px)).contains(&candy.2)
            });
            assert!(
                near.is_some(),
                "no {} blob near ({}, {}): {found:?}",
                class.name,
                candy.1,
                candy.2
            );
        }
    }

    // The orange candies' shaded undersides and rims are saturated red in the photo (U 92,
    // V 230, like the red candies): without the minimum area they show as small red blobs,
    // at the orange candies.
    cmv.set_min_area_px(100);
    let all = cmv
        .process(RgbFrame::new(width, height, photo.as_raw()).expect("valid frame"))
        .to_vec();
    let oranges: Vec<Region> = all.iter().copied().filter(|r| r.color == 1).collect();
    let small_reds: Vec<&Region> = all
        .iter()
        .filter(|r| r.color == 0 && r.area_px < CANDY_MIN_AREA_PX)
        .collect();
    assert_eq!(small_reds.len(), 3, "{small_reds:?}");
    for red in small_reds {
        let inside = oranges.iter().any(|o| {
            o.left_px <= red.centroid_x_px as u32
                && red.centroid_x_px as u32 <= o.right_px
                && o.top_px <= red.bottom_px
                && red.top_px <= o.bottom_px + 5
        });
        assert!(inside, "red blob {red:?} is not at an orange candy");
    }
}

fn draw_boxes(mut image: image::RgbImage, regions: &[Region]) -> image::RgbImage {
    let black = image::Rgb([0, 0, 0]);
    for r in regions {
        for x in r.left_px..=r.right_px {
            image.put_pixel(x, r.top_px, black);
            image.put_pixel(x, r.bottom_px, black);
        }
        for y in r.top_px..=r.bottom_px {
            image.put_pixel(r.left_px, y, black);
            image.put_pixel(r.right_px, y, black);
        }
    }
    image
}

// ---------------------------------------------------------------------------------------
// Odd inputs.

#[test]
fn frames_of_impossible_sizes_are_refused_with_the_reason() {
    let check = |width, height, len: usize, expected: FrameError| {
        let data = vec![0u8; len];
        assert_eq!(RgbFrame::new(width, height, &data).err(), Some(expected));
    };
    check(
        0,
        480,
        0,
        FrameError::Empty {
            width_px: 0,
            height_px: 480,
        },
    );
    check(
        640,
        0,
        0,
        FrameError::Empty {
            width_px: 640,
            height_px: 0,
        },
    );
    check(
        u32::MAX,
        1,
        3,
        FrameError::TooLarge {
            width_px: u32::MAX,
            height_px: 1,
        },
    );
    // A size that the buffer does not back is refused before anything is allocated.
    check(
        MAX_SIDE_PX,
        MAX_SIDE_PX,
        12,
        FrameError::WrongLength {
            width_px: MAX_SIDE_PX,
            height_px: MAX_SIDE_PX,
            expected_len: MAX_SIDE_PX as usize * MAX_SIDE_PX as usize * 3,
            actual_len: 12,
        },
    );
    check(
        2,
        2,
        11,
        FrameError::WrongLength {
            width_px: 2,
            height_px: 2,
            expected_len: 12,
            actual_len: 11,
        },
    );
    check(
        2,
        2,
        13,
        FrameError::WrongLength {
            width_px: 2,
            height_px: 2,
            expected_len: 12,
            actual_len: 13,
        },
    );
    let message = RgbFrame::new(4, 3, &[0; 5]).err().map(|e| e.to_string());
    assert_eq!(
        message.as_deref(),
        Some("frame 4x3 RGB8 needs 36 bytes but the buffer has 5")
    );
}

#[test]
fn single_pixels_lines_and_columns_are_segmented() {
    let config = ColorConfig {
        colors: vec![class((0, 255), (200, 255), (0, 255), 0.0)],
        min_area_px: 1,
    };
    let blue = [0u8, 0, 255];
    let white = [255u8, 255, 255];
    let check =
        |width: u32, height: u32, pixels: &[[u8; 3]], expected: &[(u32, u32, u32, u32, u32)]| {
            let image = Image {
                width,
                height,
                rgb: pixels.concat(),
            };
            let regions = cmvision_regions(&image, &config);
            let got: Vec<_> = regions
                .iter()
                .map(|r| (r.area_px, r.left_px, r.top_px, r.right_px, r.bottom_px))
                .collect();
            assert_eq!(got, expected, "{width}x{height}");
        };
    check(1, 1, &[blue], &[(1, 0, 0, 0, 0)]);
    check(1, 1, &[white], &[]);
    check(
        4,
        1,
        &[blue, white, blue, blue],
        &[(2, 2, 0, 3, 0), (1, 0, 0, 0, 0)],
    );
    check(
        1,
        4,
        &[blue, blue, white, blue],
        &[(2, 0, 0, 0, 1), (1, 0, 3, 0, 3)],
    );
    // Diagonal neighbours are not 4-connected.
    check(
        2,
        2,
        &[blue, white, white, blue],
        &[(1, 0, 0, 0, 0), (1, 1, 1, 1, 1)],
    );
}

#[test]
fn more_than_32_colours_are_refused() {
    let colors = vec![class((0, 255), (0, 255), (0, 255), 0.0); 33];
    let error = CmVision::new(&ColorConfig {
        colors,
        min_area_px: 1,
    })
    .err()
    .map(|e| e.to_string());
    assert_eq!(
        error.as_deref(),
        Some("33 colour classes: CMVision classifies at most 32 at once")
    );
}

/// Any failure of a colour file parser must be an `Invalid` with a place, never a panic.
fn assert_parse_is_clean(result: Result<ColorConfig, ColorFileError>, name: &str) {
    match result {
        Ok(config) => assert!(!config.colors.is_empty() && config.colors.len() <= 32),
        Err(ColorFileError::Invalid {
            source_name,
            line,
            column,
            ..
        }) => {
            assert_eq!(source_name, name);
            assert!(line >= 1 && column >= 1);
        }
        Err(other) => panic!("unexpected error kind {other}"),
    }
}

const PLAYER_SAMPLE: &str = "[Colors]\n(255,128,  0) 0.000000 10 Ball\n(  0,  0,255) 0.5 Blue\n\n[Thresholds]\n( 12:153, 99:127,143:168)\n( 64:157,144:164, 85:129)\n";
const TOML_SAMPLE: &str =
    "min_area_px = 4\n[[color]]\nname = \"Ball\"\ny = [12, 153]\nu = [99, 127]\nv = [143, 168]\n";

/// Replaces, inserts or deletes characters of `text` at the given positions.
fn mutate(text: &str, edits: &[(usize, u8, char)]) -> String {
    let mut chars: Vec<char> = text.chars().collect();
    for &(at, kind, c) in edits {
        let at = at % (chars.len() + 1);
        match kind % 3 {
            0 if at < chars.len() => chars[at] = c,
            1 => chars.insert(at, c),
            _ if at < chars.len() => {
                chars.remove(at);
            }
            _ => {}
        }
    }
    chars.into_iter().collect()
}

fn edit_char() -> impl Strategy<Value = char> {
    prop_oneof![
        prop::sample::select(vec![
            '(', ')', ',', ':', '[', ']', '#', '\n', ' ', '-', '9', '0', '.', '"', '=', 'x'
        ]),
        any::<char>(),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn arbitrary_text_never_panics_either_parser(text in ".{0,200}") {
        assert_parse_is_clean(ColorConfig::from_player_str(&text, "fuzz.txt"), "fuzz.txt");
        assert_parse_is_clean(ColorConfig::from_toml_str(&text, "fuzz.toml"), "fuzz.toml");
    }

    #[test]
    fn mutated_colour_files_never_panic(edits in prop::collection::vec((any::<usize>(), any::<u8>(), edit_char()), 1..8)) {
        let player = mutate(PLAYER_SAMPLE, &edits);
        assert_parse_is_clean(ColorConfig::from_player_str(&player, "m.txt"), "m.txt");
        let toml = mutate(TOML_SAMPLE, &edits);
        assert_parse_is_clean(ColorConfig::from_toml_str(&toml, "m.toml"), "m.toml");
    }
}

#[test]
fn a_missing_colour_file_names_the_path() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("nope.txt");
    let message = ColorConfig::load(&path)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        message.starts_with(&format!("cannot read colour file {}: ", path.display())),
        "{message}"
    );
}

#[test]
fn a_toml_file_is_chosen_by_its_extension() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("ball.toml");
    std::fs::write(&path, TOML_SAMPLE).expect("write");
    let config = ColorConfig::load(&path).expect("TOML loads");
    assert_eq!((config.colors.len(), config.min_area_px), (1, 4));
    let player =
        ColorConfig::from_player_str(PLAYER_SAMPLE, "p.txt").expect("Player sample parses");
    assert_eq!(
        (config.colors[0].y, config.colors[0].u, config.colors[0].v),
        (player.colors[0].y, player.colors[0].u, player.colors[0].v)
    );
}

// ---------------------------------------------------------------------------------------
// The Player project's own colour files.

#[test]
fn player_colour_files_parse() {
    let check = |file: &str, expected_names: &[&str]| {
        let config = ColorConfig::load(&shared_data(&format!("cmvision/{file}")))
            .unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<&str> = config.colors.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, expected_names, "{file}");
        assert!(CmVision::new(&config).is_ok());
        config
    };
    let first = check(
        "player_cmvision_colors.txt",
        &[
            "Ball",
            "Yellow_Team",
            "Blue_Team",
            "White",
            "Marker_1_(Pink)",
            "Marker_2_(Purple)",
        ],
    );
    assert_eq!(first.colors[0].display_rgb, [255, 128, 0]);
    assert_eq!(first.colors[0].y, ChannelRange { lo: 12, hi: 153 });
    // (85:190, 82:189, 141:269): the V high end is clamped to 255, as CMVision did.
    assert_eq!(first.colors[4].v, ChannelRange { lo: 141, hi: 255 });
    let second = check(
        "player_cmvision_colors2.txt",
        &[
            "Red", "Green", "Blue", "Black", "Pink", "White", "Yellow", "Orange", "Light",
        ],
    );
    assert_eq!(second.colors[0].expected_regions, 10);
    assert_eq!(second.colors[3].y, ChannelRange { lo: 0, hi: 32 });
}
