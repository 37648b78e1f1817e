//! The simulator's worlds: the shipped conference world (its map is generated here, and the
//! committed PNG must match the generator), and clear errors for bad worlds.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "test helpers fail loudly on broken fixtures"
)]

use std::path::{Path, PathBuf};

use lewis_geometry::Vec2;
use lewis_sim::world::{ObjectKind, ProblemKind};
use lewis_sim::{World, WorldError};

fn repository_path(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(relative)
}

/// A free rectangle of a generated map: (x0, y0, x1, y1) in m.
type Room = (f64, f64, f64, f64);

/// The conference centre's free space; everything else is wall. Walls between rooms are
/// the gaps between these rectangles.
const CONFERENCE_ROOMS: &[Room] = &[
    (0.5, 7.5, 7.9, 17.5),    // lobby, where the robot starts
    (7.9, 11.75, 8.1, 13.25), // entrance doorway (door "entrance")
    (8.1, 11.0, 30.0, 14.5),  // corridor, west to east
    (26.5, 14.5, 30.0, 17.2), // the corridor's turn north into the hall
    (12.0, 17.2, 39.5, 24.5), // hall: registration desk at its west end
    (19.5, 9.1, 22.0, 11.0),  // branch south from the corridor
    (19.5, 8.9, 22.0, 9.1),   // exhibit doorway (door "exhibit")
    (8.0, 0.5, 39.5, 8.9),    // exhibit hall
];
const CONFERENCE_SIZE_PX: (u32, u32) = (800, 500);
const CONFERENCE_METRES_PER_PIXEL: f64 = 0.05;

/// The map image of free rectangles: white where free, black where wall (row 0 at the top).
fn generate_map(rooms: &[Room], size_px: (u32, u32), metres_per_pixel: f64) -> image::GrayImage {
    let height_m = f64::from(size_px.1) * metres_per_pixel;
    image::GrayImage::from_fn(size_px.0, size_px.1, |px, py| {
        let x = (f64::from(px) + 0.5) * metres_per_pixel;
        let y = height_m - (f64::from(py) + 0.5) * metres_per_pixel;
        let free = rooms
            .iter()
            .any(|&(x0, y0, x1, y1)| x0 <= x && x < x1 && y0 <= y && y < y1);
        image::Luma([if free { 255 } else { 0 }])
    })
}

#[test]
fn the_committed_conference_map_is_what_its_generator_draws() {
    let generated = generate_map(
        CONFERENCE_ROOMS,
        CONFERENCE_SIZE_PX,
        CONFERENCE_METRES_PER_PIXEL,
    );
    let path = repository_path("robots/worlds/conference/map.png");
    if std::env::var_os("LEWIS_REGENERATE_WORLD_MAPS").is_some() {
        generated.save(&path).unwrap();
    }
    let committed = image::open(&path)
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e} (regenerate it: LEWIS_REGENERATE_WORLD_MAPS=1 cargo test -p lewis-sim --test it sim_world::)",
                path.display()
            )
        })
        .to_luma8();
    assert!(
        committed == generated,
        "{} differs from the rooms in this file: regenerate it with LEWIS_REGENERATE_WORLD_MAPS=1",
        path.display()
    );
}

#[test]
fn the_conference_world_loads_with_its_doors_signs_desk_queue_and_red_cap() {
    let world = World::load(&repository_path("robots/worlds/conference")).unwrap();
    assert_eq!(world.name(), "conference");
    assert_eq!(world.grid().width_cells(), 800);
    assert_eq!(world.door_is_open("entrance"), Some(true));
    assert_eq!(world.door_is_open("exhibit"), Some(false));
    let count = |kind: &str| {
        world
            .objects()
            .iter()
            .filter(|o| o.kind.name() == kind)
            .count()
    };
    assert_eq!(count("sign"), 5);
    assert_eq!(count("desk"), 1);
    assert!(count("person") >= 6);
    let capped: Vec<&str> = world
        .objects()
        .iter()
        .filter(|o| matches!(&o.kind, ObjectKind::Person(p) if p.cap.is_some()))
        .map(|o| o.name.as_str())
        .collect();
    assert_eq!(capped, ["red-cap"]);
    // The suggested start pose is free for a B21r, and the doorway is passable.
    assert!(!world.circle_collides(Vec2::new(3.0, 12.5), 0.26, 1.2));
    assert!(!world.circle_collides(Vec2::new(8.0, 12.5), 0.26, 1.2));
    // Every object stands in free space, not inside a wall of the map.
    for object in world.objects() {
        let centre = match &object.kind {
            ObjectKind::Person(p) => p.centre,
            ObjectKind::Sign(s) => s.centre,
            ObjectKind::Desk { shape, .. } | ObjectKind::Landmark { shape, .. } => {
                let (lo, hi) = shape.bounds();
                (lo + hi) * 0.5
            }
            ObjectKind::Wall { .. } | ObjectKind::Door { .. } => continue,
        };
        let (c, r) = world.grid().cell_of(centre);
        assert!(
            !world.grid().is_occupied(c, r),
            "{} is inside a wall",
            object.name
        );
    }
}

