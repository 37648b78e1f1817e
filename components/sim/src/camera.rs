//! A forward camera on a pan-tilt-zoom mount, rendering the world as a ray-cast 2.5D view:
//! one ray per image column through the map and the objects, each surface drawn between its
//! bottom and top heights with a pinhole projection, far to near. Walls have the world's
//! height, the floor and the ceiling their colours; signs are white boards with a black
//! arrow on their printed side; people have trousers, a shirt, a head and maybe a cap.
//!
//! Pinhole model (ROS convention: pixel centres at integer coordinates): the focal length
//! comes from the horizontal field of view, which zoom narrows (`tan(fov/2)` divided by the
//! zoom). Pan turns the view exactly; tilt shifts each column's elevations, which is exact
//! in the image's centre column and close elsewhere for the small tilts of a 2.5D world.

use std::f64::consts::PI;

use lewis_interfaces::msg::{CameraControl, ImageSource};

use lewis_geometry::{Pose2, SensorMount, Vec2, wrap_angle};

use super::laser::{SensorConfigError, check_non_negative, check_positive};
use super::world::{ArrowDirection, Hit, Material, Rgb, SIGN_BACK, Sign, Surface, World};
use lewis_service::Rng;

/// The camera's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraConfig {
    /// Image width, in px.
    pub width_px: u32,
    /// Image height, in px.
    pub height_px: u32,
    /// Horizontal field of view at zoom 1, in rad.
    pub horizontal_fov_rad: f64,
    /// Largest zoom (magnification; 1 is the widest).
    pub max_zoom: f64,
    /// Where the camera sits on the robot (its heading is the pan's zero).
    pub mount: SensorMount,
    /// How far the camera sees, in m.
    pub max_range_m: f64,
    /// Standard deviation of each pixel channel's noise, in levels of 255.
    pub pixel_noise_std: f64,
    /// Largest pan either way, in rad.
    pub max_pan_rad: f64,
    /// Largest tilt either way, in rad.
    pub max_tilt_rad: f64,
    /// Frames per second (the service's rate).
    pub rate_hz: f64,
}

impl Default for CameraConfig {
    /// A Sony EVI-D30-like pan-tilt-zoom camera (48.8 degrees wide, 12x zoom, +-100 degrees
    /// of pan, +-25 of tilt) on top of the B21r, 1.2 m above the floor, at 640x480 and
    /// 30 Hz.
    fn default() -> Self {
        Self {
            width_px: 640,
            height_px: 480,
            horizontal_fov_rad: 48.8f64.to_radians(),
            max_zoom: 12.0,
            mount: SensorMount {
                pose: Pose2::new(0.1, 0.0, 0.0),
                height_m: 1.2,
            },
            max_range_m: 50.0,
            pixel_noise_std: 2.0,
            max_pan_rad: 100f64.to_radians(),
            max_tilt_rad: 25f64.to_radians(),
            rate_hz: 30.0,
        }
    }
}

impl CameraConfig {
    /// Checks that every parameter can work.
    ///
    /// # Errors
    /// The first parameter that cannot.
    pub fn validate(&self) -> Result<(), SensorConfigError> {
        for (field, value) in [("width_px", self.width_px), ("height_px", self.height_px)] {
            if value == 0 || value > 8192 {
                return Err(SensorConfigError {
                    device: "camera",
                    field,
                    value: f64::from(value),
                    expected: "between 1 and 8192 pixels",
                });
            }
        }
        check_positive(
            "camera",
            &[
                ("max_range_m", self.max_range_m),
                ("rate_hz", self.rate_hz),
                ("mount.height_m", self.mount.height_m),
            ],
        )?;
        check_non_negative(
            "camera",
            &[
                ("pixel_noise_std", self.pixel_noise_std),
                ("max_pan_rad", self.max_pan_rad),
                ("max_tilt_rad", self.max_tilt_rad),
            ],
        )?;
        if !(self.horizontal_fov_rad > 0.0 && self.horizontal_fov_rad < PI) {
            return Err(SensorConfigError {
                device: "camera",
                field: "horizontal_fov_rad",
                value: self.horizontal_fov_rad,
                expected: "between 0 and pi",
            });
        }
        if !(self.max_zoom.is_finite() && self.max_zoom >= 1.0) {
            return Err(SensorConfigError {
                device: "camera",
                field: "max_zoom",
                value: self.max_zoom,
                expected: "1 or more",
            });
        }
        if self.max_tilt_rad >= PI / 2.0 {
            return Err(SensorConfigError {
                device: "camera",
                field: "max_tilt_rad",
                value: self.max_tilt_rad,
                expected: "below pi/2",
            });
        }
        Ok(())
    }
}

