//! The motion services through the `Service` trait, on a test backend: commands, replies,
//! fail-safe behaviour, and closed-loop drives of the simulator's pure models (the
//! conference world, the synchro-drive base, the laser and the sonar ring), with
//! `vector_mover` and `obstacle_avoider` talking to each other and to the base through
//! calls, as their processes do.

use std::path::Path;

use lewis_interfaces::msg::{
    Egomotion, Mover, MoverGoto, MoverStop, Pose2D, RangeFinder, SynchrodriveSetVelocity,
    SynchrodriveSetVelocityReply, SynchrodriveStop,
};
use lewis_interfaces::{Command, Interface, cdr};
use lewis_robot::Robot;
use lewis_service::Health;
use lewis_service::{BuildError, CallFailure, CallId, CommandError, ServiceRegistry};
use lewis_testkit::{Harness, robot};

use crate::MoverStatus;
use lewis_geometry::Pose2;
use lewis_sim::{BaseConfig, LaserConfig, SimBase, SimLaser, SimSonar, SonarConfig, World};

// The heartbeat period is the one these tests were written with.
const ROBOT: &str = r#"
[robot]
name = "motion-test"

[broker]
heartbeat_period_ms = 100

[[services]]
name = "base"
command = ["base"]
provides = [
    { interface = "Synchrodrive", quality = 10, cost = 1 },
    { interface = "Egomotion", quality = 10, cost = 1 },
]

[[services]]
name = "laser"
command = ["laser"]
provides = [
    { interface = "RangeFinder", quality = 10, cost = 1 },
    { interface = "Distance", quality = 10, cost = 1 },
]

[[services]]
name = "vector_mover"
kind = "vector_mover"
provides = [{ interface = "Mover", quality = 5, cost = 1 }]
requires = ["Egomotion", "Synchrodrive"]

[[services]]
name = "obstacle_avoider"
kind = "obstacle_avoider"
provides = [{ interface = "Mover", quality = 10, cost = 2 }]
requires = ["RangeFinder", "Egomotion", "Mover"]
"#;

fn build(robot: &Robot, name: &str) -> Result<Harness, BuildError> {
    let mut registry = ServiceRegistry::new();
    super::register(&mut registry);
    Harness::build(robot, name, &registry)
}

/// One service on `lewis-testkit`'s harness, driven by hand: inputs stamped as their
/// provider would, calls as tuples.
struct Rig(Harness);

impl std::ops::Deref for Rig {
    type Target = Harness;
    fn deref(&self) -> &Harness {
        &self.0
    }
}

impl std::ops::DerefMut for Rig {
    fn deref_mut(&mut self) -> &mut Harness {
        &mut self.0
    }
}

impl Rig {
    fn new(robot: &Robot, name: &str) -> Self {
        Self(build(robot, name).unwrap())
    }

    fn input<T: Interface>(&mut self, provider: &str, message: &mut T, now_ns: i64) {
        let header = message.header_mut();
        header.provider = provider.to_owned();
        header.publish_time_ns = now_ns;
        self.0.send(now_ns, provider, &*message);
    }

    /// Sends `command` at the time of the last event.
    fn command<C: Command>(&mut self, command: &C) -> Result<C::Reply, CommandError> {
        let now = self.0.backend.now_ns;
        self.0.command(now, command)
    }

    /// Answers `call` at the time of the last event.
    fn reply(
        &mut self,
        call: CallId,
        interface: &str,
        command: &str,
        result: Result<&[u8], CallFailure>,
    ) {
        let now = self.0.backend.now_ns;
        self.0.reply(now, call, interface, command, result);
    }

    /// `(call, interface, command, message)`.
    fn take_calls(&mut self) -> Vec<(CallId, String, &'static str, Vec<u8>)> {
        self.0
            .take_calls()
            .into_iter()
            .map(|c| (c.id, c.interface, c.command, c.message))
            .collect()
    }

    fn last_status(&self) -> Mover {
        self.0.last::<Mover>().expect("a Mover publication")
    }
}

fn egomotion(x: f64, y: f64, theta: f64) -> Egomotion {
    Egomotion {
        pose: Pose2D { x, y, theta },
        ..Egomotion::default()
    }
}