#[test]
fn doors_open_and_close_by_name() {
    let mut world = World::load(&repository_path("robots/worlds/conference")).unwrap();
    let doorway = Vec2::new(20.75, 9.0);
    assert!(world.circle_collides(doorway, 0.26, 1.2));
    world.set_door_open("exhibit", true).unwrap();
    assert!(!world.circle_collides(doorway, 0.26, 1.2));
    let err = world.set_door_open("kitchen", true).unwrap_err();
    assert_eq!(
        err.to_string(),
        "no door named `kitchen` in world `conference`: its doors are entrance, exhibit"
    );
}

/// A world folder with `text` as world.toml and, if given, a blank map of that many pixels.
fn world_dir(text: &str, map_px: Option<(u32, u32)>) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("world.toml"), text).unwrap();
    if let Some((w, h)) = map_px {
        image::GrayImage::from_pixel(w, h, image::Luma([255]))
            .save(dir.path().join("map.png"))
            .unwrap();
    }
    dir
}

/// Loads a world and checks its problems: (kind, "line:column: message" with the folder's
/// path written as `DIR`).
fn check(text: &str, map_px: Option<(u32, u32)>, expected: &[(ProblemKind, &str)]) {
    let dir = world_dir(text, map_px);
    let err = World::load(dir.path()).unwrap_err();
    let dir_text = dir.path().display().to_string();
    let got: Vec<(ProblemKind, String)> = err
        .problems()
        .iter()
        .map(|p| {
            let shown = p.to_string().replace(&dir_text, "DIR");
            (
                p.kind,
                shown.trim_start_matches("DIR/world.toml:").to_owned(),
            )
        })
        .collect();
    let expected: Vec<(ProblemKind, String)> = expected
        .iter()
        .map(|(k, m)| (*k, (*m).to_owned()))
        .collect();
    assert_eq!(got, expected, "\n{err}");
}

const HEADER: &str = "map = \"map.png\"\nmetres_per_pixel = 0.5\nsize_m = [10.0, 5.0]\n";

#[test]
fn a_missing_map_is_reported_where_the_file_names_it() {
    check(
        HEADER,
        None,
        &[(
            ProblemKind::MissingMap,
            "1:7: the map image DIR/map.png does not exist: draw it (a PNG, dark pixels are walls) or fix `map`",
        )],
    );
}

#[test]
fn a_map_whose_size_disagrees_with_the_file_is_reported_at_size_m() {
    check(
        HEADER,
        Some((20, 12)),
        &[(
            ProblemKind::MapSizeMismatch,
            "3:10: size_m says 10 x 5 m but the map image DIR/map.png is 20 x 12 px, which is 10 x 6 m at 0.5 m/px: fix size_m, metres_per_pixel or the image",
        )],
    );
}

#[test]
fn a_map_that_is_not_an_image_is_reported() {
    let dir = world_dir(HEADER, None);
    std::fs::write(dir.path().join("map.png"), b"not a png").unwrap();
    let err = World::load(dir.path()).unwrap_err();
    assert_eq!(err.problems()[0].kind, ProblemKind::BadMap);
    assert!(
        err.to_string().contains("1:7: cannot decode the map image"),
        "{err}"
    );
}

#[test]
fn objects_outside_the_map_are_reported_with_their_extent() {
    let text = format!(
        "{HEADER}\n[[objects]]\nkind = \"person\"\nname = \"visitor\"\ncentre = [9.9, 2.0]\nshirt_colour = \"red\"\n\n[[objects]]\nkind = \"wall\"\nfrom = [1.0, 1.0]\nto = [1.0, 7.0]\n"
    );
    check(
        &text,
        Some((20, 10)),
        &[
            (
                ProblemKind::OutsideMap,
                "8:10: person `visitor` reaches (9.68, 1.78)..(10.12, 2.22) m, outside the map (0.00, 0.00)..(10.00, 5.00) m: move it inside or enlarge the map",
            ),
            (
                ProblemKind::OutsideMap,
                "13:8: wall `wall-2` reaches (0.95, 1.00)..(1.05, 7.00) m, outside the map (0.00, 0.00)..(10.00, 5.00) m: move it inside or enlarge the map",
            ),
        ],
    );
}

#[test]
fn unknown_object_kinds_are_reported_with_the_known_ones() {
    let text = format!("{HEADER}\n[[objects]]\nkind = \"statue\"\ncentre = [1.0, 1.0]\n");
    check(
        &text,
        Some((20, 10)),
        &[(
            ProblemKind::UnknownKind,
            "6:8: unknown object kind `statue`: the simulator knows wall, door, landmark, sign, desk, person",
        )],
    );
}

