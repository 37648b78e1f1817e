//! Direction signs: white boards with a black arrow, found with CMVision and read from the
//! arrow's shape.
//!
//! 1. CMVision with two classes, the board's white and the arrow's black.
//! 2. A sign is a white region of at least `min_board_area_px` with a black region nested
//!    in its bounding box, near its centre, covering a plausible part of it (an arrow, not a
//!    speck nor a hole); the largest such black region is the arrow.
//! 3. The arrow is read in the original image: the black pixels of its box, in coordinates
//!    where the board regains its known aspect ratio (a sign seen at an angle is narrower
//!    than it is), give the arrow's axis from their second moments; the head is on the side
//!    of the axis's midpoint where the pixels spread furthest across it (the head is wide,
//!    the shaft thin). Direction: the angle of the head from the axis's midpoint, in the
//!    image plane, 0 to the right and pi/2 up; the label is the nearest of right, up, left
//!    and down; the confidence is how much more the head spreads than the shaft, 0 to 1.
//! 4. Distance from the board's known height and its height in pixels (a sign turned away
//!    keeps its height), then the position along the ray through the board's centre.
//!
//! The registration desk's own sign has a filled black disc instead of an arrow: a black
//! region whose pixels, with the board's aspect restored, are round (the second moments'
//! eigenvalues differ by less than [`DISC_MAX_ELONGATION`]) and fill their box (more than
//! [`DISC_MIN_FILL`]; an arrow fills some 40%, a disc pi/4) is read as [`ArrowLabel::Desk`].

use std::f64::consts::{FRAC_PI_2, PI};

use lewis_interfaces::msg::{Point3D, Sign, SignArrow};

use super::blobfinder::blob_of;
use super::camera_model::PinholeCamera;
use super::cmvision::{
    ChannelRange, CmVision, ColorClass, ColorConfig, ConfigError, Region, RgbFrame, rgb_to_yuv,
};

/// What a sign looks like and how strict the detector is.
#[derive(Debug, Clone, PartialEq)]
pub struct SignModel {
    /// The board's height, in m.
    pub board_height_m: f64,
    /// The board's width over its height.
    pub board_aspect: f64,
    /// Smaller white regions are not boards, in px.
    pub min_board_area_px: u32,
    /// Smaller black regions are not arrows, in px.
    pub min_arrow_area_px: u32,
    /// The arrow's pixels over the board's bounding box: the smallest and largest part that
    /// is an arrow.
    pub arrow_fraction: (f64, f64),
    /// Signs whose confidence is below this are not reported.
    pub min_confidence: f64,
}

impl Default for SignModel {
    /// The simulator's signs: 0.6 m by 0.45 m boards.
    fn default() -> Self {
        Self {
            board_height_m: 0.45,
            board_aspect: 0.6 / 0.45,
            min_board_area_px: 150,
            min_arrow_area_px: 20,
            arrow_fraction: (0.03, 0.5),
            min_confidence: 0.2,
        }
    }
}

/// The board's white and the arrow's black as CMVision classes (colour 0 white, colour 1
/// black), in YUV: white is bright and grey (walls and ceilings in warm or dim light are
/// not), black is dark and grey.
#[must_use]
pub fn default_sign_colors() -> ColorConfig {
    let class = |name: &str, rgb: [u8; 3], y: (u8, u8), uv: (u8, u8)| ColorClass {
        name: name.to_owned(),
        display_rgb: rgb,
        merge_density: 0.0,
        expected_regions: 0,
        y: ChannelRange { lo: y.0, hi: y.1 },
        u: ChannelRange { lo: uv.0, hi: uv.1 },
        v: ChannelRange { lo: uv.0, hi: uv.1 },
    };
    ColorConfig {
        colors: vec![
            class("White", [255, 255, 255], (180, 255), (118, 138)),
            class("Black", [0, 0, 0], (0, 70), (110, 146)),
        ],
        min_area_px: 10,
    }
}

/// A black region whose second moments' eigenvalues differ more than this is no disc.
pub const DISC_MAX_ELONGATION: f64 = 1.6;

