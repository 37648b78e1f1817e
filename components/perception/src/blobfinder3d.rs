//! `blobfinder3d`: Blobs placed in space with a range finder.
//!
//! Each blob's centroid gives a ray from the camera (the pinhole model of
//! [`super::camera_model`], with nalgebra); the range finder's beam along that ray's bearing,
//! as seen from the range finder (not from the camera: the two sit apart, so the bearing
//! depends on the range, which a few fixed-point steps settle), gives the horizontal
//! distance; the point of the ray at that distance is the blob's position in the robot
//! frame, and the blob's size in pixels times its depth over the focal length its size in
//! metres. The range is the median of the readings of the beams across the middle half of
//! the blob's width, so that one beam that slips past the object's edge does not move it.
//!
//! The range finder's geometry comes with every RangeFinder message (its offsets, or one
//! pose per beam); the camera's place and field of view are parameters:
//!
//! ```toml
//! [[services]]
//! name = "blobs3d"
//! kind = "blobfinder3d"
//! requires = ["Blobs", "RangeFinder"]
//! provides = [{ interface = "Blobs3D", quality = 10, cost = 1 }]
//! [services.parameters]
//! horizontal_fov_deg = 48.8     # the camera's, at the resolution of the Blobs it gets
//! max_range_m = 8.0             # readings beyond are not used
//! max_scan_age_ms = 500         # an older scan is not used
//! camera = { x_m = 0.1, y_m = 0.0, z_m = 1.2, pan_rad = 0.0, tilt_rad = 0.0 }
//! # Optional: other cameras the Blobs may come from, by service name (their images' channel
//! # is in each Blobs message's inputs); `camera` is for any other.
//! cameras = { camera2 = { x_m = 0.1, y_m = -0.12, z_m = 1.2, pan_rad = 0.0, tilt_rad = 0.0 } }
//! ```
//!
//! A blob with no usable reading is still published, with `range_valid` false and a zero
//! position and size.

use std::collections::BTreeMap;

use lewis_geometry::wrap_angle;
use lewis_images::ImageIntrinsics;
use lewis_interfaces::msg::{
    Blob, Blob3D, Blobs, Blobs3D, Blobs3DCommand, Blobs3DSetMaxRangeReply, InputRef, Point3D,
    RangeFinder,
};
use lewis_service::Health;
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Input, Reply, Service, ServiceConfig,
};
use nalgebra::Point2;
use serde::Deserialize;

use super::camera_model::{CameraMount, CameraMounts, PinholeCamera};

/// The kind name in robot files.
pub const KIND: &str = "blobfinder3d";

/// The parameters of `blobfinder3d`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// The camera's horizontal field of view, in degrees.
    pub horizontal_fov_deg: f64,
    /// Range readings beyond this are not used, in m.
    pub max_range_m: f64,
    /// A scan older than this (on the service's clock) is not used, in ms.
    pub max_scan_age_ms: u64,
    /// Where the camera sits on the robot.
    pub camera: CameraMount,
    /// Where each other camera sits, by its service's name, for Blobs found in its images
    /// (the broker may move the blob finder to another camera).
    pub cameras: BTreeMap<String, CameraMount>,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            horizontal_fov_deg: 48.8,
            max_range_m: 8.0,
            max_scan_age_ms: 500,
            camera: CameraMount::default(),
            cameras: BTreeMap::new(),
        }
    }
}

/// One beam of a range scan: where it starts and where it looks (robot frame, from above).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Beam {
    origin: Point2<f64>,
    bearing_rad: f64,
    range_m: f64,
}

/// A range scan as a list of beams, whatever the RangeFinder's layout.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scan {
    beams: Vec<Beam>,
    max_range_m: f64,
}

impl Scan {
    /// The beams of a RangeFinder message: uniform ones from the offsets and separations,
    /// others from their one pose per beam.
    #[must_use]
    pub fn from_range_finder(scan: &RangeFinder) -> Self {
        let beams = scan
            .ranges
            .iter()
            .enumerate()
            .map(|(i, &range_m)| {
                if scan.uniform {
                    // beam counts are small
                    let i = i as f64;
                    Beam {
                        origin: Point2::new(
                            scan.x_offset + i * scan.x_separation,
                            scan.y_offset + i * scan.y_separation,
                        ),
                        bearing_rad: scan.theta_offset + i * scan.theta_separation,
                        range_m,
                    }
                } else {
                    let pose = scan.sensor_positions.get(i).cloned().unwrap_or_default();
                    Beam {
                        origin: Point2::new(pose.x, pose.y),
                        bearing_rad: pose.theta,
                        range_m,
                    }
                }
            })
            .collect();
        Self {
            beams,
            max_range_m: scan.max_range,
        }
    }

