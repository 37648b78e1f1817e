//! A small pure 2D test world for the motion tests: segments and circles, a unicycle that
//! integrates the velocity commands, ray-cast laser, sonar and Distance sensors with seeded
//! noise. It knows nothing of the simulator service on purpose.

#![allow(dead_code)]

use lewis_interfaces::msg::{Distance, Pose2D, Pose3D, RangeFinder};
use lewis_motion::VelocityCommand;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

pub const STEP_NS: i64 = 100_000_000;
pub const STEP_S: f64 = 0.1;
pub const B21R_RADIUS_M: f64 = 0.26;

/// SplitMix64 with Box-Muller: the only randomness, seeded by each test.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn gaussian(&mut self, sigma: f64) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        sigma * (-2.0 * u1.ln()).sqrt() * (TAU * u2).cos()
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct P {
    pub x: f64,
    pub y: f64,
}

pub const fn p(x: f64, y: f64) -> P {
    P { x, y }
}

impl P {
    fn sub(self, o: P) -> P {
        p(self.x - o.x, self.y - o.y)
    }
    fn dot(self, o: P) -> f64 {
        self.x * o.x + self.y * o.y
    }
    fn cross(self, o: P) -> f64 {
        self.x * o.y - self.y * o.x
    }
    fn norm(self) -> f64 {
        self.x.hypot(self.y)
    }
}

/// Segments and circles (x, y, radius).
#[derive(Debug, Clone, Default)]
pub struct World {
    pub segments: Vec<(P, P)>,
    pub circles: Vec<(P, f64)>,
}

impl World {
    pub fn wall(mut self, a: P, b: P) -> Self {
        self.segments.push((a, b));
        self
    }

    pub fn pillar(mut self, c: P, r: f64) -> Self {
        self.circles.push((c, r));
        self
    }

    /// Distance from a point to the nearest obstacle surface.
    pub fn clearance(&self, q: P) -> f64 {
        let seg = self.segments.iter().map(|&(a, b)| {
            let ab = b.sub(a);
            let t = (q.sub(a).dot(ab) / ab.dot(ab)).clamp(0.0, 1.0);
            q.sub(p(a.x + ab.x * t, a.y + ab.y * t)).norm()
        });
        let circ = self
            .circles
            .iter()
            .map(|&(c, r)| (q.sub(c).norm() - r).max(0.0));
        seg.chain(circ).fold(f64::INFINITY, f64::min)
    }

    /// The first hit along a ray: (distance, incidence angle between the ray and the
    /// surface normal in rad).
    pub fn cast(&self, origin: P, angle: f64, max_range: f64) -> Option<(f64, f64)> {
        let d = p(angle.cos(), angle.sin());
        let mut best: Option<(f64, f64)> = None;
        let mut consider = |t: f64, incidence: f64| {
            if t > 1e-9 && t <= max_range && best.is_none_or(|(b, _)| t < b) {
                best = Some((t, incidence));
            }
        };
        for &(a, b) in &self.segments {
            let e = b.sub(a);
            let denom = d.cross(e);
            if denom.abs() < 1e-12 {
                continue;
            }
            let w = a.sub(origin);
            let t = w.cross(e) / denom;
            let u = w.cross(d) / denom;
            if (0.0..=1.0).contains(&u) {
                let normal_dot = (d.cross(e) / e.norm()).abs();
                consider(t, normal_dot.clamp(0.0, 1.0).acos());
            }
        }
        for &(c, r) in &self.circles {
            let w = origin.sub(c);
            let b = w.dot(d);
            let disc = b * b - (w.dot(w) - r * r);
            if disc < 0.0 {
                continue;
            }
            let t = -b - disc.sqrt();
            let hit = p(origin.x + d.x * t, origin.y + d.y * t).sub(c);
            let cos_inc = (-(hit.dot(d)) / hit.norm()).clamp(0.0, 1.0);
            consider(t, cos_inc.acos());
        }
        best
    }
}

/// Composes poses: `b` given in the frame of `a`.
pub fn compose(a: &Pose2D, b: &Pose2D) -> Pose2D {
    let (s, c) = a.theta.sin_cos();
    Pose2D {
        x: a.x + c * b.x - s * b.y,
        y: a.y + s * b.x + c * b.y,
        theta: a.theta + b.theta,
    }
}

