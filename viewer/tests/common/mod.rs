//! A small recording of a run with a failover, written with the recorder as a live run
//! would be: the robot drives for 2 s while the laser scans; at 1 s the laser goes out of
//! service and the broker rebinds the avoider to the sonar.

#![allow(dead_code)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{
    Blob, Blobs, Broker, Egomotion, GroundTruth, Header, Health, ImageSource, InputRef, LogLine,
    Mover, Point2D, Pose2D, Pose3D, Power, RangeFinder,
};
use lewis_interfaces::{Interface, interface_info};
use lewis_recorder::{ChannelId, ChannelSpec, Recorder, RecorderOptions, Sample};

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

/// Writes the run to `dir/run.mcap` and returns its path.
pub fn failover_run(dir: &Path) -> PathBuf {
    let path = dir.join("run.mcap");
    // Small chunks, so that a file cut short still has complete ones.
    let options = RecorderOptions {
        chunk_size_bytes: 16 * 1024,
        ..RecorderOptions::new(&path)
    };
    let recorder = Recorder::create(options).unwrap();
    let mut w = Writer {
        recorder,
        seqs: BTreeMap::new(),
    };
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
                    blobs: vec![blob],
                },
                t + 7_000,
            );
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
