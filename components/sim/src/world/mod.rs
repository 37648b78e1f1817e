//! The simulated world: an occupancy map (walls) plus objects (doors, landmarks, signs, a
//! desk, people), loaded from `robots/worlds/NAME/`, and the geometric queries the devices
//! need: ray casting (what a beam hits, and at what range) and collision of the robot.
//!
//! A world folder holds `world.toml` and the map image it names. The file:
//!
//! ```toml
//! name = "conference"            # optional, the folder's name otherwise
//! map = "map.png"                # dark pixels (luma < 128) are walls
//! metres_per_pixel = 0.05
//! size_m = [40.0, 25.0]          # must agree with the image's size
//! origin_m = [0.0, 0.0]          # world position of the image's bottom-left corner
//! wall_height_m = 2.5            # optional; wall_colour, floor_colour, ceiling_colour too
//!
//! [[objects]]
//! kind = "door"                  # wall, door, landmark, sign, desk or person
//! name = "entrance"
//! from = [8.0, 11.75]
//! to = [8.0, 13.25]
//! open = true
//! ```
//!
//! Kinds and their fields (units in the names; angles in degrees, counter-clockwise from +x):
//! - `wall`: `from`, `to`, `thickness_m` (a segment) or `centre`, `size_m`, `heading_deg`
//!   (a box); `height_m`, `colour`.
//! - `door`: `from`, `to`, `thickness_m`, `height_m`, `colour`, `open` (default closed).
//! - `landmark`: `shape` = "pillar" (`centre`, `radius_m`) or "box" (`centre`, `size_m`,
//!   `heading_deg`); `height_m`, `colour` (required).
//! - `sign`: `centre`, `facing_deg` (where the printed side looks), `size_m` (width,
//!   height), `mounting_height_m` (of the board's centre), `arrow` (left, right, up, down, as
//!   someone facing the sign sees it; or desk: the registration desk's own sign, a black
//!   disc), `post` (stands on a post).
//! - `desk`: `centre`, `size_m`, `heading_deg`, `height_m`, `colour`.
//! - `person`: `centre`, `radius_m`, `height_m`, `shirt_colour` (required), `trousers_colour`,
//!   `cap_colour`.
//!
//! Colours are `"#rrggbb"` or a name of [`Rgb::NAMED`].
//!
//! Optional tables say how people move (see [`crate::scene`]): `[queue]` (the people in line
//! at a desk, served one by one once the robot comes near) and `[[walks]]` (a person walking
//! a route). Without them every person stands where the file puts them.

mod error;
mod file;
mod map;
mod objects;

use std::path::Path;

pub use error::{ProblemKind, WorldError, WorldProblem};
pub use map::{OccupancyGrid, WALL_LUMA_THRESHOLD};
pub use objects::{
    ArrowDirection, Material, ObjectKind, Person, Primitive, Rgb, SIGN_BACK, SIGN_POST,
    SIGN_POST_RADIUS_M, SKIN, Sign, WorldObject,
};

use lewis_geometry::Vec2;

use crate::geometry::RayHit;
use crate::scene::ScenePlan;

/// How the parts that are not objects look: the map's walls, the floor and the ceiling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldLook {
    /// Height of the map's walls, in m (also the ceiling's).
    pub wall_height_m: f64,
    /// Colour of the map's walls.
    pub wall_colour: Rgb,
    /// Colour of the floor.
    pub floor_colour: Rgb,
    /// Colour of the ceiling.
    pub ceiling_colour: Rgb,
}

/// What a ray hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Surface {
    /// A wall of the map.
    Map,
    /// A primitive of an object: its index in [`World::primitives`].
    Primitive(usize),
}

/// Where a ray hit something, and what.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance from the ray's origin, in m.
    pub range_m: f64,
    /// Surface normal at the hit, a unit vector facing the ray's origin.
    pub normal: Vec2,
    /// What was hit.
    pub surface: Surface,
}

/// A door name that the world does not have.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("no door named `{name}` in world `{world}`: its doors are {known}")]
pub struct UnknownDoor {
    /// The name asked for.
    pub name: String,
    /// The world's name.
    pub world: String,
    /// The doors it has, comma-separated.
    pub known: String,
}