    /// The beam that looks closest to the bearing `bearing_of` gives from its origin (within
    /// 3 degrees): its index.
    fn nearest_beam(&self, bearing_of: impl Fn(Point2<f64>) -> f64) -> Option<usize> {
        self.beams
            .iter()
            .enumerate()
            .map(|(i, beam)| {
                (
                    i,
                    wrap_angle(beam.bearing_rad - bearing_of(beam.origin)).abs(),
                )
            })
            .filter(|&(_, gap)| gap < 3f64.to_radians())
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    }
}

/// Places blobs in space with a camera model and a range scan.
#[derive(Debug, Clone, PartialEq)]
pub struct BlobLocator {
    horizontal_fov_rad: f64,
    mounts: CameraMounts,
    max_range_m: f64,
}

impl BlobLocator {
    /// A locator for cameras of horizontal field of view `horizontal_fov_rad` at `mounts`,
    /// using readings up to `max_range_m`.
    #[must_use]
    pub fn new(horizontal_fov_rad: f64, mounts: CameraMounts, max_range_m: f64) -> Self {
        Self {
            horizontal_fov_rad,
            mounts,
            max_range_m,
        }
    }

    /// Changes the largest range used, in m.
    pub fn set_max_range_m(&mut self, max_range_m: f64) {
        self.max_range_m = max_range_m;
    }

    /// The model of the camera at `mount` for images of `width_px` x `height_px`.
    #[must_use]
    pub fn camera(&self, mount: &CameraMount, width_px: u32, height_px: u32) -> PinholeCamera {
        PinholeCamera::new(
            ImageIntrinsics::from_fov(width_px, height_px, self.horizontal_fov_rad),
            mount,
        )
    }

    /// Every blob of `blobs` placed with `scan` (or not placed, without a scan), seen by
    /// the camera whose images the Blobs name among their inputs.
    #[must_use]
    pub fn locate(&self, blobs: &Blobs, scan: Option<&Scan>) -> Blobs3D {
        let width = u32::try_from(blobs.image_width).unwrap_or(0).max(1);
        let height = u32::try_from(blobs.image_height).unwrap_or(0).max(1);
        let images = blobs
            .header
            .inputs
            .iter()
            .find(|input| input.channel.ends_with("/ImageSource"))
            .map_or("", |input| input.channel.as_str());
        let mount = self.mounts.of_channel(images);
        let camera = self.camera(mount, width, height);
        let placed: Vec<Blob3D> = blobs
            .blobs
            .iter()
            .map(|blob| {
                scan.and_then(|scan| self.place(&camera, blob, scan))
                    .unwrap_or_else(|| Blob3D {
                        blob: blob.clone(),
                        ..Blob3D::default()
                    })
            })
            .collect();
        Blobs3D {
            blob_count: i32::try_from(placed.len()).unwrap_or(i32::MAX),
            blobs: placed,
            ..Blobs3D::default()
        }
    }

    /// One blob placed, or `None` when no reading covers it.
    #[must_use]
    pub fn place(&self, camera: &PinholeCamera, blob: &Blob, scan: &Scan) -> Option<Blob3D> {
        let (u, v) = (blob.centroid_x, blob.centroid_y);
        let cam_xy = camera.origin().xy();
        let usable =
            |r: f64| r.is_finite() && r > 0.0 && r < scan.max_range_m && r <= self.max_range_m;
        // Start as if the range finder sat at the camera, then follow the parallax.
        let mut horizontal_m = 3.0;
        let mut found = None;
        for _ in 0..4 {
            let column_range = |column: f64| {
                let beam = scan
                    .nearest_beam(|origin| camera.bearing_from(column, v, origin, horizontal_m))?;
                let b = scan.beams[beam];
                usable(b.range_m).then_some(b)
            };
            // The middle half of the blob's width, at most 9 columns of it.
            let left = f64::from(blob.left);
            let right = f64::from(blob.right);
            let (from, to) = (u - (u - left) / 2.0, u + (right - u) / 2.0);
            let mut ranges: Vec<(f64, Beam)> = (0..9)
                .map(|k| from + (to - from) * f64::from(k) / 8.0)
                .filter_map(column_range)
                .map(|beam| {
                    let hit = beam.origin
                        + nalgebra::Vector2::new(beam.bearing_rad.cos(), beam.bearing_rad.sin())
                            * beam.range_m;
                    ((hit - cam_xy).norm(), beam)
                })
                .collect();
            if ranges.is_empty() {
                return None;
            }
            ranges.sort_by(|a, b| a.0.total_cmp(&b.0));
            let median = ranges[ranges.len() / 2].0;
            let settled = (median - horizontal_m).abs() < 1e-4;
            horizontal_m = median;
            found = Some(median);
            if settled {
                break;
            }
        }
        let horizontal_m = found?;
        let point = camera.point_at_horizontal_range(u, v, horizontal_m);
        let depth_m = camera.depth_of(&point);
        let k = camera.intrinsics();
        let width_px = f64::from(blob.right - blob.left + 1);
        let height_px = f64::from(blob.bottom - blob.top + 1);
        Some(Blob3D {
            blob: blob.clone(),
            range_valid: true,
            position: Point3D {
                x: point.x,
                y: point.y,
                z: point.z,
            },
            width: width_px * depth_m / k.focal_length_x_px,
            height: height_px * depth_m / k.focal_length_y_px,
        })
    }
}