/// A black region that fills less of its bounding box than this is no disc.
pub const DISC_MIN_FILL: f64 = 0.6;

/// Which way an arrow points, in the image; or the desk's disc.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ArrowLabel {
    /// To the right of the image.
    Right,
    /// Up the image (straight on, on a direction sign).
    Up,
    /// To the left of the image.
    Left,
    /// Down the image.
    Down,
    /// No arrow but a disc: the registration desk's own sign.
    Desk,
}

impl ArrowLabel {
    /// `right`, `up`, `left`, `down` or `desk`, as the Signs interface names them.
    #[must_use]
    pub fn name(self) -> &'static str {
        self.word().as_str()
    }

    /// The Signs interface's word for it.
    #[must_use]
    pub fn word(self) -> SignArrow {
        match self {
            Self::Right => SignArrow::Right,
            Self::Up => SignArrow::Up,
            Self::Left => SignArrow::Left,
            Self::Down => SignArrow::Down,
            Self::Desk => SignArrow::Desk,
        }
    }

    /// The label nearest to a direction (0 right, pi/2 up).
    #[must_use]
    pub fn nearest(direction_rad: f64) -> Self {
        let quarter = (direction_rad / FRAC_PI_2).round().rem_euclid(4.0);
        match quarter {
            q if q < 0.5 => Self::Right,
            q if q < 1.5 => Self::Up,
            q if q < 2.5 => Self::Left,
            _ => Self::Down,
        }
    }
}

/// How round and how full the pixels (column, row) of a black region are, with columns
/// scaled by `x_scale` first: `Some(confidence)` (how much of a disc's share of its box
/// they fill, 0 to 1) when they are the desk's disc, `None` otherwise or for fewer than 3
/// pixels.
#[must_use]
pub fn read_disc(pixels: &[(f64, f64)], x_scale: f64) -> Option<f64> {
    if pixels.len() < 3 {
        return None;
    }
    // pixel counts are far below 2^52
    let n = pixels.len() as f64;
    let (mut lo_x, mut hi_x, mut lo_y, mut hi_y) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for &(x, y) in pixels {
        lo_x = lo_x.min(x);
        hi_x = hi_x.max(x);
        lo_y = lo_y.min(y);
        hi_y = hi_y.max(y);
    }
    let fill = n / ((hi_x - lo_x + 1.0) * (hi_y - lo_y + 1.0));
    let points = || pixels.iter().map(|&(x, y)| (x * x_scale, y));
    let (sx, sy) = points().fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let (mut m20, mut m02, mut m11) = (0.0, 0.0, 0.0);
    for (x, y) in points() {
        let (dx, dy) = (x - mx, y - my);
        m20 += dx * dx;
        m02 += dy * dy;
        m11 += dx * dy;
    }
    let mean = (m20 + m02) / 2.0;
    let spread = ((m20 - m02) / 2.0).hypot(m11);
    let (major, minor) = (mean + spread, mean - spread);
    let round = minor > 0.0 && major / minor < DISC_MAX_ELONGATION;
    (round && fill > DISC_MIN_FILL).then(|| (fill / std::f64::consts::FRAC_PI_4).min(1.0))
}

/// The arrow read from its pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArrowReading {
    /// Direction in the image plane, 0 right, pi/2 up, in (-pi, pi].
    pub direction_rad: f64,
    /// How much more the head spreads across the axis than the tail, 0 to 1.
    pub confidence: f64,
}

