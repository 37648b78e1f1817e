//! The objects of a world (walls, doors, landmarks, signs, desks, people) and the solid
//! primitives they are made of: a plane shape extruded between two heights, with a look.

use lewis_geometry::Vec2;

use crate::geometry::Shape;

/// A colour, 8 bits per channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Rgb {
    /// Red.
    pub r: u8,
    /// Green.
    pub g: u8,
    /// Blue.
    pub b: u8,
}

impl Rgb {
    /// The colour (r, g, b).
    #[must_use]
    pub const fn new(r: u8, g: u8, b: u8) -> Self {
        Self { r, g, b }
    }

    /// The colour names a world file may use, with their values.
    pub const NAMED: &'static [(&'static str, Self)] = &[
        ("black", Self::new(20, 20, 20)),
        ("blue", Self::new(30, 60, 200)),
        ("brown", Self::new(120, 75, 40)),
        ("cyan", Self::new(30, 190, 200)),
        ("green", Self::new(30, 160, 50)),
        ("grey", Self::new(128, 128, 128)),
        ("magenta", Self::new(200, 40, 180)),
        ("orange", Self::new(240, 130, 20)),
        ("pink", Self::new(240, 150, 180)),
        ("purple", Self::new(110, 40, 150)),
        ("red", Self::new(210, 25, 25)),
        ("white", Self::new(245, 245, 245)),
        ("yellow", Self::new(230, 210, 30)),
    ];

    /// Parses `#rrggbb` or one of [`Rgb::NAMED`]; `None` for anything else.
    #[must_use]
    pub fn parse(text: &str) -> Option<Self> {
        if let Some(hex) = text.strip_prefix('#') {
            if hex.len() != 6 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
                return None;
            }
            let channel = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).ok();
            return Some(Self::new(channel(0)?, channel(2)?, channel(4)?));
        }
        Self::NAMED
            .iter()
            .find(|(name, _)| name.eq_ignore_ascii_case(text))
            .map(|&(_, c)| c)
    }

    /// This colour scaled by `k` (0 to 1), for shading.
    #[must_use]
    pub fn scaled(self, k: f64) -> Self {
        // clamped to 0..=255
        let f = |c: u8| (f64::from(c) * k).round().clamp(0.0, 255.0) as u8;
        Self::new(f(self.r), f(self.g), f(self.b))
    }
}

/// Which way the arrow on a sign points, as someone facing the sign sees it; or the
/// registration desk's own sign, which points nowhere.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ArrowDirection {
    /// To the viewer's left: turn left.
    Left,
    /// To the viewer's right: turn right.
    Right,
    /// Upwards: straight ahead.
    Up,
    /// Downwards: back, or here.
    Down,
    /// No arrow but a filled black disc: the registration desk is here.
    Desk,
}

impl ArrowDirection {
    /// The name used in world files and in the Signs interface.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Left => "left",
            Self::Right => "right",
            Self::Up => "up",
            Self::Down => "down",
            Self::Desk => "desk",
        }
    }

    /// Parses a name of [`ArrowDirection::name`].
    #[must_use]
    pub fn parse(text: &str) -> Option<Self> {
        [Self::Left, Self::Right, Self::Up, Self::Down, Self::Desk]
            .into_iter()
            .find(|d| d.name() == text)
    }
}

/// A direction sign: a white board with a black arrow (or the desk's disc), facing one way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sign {
    /// Centre of the board, seen from above.
    pub centre: Vec2,
    /// The direction the printed face looks towards, in rad (world frame).
    pub facing_rad: f64,
    /// Board width, in m.
    pub width_m: f64,
    /// Board height, in m.
    pub height_m: f64,
    /// Height of the board's centre above the floor, in m.
    pub mounting_height_m: f64,
    /// The arrow.
    pub arrow: ArrowDirection,
    /// Whether the board stands on a post (an obstacle down to the floor).
    pub post: bool,
}

