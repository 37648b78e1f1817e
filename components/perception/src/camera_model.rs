//! The pinhole camera on the robot: from a pixel to a ray in the robot frame, and back.
//!
//! Frames: the robot frame has x ahead, y to the left, z up (REP 103). The camera's optical
//! frame has x to the right of the image, y down the image, z along the optical axis (REP
//! 103's `_optical` frames). The camera's mount gives its position in the robot frame, its
//! pan (a turn to the left, about z) and its tilt (upwards), as the CameraControl interface
//! and the simulator name them.

use std::collections::BTreeMap;

use nalgebra::{Isometry3, Point2, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::Deserialize;

use lewis_images::ImageIntrinsics;

/// Where the camera sits on the robot, as robot files give it.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraMount {
    /// Ahead of the robot's centre, in m.
    pub x_m: f64,
    /// To the left of the robot's centre, in m.
    pub y_m: f64,
    /// Above the floor, in m.
    pub z_m: f64,
    /// Turned to the left of straight ahead, in rad.
    pub pan_rad: f64,
    /// Turned up from level, in rad.
    pub tilt_rad: f64,
}

impl Default for CameraMount {
    /// The B21r's camera as the simulator mounts it: 0.1 m ahead of the centre, 1.2 m up,
    /// looking straight ahead.
    fn default() -> Self {
        Self {
            x_m: 0.1,
            y_m: 0.0,
            z_m: 1.2,
            pan_rad: 0.0,
            tilt_rad: 0.0,
        }
    }
}

impl CameraMount {
    /// The transform from the optical frame to the robot frame.
    #[must_use]
    pub fn robot_from_optical(&self) -> Isometry3<f64> {
        // Optical (x right, y down, z ahead) to a level camera body (x ahead, y left, z up).
        let body_from_optical = Rotation3::from_matrix_unchecked(nalgebra::Matrix3::new(
            0.0, 0.0, 1.0, //
            -1.0, 0.0, 0.0, //
            0.0, -1.0, 0.0,
        ));
        // Pan about z, then tilt: a rotation about the body's y axis by -tilt lifts x upwards.
        let robot_from_body = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), self.pan_rad)
            * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -self.tilt_rad);
        Isometry3::from_parts(
            Translation3::new(self.x_m, self.y_m, self.z_m),
            robot_from_body * UnitQuaternion::from_rotation_matrix(&body_from_optical),
        )
    }
}

/// Where each camera of the robot sits, by the name of the service that provides its
/// images: perception that the broker may move from one camera to another (a stereo pair,
/// the paper's example) places what it sees from the camera each image came from.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CameraMounts {
    default: CameraMount,
    by_camera: BTreeMap<String, CameraMount>,
}

impl CameraMounts {
    /// `default` for images of any camera not named in `by_camera`.
    #[must_use]
    pub fn new(default: CameraMount, by_camera: BTreeMap<String, CameraMount>) -> Self {
        Self { default, by_camera }
    }

    /// One camera, wherever the images come from.
    #[must_use]
    pub fn single(mount: CameraMount) -> Self {
        Self::new(mount, BTreeMap::new())
    }

    /// The mount of the camera service `camera`.
    #[must_use]
    pub fn of(&self, camera: &str) -> &CameraMount {
        self.by_camera.get(camera).unwrap_or(&self.default)
    }

    /// The mount of the camera whose images came on `channel` (`/camera2/ImageSource`).
    #[must_use]
    pub fn of_channel(&self, channel: &str) -> &CameraMount {
        channel
            .strip_prefix('/')
            .and_then(|rest| rest.strip_suffix("/ImageSource"))
            .map_or(&self.default, |camera| self.of(camera))
    }
}

/// The simulated robot's stereo pair: the right camera's mount (`camera2`, 12 cm right of
/// the default), and the mounts of both.
#[cfg(test)]
pub(crate) fn stereo_pair() -> (CameraMount, CameraMounts) {
    let right = CameraMount {
        y_m: -0.12,
        ..CameraMount::default()
    };
    let mounts = CameraMounts::new(
        CameraMount::default(),
        [("camera2".to_owned(), right)].into(),
    );
    (right, mounts)
}

/// A pinhole camera at a known place on the robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinholeCamera {
    intrinsics: ImageIntrinsics,
    robot_from_optical: Isometry3<f64>,
}

impl PinholeCamera {
    /// The camera with `intrinsics` mounted at `mount`.
    #[must_use]
    pub fn new(intrinsics: ImageIntrinsics, mount: &CameraMount) -> Self {
        Self {
            intrinsics,
            robot_from_optical: mount.robot_from_optical(),
        }
    }

    /// The intrinsics.
    #[must_use]
    pub fn intrinsics(&self) -> &ImageIntrinsics {
        &self.intrinsics
    }

    /// The camera's centre in the robot frame.
    #[must_use]
    pub fn origin(&self) -> Point3<f64> {
        self.robot_from_optical.translation.vector.into()
    }

    /// The direction (not normalised; its optical z is 1) of the ray through pixel
    /// (`column_px`, `row_px`), in the robot frame.
    #[must_use]
    pub fn ray(&self, column_px: f64, row_px: f64) -> Vector3<f64> {
        let k = &self.intrinsics;
        let optical = Vector3::new(
            (column_px - k.principal_x_px) / k.focal_length_x_px,
            (row_px - k.principal_y_px) / k.focal_length_y_px,
            1.0,
        );
        self.robot_from_optical * optical
    }