#[test]
fn bad_colours_are_reported_where_they_are_written() {
    let text = format!(
        "{HEADER}floor_colour = \"#12345\"\n\n[[objects]]\nkind = \"landmark\"\nshape = \"pillar\"\ncentre = [1.0, 1.0]\nradius_m = 0.2\ncolour = \"reddish\"\n"
    );
    let names =
        "black, blue, brown, cyan, green, grey, magenta, orange, pink, purple, red, white, yellow";
    check(
        &text,
        Some((20, 10)),
        &[
            (
                ProblemKind::BadColour,
                &format!(
                    "4:16: bad colour `#12345`: write \"#rrggbb\" (hexadecimal) or one of {names}"
                ),
            ),
            (
                ProblemKind::BadColour,
                &format!(
                    "11:10: bad colour `reddish`: write \"#rrggbb\" (hexadecimal) or one of {names}"
                ),
            ),
        ],
    );
}

#[test]
fn fields_that_do_not_apply_and_missing_fields_are_reported() {
    let text = format!(
        "{HEADER}\n[[objects]]\nkind = \"sign\"\ncentre = [1.0, 1.0]\nfacing_deg = 90.0\nradius_m = 0.3\narrow = \"up\"\n\n[[objects]]\nkind = \"desk\"\ncentre = [5.0, 2.0]\n"
    );
    check(
        &text,
        Some((20, 10)),
        &[
            (
                ProblemKind::BadValue,
                "9:12: `radius_m` does not apply to a sign: it takes centre, facing_deg, size_m, mounting_height_m, arrow, post",
            ),
            (ProblemKind::BadValue, "13:8: this desk needs `size_m`"),
        ],
    );
}

#[test]
fn syntax_errors_and_unknown_keys_are_reported_at_their_place() {
    check(
        &format!("{HEADER}scale = 3\n"),
        Some((20, 10)),
        &[(
            ProblemKind::Syntax,
            "4:1: unknown field `scale`, expected one of `name`, `map`, `metres_per_pixel`, `size_m`, `origin_m`, `wall_height_m`, `wall_colour`, `floor_colour`, `ceiling_colour`, `objects`, `queue`, `walks`",
        )],
    );
    check(
        "map = \"map.png\nmetres_per_pixel = 0.5\n",
        None,
        &[(
            ProblemKind::Syntax,
            "1:15: invalid basic string, expected `\"`",
        )],
    );
}

#[test]
fn a_folder_without_a_world_file_says_what_a_world_is() {
    let dir = tempfile::tempdir().unwrap();
    let err = World::load(dir.path()).unwrap_err();
    assert!(matches!(err, WorldError::Read { .. }));
    assert!(
        err.to_string()
            .ends_with("(a world is a folder holding world.toml and its map image)"),
        "{err}"
    );
}

#[test]
fn queues_and_walks_name_people_of_the_world_and_are_checked_where_written() {
    let text = format!(
        "{HEADER}\n[[objects]]\nkind = \"person\"\nname = \"ann\"\ncentre = [2.0, 2.0]\nshirt_colour = \"red\"\n\n\
         [queue]\ndesk = \"nowhere\"\npeople = [\"ann\", \"bob\"]\nserve_s = [5.0, 3.0]\nstarts_when_robot_within_m = 4.0\nleave_by = [[1.0, 1.0]]\n\n\
         [[walks]]\nperson = \"ann\"\nroute = [[20.0, 1.0]]\nstarts_at_s = 1.0\nleaves = true\nback_and_forth = true\n"
    );
    check(
        &text,
        Some((20, 10)),
        &[
            (
                ProblemKind::BadValue,
                "12:8: the queue's desk `nowhere` is no desk of this world",
            ),
            (
                ProblemKind::BadValue,
                "13:18: `bob` is no person of this world: name a `person` object",
            ),
            (
                ProblemKind::BadValue,
                "14:11: `serve_s` must be [shortest, longest] in s, both zero or more, not [5.0, 3.0]",
            ),
            (
                ProblemKind::BadValue,
                "18:1: a walk either `leaves` or goes `back_and_forth`, not both",
            ),
            (
                ProblemKind::BadValue,
                "19:10: `ann` already moves in the queue or another walk: a person moves one way",
            ),
            (
                ProblemKind::OutsideMap,
                "20:9: `route` goes through (20, 1), outside the map: give points inside it",
            ),
        ],
    );
    // A good plan loads.
    let good = format!(
        "{HEADER}\n[[objects]]\nkind = \"person\"\nname = \"ann\"\ncentre = [2.0, 2.0]\nshirt_colour = \"red\"\n\n\
         [[walks]]\nperson = \"ann\"\nroute = [[4.0, 1.0]]\nstarts_when_robot_within_m = 2.0\nback_and_forth = true\n"
    );
    let dir = world_dir(&good, Some((20, 10)));
    let world = World::load(dir.path()).unwrap();
    assert_eq!(world.plan().walks.len(), 1);
}
