//! Small recordings written with the recorder as a live run would be.
//!
//! - [`failover_run`]: the robot drives for 2 s in the simulated conference world while the
//!   laser scans; at 1 s the laser goes out of service and the broker rebinds the avoider to
//!   the sonar. A camera image with blobs and a sign, blobs placed in space, and a mission
//!   of the sequencer with a restart, recovery and the supervisor's choice.
//! - [`replay_run`]: what `lewis replay --inject-fault laser@1s-1.5s:stall` writes: the
//!   recorded channels, and on `/replay/...` the re-simulated broker decisions, health,
//!   mover and the injected fault.

// Helpers of tests, as the files that use them: a failed unwrap is the test failing.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{
    Blob, Blob3D, Blobs, Blobs3D, Broker, Egomotion, GroundTruth, Header, Health, ImageSource,
    InputRef, LogLine, Mover, Point2D, Point3D, Pose2D, Pose3D, Power, RangeFinder, Sequencer,
    Sign, Signs,
};
use lewis_interfaces::{Interface, interface_info};
use lewis_recorder::{ChannelId, ChannelSpec, Recorder, RecorderOptions, RobotDescription, Sample};

/// Log time of the first message: 2023-11-14, as a live run's clock would say.
pub const START_NS: i64 = 1_700_000_000_000_000_000;
/// Steps of the run, 100 ms apart.
pub const STEPS: i64 = 20;
/// The step at which the laser fails.
pub const FAILOVER_STEP: i64 = 10;
const STEP_NS: i64 = 100_000_000;

struct Writer {
    recorder: Recorder,
    seqs: BTreeMap<u32, u64>,
}

impl Writer {
    fn channel<T: Interface>(&mut self, provider: &str, topic: &str) -> ChannelId {
        let info = interface_info(T::NAME).unwrap();
        self.recorder
            .add_channel(ChannelSpec::publication(info, provider, topic))
            .unwrap()
    }

    fn write<T: Interface>(&mut self, channel: ChannelId, mut message: T, time_ns: i64) {
        let seq = self.seqs.entry(channel.0).or_default();
        *seq += 1;
        let seq = *seq;
        let header = message.header_mut();
        header.seq = seq;
        header.publish_time_ns = time_ns - 20_000;
        if header.provider.is_empty() {
            header.provider = "test".to_owned();
        }
        let data = cdr::to_vec(&message);
        self.recorder
            .write(&Sample {
                channel,
                seq,
                publish_time_ns: time_ns - 20_000,
                log_time_ns: time_ns,
                data: &data,
            })
            .unwrap();
    }
}

fn header(provider: &str) -> Header {
    Header {
        provider: provider.to_owned(),
        ..Header::default()
    }
}

fn pose(k: i64) -> Pose2D {
    let k = k as f64;
    Pose2D {
        x: 0.1 * k,
        y: 0.02 * k * k / 10.0,
        theta: 0.05 * k,
    }
}

/// A laser scan: 181 beams over 180 degrees, all at 3 m but one beam with no return.
fn laser_scan() -> RangeFinder {
    let mut ranges = vec![3.0; 181];
    ranges[90] = 8.0;
    RangeFinder {
        header: header("laser"),
        range_count: 181,
        ranges,
        max_range: 8.0,
        uniform: true,
        sensor_positions: vec![Pose3D::default(); 181],
        x_offset: 0.1,
        theta_offset: -std::f64::consts::FRAC_PI_2,
        theta_separation: std::f64::consts::PI / 180.0,
        ..RangeFinder::default()
    }
}

/// A sonar ring: 24 transducers around the robot, every reading at 2 m.
fn sonar_scan() -> RangeFinder {
    let positions: Vec<Pose3D> = (0..24)
        .map(|i| {
            let theta = f64::from(i) * std::f64::consts::TAU / 24.0;
            Pose3D {
                x: 0.25 * theta.cos(),
                y: 0.25 * theta.sin(),
                theta,
                ..Pose3D::default()
            }
        })
        .collect();
    RangeFinder {
        header: header("sonar"),
        range_count: 24,
        ranges: vec![2.0; 24],
        max_range: 5.0,
        uniform: false,
        sensor_positions: positions,
        ..RangeFinder::default()
    }
}