/// Reads an arrow from the image coordinates (column, row) of its pixels, with columns
/// scaled by `x_scale` first (to undo a sign's foreshortening). `None` for fewer than 3
/// pixels.
#[must_use]
pub fn read_arrow(pixels: &[(f64, f64)], x_scale: f64) -> Option<ArrowReading> {
    if pixels.len() < 3 {
        return None;
    }
    // pixel counts are far below 2^52
    let n = pixels.len() as f64;
    // y up, so that angles read as in the Signs interface.
    let points = || pixels.iter().map(|&(x, y)| (x * x_scale, -y));
    let (sx, sy) = points().fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let (mut m20, mut m02, mut m11) = (0.0, 0.0, 0.0);
    for (x, y) in points() {
        let (dx, dy) = (x - mx, y - my);
        m20 += dx * dx;
        m02 += dy * dy;
        m11 += dx * dy;
    }
    let axis = 0.5 * (2.0 * m11).atan2(m20 - m02);
    let (sin, cos) = axis.sin_cos();
    let along = |(x, y): (f64, f64)| (x - mx) * cos + (y - my) * sin;
    let across = |(x, y): (f64, f64)| -(x - mx) * sin + (y - my) * cos;
    let (lo, hi) = points()
        .map(along)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), t| {
            (l.min(t), h.max(t))
        });
    let middle = (lo + hi) / 2.0;
    let (mut forward, mut backward) = (0.0, 0.0);
    for p in points() {
        let spread = across(p).abs();
        if along(p) > middle {
            forward += spread;
        } else {
            backward += spread;
        }
    }
    let total = forward + backward;
    if total <= 0.0 {
        return None;
    }
    let direction = if forward >= backward { axis } else { axis + PI };
    let direction = if direction > PI {
        direction - 2.0 * PI
    } else {
        direction
    };
    Some(ArrowReading {
        direction_rad: direction,
        confidence: (forward - backward).abs() / total,
    })
}

/// A sign found in an image.
#[derive(Debug, Clone, PartialEq)]
pub struct FoundSign {
    /// The board's white region.
    pub board: Region,
    /// The arrow's black region.
    pub arrow: Region,
    /// The arrow as read.
    pub reading: ArrowReading,
    /// The arrow's label.
    pub label: ArrowLabel,
    /// The board's height in the image at its middle column, in px.
    pub height_px: u32,
}

/// Finds direction signs in RGB frames.
pub struct SignFinder {
    cmvision: CmVision,
    model: SignModel,
    board_color: u8,
    arrow_color: u8,
    arrow_pixels: Vec<(f64, f64)>,
}

impl SignFinder {
    /// A finder with the classes of `colors`, where colour ids `board_color` and
    /// `arrow_color` are the board's and the arrow's.
    ///
    /// # Errors
    /// When the configuration has more classes than CMVision handles.
    pub fn new(
        colors: &ColorConfig,
        board_color: u8,
        arrow_color: u8,
        model: SignModel,
    ) -> Result<Self, ConfigError> {
        Ok(Self {
            cmvision: CmVision::new(colors)?,
            model,
            board_color,
            arrow_color,
            arrow_pixels: Vec::new(),
        })
    }

    /// The sign model.
    #[must_use]
    pub fn model(&self) -> &SignModel {
        &self.model
    }

    /// The CMVision instance (its classes).
    #[must_use]
    pub fn cmvision(&self) -> &CmVision {
        &self.cmvision
    }

    /// The signs of one frame, largest board first.
    pub fn find(&mut self, frame: RgbFrame<'_>) -> Vec<FoundSign> {
        self.cmvision.process(frame);
        let boards: Vec<Region> = self
            .cmvision
            .regions_of_color(self.board_color)
            .iter()
            .filter(|r| r.area_px >= self.model.min_board_area_px)
            .copied()
            .collect();
        let arrows = self.cmvision.regions_of_color(self.arrow_color).to_vec();
        let mut signs = Vec::new();
        for board in boards {
            let Some(arrow) = arrows
                .iter()
                .find(|arrow| self.is_arrow_of(&board, arrow))
                .copied()
            else {
                continue;
            };
            let Some((reading, label)) = self.read(frame, &board, &arrow) else {
                continue;
            };
            if reading.confidence < self.model.min_confidence {
                continue;
            }
            signs.push(FoundSign {
                height_px: self.centre_height_px(frame, &board),
                board,
                arrow,
                label,
                reading,
            });
        }
        signs
    }

