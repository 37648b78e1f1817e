//! The motion tests' world, on the real simulator (`lewis-sim`): a world of walls made in
//! code, the B21r's synchro-drive base driven by the velocity commands, and the simulated
//! SICK laser and sonar ring, each seeded by the test.
//!
//! The base's odometry is exact (`OdometryNoise::NONE`): the tests check where the motion
//! code takes the robot, and a drifting odometry would move the goal. Everything else is the
//! simulator's B21r as `sim-base`, `sim-laser` and `sim-sonar` run it.

// Helpers of tests: a configuration the test built that does not work is its failure.
#![allow(dead_code, clippy::expect_used)]

use lewis_geometry::{Pose2, Vec2, wrap_angle};
use lewis_interfaces::msg::{Distance, Pose2D, RangeFinder};
use lewis_motion::VelocityCommand;
use lewis_sim::world::{ObjectKind, OccupancyGrid, Rgb, WorldObject};
use lewis_sim::{BaseConfig, LaserConfig, OdometryNoise, Shape, SimBase, SimLaser, SimSonar};
use lewis_sim::{SonarConfig, WorldLook};

pub const STEP_NS: i64 = 100_000_000;
pub const STEP_S: f64 = 0.1;
pub const B21R_RADIUS_M: f64 = 0.26;

/// Half the side of the open square the tests run in, in m: its edge is out of every
/// sensor's range from where the tests drive.
const HALF_SIDE_M: f64 = 30.0;

/// Taller than every sensor's beam and the robot.
const WALL_HEIGHT_M: f64 = 2.0;

pub fn p(x: f64, y: f64) -> Vec2 {
    Vec2::new(x, y)
}

/// An open floor with walls (segments) on it: a simulator world made in code.
#[derive(Debug, Clone)]
pub struct World(lewis_sim::World);

impl Default for World {
    fn default() -> Self {
        Self::with(Vec::new())
    }
}

impl World {
    fn with(objects: Vec<WorldObject>) -> Self {
        let cells = (2.0 * HALF_SIDE_M) as usize;
        let grid =
            OccupancyGrid::from_fn(cells, cells, 1.0, p(-HALF_SIDE_M, -HALF_SIDE_M), |_, _| {
                false
            });
        let grey = Rgb::new(128, 128, 128);
        let look = WorldLook {
            wall_height_m: WALL_HEIGHT_M,
            wall_colour: grey,
            floor_colour: grey,
            ceiling_colour: grey,
        };
        Self(lewis_sim::World::new(
            "motion-test".into(),
            grid,
            look,
            objects,
        ))
    }

    /// This world with a wall from `a` to `b`.
    pub fn wall(self, a: Vec2, b: Vec2) -> Self {
        let mut objects = self.0.objects().to_vec();
        objects.push(WorldObject {
            name: format!("wall-{}", objects.len() + 1),
            kind: ObjectKind::Wall {
                shape: Shape::Segment { a, b },
                height_m: WALL_HEIGHT_M,
                colour: Rgb::new(128, 128, 128),
            },
        });
        Self::with(objects)
    }

    /// Distance from a point to the nearest obstacle surface (infinite beyond 5 m).
    pub fn clearance(&self, q: Vec2) -> f64 {
        let mut nearest = f64::INFINITY;
        self.0
            .for_each_obstacle_point_within(q, 5.0, WALL_HEIGHT_M, |o| {
                nearest = nearest.min((o - q).norm());
            });
        nearest
    }
}

fn pose2(pose: &Pose2D) -> Pose2 {
    Pose2::new(pose.x, pose.y, pose.theta)
}

/// The robot in the world: the simulated base, its true pose (heading counted in whole turns,
/// not wrapped, so that a test can see a turn beyond half a turn), and what it was asked.
pub struct Robot {
    base: SimBase,
    /// The true pose; `theta` is not wrapped.
    pub world_pose: Pose2D,
    /// Where the odometry frame's origin is in the world: the start pose.
    pub odom_origin: Pose2D,
    pub now_ns: i64,
    pub min_clearance_m: f64,
    pub path: Vec<Pose2D>,
    pub commands: Vec<VelocityCommand>,
}

impl Robot {
    /// A robot whose odometry frame starts where it stands.
    pub fn at(world_pose: Pose2D) -> Self {
        let config = BaseConfig {
            odometry: OdometryNoise::NONE,
            ..BaseConfig::default()
        };
        assert_eq!(config.radius_m, B21R_RADIUS_M);
        let base = SimBase::new(config, pose2(&world_pose), 0).expect("a valid base");
        Self {
            base,
            odom_origin: world_pose.clone(),
            world_pose,
            now_ns: 0,
            min_clearance_m: f64::INFINITY,
            path: Vec::new(),
            commands: Vec::new(),
        }
    }

    /// The pose in the odometry frame, as the base's Egomotion says it.
    pub fn odom_pose(&self) -> Pose2D {
        let o = self.base.odometry_pose();
        Pose2D {
            x: o.x_m,
            y: o.y_m,
            theta: o.heading_rad,
        }
    }

    /// A point of the world in the odometry frame.
    pub fn world_to_odom(&self, x: f64, y: f64) -> (f64, f64) {
        let a = &self.odom_origin;
        let (s, c) = a.theta.sin_cos();
        let (dx, dy) = (x - a.x, y - a.y);
        (c * dx + s * dy, -s * dx + c * dy)
    }

    /// Drives one control step with the command, watching the clearance every 10 ms.
    pub fn drive(&mut self, world: &World, command: VelocityCommand) {
        const SUB: i64 = 10;
        self.base
            .set_velocity(command.translation_m_s, command.rotation_rad_s);
        for _ in 0..SUB {
            self.base.step(&world.0, STEP_NS / SUB);
            let truth = self.base.true_pose();
            let turned = wrap_angle(truth.heading_rad - self.world_pose.theta);
            self.world_pose = Pose2D {
                x: truth.x_m,
                y: truth.y_m,
                theta: self.world_pose.theta + turned,
            };
            self.min_clearance_m = self.min_clearance_m.min(world.clearance(truth.position()));
        }
        self.now_ns += STEP_NS;
        self.path.push(self.world_pose.clone());
        self.commands.push(command);
    }

    /// Bumps into things counted by the base.
    pub fn collisions(&self) -> u64 {
        self.base.collision_count()
    }
}

/// The simulated range finders, each drawing its noise from the test's seed.
pub struct Sensors {
    laser: SimLaser,
    sonar: SimSonar,
}

impl Sensors {
    pub fn new(seed: u64) -> Self {
        Self {
            laser: SimLaser::new(LaserConfig::default(), seed).expect("a valid laser"),
            sonar: SimSonar::new(SonarConfig::default(), seed).expect("a valid sonar ring"),
        }
    }

    /// A scan of the SICK laser from the robot's true pose.
    pub fn laser(&mut self, world: &World, pose: &Pose2D) -> RangeFinder {
        self.laser.scan(&world.0, pose2(pose))
    }

    /// A reading of the sonar ring from the robot's true pose.
    pub fn sonar(&mut self, world: &World, pose: &Pose2D) -> RangeFinder {
        self.sonar.scan(&world.0, pose2(pose))
    }

    /// The laser's Distance in `sectors` sectors, as `sim-laser` publishes it.
    pub fn distance(&mut self, world: &World, pose: &Pose2D, sectors: usize) -> Distance {
        let scan = self.laser(world, pose);
        self.laser.distance(&scan, sectors)
    }
}