/// Writes `frames` camera frames (64x48 rgb8, of noise), 100 ms apart, to `dir/camera.mcap`
/// and returns its path.
pub fn camera_run(dir: &Path, frames: i64) -> PathBuf {
    let path = dir.join("camera.mcap");
    let mut w = writer(&path, None);
    let camera = w.channel::<ImageSource>("camera", "/camera/ImageSource");
    let (width, height) = (64_i32, 48_i32);
    let mut noise = lewis_service::NoiseBytes::new(1, 0);
    for k in 0..frames {
        let data: Vec<u8> = (0..width * height * 3).map(|_| noise.next_byte()).collect();
        w.write(
            camera,
            ImageSource {
                header: header("camera"),
                width,
                height,
                encoding: "rgb8".to_owned(),
                step: width * 3,
                data,
                ..ImageSource::default()
            },
            START_NS + k * STEP_NS,
        );
    }
    w.recorder.close().unwrap();
    path
}

/// A robot description whose simulated base lives in `world`, as `lewis up` stores it.
pub fn robot_toml(world: &str) -> String {
    format!(
        "[robot]\nname = \"sim\"\n\n[[services]]\nname = \"sim-base\"\nkind = \"sim-base\"\n\n\
         [services.parameters]\nworld = \"{world}\"\n"
    )
}

/// The conference world of the repository, by its absolute path.
pub fn conference_world() -> String {
    lewis_testkit::repository_root()
        .join("robots/worlds/conference")
        .display()
        .to_string()
}

fn writer(path: &Path, robot_toml: Option<String>) -> Writer {
    // Small chunks, so that a file cut short still has complete ones.
    let options = RecorderOptions {
        chunk_size_bytes: 16 * 1024,
        robot_description: robot_toml.map(|toml| RobotDescription {
            file_name: "sim.toml".to_owned(),
            toml,
        }),
        ..RecorderOptions::new(path)
    };
    Writer {
        recorder: Recorder::create(options).unwrap(),
        seqs: BTreeMap::new(),
    }
}

/// Writes the run to `dir/run.mcap` in the repository's conference world and returns its
/// path.
pub fn failover_run(dir: &Path) -> PathBuf {
    failover_run_in(dir, Some(&conference_world()))
}