/// The simulated world. Immutable but for its doors and where its people stand.
#[derive(Debug, Clone, PartialEq)]
pub struct World {
    name: String,
    grid: OccupancyGrid,
    look: WorldLook,
    objects: Vec<WorldObject>,
    primitives: Vec<Primitive>,
    /// Per object: the range of its primitives in `primitives`.
    object_primitives: Vec<std::ops::Range<usize>>,
    /// Per object: whether it has left the world (a person who walked away).
    gone: Vec<bool>,
    /// Per door (in the order of the objects): its object's index and whether it is open.
    doors: Vec<(usize, bool)>,
    /// How its people move.
    plan: ScenePlan,
}

impl World {
    /// Loads the world in folder `dir` (`dir/world.toml` and the map image it names).
    ///
    /// # Errors
    /// When the file cannot be read, or anything in it or its map is wrong: every problem,
    /// each at its line and column.
    pub fn load(dir: &Path) -> Result<Self, WorldError> {
        file::load(dir)
    }

    /// A world from the text of a world file; `path` names it in errors and the map is read
    /// from `dir`.
    ///
    /// # Errors
    /// As [`World::load`].
    pub fn parse(text: &str, path: &Path, dir: &Path) -> Result<Self, WorldError> {
        file::parse(text, path, dir)
    }

    /// A world made in code (tests, generated worlds). Objects are trusted as given.
    #[must_use]
    pub fn new(
        name: String,
        grid: OccupancyGrid,
        look: WorldLook,
        objects: Vec<WorldObject>,
    ) -> Self {
        let mut primitives = Vec::new();
        let mut object_primitives = Vec::with_capacity(objects.len());
        let mut door_count = 0;
        let mut doors = Vec::new();
        for (index, object) in objects.iter().enumerate() {
            let first = primitives.len();
            objects::primitives_of(object, index, &mut door_count, &mut primitives);
            object_primitives.push(first..primitives.len());
            if let ObjectKind::Door { open, .. } = object.kind {
                doors.push((index, open));
            }
        }
        let gone = vec![false; objects.len()];
        Self {
            name,
            grid,
            look,
            objects,
            primitives,
            object_primitives,
            gone,
            doors,
            plan: ScenePlan::default(),
        }
    }

    /// This world with its people moving as `plan` says (the plan is trusted as given: the
    /// world file's reader checks it).
    #[must_use]
    pub fn with_plan(mut self, plan: ScenePlan) -> Self {
        self.plan = plan;
        self
    }

    /// How its people move (empty when they all stand still).
    #[must_use]
    pub fn plan(&self) -> &ScenePlan {
        &self.plan
    }

    /// The index of the object called `name`.
    #[must_use]
    pub fn object_index(&self, name: &str) -> Option<usize> {
        self.objects.iter().position(|o| o.name == name)
    }

    /// Puts the person of object `index` at `centre`, or takes them out of the world
    /// (`None`: they left). Returns false, changing nothing, when that object is no person.
    /// Only their primitives are redrawn: everything else stays as it was computed.
    pub fn place_person(&mut self, index: usize, centre: Option<Vec2>) -> bool {
        let Some(WorldObject {
            kind: ObjectKind::Person(person),
            ..
        }) = self.objects.get_mut(index)
        else {
            return false;
        };
        match centre {
            None => self.gone[index] = true,
            Some(centre) => {
                self.gone[index] = false;
                if person.centre != centre {
                    person.centre = centre;
                    let range = self.object_primitives[index].clone();
                    let mut redrawn = Vec::with_capacity(range.len());
                    objects::primitives_of(&self.objects[index], index, &mut 0, &mut redrawn);
                    // A person's primitives depend on their look only, never on where they
                    // stand: the count is the same.
                    for (slot, primitive) in self.primitives[range].iter_mut().zip(redrawn) {
                        *slot = primitive;
                    }
                }
            }
        }
        true
    }

    /// Whether object `index` is in the world now (false for a person who left).
    #[must_use]
    pub fn is_here(&self, index: usize) -> bool {
        !self.gone.get(index).copied().unwrap_or(false)
    }

    /// Its name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The map's walls.
    #[must_use]
    pub fn grid(&self) -> &OccupancyGrid {
        &self.grid
    }

    /// How walls, floor and ceiling look.
    #[must_use]
    pub fn look(&self) -> &WorldLook {
        &self.look
    }

    /// The objects, in the order of the file.
    #[must_use]
    pub fn objects(&self) -> &[WorldObject] {
        &self.objects
    }

    /// The object called `name`.
    #[must_use]
    pub fn object(&self, name: &str) -> Option<&WorldObject> {
        self.objects.iter().find(|o| o.name == name)
    }

    /// The solid primitives the objects are made of.
    #[must_use]
    pub fn primitives(&self) -> &[Primitive] {
        &self.primitives
    }

