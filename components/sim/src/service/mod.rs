//! The simulated devices as services, each in its own process: `sim-base` owns the true
//! pose and publishes it as GroundTruth; `sim-laser`, `sim-sonar` and `sim-camera` require
//! GroundTruth and render the world from the latest true pose at their own rates;
//! `sim-speech` is the robot's voice and the registrar who answers it. Killing one leaves
//! the others running.
//!
//! Every kind loads the world from its `world` parameter (a folder holding `world.toml`
//! and its map). A relative path is taken from the current directory of the process, which
//! `lewis up` passes on to the services it starts: run `lewis up` from the repository's
//! root, or give an absolute path.
//!
//! Each device's noise is drawn from its own generator, seeded from the service's `seed`
//! parameter (a hash of the service's name when absent), so the same seed and the same
//! commands at the same times give the same bytes.
//!
//! Every sensor publication names, in its header's `inputs`, the GroundTruth sample it was
//! rendered from, and the WorldState sample when the sensor requires WorldState: then it
//! draws the people where `sim-base` has them (the queue moves, people walk). A sensor
//! that does not require it draws them where the world file puts them.

pub mod base;
pub mod camera;
pub mod laser;
pub mod range;
pub mod sonar;
pub mod speech;

use std::path::Path;

use lewis_geometry::{Pose2, SensorMount};
use lewis_interfaces::Interface;
use lewis_interfaces::msg::{GroundTruth, InputRef, PersonState, WorldState};
use lewis_service::{BuildError, Context, Input, Role, ServiceConfig, ServiceRegistry};
use serde::Deserialize;

use super::world::World;

pub use base::{BaseLimits, BaseParams, BatteryParams, BodyParams, OdometryParams, SimBaseService};
pub use camera::{CameraParams, SimCameraService, TruePoseSource};
pub use laser::{LaserParams, SimLaserService};
pub use sonar::{SimSonarService, SonarParams};
pub use speech::{SimSpeechService, SpeechParams};

/// Registers `sim-base`, `sim-laser`, `sim-sonar`, `sim-camera` and `sim-speech`, each a
/// simulated device (a replay feeds it from the recording, `lewis replay --all` runs it
/// again in the recorded world).
pub fn register(registry: &mut ServiceRegistry) {
    registry.register_with_parameters::<BaseParams>(base::KIND, base::build);
    registry.register_with_parameters::<LaserParams>(laser::KIND, laser::build);
    registry.register_with_parameters::<SonarParams>(sonar::KIND, sonar::build);
    registry.register_with_parameters::<CameraParams>(camera::KIND, camera::build);
    registry.register_with_parameters::<SpeechParams>(speech::KIND, speech::build);
    for kind in [
        base::KIND,
        laser::KIND,
        sonar::KIND,
        camera::KIND,
        speech::KIND,
    ] {
        registry.set_role(kind, Role::SimulatedDevice);
    }
}

/// A pose in the world frame, as robot files write it.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseParams {
    /// East, in m.
    pub x_m: f64,
    /// North, in m.
    pub y_m: f64,
    /// Heading, counter-clockwise from east, in degrees.
    #[serde(default)]
    pub heading_deg: f64,
}

impl PoseParams {
    /// As the simulator's pose.
    #[must_use]
    pub fn to_pose(self) -> Pose2 {
        Pose2::new(self.x_m, self.y_m, self.heading_deg.to_radians())
    }
}

/// Where a sensor sits on the robot, as robot files write it.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MountParams {
    /// Forward of the robot's centre, in m.
    pub x_m: f64,
    /// Left of the robot's centre, in m.
    pub y_m: f64,
    /// Where it looks, counter-clockwise from straight ahead, in degrees.
    #[serde(default)]
    pub heading_deg: f64,
    /// Above the floor, in m.
    pub height_m: f64,
}

impl MountParams {
    /// As the simulator's mount.
    #[must_use]
    pub fn to_mount(self) -> SensorMount {
        SensorMount {
            pose: Pose2::new(self.x_m, self.y_m, self.heading_deg.to_radians()),
            height_m: self.height_m,
        }
    }

    /// The parameters that describe `mount`.
    #[must_use]
    pub fn from_mount(mount: SensorMount) -> Self {
        Self {
            x_m: mount.pose.x_m,
            y_m: mount.pose.y_m,
            heading_deg: mount.pose.heading_rad.to_degrees(),
            height_m: mount.height_m,
        }
    }
}

/// A parameter error of service `config`.
fn invalid(config: &ServiceConfig<'_>, reason: impl Into<String>) -> BuildError {
    BuildError::Parameters {
        service: config.name().to_owned(),
        reason: reason.into(),
    }
}

/// The period of a rate parameter, in ns.
fn period_ns(config: &ServiceConfig<'_>, field: &str, rate_hz: f64) -> Result<i64, BuildError> {
    if !(rate_hz.is_finite() && (0.01..=1000.0).contains(&rate_hz)) {
        return Err(invalid(
            config,
            format!("`{field}` is {rate_hz}: give a rate between 0.01 and 1000 Hz"),
        ));
    }
    // 1e9 / rate is at most 1e11 for a rate in range: it fits an i64.
    Ok((1e9 / rate_hz).round() as i64)
}