/// Writes the run to `dir/run.mcap`, its robot description naming `world` (or none), and
/// returns its path.
pub fn failover_run_in(dir: &Path, world: Option<&str>) -> PathBuf {
    let path = dir.join("run.mcap");
    let mut w = writer(&path, world.map(robot_toml));
    let truth = w.channel::<GroundTruth>("sim-base", "/sim-base/GroundTruth");
    let odometry = w.channel::<Egomotion>("sim-base", "/sim-base/Egomotion");
    let laser = w.channel::<RangeFinder>("laser", "/laser/RangeFinder");
    let sonar = w.channel::<RangeFinder>("sonar", "/sonar/RangeFinder");
    let broker = w.channel::<Broker>("broker", "/lewis/broker");
    let laser_health = w.channel::<Health>("laser", "/lewis/health/laser");
    let log = w.channel::<LogLine>("lewis", "/lewis/log");
    let camera = w.channel::<ImageSource>("camera", "/camera/ImageSource");
    let blobs = w.channel::<Blobs>("blobs", "/blobs/Blobs");
    let mover = w.channel::<Mover>("mover", "/mover/Mover");
    let power = w.channel::<Power>("base", "/base/Power");
    let blobs3d = w.channel::<Blobs3D>("blobfinder3d", "/blobfinder3d/Blobs3D");
    let signs = w.channel::<Signs>("signs", "/signs/Signs");
    let sequencer = w.channel::<Sequencer>("lewis-sequencer", "/lewis/sequencer");
    let mission = mission();

    for k in 0..STEPS {
        let t = START_NS + k * STEP_NS;
        w.write(
            truth,
            GroundTruth {
                header: header("sim-base"),
                pose: pose(k),
                translation_velocity: 1.0,
                ..GroundTruth::default()
            },
            t,
        );
        w.write(
            odometry,
            Egomotion {
                header: header("sim-base"),
                pose: Pose2D {
                    x: pose(k).x * 1.01,
                    ..pose(k)
                },
                translation_velocity: 1.0,
                ..Egomotion::default()
            },
            t + 1_000,
        );
        if k < FAILOVER_STEP {
            w.write(laser, laser_scan(), t + 2_000);
            w.write(
                laser_health,
                Health {
                    header: header("laser"),
                    state: "ok".to_owned(),
                    reason: String::new(),
                },
                t + 3_000,
            );
        } else {
            w.write(sonar, sonar_scan(), t + 2_000);
        }
        if k == FAILOVER_STEP {
            w.write(
                laser_health,
                Health {
                    header: header("laser"),
                    state: "out-of-service".to_owned(),
                    reason: "no data from the serial port".to_owned(),
                },
                t + 3_000,
            );
            w.write(
                broker,
                Broker {
                    header: header("broker"),
                    action: "rebind".to_owned(),
                    reason: "laser is out of service".to_owned(),
                    client: "avoider".to_owned(),
                    interface: "RangeFinder".to_owned(),
                    from_service: "laser".to_owned(),
                    to_service: "sonar".to_owned(),
                    at_ns: t,
                    ..Broker::default()
                },
                t + 4_000,
            );
            w.write(
                log,
                LogLine {
                    header: header("lewis"),
                    service: "laser".to_owned(),
                    stream: "stderr".to_owned(),
                    level: "error".to_owned(),
                    text: "lost the serial port".to_owned(),
                },
                t + 5_000,
            );
        }
        if k == 5 {
            let (width, height) = (8_usize, 6_usize);
            let data: Vec<u8> = (0..width * height * 3)
                .map(|i| (i * 5 % 256) as u8)
                .collect();
            w.write(
                camera,
                ImageSource {
                    header: header("camera"),
                    width: width as i32,
                    height: height as i32,
                    encoding: "rgb8".to_owned(),
                    step: (width * 3) as i32,
                    data,
                    ..ImageSource::default()
                },
                t + 6_000,
            );
            let blob = Blob {
                colour_index: 0,
                colour_name: "orange".to_owned(),
                colour_rgb: 0x00ff_8000,
                area: 6,
                centroid_x: 3.0,
                centroid_y: 2.5,
                left: 2,
                top: 2,
                right: 4,
                bottom: 3,
            };
            w.write(
                blobs,
                Blobs {
                    header: Header {
                        inputs: vec![InputRef {
                            channel: "/camera/ImageSource".to_owned(),
                            seq: 1,
                        }],
                        ..header("blobs")
                    },
                    image_width: width as i32,
                    image_height: height as i32,
                    blob_count: 1,
                    blobs: vec![blob.clone()],
                },
                t + 7_000,
            );
            w.write(blobs3d, blobs_in_space(&blob), t + 7_500);
            w.write(
                signs,
                Signs {
                    header: Header {
                        inputs: vec![InputRef {
                            channel: "/camera/ImageSource".to_owned(),
                            seq: 1,
                        }],
                        ..header("signs")
                    },
                    sign_count: 1,
                    signs: vec![Sign {
                        position: Point3D {
                            x: 2.0,
                            y: -0.5,
                            z: 1.5,
                        },
                        arrow_direction: std::f64::consts::PI,
                        arrow: "left".to_owned(),
                        confidence: 0.9,
                        board: Blob {
                            left: 1,
                            top: 1,
                            right: 6,
                            bottom: 4,
                            ..Blob::default()
                        },
                    }],
                },
                t + 7_600,
            );
        }
        // The mission's records, a few per step, in order.
        for record in mission.iter().skip(usize::try_from(k).unwrap() * 2).take(2) {
            w.write(sequencer, record.clone(), t + 9_500);
        }
        w.write(
            mover,
            Mover {
                header: header("mover"),
                goal_id: 1,
                goal: Pose2D {
                    x: 3.0,
                    y: 1.0,
                    theta: 0.0,
                },
                status: if k == STEPS - 1 { "arrived" } else { "moving" }.to_owned(),
                distance_to_goal: 3.0 - pose(k).x,
                translation_velocity: 0.5,
                rotation_velocity: 0.1,
                waypoint: Point2D { x: 2.0, y: 0.5 },
            },
            t + 8_000,
        );
        w.write(
            power,
            Power {
                header: header("base"),
                voltage: 48.0 - 0.01 * k as f64,
                charge_fraction: 0.9,
                charging: false,
                low: false,
            },
            t + 9_000,
        );
    }
    w.recorder.close().unwrap();
    path
}

/// The blobs seen at step 5 placed in space: one with a range, one without.
fn blobs_in_space(blob: &Blob) -> Blobs3D {
    let placed = |range_valid: bool, y: f64| Blob3D {
        blob: blob.clone(),
        range_valid,
        position: Point3D { x: 1.5, y, z: 0.3 },
        width: 0.2,
        height: 0.2,
    };
    Blobs3D {
        header: header("blobfinder3d"),
        blob_count: 2,
        blobs: vec![placed(true, 0.4), placed(false, -0.4)],
    }
}

/// One record of the sequencer.
fn record(entry: &str, kind: &str, state: &str) -> Sequencer {
    Sequencer {
        header: header("lewis-sequencer"),
        entry: entry.to_owned(),
        kind: kind.to_owned(),
        state: state.to_owned(),
        ..Sequencer::default()
    }
}