const TICK_NS: i64 = 100_000_000;

#[test]
fn a_vector_mover_drives_towards_a_goal_and_publishes_its_status() {
    let robot = robot(ROBOT);
    let mut rig = Rig::new(&robot, "vector_mover");
    let reply = rig
        .command(&MoverGoto {
            x: 2.0,
            y: 0.0,
            ..MoverGoto::default()
        })
        .unwrap();
    assert_eq!(reply.goal_id, 1);
    rig.input("base", &mut egomotion(0.0, 0.0, 0.0), 0);
    rig.tick(TICK_NS / 2);
    let calls = rig.take_calls();
    assert_eq!(calls.len(), 1, "one velocity command per tick");
    let (_, interface, command, message) = &calls[0];
    assert_eq!(
        (interface.as_str(), *command),
        ("Synchrodrive", "set_velocity")
    );
    let velocity: SynchrodriveSetVelocity = cdr::from_bytes(message).unwrap();
    assert!(velocity.translation_velocity > 0.0, "{velocity:?}");
    let status = rig.last_status();
    assert_eq!((status.goal_id, status.status.as_str()), (1, "moving"));
    assert_eq!(status.header.provider, "vector_mover");
    assert_eq!(status.header.inputs[0].channel, "/base/Egomotion");
}

#[test]
fn a_vector_mover_holds_the_robot_when_odometry_goes_stale_and_says_so() {
    let robot = robot(ROBOT);
    let mut rig = Rig::new(&robot, "vector_mover");
    rig.command(&MoverGoto {
        x: 2.0,
        ..MoverGoto::default()
    })
    .unwrap();
    rig.input("base", &mut egomotion(0.0, 0.0, 0.0), 0);
    rig.tick(TICK_NS);
    // No odometry for a second.
    rig.tick(TICK_NS + 1_000_000_000);
    let calls = rig.take_calls();
    let last: SynchrodriveSetVelocity = cdr::from_bytes(&calls.last().unwrap().3).unwrap();
    assert_eq!(
        (last.translation_velocity, last.rotation_velocity),
        (0.0, 0.0)
    );
    assert!(
        matches!(rig.backend.health.last(), Some(Health::Degraded(why)) if why.contains("Egomotion")),
        "{:?}",
        rig.backend.health
    );
    assert_eq!(rig.last_status().status, "moving", "the goal is kept");
    rig.input("base", &mut egomotion(0.0, 0.0, 0.0), 2_000_000_000);
    rig.tick(2_000_000_000);
    assert_eq!(rig.backend.health.last(), Some(&Health::Ok));
}

#[test]
fn a_vector_mover_at_rest_stops_sending_once_the_base_confirmed_zero() {
    let robot = robot(ROBOT);
    let mut rig = Rig::new(&robot, "vector_mover");
    rig.input("base", &mut egomotion(0.0, 0.0, 0.0), 0);
    rig.tick(TICK_NS);
    assert!(
        rig.take_calls().is_empty(),
        "no goal, never moved: nothing to say"
    );
    rig.command(&MoverGoto {
        x: 1.0,
        ..MoverGoto::default()
    })
    .unwrap();
    rig.tick(2 * TICK_NS);
    rig.command(&MoverStop::default()).unwrap();
    let mut now = 3 * TICK_NS;
    let mut zero_answered = false;
    for _ in 0..30 {
        rig.input("base", &mut egomotion(0.0, 0.0, 0.0), now);
        rig.tick(now);
        let calls = rig.take_calls();
        if zero_answered {
            assert!(calls.is_empty(), "resting and confirmed: {calls:?}");
        }
        for (call, _, command, message) in calls {
            let sent: SynchrodriveSetVelocity = cdr::from_bytes(&message).unwrap();
            let reply = cdr::to_vec(&SynchrodriveSetVelocityReply::default());
            rig.reply(call, "Synchrodrive", command, Ok(&reply));
            zero_answered = sent.translation_velocity == 0.0 && sent.rotation_velocity == 0.0;
        }
        now += TICK_NS;
    }
    assert!(zero_answered);
}

