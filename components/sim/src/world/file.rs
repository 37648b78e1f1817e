//! Reading a world folder: `world.toml` (scale, origin, size, objects) and the map image it
//! names. Every problem is reported at its line and column, all of them at once.

use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use lewis_stdx::Diagnostic;

use super::error::{ProblemKind, WorldError, WorldProblem};
use super::map::OccupancyGrid;
use super::objects::{ArrowDirection, ObjectKind, Person, Rgb, Sign, WorldObject};
use super::{World, WorldLook};
use lewis_geometry::Vec2;

use crate::geometry::Shape;
use crate::scene::{QueuePlan, ScenePlan, WalkEnd, WalkPlan, WalkStart};

type Field<T> = Option<Spanned<T>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWorld {
    name: Option<String>,
    map: Spanned<String>,
    metres_per_pixel: Spanned<f64>,
    size_m: Spanned<[f64; 2]>,
    origin_m: Field<[f64; 2]>,
    wall_height_m: Field<f64>,
    wall_colour: Field<String>,
    floor_colour: Field<String>,
    ceiling_colour: Field<String>,
    #[serde(default)]
    objects: Vec<Spanned<RawObject>>,
    queue: Option<Spanned<RawQueue>>,
    #[serde(default)]
    walks: Vec<Spanned<RawWalk>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawQueue {
    desk: Spanned<String>,
    people: Spanned<Vec<Spanned<String>>>,
    serve_s: Spanned<[f64; 2]>,
    starts_when_robot_within_m: Spanned<f64>,
    leave_by: Spanned<Vec<[f64; 2]>>,
    walk_speed_mps: Field<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWalk {
    person: Spanned<String>,
    route: Spanned<Vec<[f64; 2]>>,
    speed_mps: Field<f64>,
    starts_when_robot_within_m: Field<f64>,
    starts_at_s: Field<f64>,
    leaves: Field<bool>,
    back_and_forth: Field<bool>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObject {
    kind: Spanned<String>,
    name: Field<String>,
    from: Field<[f64; 2]>,
    to: Field<[f64; 2]>,
    thickness_m: Field<f64>,
    centre: Field<[f64; 2]>,
    size_m: Field<[f64; 2]>,
    heading_deg: Field<f64>,
    radius_m: Field<f64>,
    height_m: Field<f64>,
    shape: Field<String>,
    colour: Field<String>,
    open: Field<bool>,
    facing_deg: Field<f64>,
    mounting_height_m: Field<f64>,
    arrow: Field<String>,
    post: Field<bool>,
    shirt_colour: Field<String>,
    trousers_colour: Field<String>,
    cap_colour: Field<String>,
}

/// The object kinds and the fields each accepts (besides `kind` and `name`).
const KINDS: &[(&str, &[&str])] = &[
    (
        "wall",
        &[
            "from",
            "to",
            "thickness_m",
            "centre",
            "size_m",
            "heading_deg",
            "height_m",
            "colour",
        ],
    ),
    (
        "door",
        &["from", "to", "thickness_m", "height_m", "colour", "open"],
    ),
    (
        "landmark",
        &[
            "shape",
            "centre",
            "radius_m",
            "size_m",
            "heading_deg",
            "height_m",
            "colour",
        ],
    ),
    (
        "sign",
        &[
            "centre",
            "facing_deg",
            "size_m",
            "mounting_height_m",
            "arrow",
            "post",
        ],
    ),
    (
        "desk",
        &["centre", "size_m", "heading_deg", "height_m", "colour"],
    ),
    (
        "person",
        &[
            "centre",
            "radius_m",
            "height_m",
            "shirt_colour",
            "trousers_colour",
            "cap_colour",
        ],
    ),
];

const DEFAULT_WALL_HEIGHT_M: f64 = 2.5;
const DEFAULT_WALL_THICKNESS_M: f64 = 0.1;
const DEFAULT_WALL_COLOUR: Rgb = Rgb::new(196, 186, 158);
const DEFAULT_FLOOR_COLOUR: Rgb = Rgb::new(96, 92, 88);
const DEFAULT_CEILING_COLOUR: Rgb = Rgb::new(172, 172, 178);
const DEFAULT_DOOR_COLOUR: Rgb = Rgb::new(120, 75, 40);
const DEFAULT_DOOR_HEIGHT_M: f64 = 2.1;
const DEFAULT_DESK_COLOUR: Rgb = Rgb::new(150, 105, 60);
const DEFAULT_DESK_HEIGHT_M: f64 = 0.9;
const DEFAULT_LANDMARK_HEIGHT_M: f64 = 1.2;
const DEFAULT_SIGN_SIZE_M: [f64; 2] = [0.6, 0.45];
const DEFAULT_SIGN_MOUNTING_HEIGHT_M: f64 = 1.4;
const DEFAULT_PERSON_RADIUS_M: f64 = 0.22;
const DEFAULT_PERSON_HEIGHT_M: f64 = 1.75;
const DEFAULT_TROUSERS: Rgb = Rgb::new(45, 50, 75);
const DEFAULT_WALK_SPEED_MPS: f64 = 1.0;

/// Loads `dir/world.toml` and the map it names.
pub(super) fn load(dir: &Path) -> Result<World, WorldError> {
    let path = dir.join("world.toml");
    let text = std::fs::read_to_string(&path).map_err(|source| WorldError::Read {
        path: path.clone(),
        source,
    })?;
    parse(&text, &path, dir)
}

/// Builds a world from the text of a world file at `path`, reading its map from `dir`.
pub(super) fn parse(text: &str, path: &Path, dir: &Path) -> Result<World, WorldError> {
    let mut checker = Checker {
        text,
        path,
        problems: Vec::new(),
    };
    let raw: RawWorld = match toml::from_str(text) {
        Ok(raw) => raw,
        Err(e) => {
            let span = e.span().unwrap_or(0..0);
            checker.problem(
                &span,
                ProblemKind::Syntax,
                e.message().trim_end_matches('.'),
            );
            return Err(checker.into_error());
        }
    };
    let world = checker.world(&raw, dir);
    match world {
        Some(world) if checker.problems.is_empty() => Ok(world),
        _ => Err(checker.into_error()),
    }
}

struct Checker<'a> {
    text: &'a str,
    path: &'a Path,
    problems: Vec<WorldProblem>,
}

impl Checker<'_> {
    fn problem(&mut self, span: &Range<usize>, kind: ProblemKind, message: impl Into<String>) {
        self.problems.push(WorldProblem {
            kind,
            diagnostic: Diagnostic::plain_at_offset(self.path, self.text, span.start, message),
        });
    }

    fn into_error(mut self) -> WorldError {
        self.problems.sort_by_key(|p| p.diagnostic.position);
        WorldError::Invalid {
            path: self.path.to_path_buf(),
            problems: self.problems,
        }
    }

    fn world(&mut self, raw: &RawWorld, dir: &Path) -> Option<World> {
        let mpp = self.positive(&raw.metres_per_pixel, "metres_per_pixel");
        let size = self.positive_pair(&raw.size_m, "size_m");
        let origin = raw
            .origin_m
            .as_ref()
            .map_or(Some([0.0, 0.0]), |o| self.finite_pair(o, "origin_m"));
        let wall_height_m = match &raw.wall_height_m {
            Some(h) => self.positive(h, "wall_height_m"),
            None => Some(DEFAULT_WALL_HEIGHT_M),
        };
        let look = WorldLook {
            wall_height_m: wall_height_m.unwrap_or(DEFAULT_WALL_HEIGHT_M),
            wall_colour: self.colour_or(raw.wall_colour.as_ref(), DEFAULT_WALL_COLOUR),
            floor_colour: self.colour_or(raw.floor_colour.as_ref(), DEFAULT_FLOOR_COLOUR),
            ceiling_colour: self.colour_or(raw.ceiling_colour.as_ref(), DEFAULT_CEILING_COLOUR),
        };
        let grid = match (mpp, size, origin) {
            (Some(mpp), Some(size), Some(origin)) => {
                self.grid(raw, dir, mpp, size, Vec2::new(origin[0], origin[1]))
            }
            _ => None,
        };
        let bounds = match (size, origin) {
            (Some(size), Some(o)) => Some((
                Vec2::new(o[0], o[1]),
                Vec2::new(o[0] + size[0], o[1] + size[1]),
            )),
            _ => None,
        };
        let mut objects = Vec::with_capacity(raw.objects.len());
        let mut seen = std::collections::BTreeSet::new();
        for (index, spanned) in raw.objects.iter().enumerate() {
            let Some(object) = self.object(spanned, index, &look, bounds) else {
                continue;
            };
            if !seen.insert(object.name.clone()) {
                let raw_object = spanned.get_ref();
                let span = raw_object
                    .name
                    .as_ref()
                    .map_or(raw_object.kind.span(), Spanned::span);
                self.problem(
                    &span,
                    ProblemKind::BadValue,
                    format!(
                        "a second object named `{}`: give each object its own name",
                        object.name
                    ),
                );
            }
            objects.push(object);
        }
        let name = raw.name.clone().unwrap_or_else(|| {
            dir.file_name()
                .map_or_else(|| "world".to_owned(), |n| n.to_string_lossy().into_owned())
        });
        let plan = self.plan(raw, &objects, bounds);
        Some(World::new(name, grid?, look, objects).with_plan(plan))
    }

    /// The `[queue]` and `[[walks]]` tables: who moves and how.
    fn plan(
        &mut self,
        raw: &RawWorld,
        objects: &[WorldObject],
        bounds: Option<(Vec2, Vec2)>,
    ) -> ScenePlan {
        let mut plan = ScenePlan::default();
        let mut moving: Vec<String> = Vec::new();
        if let Some(q) = &raw.queue {
            let q = q.get_ref();
            let desk = q.desk.get_ref();
            if !objects
                .iter()
                .any(|o| &o.name == desk && matches!(o.kind, ObjectKind::Desk { .. }))
            {
                self.problem(
                    &q.desk.span(),
                    ProblemKind::BadValue,
                    format!("the queue's desk `{desk}` is no desk of this world"),
                );
            }
            let mut people = Vec::new();
            for name in q.people.get_ref() {
                if self.person(name, objects, &mut moving) {
                    people.push(name.get_ref().clone());
                }
            }
            if q.people.get_ref().is_empty() {
                self.problem(
                    &q.people.span(),
                    ProblemKind::BadValue,
                    "the queue needs at least one person",
                );
            }
            let serve = *q.serve_s.get_ref();
            if !(serve.iter().all(|s| s.is_finite() && *s >= 0.0) && serve[0] <= serve[1]) {
                self.problem(
                    &q.serve_s.span(),
                    ProblemKind::BadValue,
                    format!(
                        "`serve_s` must be [shortest, longest] in s, both zero or more, not {serve:?}"
                    ),
                );
            }
            let within =
                self.non_negative(&q.starts_when_robot_within_m, "starts_when_robot_within_m");
            let leave_by = self.route(&q.leave_by, "leave_by", bounds);
            let speed = self.speed(q.walk_speed_mps.as_ref(), "walk_speed_mps");
            if let (Some(within), Some(leave_by), Some(speed)) = (within, leave_by, speed) {
                plan.queue = Some(QueuePlan {
                    desk: desk.clone(),
                    people,
                    serve_s: (serve[0], serve[1]),
                    starts_when_robot_within_m: within,
                    leave_by,
                    walk_speed_mps: speed,
                });
            }
        }
        for walk in &raw.walks {
            let span = walk.span();
            let w = walk.get_ref();
            let known = self.person(&w.person, objects, &mut moving);
            let route = self.route(&w.route, "route", bounds);
            let speed = self.speed(w.speed_mps.as_ref(), "speed_mps");
            let start = match (&w.starts_when_robot_within_m, &w.starts_at_s) {
                (Some(d), None) => self
                    .non_negative(d, "starts_when_robot_within_m")
                    .map(WalkStart::RobotWithin),
                (None, Some(t)) => self.non_negative(t, "starts_at_s").map(WalkStart::At),
                _ => {
                    self.problem(
                        &span,
                        ProblemKind::BadValue,
                        "a walk starts either when the robot comes near (`starts_when_robot_within_m`) or at a time (`starts_at_s`): give one of the two",
                    );
                    None
                }
            };
            let flag = |f: &Field<bool>| f.as_ref().is_some_and(|f| *f.get_ref());
            let end = match (flag(&w.leaves), flag(&w.back_and_forth)) {
                (false, false) => Some(WalkEnd::Stays),
                (true, false) => Some(WalkEnd::Leaves),
                (false, true) => Some(WalkEnd::BackAndForth),
                (true, true) => {
                    self.problem(
                        &span,
                        ProblemKind::BadValue,
                        "a walk either `leaves` or goes `back_and_forth`, not both",
                    );
                    None
                }
            };
            if let (true, Some(route), Some(speed_mps), Some(start), Some(end)) =
                (known, route, speed, start, end)
            {
                plan.walks.push(WalkPlan {
                    person: w.person.get_ref().clone(),
                    route,
                    speed_mps,
                    start,
                    end,
                });
            }
        }
        plan
    }

    /// Whether `name` is a person of `objects` that nothing else moves yet (noted in
    /// `moving`).
    fn person(
        &mut self,
        name: &Spanned<String>,
        objects: &[WorldObject],
        moving: &mut Vec<String>,
    ) -> bool {
        let text = name.get_ref();
        if !objects
            .iter()
            .any(|o| &o.name == text && matches!(o.kind, ObjectKind::Person(_)))
        {
            self.problem(
                &name.span(),
                ProblemKind::BadValue,
                format!("`{text}` is no person of this world: name a `person` object"),
            );
            return false;
        }
        if moving.contains(text) {
            self.problem(
                &name.span(),
                ProblemKind::BadValue,
                format!(
                    "`{text}` already moves in the queue or another walk: a person moves one way"
                ),
            );
            return false;
        }
        moving.push(text.clone());
        true
    }

    /// A route: points inside the map.
    fn route(
        &mut self,
        value: &Spanned<Vec<[f64; 2]>>,
        name: &str,
        bounds: Option<(Vec2, Vec2)>,
    ) -> Option<Vec<Vec2>> {
        let points: Vec<Vec2> = value
            .get_ref()
            .iter()
            .map(|p| Vec2::new(p[0], p[1]))
            .collect();
        let outside = points.iter().find(|p| {
            !p.is_finite()
                || bounds
                    .is_some_and(|(lo, hi)| p.x < lo.x || p.y < lo.y || p.x > hi.x || p.y > hi.y)
        });
        if let Some(p) = outside {
            self.problem(
                &value.span(),
                ProblemKind::OutsideMap,
                format!(
                    "`{name}` goes through ({}, {}), outside the map: give points inside it",
                    p.x, p.y
                ),
            );
            return None;
        }
        Some(points)
    }

    fn speed(&mut self, value: Option<&Spanned<f64>>, name: &str) -> Option<f64> {
        match value {
            Some(v) => self.positive(v, name),
            None => Some(DEFAULT_WALK_SPEED_MPS),
        }
    }

    fn grid(
        &mut self,
        raw: &RawWorld,
        dir: &Path,
        mpp: f64,
        size: [f64; 2],
        origin: Vec2,
    ) -> Option<OccupancyGrid> {
        let map_path: PathBuf = dir.join(raw.map.get_ref());
        let span = raw.map.span();
        if !map_path.is_file() {
            self.problem(
                &span,
                ProblemKind::MissingMap,
                format!(
                    "the map image {} does not exist: draw it (a PNG, dark pixels are walls) or fix `map`",
                    map_path.display()
                ),
            );
            return None;
        }
        let image = match image::open(&map_path) {
            Ok(image) => image.to_luma8(),
            Err(e) => {
                self.problem(
                    &span,
                    ProblemKind::BadMap,
                    format!("cannot decode the map image {}: {e}", map_path.display()),
                );
                return None;
            }
        };
        let (w, h) = image.dimensions();
        let (w_m, h_m) = (f64::from(w) * mpp, f64::from(h) * mpp);
        if (w_m - size[0]).abs() > mpp / 2.0 || (h_m - size[1]).abs() > mpp / 2.0 {
            self.problem(
                &raw.size_m.span(),
                ProblemKind::MapSizeMismatch,
                format!(
                    "size_m says {} x {} m but the map image {} is {w} x {h} px, which is {w_m} x {h_m} m at {mpp} m/px: fix size_m, metres_per_pixel or the image",
                    size[0],
                    size[1],
                    map_path.display()
                ),
            );
            return None;
        }
        Some(OccupancyGrid::from_luma(&image, mpp, origin))
    }

    fn positive(&mut self, value: &Spanned<f64>, name: &str) -> Option<f64> {
        let v = *value.get_ref();
        if v.is_finite() && v > 0.0 {
            Some(v)
        } else {
            self.problem(
                &value.span(),
                ProblemKind::BadValue,
                format!("`{name}` must be a positive number, not {v}"),
            );
            None
        }
    }

    fn non_negative(&mut self, value: &Spanned<f64>, name: &str) -> Option<f64> {
        let v = *value.get_ref();
        if v.is_finite() && v >= 0.0 {
            Some(v)
        } else {
            self.problem(
                &value.span(),
                ProblemKind::BadValue,
                format!("`{name}` must be zero or more, not {v}"),
            );
            None
        }
    }

    fn finite(&mut self, value: &Spanned<f64>, name: &str) -> Option<f64> {
        let v = *value.get_ref();
        if v.is_finite() {
            Some(v)
        } else {
            self.problem(
                &value.span(),
                ProblemKind::BadValue,
                format!("`{name}` must be a finite number"),
            );
            None
        }
    }

    fn positive_pair(&mut self, value: &Spanned<[f64; 2]>, name: &str) -> Option<[f64; 2]> {
        let v = *value.get_ref();
        if v.iter().all(|x| x.is_finite() && *x > 0.0) {
            Some(v)
        } else {
            self.problem(
                &value.span(),
                ProblemKind::BadValue,
                format!("`{name}` must be two positive numbers, not {v:?}"),
            );
            None
        }
    }

    fn finite_pair(&mut self, value: &Spanned<[f64; 2]>, name: &str) -> Option<[f64; 2]> {
        let v = *value.get_ref();
        if v.iter().all(|x| x.is_finite()) {
            Some(v)
        } else {
            self.problem(
                &value.span(),
                ProblemKind::BadValue,
                format!("`{name}` must be two finite numbers"),
            );
            None
        }
    }

    fn colour(&mut self, value: &Spanned<String>) -> Option<Rgb> {
        let parsed = Rgb::parse(value.get_ref());
        if parsed.is_none() {
            let names: Vec<&str> = Rgb::NAMED.iter().map(|(n, _)| *n).collect();
            self.problem(
                &value.span(),
                ProblemKind::BadColour,
                format!(
                    "bad colour `{}`: write \"#rrggbb\" (hexadecimal) or one of {}",
                    value.get_ref(),
                    names.join(", ")
                ),
            );
        }
        parsed
    }

    fn colour_or(&mut self, value: Option<&Spanned<String>>, default: Rgb) -> Rgb {
        value.and_then(|v| self.colour(v)).unwrap_or(default)
    }

    fn require<'v, T>(
        &mut self,
        value: Option<&'v Spanned<T>>,
        name: &str,
        kind: &str,
        object_span: &Range<usize>,
    ) -> Option<&'v Spanned<T>> {
        if value.is_none() {
            self.problem(
                object_span,
                ProblemKind::BadValue,
                format!("this {kind} needs `{name}`"),
            );
        }
        value
    }

    /// Checks the fields given against the kind; returns the kind's name.
    fn kind_fields(&mut self, raw: &RawObject) -> Option<&'static str> {
        let kind = raw.kind.get_ref().as_str();
        let Some(&(kind, allowed)) = KINDS.iter().find(|(k, _)| *k == kind) else {
            let known: Vec<&str> = KINDS.iter().map(|(k, _)| *k).collect();
            self.problem(
                &raw.kind.span(),
                ProblemKind::UnknownKind,
                format!(
                    "unknown object kind `{kind}`: the simulator knows {}",
                    known.join(", ")
                ),
            );
            return None;
        };
        let spans = |f: &Field<f64>| f.as_ref().map(Spanned::span);
        let pair = |f: &Field<[f64; 2]>| f.as_ref().map(Spanned::span);
        let text = |f: &Field<String>| f.as_ref().map(Spanned::span);
        let flag = |f: &Field<bool>| f.as_ref().map(Spanned::span);
        let given = [
            ("from", pair(&raw.from)),
            ("to", pair(&raw.to)),
            ("thickness_m", spans(&raw.thickness_m)),
            ("centre", pair(&raw.centre)),
            ("size_m", pair(&raw.size_m)),
            ("heading_deg", spans(&raw.heading_deg)),
            ("radius_m", spans(&raw.radius_m)),
            ("height_m", spans(&raw.height_m)),
            ("shape", text(&raw.shape)),
            ("colour", text(&raw.colour)),
            ("open", flag(&raw.open)),
            ("facing_deg", spans(&raw.facing_deg)),
            ("mounting_height_m", spans(&raw.mounting_height_m)),
            ("arrow", text(&raw.arrow)),
            ("post", flag(&raw.post)),
            ("shirt_colour", text(&raw.shirt_colour)),
            ("trousers_colour", text(&raw.trousers_colour)),
            ("cap_colour", text(&raw.cap_colour)),
        ];
        let mut ok = true;
        for (field, span) in given {
            if let Some(span) = span
                && !allowed.contains(&field)
            {
                self.problem(
                    &span,
                    ProblemKind::BadValue,
                    format!(
                        "`{field}` does not apply to a {kind}: it takes {}",
                        allowed.join(", ")
                    ),
                );
                ok = false;
            }
        }
        ok.then_some(kind)
    }

    fn object(
        &mut self,
        spanned: &Spanned<RawObject>,
        index: usize,
        look: &WorldLook,
        bounds: Option<(Vec2, Vec2)>,
    ) -> Option<WorldObject> {
        let raw = spanned.get_ref();
        let span = raw.kind.span();
        let kind_name = self.kind_fields(raw)?;
        let heading = |c: &mut Self| match &raw.heading_deg {
            Some(h) => c.finite(h, "heading_deg").map(f64::to_radians),
            None => Some(0.0),
        };
        let height = |c: &mut Self, default: f64| match &raw.height_m {
            Some(h) => c.positive(h, "height_m"),
            None => Some(default),
        };
        let rect_at = |c: &mut Self| -> Option<Shape> {
            let centre = c.require(raw.centre.as_ref(), "centre", kind_name, &span)?;
            let centre = c.finite_pair(centre, "centre")?;
            let size = c.require(raw.size_m.as_ref(), "size_m", kind_name, &span)?;
            let size = c.positive_pair(size, "size_m")?;
            let heading = heading(c)?;
            Some(Shape::rect(
                Vec2::new(centre[0], centre[1]),
                size[0],
                size[1],
                heading,
            ))
        };
        let segment = |c: &mut Self| -> Option<Shape> {
            let from = c.require(raw.from.as_ref(), "from", kind_name, &span)?;
            let to = c.require(raw.to.as_ref(), "to", kind_name, &span)?;
            let (from, to) = (c.finite_pair(from, "from")?, c.finite_pair(to, "to")?);
            let thickness = match &raw.thickness_m {
                Some(t) => c.positive(t, "thickness_m")?,
                None => DEFAULT_WALL_THICKNESS_M,
            };
            Some(Shape::thick_segment(
                Vec2::new(from[0], from[1]),
                Vec2::new(to[0], to[1]),
                thickness,
            ))
        };
        let kind = match kind_name {
            "wall" => {
                let shape = match (&raw.from, &raw.centre) {
                    (Some(_), None) => segment(self),
                    (None, Some(_)) => rect_at(self),
                    _ => {
                        self.problem(
                            &span,
                            ProblemKind::BadValue,
                            "a wall is either a segment (`from`, `to`, optional `thickness_m`) or a box (`centre`, `size_m`, optional `heading_deg`): give one of the two",
                        );
                        None
                    }
                };
                let height_m = height(self, look.wall_height_m);
                let colour = self.colour_or(raw.colour.as_ref(), look.wall_colour);
                ObjectKind::Wall {
                    shape: shape?,
                    height_m: height_m?,
                    colour,
                }
            }
            "door" => {
                let shape = segment(self);
                let height_m = height(self, DEFAULT_DOOR_HEIGHT_M);
                let colour = self.colour_or(raw.colour.as_ref(), DEFAULT_DOOR_COLOUR);
                ObjectKind::Door {
                    shape: shape?,
                    height_m: height_m?,
                    colour,
                    open: raw.open.as_ref().is_some_and(|o| *o.get_ref()),
                }
            }
            "landmark" => {
                let shape = match raw.shape.as_ref().map(|s| (s.get_ref().as_str(), s.span())) {
                    Some(("pillar", _)) => {
                        let centre = self
                            .require(raw.centre.as_ref(), "centre", "pillar", &span)
                            .and_then(|c| self.finite_pair(c, "centre"));
                        let radius = self
                            .require(raw.radius_m.as_ref(), "radius_m", "pillar", &span)
                            .and_then(|r| self.positive(r, "radius_m"));
                        match (centre, radius) {
                            (Some(c), Some(r)) => Some(Shape::Circle {
                                centre: Vec2::new(c[0], c[1]),
                                radius_m: r,
                            }),
                            _ => None,
                        }
                    }
                    Some(("box", _)) => rect_at(self),
                    Some((other, shape_span)) => {
                        self.problem(
                            &shape_span,
                            ProblemKind::BadValue,
                            format!(
                                "unknown landmark shape `{other}`: write \"pillar\" or \"box\""
                            ),
                        );
                        None
                    }
                    None => {
                        self.problem(
                            &span,
                            ProblemKind::BadValue,
                            "this landmark needs `shape` (\"pillar\" or \"box\")",
                        );
                        None
                    }
                };
                let height_m = height(self, DEFAULT_LANDMARK_HEIGHT_M);
                let colour = self
                    .require(raw.colour.as_ref(), "colour", "landmark", &span)
                    .and_then(|c| self.colour(c));
                ObjectKind::Landmark {
                    shape: shape?,
                    height_m: height_m?,
                    colour: colour?,
                }
            }
            "sign" => {
                let centre = self
                    .require(raw.centre.as_ref(), "centre", "sign", &span)
                    .and_then(|c| self.finite_pair(c, "centre"));
                let facing = self
                    .require(raw.facing_deg.as_ref(), "facing_deg", "sign", &span)
                    .and_then(|f| self.finite(f, "facing_deg"));
                let size = match &raw.size_m {
                    Some(s) => self.positive_pair(s, "size_m"),
                    None => Some(DEFAULT_SIGN_SIZE_M),
                };
                let mounting = match &raw.mounting_height_m {
                    Some(m) => self.non_negative(m, "mounting_height_m"),
                    None => Some(DEFAULT_SIGN_MOUNTING_HEIGHT_M),
                };
                let arrow = self
                    .require(raw.arrow.as_ref(), "arrow", "sign", &span)
                    .and_then(|a| {
                        let parsed = ArrowDirection::parse(a.get_ref());
                        if parsed.is_none() {
                            self.problem(
                                &a.span(),
                                ProblemKind::BadValue,
                                format!(
                                    "unknown arrow `{}`: write left, right, up, down or desk",
                                    a.get_ref()
                                ),
                            );
                        }
                        parsed
                    });
                let (centre, facing, size, mounting, arrow) =
                    (centre?, facing?, size?, mounting?, arrow?);
                if mounting < size[1] / 2.0 {
                    let at = raw
                        .mounting_height_m
                        .as_ref()
                        .map_or(span.clone(), Spanned::span);
                    self.problem(&at, ProblemKind::BadValue, format!("the board's centre at {mounting} m is too low for its height of {} m: it would go through the floor", size[1]));
                    return None;
                }
                ObjectKind::Sign(Sign {
                    centre: Vec2::new(centre[0], centre[1]),
                    facing_rad: facing.to_radians(),
                    width_m: size[0],
                    height_m: size[1],
                    mounting_height_m: mounting,
                    arrow,
                    post: raw.post.as_ref().is_some_and(|p| *p.get_ref()),
                })
            }
            "desk" => {
                let shape = rect_at(self);
                let height_m = height(self, DEFAULT_DESK_HEIGHT_M);
                let colour = self.colour_or(raw.colour.as_ref(), DEFAULT_DESK_COLOUR);
                ObjectKind::Desk {
                    shape: shape?,
                    height_m: height_m?,
                    colour,
                }
            }
            _ => {
                // "person": the last of KINDS.
                let centre = self
                    .require(raw.centre.as_ref(), "centre", "person", &span)
                    .and_then(|c| self.finite_pair(c, "centre"));
                let radius = match &raw.radius_m {
                    Some(r) => self.positive(r, "radius_m"),
                    None => Some(DEFAULT_PERSON_RADIUS_M),
                };
                let height_m = height(self, DEFAULT_PERSON_HEIGHT_M);
                let shirt = self
                    .require(raw.shirt_colour.as_ref(), "shirt_colour", "person", &span)
                    .and_then(|c| self.colour(c));
                let trousers = self.colour_or(raw.trousers_colour.as_ref(), DEFAULT_TROUSERS);
                let cap = match &raw.cap_colour {
                    Some(c) => Some(Some(self.colour(c)?)),
                    None => Some(None),
                };
                ObjectKind::Person(Person {
                    centre: Vec2::new(centre?[0], centre?[1]),
                    radius_m: radius?,
                    height_m: height_m?,
                    shirt: shirt?,
                    trousers,
                    cap: cap?,
                })
            }
        };
        let name = raw.name.as_ref().map_or_else(
            || format!("{kind_name}-{}", index + 1),
            |n| n.get_ref().clone(),
        );
        let object = WorldObject { name, kind };
        if let Some((lo, hi)) = bounds {
            let at = raw
                .centre
                .as_ref()
                .or(raw.from.as_ref())
                .map_or(span, Spanned::span);
            self.inside(&object, lo, hi, &at)?;
        }
        Some(object)
    }

    fn inside(
        &mut self,
        object: &WorldObject,
        lo: Vec2,
        hi: Vec2,
        at: &Range<usize>,
    ) -> Option<()> {
        let mut primitives = Vec::new();
        super::objects::primitives_of(object, 0, &mut 0, &mut primitives);
        let Some((mut a, mut b)) = primitives.first().map(|p| p.shape.bounds()) else {
            return Some(());
        };
        for p in &primitives {
            let (lo_p, hi_p) = p.shape.bounds();
            a = Vec2::new(a.x.min(lo_p.x), a.y.min(lo_p.y));
            b = Vec2::new(b.x.max(hi_p.x), b.y.max(hi_p.y));
        }
        let eps = 1e-9;
        if a.x < lo.x - eps || a.y < lo.y - eps || b.x > hi.x + eps || b.y > hi.y + eps {
            self.problem(
                at,
                ProblemKind::OutsideMap,
                format!(
                    "{} `{}` reaches ({:.2}, {:.2})..({:.2}, {:.2}) m, outside the map ({:.2}, {:.2})..({:.2}, {:.2}) m: move it inside or enlarge the map",
                    object.kind.name(),
                    object.name,
                    a.x,
                    a.y,
                    b.x,
                    b.y,
                    lo.x,
                    lo.y,
                    hi.x,
                    hi.y
                ),
            );
            return None;
        }
        Some(())
    }
}