/// The number of records of [`mission`].
pub const MISSION_RECORDS: u64 = 20;

/// A mission as the sequencer records it: `door` exits 0 to `sign`, `sign` crashes, is
/// restarted, exits with an unlisted code, `oops` recovers, the supervisor chooses `sign`,
/// which leads to `stop`.
fn mission() -> Vec<Sequencer> {
    let mut started = record("mission_started", "", "");
    started.program = "challenge.seq".to_owned();
    started.states = vec!["door".into(), "sign".into(), "oops".into()];
    started.state_count = 3;
    started.use_gui = true;
    started.supervision = "page".to_owned();
    let run = |state: &str, attempt: u32| Sequencer {
        attempt,
        program: format!("./bin/{state}"),
        ..record("decided", "run", state)
    };
    let exited = |code: i32| Sequencer {
        code,
        ..record("observed", "exited", "")
    };
    let mut ask = record("decided", "ask_supervisor", "");
    ask.states = vec!["door".into(), "sign".into(), "oops".into()];
    ask.state_count = 3;
    ask.suggested = "stop".to_owned();
    ask.reason = "recovery `oops` is over (exit code 0)".to_owned();
    let transition = |from: &str, to: &str| Sequencer {
        to: to.to_owned(),
        ..record("decided", "transition", from)
    };
    let records = vec![
        started,
        run("door", 1),
        exited(0),
        transition("door", "sign"),
        run("sign", 1),
        Sequencer {
            code: 11,
            ..record("observed", "signalled", "")
        },
        Sequencer {
            attempt: 2,
            ..record("decided", "restart", "sign")
        },
        run("sign", 2),
        exited(5),
        record("decided", "enter_recovery", "sign"),
        run("oops", 1),
        exited(0),
        ask,
        record("observed", "supervisor_chose", "sign"),
        record("decided", "resume", "sign"),
        run("sign", 1),
        exited(0),
        transition("sign", "stop"),
        record("decided", "finished", ""),
        Sequencer {
            pid: 4242,
            attempt: 1,
            ..record("program_started", "", "sign")
        },
    ];
    assert_eq!(records.len() as u64, MISSION_RECORDS);
    records
}

/// The broker's decision to bind the avoider's RangeFinder to `service`, or to move it.
fn binding(action: &str, from: &str, to: &str, at_ns: i64) -> Broker {
    Broker {
        header: header("broker"),
        action: action.to_owned(),
        reason: "test".to_owned(),
        client: "avoider".to_owned(),
        interface: "RangeFinder".to_owned(),
        service: to.to_owned(),
        from_service: from.to_owned(),
        to_service: to.to_owned(),
        at_ns,
    }
}

/// Writes a replay's output to `dir/replay.mcap` (see the module's documentation) and
/// returns its path. No world is named.
pub fn replay_run(dir: &Path) -> PathBuf {
    let path = dir.join("replay.mcap");
    let mut w = writer(&path, None);
    let truth = w.channel::<GroundTruth>("sim-base", "/sim-base/GroundTruth");
    let broker = w.channel::<Broker>("broker", "/lewis/broker");
    let laser = w.channel::<RangeFinder>("laser", "/laser/RangeFinder");
    let mover = w.channel::<Mover>("mover", "/mover/Mover");
    let replay_broker = w.channel::<Broker>("broker", "/replay/lewis/broker");
    let replay_health = w.channel::<Health>("laser", "/replay/lewis/health/laser");
    let replay_mover = w.channel::<Mover>("mover", "/replay/mover/Mover");
    let faults = w.channel::<LogLine>("lewis-replay", "/replay/lewis/faults");
    for k in 0..STEPS {
        let t = START_NS + k * STEP_NS;
        w.write(
            truth,
            GroundTruth {
                header: header("sim-base"),
                pose: pose(k),
                ..GroundTruth::default()
            },
            t,
        );
        if k == 0 {
            w.write(broker, binding("bind", "", "laser", t), t + 1_000);
            w.write(replay_broker, binding("bind", "", "laser", t), t + 1_000);
        }
        w.write(laser, laser_scan(), t + 2_000);
        let moving = Mover {
            header: header("mover"),
            goal_id: 1,
            goal: Pose2D {
                x: 3.0,
                y: 1.0,
                theta: 0.0,
            },
            status: "moving".to_owned(),
            ..Mover::default()
        };
        w.write(mover, moving.clone(), t + 3_000);
        w.write(replay_mover, moving, t + 3_000);
        let fault = |text: String| LogLine {
            header: header("lewis-replay"),
            service: "laser".to_owned(),
            stream: "fault".to_owned(),
            level: "warn".to_owned(),
            text,
        };
        if k == FAILOVER_STEP {
            w.write(
                faults,
                fault("fault injected: laser stall (laser@1s-1.5s:stall)".to_owned()),
                t + 4_000,
            );
        }
        if k == FAILOVER_STEP + 1 {
            w.write(
                replay_health,
                Health {
                    header: header("laser"),
                    state: "out-of-service".to_owned(),
                    reason: "missed its heartbeat".to_owned(),
                },
                t + 5_000,
            );
            w.write(
                replay_broker,
                binding("rebind", "laser", "sonar", t),
                t + 6_000,
            );
        }
        if k == FAILOVER_STEP + 5 {
            w.write(
                faults,
                fault("fault ends: laser recovers (laser@1s-1.5s:stall)".to_owned()),
                t + 4_000,
            );
        }
    }
    w.recorder.close().unwrap();
    path
}