/// Builds a `blobfinder3d` service from its robot-file entry.
///
/// # Errors
/// When a parameter is out of range.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: Params = config.parameters()?;
    let invalid = |reason: &str| BuildError::Parameters {
        service: config.name().to_owned(),
        reason: reason.to_owned(),
    };
    if !(params.horizontal_fov_deg > 0.0 && params.horizontal_fov_deg < 180.0) {
        return Err(invalid("horizontal_fov_deg must be between 0 and 180"));
    }
    if !(params.max_range_m.is_finite() && params.max_range_m > 0.0) {
        return Err(invalid("max_range_m must be positive"));
    }
    Ok(Box::new(BlobFinder3D {
        locator: BlobLocator::new(
            params.horizontal_fov_deg.to_radians(),
            CameraMounts::new(params.camera, params.cameras),
            params.max_range_m,
        ),
        max_scan_age_ns: i64::try_from(params.max_scan_age_ms)
            .unwrap_or(i64::MAX / 1_000_000)
            .saturating_mul(1_000_000),
        scan: None,
    }))
}

/// The last scan, when it came, and where from.
struct LastScan {
    scan: Scan,
    received_ns: i64,
    source: InputRef,
}

/// The `blobfinder3d` service.
struct BlobFinder3D {
    locator: BlobLocator,
    max_scan_age_ns: i64,
    scan: Option<LastScan>,
}

fn input_ref(input: &Input<'_>) -> InputRef {
    InputRef {
        channel: input.channel.to_owned(),
        seq: input.header().map_or(0, |h| h.seq),
    }
}