impl Sign {
    /// The unit vector pointing to the right of someone facing the printed side.
    #[must_use]
    pub fn viewer_right(&self) -> Vec2 {
        // The viewer looks along -facing; their right is that turned clockwise.
        Vec2::from_angle(self.facing_rad).perpendicular()
    }

    /// The board's left edge as the viewer sees it.
    #[must_use]
    pub fn viewer_left_edge(&self) -> Vec2 {
        self.centre - self.viewer_right() * (self.width_m / 2.0)
    }
}

/// A person standing still: a body, a head, and possibly a cap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Person {
    /// Where they stand.
    pub centre: Vec2,
    /// Radius of the body seen from above, in m.
    pub radius_m: f64,
    /// Height, in m.
    pub height_m: f64,
    /// Shirt colour.
    pub shirt: Rgb,
    /// Trousers colour.
    pub trousers: Rgb,
    /// Cap colour, if they wear one.
    pub cap: Option<Rgb>,
}

/// One object of the world, as its file describes it.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldObject {
    /// Its name (given in the file, or `KIND-N`).
    pub name: String,
    /// What it is.
    pub kind: ObjectKind,
}

/// What an object is.
#[derive(Debug, Clone, PartialEq)]
pub enum ObjectKind {
    /// A wall added to the map's.
    Wall {
        /// Its footprint.
        shape: Shape,
        /// Height, in m.
        height_m: f64,
        /// Colour.
        colour: Rgb,
    },
    /// A door that can be open (no obstacle) or closed (a panel across the doorway).
    Door {
        /// The panel's footprint.
        shape: Shape,
        /// Height, in m.
        height_m: f64,
        /// Colour.
        colour: Rgb,
        /// Whether it is open when the world is loaded.
        open: bool,
    },
    /// A coloured pillar or box, to be found by colour.
    Landmark {
        /// Its footprint (a circle for a pillar, a rectangle for a box).
        shape: Shape,
        /// Height, in m.
        height_m: f64,
        /// Colour.
        colour: Rgb,
    },
    /// A direction sign.
    Sign(Sign),
    /// The registration desk.
    Desk {
        /// Its footprint.
        shape: Shape,
        /// Height, in m.
        height_m: f64,
        /// Colour.
        colour: Rgb,
    },
    /// A person.
    Person(Person),
}

impl ObjectKind {
    /// The kind's name in world files.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::Wall { .. } => "wall",
            Self::Door { .. } => "door",
            Self::Landmark { .. } => "landmark",
            Self::Sign(_) => "sign",
            Self::Desk { .. } => "desk",
            Self::Person(_) => "person",
        }
    }
}

/// How a primitive looks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Material {
    /// One colour all over.
    Solid(Rgb),
    /// A sign board: white with a black arrow on the printed side, grey at the back.
    SignBoard(Sign),
}

/// A solid piece of an object: a plane shape between two heights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Primitive {
    /// Footprint.
    pub shape: Shape,
    /// Bottom, in m above the floor.
    pub bottom_m: f64,
    /// Top, in m above the floor.
    pub top_m: f64,
    /// Look.
    pub material: Material,
    /// Index of the object it belongs to.
    pub object: usize,
    /// Index of the door it belongs to, if it is a door's panel (absent while open).
    pub door: Option<usize>,
}

impl Primitive {
    /// Whether it covers height `z_m`.
    #[must_use]
    pub fn spans_height(&self, z_m: f64) -> bool {
        self.bottom_m <= z_m && z_m <= self.top_m
    }
}

/// Colour of a sign's back and of its post.
pub const SIGN_BACK: Rgb = Rgb::new(150, 150, 150);
/// Colour of a sign's post.
pub const SIGN_POST: Rgb = Rgb::new(70, 70, 75);
/// Skin colour of the simulated people.
pub const SKIN: Rgb = Rgb::new(224, 172, 140);
/// Radius of a sign's post, in m.
pub const SIGN_POST_RADIUS_M: f64 = 0.025;