/// The pose `b` (world) seen from frame `a` (world).
pub fn relative(a: &Pose2D, b: &Pose2D) -> Pose2D {
    let (s, c) = a.theta.sin_cos();
    let dx = b.x - a.x;
    let dy = b.y - a.y;
    Pose2D {
        x: c * dx + s * dy,
        y: -s * dx + c * dy,
        theta: b.theta - a.theta,
    }
}

/// The robot in the world: true pose, the odometry frame's origin in the world, and what
/// it has been asked.
pub struct Robot {
    pub world_pose: Pose2D,
    pub odom_origin: Pose2D,
    pub now_ns: i64,
    pub min_clearance_m: f64,
    pub path: Vec<Pose2D>,
    pub commands: Vec<VelocityCommand>,
}

impl Robot {
    /// A robot whose odometry frame starts where it stands.
    pub fn at(world_pose: Pose2D) -> Self {
        Self {
            odom_origin: world_pose.clone(),
            world_pose,
            now_ns: 0,
            min_clearance_m: f64::INFINITY,
            path: Vec::new(),
            commands: Vec::new(),
        }
    }

    pub fn odom_pose(&self) -> Pose2D {
        relative(&self.odom_origin, &self.world_pose)
    }

    /// A point of the odometry frame in the world.
    pub fn odom_to_world(&self, x: f64, y: f64) -> (f64, f64) {
        let w = compose(&self.odom_origin, &Pose2D { x, y, theta: 0.0 });
        (w.x, w.y)
    }

    /// A point of the world in the odometry frame.
    pub fn world_to_odom(&self, x: f64, y: f64) -> (f64, f64) {
        let o = relative(&self.odom_origin, &Pose2D { x, y, theta: 0.0 });
        (o.x, o.y)
    }

    /// Drives one control step with the command, in small sub-steps, watching clearance.
    pub fn drive(&mut self, world: &World, command: VelocityCommand) {
        const SUB: u32 = 10;
        let dt = STEP_S / f64::from(SUB);
        for _ in 0..SUB {
            let pose = &mut self.world_pose;
            let mid = pose.theta + command.rotation_rad_s * dt / 2.0;
            pose.x += command.translation_m_s * dt * mid.cos();
            pose.y += command.translation_m_s * dt * mid.sin();
            pose.theta += command.rotation_rad_s * dt;
            self.min_clearance_m = self.min_clearance_m.min(world.clearance(p(pose.x, pose.y)));
        }
        self.now_ns += STEP_NS;
        self.path.push(self.world_pose.clone());
        self.commands.push(command);
    }
}

/// A SICK-like laser: 181 beams over the front 180 degrees, 0.1 m ahead of the centre.
pub struct Laser {
    pub beams: usize,
    pub max_range_m: f64,
    pub sigma_m: f64,
    pub x_offset_m: f64,
}

impl Default for Laser {
    fn default() -> Self {
        Self {
            beams: 181,
            max_range_m: 8.0,
            sigma_m: 0.01,
            x_offset_m: 0.1,
        }
    }
}

impl Laser {
    pub fn read(&self, world: &World, pose: &Pose2D, rng: &mut Rng) -> RangeFinder {
        let separation = PI / (self.beams - 1) as f64;
        let origin = compose(
            pose,
            &Pose2D {
                x: self.x_offset_m,
                y: 0.0,
                theta: 0.0,
            },
        );
        let ranges = (0..self.beams)
            .map(|i| {
                let bearing = -FRAC_PI_2 + i as f64 * separation;
                match world.cast(
                    p(origin.x, origin.y),
                    pose.theta + bearing,
                    self.max_range_m,
                ) {
                    Some((t, _)) => (t + rng.gaussian(self.sigma_m)).clamp(0.01, self.max_range_m),
                    None => self.max_range_m,
                }
            })
            .collect::<Vec<f64>>();
        RangeFinder {
            range_count: ranges.len() as i32,
            ranges,
            max_range: self.max_range_m,
            uniform: true,
            x_offset: self.x_offset_m,
            theta_offset: -FRAC_PI_2,
            theta_separation: separation,
            ..Default::default()
        }
    }
}