    /// The bearing (counter-clockwise from the robot's x axis, seen from above) of the point
    /// at horizontal distance `range_m` along the ray through the pixel, as seen from
    /// `from` (a point of the robot frame, seen from above): the bearing a sensor at `from`
    /// must look along to see what the pixel shows.
    #[must_use]
    pub fn bearing_from(
        &self,
        column_px: f64,
        row_px: f64,
        from: Point2<f64>,
        range_m: f64,
    ) -> f64 {
        let point = self.point_at_horizontal_range(column_px, row_px, range_m);
        (point.y - from.y).atan2(point.x - from.x)
    }

    /// The point of the ray through the pixel that lies `range_m` from the camera, measured
    /// horizontally (seen from above). For a ray that runs straight up or down, the camera's
    /// own position.
    #[must_use]
    pub fn point_at_horizontal_range(
        &self,
        column_px: f64,
        row_px: f64,
        range_m: f64,
    ) -> Point3<f64> {
        let ray = self.ray(column_px, row_px);
        let horizontal = ray.xy().norm();
        if horizontal < 1e-12 {
            return self.origin();
        }
        self.origin() + ray * (range_m / horizontal)
    }

    /// The depth (distance along the optical axis) of a robot-frame point.
    #[must_use]
    pub fn depth_of(&self, point: &Point3<f64>) -> f64 {
        self.robot_from_optical.inverse_transform_point(point).z
    }

    /// Where a robot-frame point appears in the image: (column, row), or `None` behind the
    /// camera.
    #[must_use]
    pub fn project(&self, point: &Point3<f64>) -> Option<(f64, f64)> {
        let p = self.robot_from_optical.inverse_transform_point(point);
        if p.z <= 1e-9 {
            return None;
        }
        let k = &self.intrinsics;
        Some((
            k.principal_x_px + k.focal_length_x_px * p.x / p.z,
            k.principal_y_px + k.focal_length_y_px * p.y / p.z,
        ))
    }

    /// The point on the ray through the pixel at depth `depth_m` along the optical axis.
    #[must_use]
    pub fn point_at_depth(&self, column_px: f64, row_px: f64, depth_m: f64) -> Point3<f64> {
        self.origin() + self.ray(column_px, row_px) * depth_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(mount: CameraMount) -> PinholeCamera {
        PinholeCamera::new(
            ImageIntrinsics::from_fov(640, 480, 90f64.to_radians()),
            &mount,
        )
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn the_image_centre_looks_along_the_mount_and_left_columns_look_left() {
        let cam = camera(CameraMount::default());
        let k = *cam.intrinsics();
        let centre = cam.ray(k.principal_x_px, k.principal_y_px);
        assert!(close(centre.x, 1.0) && close(centre.y, 0.0) && close(centre.z, 0.0));
        let left = cam.ray(0.0, k.principal_y_px);
        assert!(left.y > 0.0, "{left:?}");
        let up = cam.ray(k.principal_x_px, 0.0);
        assert!(up.z > 0.0, "{up:?}");
        // 90 degrees wide: the left edge of the image is 45 degrees to the left.
        assert!((left.y.atan2(left.x) - 45f64.to_radians()).abs() < 0.01);
    }

    #[test]
    fn projection_inverts_the_ray_for_panned_and_tilted_mounts() {
        for (pan, tilt) in [(0.0, 0.0), (0.4, 0.0), (-0.3, 0.2), (1.0, -0.25)] {
            let cam = camera(CameraMount {
                pan_rad: pan,
                tilt_rad: tilt,
                ..CameraMount::default()
            });
            for (u, v) in [(10.0, 20.0), (320.0, 240.0), (600.0, 400.0)] {
                let point = cam.point_at_depth(u, v, 3.0);
                let (pu, pv) = cam.project(&point).unwrap_or((f64::NAN, f64::NAN));
                assert!(
                    close(pu, u) && close(pv, v),
                    "{pan} {tilt}: {u},{v} -> {pu},{pv}"
                );
                assert!(close(cam.depth_of(&point), 3.0));
            }
            let k = *cam.intrinsics();
            let centre = cam.ray(k.principal_x_px, k.principal_y_px);
            assert!(close(centre.y.atan2(centre.x), pan), "{centre:?}");
            assert!(
                close(centre.z.atan2(centre.xy().norm()), tilt),
                "{centre:?}"
            );
        }
    }

    #[test]
    fn a_point_at_a_horizontal_range_is_that_far_seen_from_above() {
        let cam = camera(CameraMount::default());
        let point = cam.point_at_horizontal_range(100.0, 100.0, 2.5);
        assert!(close((point - cam.origin()).xy().norm(), 2.5));
        let bearing = cam.bearing_from(100.0, 100.0, Point2::new(0.1, 0.0), 2.5);
        assert!(close(bearing, point.y.atan2(point.x - 0.1)));
    }

    #[test]
    fn each_camera_has_its_mount_and_the_others_the_default() {
        let (right, mounts) = stereo_pair();
        assert_eq!(mounts.of("camera2"), &right);
        assert_eq!(mounts.of("camera"), &CameraMount::default());
        assert_eq!(mounts.of_channel("/camera2/ImageSource"), &right);
        for other in ["/camera2/Blobs", "camera2/ImageSource", "/camera2", ""] {
            assert_eq!(mounts.of_channel(other), &CameraMount::default(), "{other}");
        }
    }
}