/// The signs' places along [`corridor_run`]'s path (world frame, m).
pub const CORRIDOR_SIGNS: [[f64; 2]; 2] = [[12.0, 14.4], [20.0, 11.1]];
/// Where the laser fails for good in [`corridor_run`] (world frame, m).
pub const LASER_DIES_AT: [f64; 2] = [16.0, 12.5];

/// A mission along the conference world's corridor, for the picture: `door` from x 3 to
/// 9 m, then `sign` to x 26 m; the camera sees a sign beside the path twice (at x 12 and
/// 20 m, 1.9 m to the left and 1.4 m to the right) on every step within 4 m of it; the laser
/// fails for good at x 16 m. Writes `dir/corridor.mcap` and returns its path.
pub fn corridor_run(dir: &Path) -> PathBuf {
    let path = dir.join("corridor.mcap");
    let mut w = writer(&path, Some(robot_toml(&conference_world())));
    let truth = w.channel::<GroundTruth>("base", "/base/GroundTruth");
    let broker = w.channel::<Broker>("broker", "/lewis/broker");
    let signs = w.channel::<Signs>("sign_detector", "/sign_detector/Signs");
    let sequencer = w.channel::<Sequencer>("lewis-sequencer", "/lewis/sequencer");
    let run = |state: &str| Sequencer {
        attempt: 1,
        program: format!("./bin/{state}"),
        ..record("decided", "run", state)
    };
    let mut t = START_NS;
    w.write(sequencer, run("door"), t);
    let mut failed = false;
    for k in 0..=230 {
        t += STEP_NS;
        let x = 3.0 + 0.1 * f64::from(k);
        if (x - 9.0).abs() < 1e-9 {
            w.write(
                sequencer,
                Sequencer {
                    to: "sign".to_owned(),
                    ..record("decided", "transition", "door")
                },
                t,
            );
            w.write(sequencer, run("sign"), t + 1);
        }
        let pose = Pose2D {
            x,
            y: 12.5,
            theta: 0.0,
        };
        w.write(
            truth,
            GroundTruth {
                header: header("base"),
                pose: pose.clone(),
                ..GroundTruth::default()
            },
            t + 10,
        );
        if !failed && x >= LASER_DIES_AT[0] {
            failed = true;
            w.write(
                broker,
                Broker {
                    header: header("broker"),
                    action: "service-failed".to_owned(),
                    reason: "laser crashed 3 times within 60 s".to_owned(),
                    service: "laser".to_owned(),
                    at_ns: t,
                    ..Broker::default()
                },
                t + 20,
            );
        }
        let seen: Vec<Sign> = CORRIDOR_SIGNS
            .iter()
            .zip(["right", "up"])
            .filter(|([sx, _], _)| (sx - x).abs() < 4.0 && *sx > x)
            .map(|([sx, sy], arrow)| Sign {
                position: Point3D {
                    x: sx - x,
                    y: sy - 12.5,
                    z: 1.2,
                },
                arrow: arrow.to_owned(),
                confidence: 0.9,
                ..Sign::default()
            })
            .collect();
        if !seen.is_empty() {
            w.write(
                signs,
                Signs {
                    header: header("sign_detector"),
                    sign_count: seen.len() as i32,
                    signs: seen,
                },
                t + 30,
            );
        }
    }
    w.write(sequencer, record("decided", "finished", ""), t + 40);
    w.recorder.close().unwrap();
    path
}