/// The pinhole intrinsics of the current zoom, in px.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Focal length (square pixels: the same both ways), in px.
    pub focal_length_px: f64,
    /// Principal point, column, in px.
    pub principal_x_px: f64,
    /// Principal point, row, in px.
    pub principal_y_px: f64,
}

/// The simulated camera.
#[derive(Debug, Clone)]
pub struct SimCamera {
    config: CameraConfig,
    zoom: f64,
    pan_rad: f64,
    tilt_rad: f64,
    rng: Rng,
    hits: Vec<Hit>,
    grain: Vec<i8>,
}

impl SimCamera {
    /// A camera at zoom 1, looking straight ahead, with its own random generator seeded from
    /// `seed`.
    ///
    /// # Errors
    /// When a parameter cannot work.
    pub fn new(config: CameraConfig, seed: u64) -> Result<Self, SensorConfigError> {
        config.validate()?;
        let mut rng = Rng::for_device(seed, "camera");
        let frame_bytes = config.width_px as usize * config.height_px as usize * 3;
        let grain = grain(config.pixel_noise_std, frame_bytes, &mut rng);
        Ok(Self {
            config,
            zoom: 1.0,
            pan_rad: 0.0,
            tilt_rad: 0.0,
            rng,
            hits: Vec::new(),
            grain,
        })
    }

    /// Its parameters.
    #[must_use]
    pub fn config(&self) -> &CameraConfig {
        &self.config
    }

    /// Sets the zoom, clamped to 1..=max; returns the zoom set (non-finite reads as 1).
    pub fn set_zoom(&mut self, zoom: f64) -> f64 {
        self.zoom = if zoom.is_finite() {
            zoom.clamp(1.0, self.config.max_zoom)
        } else {
            1.0
        };
        self.zoom
    }

    /// Sets pan and tilt, each clamped to its limit; returns what was set.
    pub fn set_pan_tilt(&mut self, pan_rad: f64, tilt_rad: f64) -> (f64, f64) {
        let clamp = |v: f64, max: f64| {
            if v.is_finite() {
                v.clamp(-max, max)
            } else {
                0.0
            }
        };
        self.pan_rad = clamp(pan_rad, self.config.max_pan_rad);
        self.tilt_rad = clamp(tilt_rad, self.config.max_tilt_rad);
        (self.pan_rad, self.tilt_rad)
    }

    /// The CameraControl publication (header left for the service to fill).
    #[must_use]
    pub fn camera_control(&self) -> CameraControl {
        CameraControl {
            zoom: self.zoom,
            focus: self.config.max_range_m,
            iris: 1.0,
            shutter: 1.0 / self.config.rate_hz,
            gain: 0.0,
            pan: self.pan_rad,
            tilt: self.tilt_rad,
            ..CameraControl::default()
        }
    }

    /// The horizontal field of view at the current zoom, in rad.
    #[must_use]
    pub fn horizontal_fov_rad(&self) -> f64 {
        2.0 * ((self.config.horizontal_fov_rad / 2.0).tan() / self.zoom).atan()
    }

    /// The pinhole intrinsics at the current zoom.
    #[must_use]
    pub fn intrinsics(&self) -> Intrinsics {
        let w = f64::from(self.config.width_px);
        let h = f64::from(self.config.height_px);
        Intrinsics {
            focal_length_px: (w / 2.0) / (self.horizontal_fov_rad() / 2.0).tan(),
            principal_x_px: (w - 1.0) / 2.0,
            principal_y_px: (h - 1.0) / 2.0,
        }
    }

    /// The camera's pose in the world (pan included) with the robot at `robot_pose`.
    #[must_use]
    pub fn camera_pose(&self, robot_pose: Pose2) -> Pose2 {
        let mut mount = self.config.mount.pose;
        mount.heading_rad += self.pan_rad;
        robot_pose.compose(mount)
    }