    /// Whether `arrow` (a black region; they come largest first) sits inside `board` as an
    /// arrow does.
    fn is_arrow_of(&self, board: &Region, arrow: &Region) -> bool {
        let inside = arrow.left_px > board.left_px
            && arrow.right_px < board.right_px
            && arrow.top_px > board.top_px
            && arrow.bottom_px < board.bottom_px;
        let box_area = f64::from(board.width_px()) * f64::from(board.height_px());
        let fraction = f64::from(arrow.area_px) / box_area;
        let board_cx = f64::from(board.left_px + board.right_px) / 2.0;
        let board_cy = f64::from(board.top_px + board.bottom_px) / 2.0;
        let centred = (arrow.centroid_x_px - board_cx).abs() < 0.25 * f64::from(board.width_px())
            && (arrow.centroid_y_px - board_cy).abs() < 0.25 * f64::from(board.height_px());
        inside
            && centred
            && arrow.area_px >= self.model.min_arrow_area_px
            && (self.model.arrow_fraction.0..=self.model.arrow_fraction.1).contains(&fraction)
    }

    /// Reads the arrow (or the desk's disc) from the pixels of its box that are of the
    /// arrow's class.
    fn read(
        &mut self,
        frame: RgbFrame<'_>,
        board: &Region,
        arrow: &Region,
    ) -> Option<(ArrowReading, ArrowLabel)> {
        let width = frame.width_px() as usize;
        let bit = 1u32 << self.arrow_color;
        self.arrow_pixels.clear();
        for row in arrow.top_px..=arrow.bottom_px {
            for column in arrow.left_px..=arrow.right_px {
                let i = (row as usize * width + column as usize) * 3;
                let p = frame.data().get(i..i + 3)?;
                if self.cmvision.class_mask_yuv(rgb_to_yuv(p[0], p[1], p[2])) & bit != 0 {
                    self.arrow_pixels.push((f64::from(column), f64::from(row)));
                }
            }
        }
        let apparent_aspect = f64::from(board.width_px()) / f64::from(board.height_px());
        let x_scale = self.model.board_aspect / apparent_aspect;
        if let Some(confidence) = read_disc(&self.arrow_pixels, x_scale) {
            let reading = ArrowReading {
                direction_rad: 0.0,
                confidence,
            };
            return Some((reading, ArrowLabel::Desk));
        }
        let reading = read_arrow(&self.arrow_pixels, x_scale)?;
        Some((reading, ArrowLabel::nearest(reading.direction_rad)))
    }

    /// The board's height in px at the middle column of its box: where a sign turned
    /// away from the camera is as far as its centre (its box's height is that of its nearer
    /// edge). The board's and the arrow's pixels both count.
    fn centre_height_px(&self, frame: RgbFrame<'_>, board: &Region) -> u32 {
        let width = frame.width_px() as usize;
        let column = ((board.left_px + board.right_px) / 2) as usize;
        let bits = (1u32 << self.board_color) | (1u32 << self.arrow_color);
        let on_board = |row: u32| {
            let i = (row as usize * width + column) * 3;
            frame.data().get(i..i + 3).is_some_and(|p| {
                self.cmvision.class_mask_yuv(rgb_to_yuv(p[0], p[1], p[2])) & bits != 0
            })
        };
        let top = (board.top_px..=board.bottom_px).find(|&r| on_board(r));
        let bottom = (board.top_px..=board.bottom_px)
            .rev()
            .find(|&r| on_board(r));
        match (top, bottom) {
            (Some(top), Some(bottom)) => bottom - top + 1,
            _ => board.height_px(),
        }
    }