#[test]
fn a_vector_mover_sends_no_more_commands_to_a_base_that_does_not_answer() {
    let robot = robot(ROBOT);
    let mut rig = Rig::new(&robot, "vector_mover");
    rig.command(&MoverGoto {
        x: 3.0,
        ..MoverGoto::default()
    })
    .unwrap();
    let mut now = 0;
    for _ in 0..10 {
        rig.input("base", &mut egomotion(0.0, 0.0, 0.0), now);
        rig.tick(now);
        now += TICK_NS;
    }
    assert_eq!(
        rig.take_calls().len(),
        super::vector_mover::MAX_CALLS_IN_FLIGHT
    );
    assert!(
        rig.backend
            .logs
            .iter()
            .any(|(_, text)| text.contains("has not answered")),
        "{:?}",
        rig.backend.logs
    );
}

#[test]
fn goals_that_are_not_finite_are_refused_with_the_reason() {
    let robot = robot(ROBOT);
    for name in ["vector_mover", "obstacle_avoider"] {
        let mut rig = Rig::new(&robot, name);
        let err = rig
            .command(&MoverGoto {
                x: f64::NAN,
                ..MoverGoto::default()
            })
            .unwrap_err();
        assert!(
            err.0.contains("Mover.goto: argument x is NaN"),
            "{name}: {err}"
        );
    }
}

#[test]
fn services_missing_a_requirement_or_with_bad_parameters_are_not_built() {
    fn check(edit: (&str, &str), name: &str, expected: &str) {
        let text = ROBOT.replace(edit.0, edit.1);
        let robot = robot(&text);
        let err = build(&robot, name).map(|_| ()).unwrap_err();
        assert!(err.to_string().contains(expected), "{err}");
    }
    check(
        (
            "requires = [\"RangeFinder\", \"Egomotion\", \"Mover\"]",
            "requires = [\"Egomotion\", \"Mover\"]",
        ),
        "obstacle_avoider",
        "add \"RangeFinder\" to `requires`",
    );
    check(
        (
            "requires = [\"Egomotion\", \"Synchrodrive\"]",
            "requires = [\"Egomotion\"]",
        ),
        "vector_mover",
        "add \"Synchrodrive\" to `requires`",
    );
    check(
        (
            "requires = [\"Egomotion\", \"Synchrodrive\"]",
            "requires = [\"Egomotion\", \"Synchrodrive\"]\nparameters = { rate_hz = 0.0 }",
        ),
        "vector_mover",
        "rate_hz = 0",
    );
    check(
        (
            "requires = [\"Egomotion\", \"Synchrodrive\"]",
            "requires = [\"Egomotion\", \"Synchrodrive\"]\nparameters = { max_translation_m_s = -1.0 }",
        ),
        "vector_mover",
        "max_translation_m_s = -1",
    );
    check(
        (
            "requires = [\"RangeFinder\", \"Egomotion\", \"Mover\"]",
            "requires = [\"RangeFinder\", \"Egomotion\", \"Mover\"]\nparameters = { speed = 2.0 }",
        ),
        "obstacle_avoider",
        "unknown field `speed`",
    );
}

#[test]
fn an_avoider_with_a_goal_parameter_heads_for_it_from_its_start() {
    let text = ROBOT.replace(
        "requires = [\"RangeFinder\", \"Egomotion\", \"Mover\"]",
        "requires = [\"RangeFinder\", \"Egomotion\", \"Mover\"]\nparameters = { goal = { x_m = 2.0, y_m = 0.0 } }",
    );
    let with_goal = robot(&text);
    let mut rig = Rig::new(&with_goal, "obstacle_avoider");
    rig.start(0).unwrap();
    let scan = RangeFinder {
        range_count: 3,
        ranges: vec![5.0; 3],
        max_range: 5.0,
        uniform: true,
        sensor_positions: vec![Default::default(); 3],
        theta_offset: -0.5,
        theta_separation: 0.5,
        ..RangeFinder::default()
    };
    rig.input("base", &mut egomotion(0.0, 0.0, 0.0), 0);
    rig.input("laser", &mut scan.clone(), 0);
    rig.tick(TICK_NS);
    assert_eq!(rig.last_status().status, MoverStatus::Moving.as_str());
    let calls = rig.take_calls();
    assert_eq!(calls.len(), 1, "{calls:?}");
    assert_eq!((calls[0].1.as_str(), calls[0].2), ("Mover", "goto"));

    let bad = ROBOT.replace(
        "requires = [\"RangeFinder\", \"Egomotion\", \"Mover\"]",
        "requires = [\"RangeFinder\", \"Egomotion\", \"Mover\"]\nparameters = { goal = { x_m = inf, y_m = 0.0 } }",
    );
    let err = build(&robot(&bad), "obstacle_avoider")
        .map(|_| ())
        .unwrap_err();
    assert!(err.to_string().contains("give finite coordinates"), "{err}");
}