/// The B21r sonar ring: 24 transducers on a 0.25 m ring, a cone of rays, returns only from
/// surfaces seen near the normal (specular misses otherwise), noisy and coarse.
pub struct Sonar {
    pub transducers: usize,
    pub ring_radius_m: f64,
    pub cone_half_rad: f64,
    pub max_range_m: f64,
    pub max_incidence_rad: f64,
    pub sigma_m: f64,
    pub quantum_m: f64,
}

impl Default for Sonar {
    fn default() -> Self {
        Self {
            transducers: 24,
            ring_radius_m: 0.25,
            cone_half_rad: 12.5_f64.to_radians(),
            max_range_m: 5.0,
            max_incidence_rad: 65_f64.to_radians(),
            sigma_m: 0.03,
            quantum_m: 0.025,
        }
    }
}

impl Sonar {
    pub fn positions(&self) -> Vec<Pose3D> {
        (0..self.transducers)
            .map(|i| {
                let theta = i as f64 * TAU / self.transducers as f64;
                Pose3D {
                    x: self.ring_radius_m * theta.cos(),
                    y: self.ring_radius_m * theta.sin(),
                    z: 0.6,
                    theta,
                    phi: 0.0,
                    psi: 0.0,
                }
            })
            .collect()
    }

    pub fn read(&self, world: &World, pose: &Pose2D, rng: &mut Rng) -> RangeFinder {
        let positions = self.positions();
        let ranges = positions
            .iter()
            .map(|s| {
                let origin = compose(
                    pose,
                    &Pose2D {
                        x: s.x,
                        y: s.y,
                        theta: s.theta,
                    },
                );
                let nearest = (0..=6)
                    .filter_map(|k| {
                        let a = origin.theta - self.cone_half_rad
                            + f64::from(k) * self.cone_half_rad / 3.0;
                        world.cast(p(origin.x, origin.y), a, self.max_range_m)
                    })
                    .filter(|&(_, incidence)| incidence <= self.max_incidence_rad)
                    .map(|(t, _)| t)
                    .fold(f64::INFINITY, f64::min);
                if nearest.is_finite() {
                    let noisy = nearest + rng.gaussian(self.sigma_m + 0.01 * nearest);
                    ((noisy / self.quantum_m).round() * self.quantum_m)
                        .clamp(0.05, self.max_range_m)
                } else {
                    self.max_range_m
                }
            })
            .collect::<Vec<f64>>();
        RangeFinder {
            range_count: ranges.len() as i32,
            ranges,
            max_range: self.max_range_m,
            uniform: false,
            sensor_positions: positions,
            ..Default::default()
        }
    }
}

/// Distance sectors over the laser's field of view: the nearest laser reading per sector.
pub fn distance_from_laser(laser: &RangeFinder, sectors: usize) -> Distance {
    let span = laser.theta_separation * f64::from(laser.range_count - 1);
    let width = span / sectors as f64;
    let mut distances = vec![laser.max_range; sectors];
    for (i, &r) in laser.ranges.iter().enumerate() {
        let bearing = i as f64 * laser.theta_separation;
        let k = ((bearing / width) as usize).min(sectors - 1);
        // The sector reading is measured from the robot centre.
        let angle = laser.theta_offset + bearing;
        let from_centre = if r < laser.max_range {
            (laser.x_offset + r * angle.cos()).hypot(r * angle.sin())
        } else {
            laser.max_range
        };
        distances[k] = distances[k].min(from_centre);
    }
    let (min_k, min_d) =
        distances
            .iter()
            .copied()
            .enumerate()
            .fold(
                (0, f64::INFINITY),
                |best, (k, d)| if d < best.1 { (k, d) } else { best },
            );
    Distance {
        sector_count: sectors as i32,
        sector_distances: distances,
        first_sector_angle: laser.theta_offset + width / 2.0,
        sector_width: width,
        max_range: laser.max_range,
        min_distance: min_d,
        min_bearing: laser.theta_offset + width * (min_k as f64 + 0.5),
        ..Default::default()
    }
}