    /// Where the world point (`point`, height `z_m`) appears in the image: (column, row) in
    /// px, or `None` when it is behind the camera or outside the field of view.
    #[must_use]
    pub fn project(&self, robot_pose: Pose2, point: Vec2, z_m: f64) -> Option<(f64, f64)> {
        let cam = self.camera_pose(robot_pose);
        let k = self.intrinsics();
        let d = point - cam.position();
        let bearing = wrap_angle(d.angle() - cam.heading_rad);
        if bearing.abs() >= self.horizontal_fov_rad() / 2.0 {
            return None;
        }
        let u = k.principal_x_px - k.focal_length_px * bearing.tan();
        let depth = d.norm() * bearing.cos();
        let v = self.row_of_height(depth, z_m, &k);
        let h = f64::from(self.config.height_px);
        let w = f64::from(self.config.width_px);
        ((-0.5..w - 0.5).contains(&u) && (-0.5..h - 0.5).contains(&v)).then_some((u, v))
    }

    /// The image row where height `z_m` appears at perpendicular depth `depth_m`.
    fn row_of_height(&self, depth_m: f64, z_m: f64, k: &Intrinsics) -> f64 {
        let elevation = ((z_m - self.config.mount.height_m) / depth_m).atan();
        k.principal_y_px - k.focal_length_px * (elevation - self.tilt_rad).tan()
    }

    /// The height seen at image row `row` at perpendicular depth `depth_m`.
    fn height_of_row(&self, depth_m: f64, row: f64, k: &Intrinsics) -> f64 {
        let elevation = ((k.principal_y_px - row) / k.focal_length_px).atan() + self.tilt_rad;
        self.config.mount.height_m + depth_m * elevation.tan()
    }

    /// Renders the view from `robot_pose` as the ImageSource publication (rgb8; header left
    /// for the service to fill).
    pub fn render(&mut self, world: &World, robot_pose: Pose2) -> ImageSource {
        let mut data = vec![0; self.frame_len()];
        self.render_into(world, robot_pose, &mut data);
        ImageSource {
            data,
            ..self.frame_fields()
        }
    }

    /// The ImageSource publication of a frame but its pixels: size, rgb8, intrinsics
    /// (header left for the service to fill). What a frame rendered in place is sent with.
    #[must_use]
    pub fn frame_fields(&self) -> ImageSource {
        let k = self.intrinsics();
        let width = i32::try_from(self.config.width_px).unwrap_or(i32::MAX);
        ImageSource {
            width,
            height: i32::try_from(self.config.height_px).unwrap_or(i32::MAX),
            encoding: "rgb8".to_owned(),
            step: width.saturating_mul(3),
            focal_length_x: k.focal_length_px,
            focal_length_y: k.focal_length_px,
            principal_point_x: k.principal_x_px,
            principal_point_y: k.principal_y_px,
            ..ImageSource::default()
        }
    }

    /// The bytes of one rgb8 frame: width x height x 3.
    #[must_use]
    pub fn frame_len(&self) -> usize {
        self.config.width_px as usize * self.config.height_px as usize * 3
    }

    /// Renders the view from `robot_pose` into `rgb`, rows top first: every byte is
    /// written, whatever it held (a shared-memory loan holds an earlier frame). `rgb` must be
    /// [`SimCamera::frame_len`] bytes long; a buffer of another length is left as it is.
    pub fn render_into(&mut self, world: &World, robot_pose: Pose2, rgb: &mut [u8]) {
        if rgb.len() != self.frame_len() {
            return;
        }
        let k = self.intrinsics();
        self.paint_floor_and_ceiling(world, &k, rgb);
        self.paint_columns(world, robot_pose, &mut RgbCanvas(rgb));
        self.add_noise(rgb);
    }

    /// What each pixel of the view from `robot_pose` shows, rows top first: the same
    /// rendering as [`SimCamera::render_into`] (without its noise), but naming the surface
    /// of each pixel rather than its colour. This is the simulator's ground truth of an
    /// image: which object is seen where, behind what.
    #[must_use]
    pub fn render_sources(&mut self, world: &World, robot_pose: Pose2) -> Vec<PixelSource> {
        let pixels = self.config.width_px as usize * self.config.height_px as usize;
        let mut sources = vec![PixelSource::Background; pixels];
        self.paint_columns(world, robot_pose, &mut SourceCanvas(&mut sources));
        sources
    }