#[test]
fn an_avoider_that_cannot_reach_its_vector_mover_asks_again_at_the_next_step() {
    let robot = robot(ROBOT);
    let mut rig = Rig::new(&robot, "obstacle_avoider");
    rig.command(&MoverGoto {
        x: 2.0,
        ..MoverGoto::default()
    })
    .unwrap();
    let scan = RangeFinder {
        range_count: 3,
        ranges: vec![5.0; 3],
        max_range: 5.0,
        uniform: true,
        sensor_positions: vec![Default::default(); 3],
        theta_offset: -0.5,
        theta_separation: 0.5,
        ..RangeFinder::default()
    };
    rig.backend.refuse_calls = Some(CallFailure::NoProvider {
        interface: "Mover".into(),
    });
    rig.input("base", &mut egomotion(0.0, 0.0, 0.0), 0);
    rig.input("laser", &mut scan.clone(), 0);
    rig.tick(TICK_NS / 2);
    assert!(
        rig.backend
            .logs
            .iter()
            .any(|(_, t)| t.contains("cannot reach the VectorMover")),
        "{:?}",
        rig.backend.logs
    );
    rig.backend.refuse_calls = None;
    rig.input("laser", &mut scan.clone(), TICK_NS);
    rig.tick(TICK_NS);
    let calls = rig.take_calls();
    assert_eq!(calls.len(), 1, "{calls:?}");
    assert_eq!((calls[0].1.as_str(), calls[0].2), ("Mover", "goto"));
}

/// A forward laser of 61 beams over 180 degrees reading `range_m` within `half_width_rad`
/// of straight ahead and 5 m elsewhere.
fn laser_scan(range_m: f64, half_width_rad: f64) -> RangeFinder {
    let count = 61;
    let separation = std::f64::consts::PI / f64::from(count - 1);
    let offset = -std::f64::consts::FRAC_PI_2;
    RangeFinder {
        range_count: count,
        ranges: (0..count)
            .map(|i| {
                if (offset + f64::from(i) * separation).abs() <= half_width_rad {
                    range_m
                } else {
                    5.0
                }
            })
            .collect(),
        max_range: 5.0,
        uniform: true,
        sensor_positions: vec![Default::default(); count as usize],
        theta_offset: offset,
        theta_separation: separation,
        ..RangeFinder::default()
    }
}

#[test]
fn an_avoider_asks_for_a_stop_in_the_event_of_the_reading_that_shows_an_obstacle_on_the_way() {
    let robot = robot(ROBOT);
    let mut rig = Rig::new(&robot, "obstacle_avoider");
    rig.command(&MoverGoto {
        x: 3.0,
        ..MoverGoto::default()
    })
    .unwrap();
    rig.input("base", &mut egomotion(0.0, 0.0, 0.0), 0);
    rig.input("laser", &mut laser_scan(5.0, 0.0), 10_000_000);
    rig.tick(TICK_NS);
    let calls = rig.take_calls();
    assert_eq!(calls.len(), 1, "{calls:?}");
    assert_eq!((calls[0].1.as_str(), calls[0].2), ("Mover", "goto"));
    // A clear reading between ticks: nothing.
    rig.input("laser", &mut laser_scan(5.0, 0.0), TICK_NS + 20_000_000);
    assert!(rig.take_calls().is_empty());
    // Something 0.6 m ahead: the stop goes out in that reading's event, before any tick.
    rig.input("laser", &mut laser_scan(0.6, 0.1), TICK_NS + 40_000_000);
    let calls = rig.take_calls();
    assert_eq!(calls.len(), 1, "{calls:?}");
    assert_eq!((calls[0].1.as_str(), calls[0].2), ("Mover", "stop"));
    assert_eq!(rig.last_status().status, "moving", "the goal is kept");
}