/// Loads the world of service `config` from folder `dir`.
fn load_world(config: &ServiceConfig<'_>, dir: &Path) -> Result<World, BuildError> {
    World::load(dir).map_err(|e| {
        let place = if dir.is_relative() {
            std::env::current_dir().map_or_else(
                |_| String::new(),
                |cwd| format!(" (relative to {})", cwd.display()),
            )
        } else {
            String::new()
        };
        invalid(config, format!("world `{}`{place}: {e}", dir.display()))
    })
}

/// Whether service `config` provides `T` in the robot file.
fn provides<T: Interface>(config: &ServiceConfig<'_>) -> bool {
    config.spec.provision(T::NAME).is_some()
}

/// Publishes `message`, logging (not failing) when the channel refuses it: a sensor that
/// misses one sample goes on with the next.
fn publish<T: Interface>(ctx: &mut Context<'_>, message: &mut T) {
    if let Err(e) = ctx.publish(message) {
        ctx.warn(&format!("cannot publish {}: {e}", T::NAME));
    }
}

/// The true pose a sensor renders from: the latest GroundTruth sample, and the reference
/// to it that every publication rendered from it carries as provenance; and where the
/// people are, from the latest WorldState sample (when the sensor requires WorldState).
///
/// A sensor's follower ([`TruthFollower::for_sensor`]) does not render from a pose older
/// than [`MAX_TRUTH_AGE_NS`]: without the simulator (the base failed) there is no world to
/// see, and a sensor that went on rendering the last pose would report a world standing
/// still whatever happened in it. It falls silent instead, and the broker blames its
/// silence on the missing input, not on the sensor.
#[derive(Debug, Clone, Default)]
pub struct TruthFollower {
    /// The oldest pose rendered from, if any is too old.
    max_age_ns: Option<i64>,
    /// The pose, its provenance, and when it was received.
    latest: Option<(Pose2, InputRef, i64)>,
    people: Option<(Vec<PersonState>, InputRef)>,
    /// Whether `people` changed since it was last put in a world.
    people_changed: bool,
    warned: bool,
    /// Whether the pose's going stale was said (once, until a new pose comes).
    said_stale: bool,
}

/// The oldest GroundTruth a sensor renders from: 25 periods of the base's 50 Hz, longer
/// than any restart's gap that the base's own checks let pass.
pub const MAX_TRUTH_AGE_NS: i64 = 500_000_000;

impl TruthFollower {
    /// A sensor's follower: nothing is rendered from a pose older than
    /// [`MAX_TRUTH_AGE_NS`].
    #[must_use]
    pub fn for_sensor() -> Self {
        Self {
            max_age_ns: Some(MAX_TRUTH_AGE_NS),
            ..Self::default()
        }
    }

    /// Takes in `input` when it is a GroundTruth or WorldState sample (other inputs are
    /// ignored).
    pub fn take(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        let source = |seq| InputRef {
            channel: input.channel.to_owned(),
            seq,
        };
        let taken = if input.interface == GroundTruth::NAME {
            input.decode::<GroundTruth>().map(|truth| {
                self.latest = Some((
                    Pose2::from_msg(&truth.pose),
                    source(truth.header.seq),
                    ctx.now(),
                ));
                if std::mem::take(&mut self.said_stale) {
                    ctx.info("GroundTruth is back: rendering again");
                }
            })
        } else if input.interface == WorldState::NAME {
            input.decode::<WorldState>().map(|state| {
                self.people = Some((state.people, source(state.header.seq)));
                self.people_changed = true;
            })
        } else {
            return;
        };
        match taken {
            Ok(()) => self.warned = false,
            Err(e) => {
                if !self.warned {
                    ctx.warn(&format!("ignoring a {} sample: {e}", input.interface));
                    self.warned = true;
                }
            }
        }
    }

    /// The latest true pose, after putting the people of the latest WorldState sample in
    /// `world` and setting the provenance of the publications that follow to the samples;
    /// `None` (nothing to render) before the first GroundTruth sample, and for a sensor
    /// while the latest is older than [`MAX_TRUTH_AGE_NS`].
    pub fn pose_for_rendering(
        &mut self,
        ctx: &mut Context<'_>,
        world: &mut World,
    ) -> Option<Pose2> {
        let (pose, source, received_ns) = self.latest.as_ref()?;
        if self
            .max_age_ns
            .is_some_and(|max| ctx.now().saturating_sub(*received_ns) > max)
        {
            if !self.said_stale {
                self.said_stale = true;
                ctx.warn(&format!(
                    "no GroundTruth for more than {} ms: nothing rendered until it comes back",
                    MAX_TRUTH_AGE_NS / 1_000_000
                ));
            }
            return None;
        }
        let mut inputs = vec![source.clone()];
        if let Some((people, source)) = &self.people {
            if self.people_changed {
                self.people_changed = false;
                for person in people {
                    if let Some(index) = world.object_index(&person.name) {
                        let at = lewis_geometry::Vec2::new(person.position.x, person.position.y);
                        world.place_person(index, person.present.then_some(at));
                    }
                }
            }
            inputs.push(source.clone());
        }
        ctx.set_inputs(inputs);
        Some(*pose)
    }
}

/// A sector count from a command or a parameter, checked.
fn sector_count(count: i64) -> Option<usize> {
    usize::try_from(count)
        .ok()
        .filter(|n| (1..=360).contains(n))
}