    /// Paints the walls and the objects of every column over what `canvas` holds.
    fn paint_columns(&mut self, world: &World, robot_pose: Pose2, canvas: &mut impl Canvas) {
        let width = self.config.width_px as usize;
        let height = self.config.height_px as usize;
        let k = self.intrinsics();
        let cam = self.camera_pose(robot_pose);
        let origin = cam.position();
        let mut hits = std::mem::take(&mut self.hits);
        for column in 0..width {
            let x = column as f64;
            let relative = ((k.principal_x_px - x) / k.focal_length_px).atan();
            let dir = Vec2::from_angle(cam.heading_rad + relative);
            hits.clear();
            let wall = world.cast_ray_through(origin, dir, self.config.max_range_m, &mut hits);
            // Far to near, so nearer surfaces cover farther ones.
            hits.sort_by(|a, b| b.range_m.total_cmp(&a.range_m));
            let column_view = Column {
                camera: self,
                world,
                k: &k,
                origin,
                dir,
                cos_relative: relative.cos(),
                column,
                width,
                height,
            };
            if let Some(wall) = wall {
                column_view.paint(&wall, canvas);
            }
            for hit in &hits {
                column_view.paint(hit, canvas);
            }
        }
        self.hits = hits;
    }

    fn paint_floor_and_ceiling(&self, world: &World, k: &Intrinsics, rgb: &mut [u8]) {
        let width = self.config.width_px as usize;
        let look = world.look();
        for (row, line) in rgb.chunks_exact_mut(width * 3).enumerate() {
            let y = row as f64;
            let elevation = ((k.principal_y_px - y) / k.focal_length_px).atan() + self.tilt_rad;
            // A gentle gradient: surfaces far away (near the horizon) a little darker.
            let steepness = elevation.abs().min(0.6) / 0.6;
            let colour = if elevation >= 0.0 {
                look.ceiling_colour.scaled(0.85 + 0.15 * steepness)
            } else {
                look.floor_colour.scaled(0.8 + 0.2 * steepness)
            };
            for pixel in line.chunks_exact_mut(3) {
                pixel.copy_from_slice(&[colour.r, colour.g, colour.b]);
            }
        }
    }

    fn add_noise(&mut self, rgb: &mut [u8]) {
        if self.grain.is_empty() {
            return;
        }
        // A window of the grain at a random place: the noise differs from frame to frame
        // at the cost of one draw, and the addition vectorises.
        let spare = self.grain.len() - rgb.len();
        // below `spare`
        let start = ((self.rng.next_f64() * spare as f64) as usize).min(spare);
        for (value, &offset) in rgb.iter_mut().zip(&self.grain[start..]) {
            *value = value.saturating_add_signed(offset);
        }
    }
}

/// Twice a frame's worth of pixel noise, each channel's value the sum of two uniforms
/// (triangular: close enough to a normal for a sensor's grain) with standard deviation `std`
/// levels, drawn once from `rng`. Empty for no noise.
fn grain(std: f64, frame_bytes: usize, rng: &mut Rng) -> Vec<i8> {
    if std <= 0.0 {
        return Vec::new();
    }
    // The sum of two uniforms on [-0.5, 0.5] has standard deviation 1 / sqrt(6).
    let scale = std * 6f64.sqrt();
    (0..2 * frame_bytes)
        .map(|_| {
            let sum = rng.next_f64() + rng.next_f64() - 1.0;
            // clamped to the i8 range
            (sum * scale).round().clamp(-127.0, 127.0) as i8
        })
        .collect()
}

/// One image column being painted.
struct Column<'a> {
    camera: &'a SimCamera,
    world: &'a World,
    k: &'a Intrinsics,
    origin: Vec2,
    dir: Vec2,
    cos_relative: f64,
    column: usize,
    width: usize,
    height: usize,
}