#[test]
fn a_vector_mover_sends_the_velocities_of_a_command_in_the_command_event() {
    let robot = robot(ROBOT);
    let mut rig = Rig::new(&robot, "vector_mover");
    rig.command(&MoverGoto {
        x: 3.0,
        ..MoverGoto::default()
    })
    .unwrap();
    assert!(
        rig.take_calls().is_empty(),
        "no pose stepped yet: the tick carries the goal out"
    );
    let mut last = SynchrodriveSetVelocity::default();
    for i in 1..=8 {
        rig.input("base", &mut egomotion(0.0, 0.0, 0.0), i * TICK_NS - 1);
        rig.tick(i * TICK_NS);
        for (call, _, command, message) in rig.take_calls() {
            last = cdr::from_bytes(&message).unwrap();
            let reply = cdr::to_vec(&SynchrodriveSetVelocityReply::default());
            rig.reply(call, "Synchrodrive", command, Ok(&reply));
        }
    }
    assert!(last.translation_velocity > 0.0, "{last:?}");
    rig.command(&MoverStop::default()).unwrap();
    let calls = rig.take_calls();
    assert_eq!(calls.len(), 1, "{calls:?}");
    assert_eq!(calls[0].2, SynchrodriveSetVelocity::NAME);
    let braking: SynchrodriveSetVelocity = cdr::from_bytes(&calls[0].3).unwrap();
    assert!(
        braking.translation_velocity < last.translation_velocity,
        "{braking:?} after {last:?}"
    );
}

/// The drive of the end-to-end tests, in one thread on the simulator's pure models: the
/// conference world, a B21r base starting in the lobby, a laser and a sonar ring, and the
/// two motion services wired as the broker binds them (obstacle_avoider -> vector_mover ->
/// base). Events run in a fixed order on a simulated clock.
struct Drive {
    world: World,
    base: SimBase,
    laser: SimLaser,
    sonar: SimSonar,
    avoider: Rig,
    mover: Rig,
    now_ns: i64,
    egomotion_seq: u64,
    scan_seq: u64,
}

const SIM_STEP_NS: i64 = 10_000_000;

impl Drive {
    fn new() -> Self {
        let world = World::load(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../robots/worlds/conference"),
        )
        .unwrap();
        let robot = robot(ROBOT);
        Self {
            world,
            base: SimBase::new(BaseConfig::default(), Pose2::new(3.0, 12.5, 0.0), 7).unwrap(),
            laser: SimLaser::new(LaserConfig::default(), 8).unwrap(),
            sonar: SimSonar::new(SonarConfig::default(), 9).unwrap(),
            avoider: Rig::new(&robot, "obstacle_avoider"),
            mover: Rig::new(&robot, "vector_mover"),
            now_ns: 0,
            egomotion_seq: 0,
            scan_seq: 0,
        }
    }

    /// Runs until the avoider's status is final or `limit_ns` passes; `sensor_at` says which
    /// range finder publishes at a time (`None`: none, as during a failover).
    fn run(
        &mut self,
        limit_ns: i64,
        sensor_at: impl Fn(i64) -> Option<&'static str>,
    ) -> MoverStatus {
        let mut status = MoverStatus::Moving;
        while self.now_ns < limit_ns {
            self.base.step(&self.world, SIM_STEP_NS);
            self.now_ns += SIM_STEP_NS;
            let now = self.now_ns;
            if now % 50_000_000 == 0 {
                let mut pose = self.base.egomotion();
                self.egomotion_seq += 1;
                pose.header.seq = self.egomotion_seq;
                self.mover.input("base", &mut pose.clone(), now);
                self.avoider.input("base", &mut pose, now);
            }
            if now % 100_000_000 == 0 {
                let truth = self.base.true_pose();
                let scan = match sensor_at(now) {
                    Some("laser") => Some(self.laser.scan(&self.world, truth)),
                    Some(_) => Some(self.sonar.scan(&self.world, truth)),
                    None => None,
                };
                if let (Some(mut scan), Some(provider)) = (scan, sensor_at(now)) {
                    self.scan_seq += 1;
                    scan.header.seq = self.scan_seq;
                    self.avoider.input(provider, &mut scan, now);
                }
                self.avoider.tick(now);
                self.route_avoider_calls();
                self.mover.tick(now);
                self.route_mover_calls();
                for mut status in self.mover.take::<Mover>() {
                    self.avoider.input("vector_mover", &mut status, now);
                }
                self.mover.backend.published.clear();
                status = self.avoider.last_status().status.parse().unwrap();
                self.avoider.backend.published.clear();
                if status.is_final() {
                    break;
                }
            }
        }
        status
    }