/// The primitives of one object, appended to `out`; `door` numbers the doors seen so far.
pub(crate) fn primitives_of(
    object: &WorldObject,
    index: usize,
    door_index: &mut usize,
    out: &mut Vec<Primitive>,
) {
    let mut push = |shape: Shape, bottom_m: f64, top_m: f64, material: Material, door| {
        out.push(Primitive {
            shape,
            bottom_m,
            top_m,
            material,
            object: index,
            door,
        });
    };
    match &object.kind {
        ObjectKind::Wall {
            shape,
            height_m,
            colour,
        }
        | ObjectKind::Landmark {
            shape,
            height_m,
            colour,
        }
        | ObjectKind::Desk {
            shape,
            height_m,
            colour,
        } => push(*shape, 0.0, *height_m, Material::Solid(*colour), None),
        ObjectKind::Door {
            shape,
            height_m,
            colour,
            ..
        } => {
            push(
                *shape,
                0.0,
                *height_m,
                Material::Solid(*colour),
                Some(*door_index),
            );
            *door_index += 1;
        }
        ObjectKind::Sign(sign) => {
            let left = sign.viewer_left_edge();
            let right = left + sign.viewer_right() * sign.width_m;
            let bottom = sign.mounting_height_m - sign.height_m / 2.0;
            push(
                Shape::Segment { a: left, b: right },
                bottom,
                bottom + sign.height_m,
                Material::SignBoard(*sign),
                None,
            );
            if sign.post && bottom > 0.0 {
                let post = Shape::Circle {
                    centre: sign.centre - Vec2::from_angle(sign.facing_rad) * SIGN_POST_RADIUS_M,
                    radius_m: SIGN_POST_RADIUS_M,
                };
                push(post, 0.0, bottom, Material::Solid(SIGN_POST), None);
            }
        }
        ObjectKind::Person(p) => {
            let h = p.height_m;
            let r = p.radius_m;
            let circle = |radius_m| Shape::Circle {
                centre: p.centre,
                radius_m,
            };
            push(
                circle(0.8 * r),
                0.0,
                0.47 * h,
                Material::Solid(p.trousers),
                None,
            );
            push(
                circle(r),
                0.47 * h,
                0.82 * h,
                Material::Solid(p.shirt),
                None,
            );
            push(circle(0.45 * r), 0.82 * h, h, Material::Solid(SKIN), None);
            if let Some(cap) = p.cap {
                // A cap slightly wider than the head, over its top part.
                push(
                    circle(0.52 * r),
                    0.925 * h,
                    h + 0.02,
                    Material::Solid(cap),
                    None,
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_parse_from_hex_and_names_and_nothing_else() {
        for (text, expected) in [
            ("#ff0080", Some(Rgb::new(255, 0, 128))),
            ("#FF0080", Some(Rgb::new(255, 0, 128))),
            ("red", Some(Rgb::new(210, 25, 25))),
            ("Red", Some(Rgb::new(210, 25, 25))),
            ("#ff008", None),
            ("#gg0000", None),
            ("reddish", None),
            ("", None),
        ] {
            assert_eq!(Rgb::parse(text), expected, "{text}");
        }
    }

    #[test]
    fn a_viewer_facing_a_sign_has_its_left_edge_on_their_left() {
        // The sign faces west (-x): the viewer stands west of it looking east, and their
        // left is north (+y).
        let sign = Sign {
            centre: Vec2::new(0.0, 0.0),
            facing_rad: std::f64::consts::PI,
            width_m: 1.0,
            height_m: 0.5,
            mounting_height_m: 1.5,
            arrow: ArrowDirection::Left,
            post: false,
        };
        let left = sign.viewer_left_edge();
        assert!(
            (left.y - 0.5).abs() < 1e-12 && left.x.abs() < 1e-12,
            "{left:?}"
        );
    }
}