impl Column<'_> {
    fn paint(&self, hit: &Hit, canvas: &mut impl Canvas) {
        let (bottom_m, top_m, material) = match hit.surface {
            Surface::Map => (
                0.0,
                self.world.look().wall_height_m,
                Material::Solid(self.world.look().wall_colour),
            ),
            Surface::Primitive(i) => {
                let p = &self.world.primitives()[i];
                (p.bottom_m, p.top_m, p.material)
            }
        };
        // Perpendicular depth, so that straight walls stay straight (no fish-eye).
        let depth = (hit.range_m * self.cos_relative).max(1e-3);
        let top_row = self.camera.row_of_height(depth, top_m, self.k);
        let bottom_row = self.camera.row_of_height(depth, bottom_m, self.k);
        let last = (self.height - 1) as f64;
        let first_row = top_row.ceil().max(0.0);
        let last_row = bottom_row.floor().min(last);
        if first_row > last_row {
            return;
        }
        let facing = (-self.dir).dot(hit.normal).abs();
        let shade = 0.65 + 0.35 * facing;
        // within the image
        let (first_row, last_row) = (first_row as usize, last_row as usize);
        match material {
            Material::Solid(colour) => {
                let c = colour.scaled(shade);
                let source = match hit.surface {
                    Surface::Map => PixelSource::Wall,
                    Surface::Primitive(index) => PixelSource::Primitive {
                        index,
                        part: PrimitivePart::Solid,
                    },
                };
                for row in first_row..=last_row {
                    canvas.put(self.index(row), c, source);
                }
            }
            Material::SignBoard(sign) => {
                let point = self.origin + self.dir * hit.range_m;
                let printed_side = self.dir.dot(Vec2::from_angle(sign.facing_rad)) < 0.0;
                let u = (point - sign.viewer_left_edge()).dot(sign.viewer_right()) / sign.width_m;
                let bottom = sign.mounting_height_m - sign.height_m / 2.0;
                for row in first_row..=last_row {
                    let z = self.camera.height_of_row(depth, row as f64, self.k);
                    let v = (z - bottom) / sign.height_m;
                    let part = sign_part(&sign, printed_side, u, v);
                    let colour = part_colour(part).scaled(shade);
                    let source = match hit.surface {
                        Surface::Primitive(index) => PixelSource::Primitive { index, part },
                        Surface::Map => PixelSource::Wall,
                    };
                    canvas.put(self.index(row), colour, source);
                }
            }
        }
    }

    /// The index of the pixel at `row` of this column.
    fn index(&self, row: usize) -> usize {
        row * self.width + self.column
    }
}

/// White of a sign's board.
pub const SIGN_WHITE: Rgb = Rgb::new(245, 245, 245);
/// Black of a sign's arrow.
pub const SIGN_BLACK: Rgb = Rgb::new(15, 15, 15);

fn sign_part(sign: &Sign, printed_side: bool, u: f64, v: f64) -> PrimitivePart {
    if !printed_side {
        return PrimitivePart::SignBack;
    }
    if arrow_covers(sign.arrow, u, v, sign.width_m, sign.height_m) {
        PrimitivePart::SignArrow
    } else {
        PrimitivePart::SignBoard
    }
}

/// The colour of a part of a sign (a solid primitive has its own).
fn part_colour(part: PrimitivePart) -> Rgb {
    match part {
        PrimitivePart::SignBack | PrimitivePart::Solid => SIGN_BACK,
        PrimitivePart::SignArrow => SIGN_BLACK,
        PrimitivePart::SignBoard => SIGN_WHITE,
    }
}

/// What a pixel of a rendering shows ([`SimCamera::render_sources`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelSource {
    /// The floor or the ceiling.
    Background,
    /// A wall of the map.
    Wall,
    /// A primitive of an object.
    Primitive {
        /// Its index in [`World::primitives`].
        index: usize,
        /// Which part of it.
        part: PrimitivePart,
    },
}

/// Which part of a primitive a pixel shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrimitivePart {
    /// A primitive of one colour all over.
    Solid,
    /// The white of a sign's printed side.
    SignBoard,
    /// The black arrow (or disc) of a sign's printed side.
    SignArrow,
    /// The grey back of a sign.
    SignBack,
}

/// Where a rendering's columns are painted: pixels (by index, rows top first) given their
/// colour and what they show; each canvas keeps what it needs.
trait Canvas {
    fn put(&mut self, index: usize, colour: Rgb, source: PixelSource);
}