    /// Opens or closes the door called `name`.
    ///
    /// # Errors
    /// When there is no such door.
    pub fn set_door_open(&mut self, name: &str, open: bool) -> Result<(), UnknownDoor> {
        let objects = &self.objects;
        match self
            .doors
            .iter_mut()
            .find(|(i, _)| objects[*i].name == name)
        {
            Some((_, state)) => {
                *state = open;
                Ok(())
            }
            None => Err(UnknownDoor {
                name: name.to_owned(),
                world: self.name.clone(),
                known: self
                    .doors
                    .iter()
                    .map(|(i, _)| self.objects[*i].name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            }),
        }
    }

    /// Whether the door called `name` is open; `None` when there is no such door.
    #[must_use]
    pub fn door_is_open(&self, name: &str) -> Option<bool> {
        self.doors
            .iter()
            .find(|(i, _)| self.objects[*i].name == name)
            .map(|&(_, open)| open)
    }

    /// Whether a primitive is there now (a door's panel is not while the door is open, nor
    /// a person who left).
    #[must_use]
    pub fn is_present(&self, primitive: &Primitive) -> bool {
        primitive.door.is_none_or(|d| !self.doors[d].1) && !self.gone[primitive.object]
    }

    /// The nearest surface along the ray from `origin` in the unit direction `dir`, within
    /// `max_range_m`, among the map's walls and the objects that reach height `height_m`
    /// (the beam of a laser or a sonar is a plane at that height).
    #[must_use]
    pub fn cast_ray(
        &self,
        origin: Vec2,
        dir: Vec2,
        max_range_m: f64,
        height_m: f64,
    ) -> Option<Hit> {
        let mut best = self
            .grid
            .cast_ray(origin, dir, max_range_m)
            .map(|h| hit(h, Surface::Map));
        for (index, p) in self.primitives.iter().enumerate() {
            if !p.spans_height(height_m) || !self.is_present(p) {
                continue;
            }
            let limit = best.map_or(max_range_m, |b| b.range_m);
            if let Some(h) = p.shape.ray_hit(origin, dir, limit)
                && best.is_none_or(|b| h.range_m < b.range_m)
            {
                best = Some(hit(h, Surface::Primitive(index)));
            }
        }
        best
    }

    /// Everything along a ray at every height, for the camera: returns the map wall that
    /// ends the ray (if within `max_range_m`) and appends to `hits` every object primitive
    /// met before it (in the order of the primitives, not of range).
    pub fn cast_ray_through(
        &self,
        origin: Vec2,
        dir: Vec2,
        max_range_m: f64,
        hits: &mut Vec<Hit>,
    ) -> Option<Hit> {
        let wall = self
            .grid
            .cast_ray(origin, dir, max_range_m)
            .map(|h| hit(h, Surface::Map));
        let limit = wall.map_or(max_range_m, |w| w.range_m);
        for (index, p) in self.primitives.iter().enumerate() {
            if !self.is_present(p) {
                continue;
            }
            if let Some(h) = p.shape.ray_hit(origin, dir, limit) {
                hits.push(hit(h, Surface::Primitive(index)));
            }
        }
        wall
    }

    /// Calls `visit` with the nearest point of every obstacle (map wall cell or object lower
    /// than `height_m`) within `radius_m` of `centre`.
    pub fn for_each_obstacle_point_within(
        &self,
        centre: Vec2,
        radius_m: f64,
        height_m: f64,
        mut visit: impl FnMut(Vec2),
    ) {
        self.grid
            .for_each_wall_point_within(centre, radius_m, &mut visit);
        for p in &self.primitives {
            if p.bottom_m >= height_m || !self.is_present(p) {
                continue;
            }
            let nearest = p.shape.nearest_point(centre);
            if (nearest - centre).norm() <= radius_m {
                visit(nearest);
            }
        }
    }

    /// Whether a round robot of `radius_m` and `height_m` at `centre` overlaps a wall or an
    /// object.
    #[must_use]
    pub fn circle_collides(&self, centre: Vec2, radius_m: f64, height_m: f64) -> bool {
        let mut collides = false;
        // Points exactly at the radius touch without overlapping.
        self.for_each_obstacle_point_within(centre, radius_m, height_m, |p| {
            collides |= (p - centre).norm() < radius_m;
        });
        collides
    }
}

fn hit(h: RayHit, surface: Surface) -> Hit {
    Hit {
        range_m: h.range_m,
        normal: h.normal,
        surface,
    }
}