impl Service for BlobFinder3D {
    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        match input.interface {
            "RangeFinder" => match input.decode::<RangeFinder>() {
                Ok(scan) => {
                    self.scan = Some(LastScan {
                        scan: Scan::from_range_finder(&scan),
                        received_ns: ctx.now(),
                        source: input_ref(input),
                    });
                }
                Err(e) => ctx.warn(&format!("scan skipped: {e}")),
            },
            "Blobs" => {
                let blobs = match input.decode::<Blobs>() {
                    Ok(blobs) => blobs,
                    Err(e) => {
                        ctx.warn(&format!("blobs skipped: {e}"));
                        return;
                    }
                };
                let now = ctx.now();
                let fresh = self
                    .scan
                    .as_ref()
                    .filter(|s| now.saturating_sub(s.received_ns) <= self.max_scan_age_ns);
                let mut inputs = vec![input_ref(input)];
                if let Some(scan) = fresh {
                    inputs.push(scan.source.clone());
                    ctx.set_health(Health::Ok);
                } else {
                    ctx.set_health(Health::Degraded(
                        "no recent RangeFinder scan: blobs are published without range".into(),
                    ));
                }
                let mut placed = self.locator.locate(&blobs, fresh.map(|s| &s.scan));
                ctx.set_inputs(inputs);
                if let Err(e) = ctx.publish(&mut placed) {
                    ctx.warn(&format!("cannot publish Blobs3D: {e}"));
                }
            }
            _ => {}
        }
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        match command.decode::<Blobs3D>()? {
            Blobs3DCommand::SetMaxRange(set) => {
                if !(set.max_range.is_finite() && set.max_range > 0.0) {
                    return Err(CommandError::new(format!(
                        "max_range {} must be a positive number of metres",
                        set.max_range
                    )));
                }
                self.locator.set_max_range_m(set.max_range);
                Ok(ctx.reply(Blobs3DSetMaxRangeReply::default()))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    /// A uniform scan from a laser at (0.12, 0) seeing a wall `wall_m` ahead everywhere
    /// (a circle, for simplicity).
    fn circle_scan(range_m: f64) -> RangeFinder {
        let count = 361;
        RangeFinder {
            range_count: count,
            ranges: vec![range_m; 361],
            max_range: 8.0,
            uniform: true,
            x_offset: 0.12,
            theta_offset: -PI / 2.0,
            theta_separation: PI / 360.0,
            ..RangeFinder::default()
        }
    }

    fn blob(left: i32, top: i32, right: i32, bottom: i32) -> Blob {
        Blob {
            centroid_x: f64::from(left + right) / 2.0,
            centroid_y: f64::from(top + bottom) / 2.0,
            left,
            top,
            right,
            bottom,
            ..Blob::default()
        }
    }

    #[test]
    fn a_blob_is_placed_where_the_beam_along_its_bearing_ends() {
        let locator = BlobLocator::new(90f64.to_radians(), CameraMounts::default(), 8.0);
        let scan = Scan::from_range_finder(&circle_scan(3.0));
        let blobs = Blobs {
            image_width: 640,
            image_height: 480,
            blob_count: 2,
            blobs: vec![blob(310, 230, 330, 250), blob(0, 100, 40, 140)],
            ..Blobs::default()
        };
        let placed = locator.locate(&blobs, Some(&scan));
        for b in &placed.blobs {
            assert!(b.range_valid);
            let from_laser = (b.position.x - 0.12).hypot(b.position.y);
            assert!((from_laser - 3.0).abs() < 0.02, "{b:?}");
        }
        let centre = &placed.blobs[0];
        assert!(centre.position.y.abs() < 0.01 && (centre.position.z - 1.2).abs() < 0.01);
        // 21 px at about 3 m with a focal length of 320 px: about 0.2 m.
        assert!(
            (centre.width - 21.0 * (3.12 - 0.1) / 320.0).abs() < 0.01,
            "{centre:?}"
        );
        assert!(placed.blobs[1].position.y > 0.5, "{:?}", placed.blobs[1]);
    }

    #[test]
    fn blobs_are_placed_from_the_camera_whose_images_they_came_from() {
        let (_, mounts) = crate::camera_model::stereo_pair();
        let locator = BlobLocator::new(90f64.to_radians(), mounts, 8.0);
        let scan = Scan::from_range_finder(&circle_scan(3.0));
        let from = |channel: &str| Blobs {
            image_width: 640,
            image_height: 480,
            blob_count: 1,
            blobs: vec![blob(310, 230, 330, 250)],
            header: lewis_interfaces::msg::Header {
                inputs: vec![InputRef {
                    channel: channel.to_owned(),
                    seq: 1,
                }],
                ..Default::default()
            },
        };
        let y_of = |channel: &str| {
            locator.locate(&from(channel), Some(&scan)).blobs[0]
                .position
                .y
        };
        // The image centre, straight ahead of each camera: on its own line across the robot.
        assert!(y_of("/camera/ImageSource").abs() < 0.01);
        assert!((y_of("/camera2/ImageSource") + 0.12).abs() < 0.01);
        // A camera not named, or no image among the inputs: the default mount.
        assert!(y_of("/camera3/ImageSource").abs() < 0.01);
        assert!(y_of("/laser/RangeFinder").abs() < 0.01);
    }

    #[test]
    fn blobs_beyond_the_range_or_without_a_scan_have_no_position() {
        let mut locator = BlobLocator::new(90f64.to_radians(), CameraMounts::default(), 8.0);
        let blobs = Blobs {
            image_width: 640,
            image_height: 480,
            blob_count: 1,
            blobs: vec![blob(310, 230, 330, 250)],
            ..Blobs::default()
        };
        assert!(!locator.locate(&blobs, None).blobs[0].range_valid);
        locator.set_max_range_m(2.0);
        let scan = Scan::from_range_finder(&circle_scan(3.0));
        assert!(!locator.locate(&blobs, Some(&scan)).blobs[0].range_valid);
        let behind = Scan::from_range_finder(&RangeFinder {
            theta_offset: PI / 2.0 + 0.1,
            ..circle_scan(1.0)
        });
        assert!(!locator.locate(&blobs, Some(&behind)).blobs[0].range_valid);
    }
}