/// An rgb8 frame.
struct RgbCanvas<'a>(&'a mut [u8]);

impl Canvas for RgbCanvas<'_> {
    #[inline(always)]
    fn put(&mut self, index: usize, c: Rgb, _: PixelSource) {
        let i = index * 3;
        self.0[i..i + 3].copy_from_slice(&[c.r, c.g, c.b]);
    }
}

/// What each pixel shows.
struct SourceCanvas<'a>(&'a mut [PixelSource]);

impl Canvas for SourceCanvas<'_> {
    fn put(&mut self, index: usize, _: Rgb, source: PixelSource) {
        self.0[index] = source;
    }
}

/// Whether the black arrow covers the point (`u`, `v`) of a sign's printed side, `u` from
/// 0 at the viewer's left edge to 1 at the right, `v` from 0 at the bottom to 1 at the top.
/// The arrow fills a centred square of 80% of the board's smaller side: a shaft and a
/// triangular head, pointing `direction`; the desk's sign has a disc filling that square
/// instead.
#[must_use]
pub fn arrow_covers(
    direction: ArrowDirection,
    u: f64,
    v: f64,
    width_m: f64,
    height_m: f64,
) -> bool {
    let side = 0.8 * width_m.min(height_m);
    let a = (u - 0.5) * width_m / side;
    let b = (v - 0.5) * height_m / side;
    // (along, across) the arrow, the tip towards +along.
    let (along, across) = match direction {
        ArrowDirection::Right => (a, b),
        ArrowDirection::Left => (-a, b),
        ArrowDirection::Up => (b, a),
        ArrowDirection::Down => (-b, a),
        ArrowDirection::Desk => return a.hypot(b) <= 0.45,
    };
    let shaft = (-0.45..=0.0).contains(&along) && across.abs() <= 0.12;
    let head = (0.0..=0.45).contains(&along) && across.abs() <= 0.4 * (0.45 - along) / 0.45;
    shaft || head
}

#[cfg(test)]
mod tests {
    use super::*;

    fn draw(direction: ArrowDirection) -> String {
        let mut out = String::new();
        for row in 0..15 {
            for col in 0..15 {
                let u = (f64::from(col) + 0.5) / 15.0;
                let v = 1.0 - (f64::from(row) + 0.5) / 15.0;
                out.push(if arrow_covers(direction, u, v, 1.0, 1.0) {
                    '#'
                } else {
                    '.'
                });
            }
            out.push('\n');
        }
        out
    }

    fn turned_counter_clockwise(art: &str) -> String {
        let rows: Vec<Vec<char>> = art.lines().map(|l| l.chars().collect()).collect();
        let n = rows.len();
        (0..n)
            .map(|r| (0..n).map(|c| rows[c][n - 1 - r]).collect::<String>() + "\n")
            .collect()
    }

    #[test]
    fn arrows_point_the_way_they_are_named() {
        assert_eq!(
            draw(ArrowDirection::Right),
            concat!(
                "...............\n",
                "...............\n",
                "...............\n",
                ".......#.......\n",
                ".......###.....\n",
                ".......####....\n",
                "..##########...\n",
                "..###########..\n",
                "..##########...\n",
                ".......####....\n",
                ".......###.....\n",
                ".......#.......\n",
                "...............\n",
                "...............\n",
                "...............\n",
            )
        );
        let right = draw(ArrowDirection::Right);
        let up = turned_counter_clockwise(&right);
        let left = turned_counter_clockwise(&up);
        let down = turned_counter_clockwise(&left);
        assert_eq!(draw(ArrowDirection::Up), up);
        assert_eq!(draw(ArrowDirection::Left), left);
        assert_eq!(draw(ArrowDirection::Down), down);
    }

    #[test]
    fn the_desk_sign_is_a_disc() {
        assert_eq!(
            draw(ArrowDirection::Desk),
            concat!(
                "...............\n",
                "...............\n",
                ".....#####.....\n",
                "....#######....\n",
                "...#########...\n",
                "..###########..\n",
                "..###########..\n",
                "..###########..\n",
                "..###########..\n",
                "..###########..\n",
                "...#########...\n",
                "....#######....\n",
                ".....#####.....\n",
                "...............\n",
                "...............\n",
            )
        );
    }
}