    fn route_avoider_calls(&mut self) {
        for (call, interface, command, message) in self.avoider.take_calls() {
            assert_eq!(interface, "Mover");
            let now = self.mover.backend.now_ns;
            let answer = self
                .mover
                .command_bytes(now, "Mover", command, &message)
                .map_err(|e| CallFailure::Refused(e.0));
            match answer {
                Ok(reply) => self.avoider.reply(call, "Mover", command, Ok(&reply)),
                Err(e) => self.avoider.reply(call, "Mover", command, Err(e)),
            }
        }
    }

    fn route_mover_calls(&mut self) {
        for (call, interface, command, message) in self.mover.take_calls() {
            assert_eq!(interface, "Synchrodrive");
            let reply = if command == SynchrodriveSetVelocity::NAME {
                let v: SynchrodriveSetVelocity = cdr::from_bytes(&message).unwrap();
                self.base
                    .set_velocity(v.translation_velocity, v.rotation_velocity);
                cdr::to_vec(&SynchrodriveSetVelocityReply::default())
            } else {
                assert_eq!(command, SynchrodriveStop::NAME);
                self.base.stop();
                cdr::to_vec(&lewis_interfaces::msg::SynchrodriveStopReply::default())
            };
            self.mover.reply(call, "Synchrodrive", command, Ok(&reply));
        }
    }

    /// Sends the avoider a goal given in the world frame (the odometry starts at zero at
    /// the start pose).
    fn goto_world(&mut self, x: f64, y: f64) {
        let start = Pose2::new(3.0, 12.5, 0.0);
        let (dx, dy) = (x - start.x_m, y - start.y_m);
        let (sin, cos) = start.heading_rad.sin_cos();
        let reply = self
            .avoider
            .command(&MoverGoto {
                x: cos * dx + sin * dy,
                y: -sin * dx + cos * dy,
                ..MoverGoto::default()
            })
            .unwrap();
        assert_eq!(reply.goal_id, 1);
    }
}

#[test]
fn the_services_drive_the_simulated_robot_through_the_entrance_without_a_collision() {
    let mut drive = Drive::new();
    drive.goto_world(12.0, 13.0);
    let status = drive.run(90_000_000_000, |_| Some("laser"));
    let truth = drive.base.true_pose();
    assert_eq!(
        status,
        MoverStatus::Arrived,
        "at {truth:?} after {} ns",
        drive.now_ns
    );
    assert_eq!(drive.base.collision_count(), 0);
    assert!(
        (truth.x_m - 12.0).hypot(truth.y_m - 13.0) < 0.3,
        "arrived at {truth:?}"
    );
}

#[test]
fn the_drive_goes_on_on_sonar_when_the_laser_is_lost_half_way() {
    let mut drive = Drive::new();
    drive.goto_world(12.0, 13.0);
    // The laser until 6 s, nothing for a second (the failover), then the sonar ring.
    let status = drive.run(120_000_000_000, |now| match now {
        ..6_000_000_000 => Some("laser"),
        6_000_000_000..7_000_000_000 => None,
        _ => Some("sonar"),
    });
    let truth = drive.base.true_pose();
    assert_eq!(
        status,
        MoverStatus::Arrived,
        "at {truth:?} after {} ns",
        drive.now_ns
    );
    assert_eq!(drive.base.collision_count(), 0);
}