    /// The Signs interface's record of a found sign, placed with `camera` (by the board's
    /// known height).
    #[must_use]
    pub fn sign_message(&self, sign: &FoundSign, camera: &PinholeCamera) -> Sign {
        let k = camera.intrinsics();
        let board = &sign.board;
        let depth_m = self.model.board_height_m * k.focal_length_y_px / f64::from(sign.height_px);
        let centre_x = f64::from(board.left_px + board.right_px) / 2.0;
        let centre_y = f64::from(board.top_px + board.bottom_px) / 2.0;
        let point = camera.point_at_depth(centre_x, centre_y, depth_m);
        Sign {
            position: Point3D {
                x: point.x,
                y: point.y,
                z: point.z,
            },
            arrow_direction: sign.reading.direction_rad,
            arrow: sign.label.name().to_owned(),
            confidence: sign.reading.confidence,
            board: blob_of(
                board,
                self.cmvision.colors().get(usize::from(self.board_color)),
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pixels of an arrow drawn on a grid: `#` is black.
    fn pixels(art: &str) -> Vec<(f64, f64)> {
        art.lines()
            .enumerate()
            .flat_map(|(row, line)| {
                line.chars()
                    .enumerate()
                    .filter(|&(_, c)| c == '#')
                    .map(move |(col, _)| (col as f64, row as f64))
            })
            .collect()
    }

    const RIGHT: &str = "\
.......#.......
.......###.....
.......####....
..##########...
..###########..
..##########...
.......####....
.......###.....
.......#.......
";

    fn turned_counter_clockwise(art: &str) -> String {
        let rows: Vec<Vec<char>> = art.lines().map(|l| l.chars().collect()).collect();
        let (h, w) = (rows.len(), rows[0].len());
        (0..w)
            .map(|r| (0..h).map(|c| rows[c][w - 1 - r]).collect::<String>() + "\n")
            .collect()
    }

    fn check(art: &str, x_scale: f64, expected: ArrowLabel) {
        let reading = read_arrow(&pixels(art), x_scale).unwrap();
        assert_eq!(
            ArrowLabel::nearest(reading.direction_rad),
            expected,
            "{art}\n{reading:?}"
        );
        assert!(reading.confidence > 0.3, "{art}\n{reading:?}");
    }

    #[test]
    fn arrows_are_read_in_all_four_directions() {
        let up = turned_counter_clockwise(RIGHT);
        let left = turned_counter_clockwise(&up);
        let down = turned_counter_clockwise(&left);
        check(RIGHT, 1.0, ArrowLabel::Right);
        check(&up, 1.0, ArrowLabel::Up);
        check(&left, 1.0, ArrowLabel::Left);
        check(&down, 1.0, ArrowLabel::Down);
    }

    #[test]
    fn a_squashed_arrow_is_read_once_its_width_is_restored() {
        // Every other column of the right arrow: as seen from 60 degrees aside.
        let squashed: String = RIGHT
            .lines()
            .map(|l| l.chars().step_by(2).collect::<String>() + "\n")
            .collect();
        check(&squashed, 2.0, ArrowLabel::Right);
    }

    #[test]
    fn labels_are_the_nearest_quarter_turn() {
        let cases = [
            (0.0, ArrowLabel::Right),
            (0.7, ArrowLabel::Right),
            (0.9, ArrowLabel::Up),
            (PI, ArrowLabel::Left),
            (-PI, ArrowLabel::Left),
            (-1.6, ArrowLabel::Down),
            (4.7, ArrowLabel::Down),
        ];
        for (direction, label) in cases {
            assert_eq!(ArrowLabel::nearest(direction), label, "{direction}");
        }
    }

    const DISC: &str = "\
.....#####.....
....#######....
...#########...
..###########..
..###########..
..###########..
..###########..
..###########..
...#########...
....#######....
.....#####.....
";

    #[test]
    fn a_disc_is_the_desk_and_no_arrow_is() {
        let confidence = read_disc(&pixels(DISC), 1.0).unwrap();
        assert!(confidence > 0.9, "{confidence}");
        // Seen from the side and restored.
        let squashed: String = DISC
            .lines()
            .map(|l| l.chars().step_by(2).collect::<String>() + "\n")
            .collect();
        assert!(read_disc(&pixels(&squashed), 2.0).is_some());
        let up = turned_counter_clockwise(RIGHT);
        for arrow in [RIGHT, &up] {
            assert_eq!(read_disc(&pixels(arrow), 1.0), None, "{arrow}");
        }
        assert_eq!(ArrowLabel::Desk.name(), "desk");
    }

    #[test]
    fn too_few_pixels_are_no_arrow() {
        assert_eq!(read_arrow(&[(0.0, 0.0), (1.0, 0.0)], 1.0), None);
    }
}
