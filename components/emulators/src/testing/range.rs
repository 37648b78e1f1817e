//! `test-range`: a synthetic range finder (laser or sonar, by its parameters).
//!
//! It stands at the origin of a rectangular room and publishes, every tick, the distances
//! along its beams (RangeFinder) and the nearest reading in each of 8 sectors around the
//! robot (Distance), with seeded Gaussian noise.
//!
//! Faults on demand, for tests: when `fault_file` is set, the service reads that file at
//! every tick and acts on the word it holds (a test writes the file when it wants the fault,
//! so nothing depends on timing):
//!
//! | word | what the service does |
//! |---|---|
//! | `ok` (or no file) | works; declares itself healthy |
//! | `degraded` | works; declares itself degraded |
//! | `out-of-service` | stops publishing; declares itself out of service (keeps its heartbeat) |
//! | `stall` | hangs for ever inside its tick: no data, no heartbeat, no reaction to SIGTERM |
//! | `crash` | aborts (SIGABRT), at once and again after every restart |
//! | `garbage` | publishes scans of junk: readings beyond the maximum range, negative ones |
//! | `nan` | publishes scans with NaN readings |
//! | `frozen` | publishes the same readings again and again (new headers, no noise) |
//! | `slow` | publishes one tick in three (heartbeats go on) |
//!
//! The last four keep the process healthy by every other measure (heartbeats, declared
//! health): only the broker's checks of the data can see them.
//!
//! ```toml
//! [services.parameters]
//! beams = 181
//! field_of_view_deg = 180.0
//! max_range_m = 8.0
//! rate_hz = 10.0
//! noise_m = 0.01
//! seed = 1
//! fault_file = "/tmp/laser.fault"   # optional
//! start_delay_ms = 0                # optional: on_start blocks this long, as a device
//!                                   # that takes long to open and probe would
//! ```

use std::f64::consts::{PI, TAU};
use std::path::PathBuf;

use lewis_interfaces::msg::{
    Distance, DistanceCommand, DistanceSetSectorCountReply, Pose3D, RangeFinder,
    RangeFinderCommand, RangeFinderGetGeometryReply,
};
use lewis_service::Health;
use lewis_service::fault::{FAULT_FILE_FAULTS, ServiceFault, UnknownFaultWord};
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Reply, Rng, Service, ServiceConfig,
};
use serde::Deserialize;

/// The kind name in robot files.
pub const KIND: &str = "test-range";

/// The parameters of `test-range`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Beams per scan.
    pub beams: u32,
    /// The angle the beams cover, centred ahead, in degrees (360: all around).
    pub field_of_view_deg: f64,
    /// Readings beyond this are reported as this, in metres.
    pub max_range_m: f64,
    /// Scans per second.
    pub rate_hz: f64,
    /// Standard deviation of the noise on each reading, in metres.
    pub noise_m: f64,
    /// Seed of the noise (read by the runtime's seeded random source).
    pub seed: Option<u64>,
    /// The file whose word selects a fault (see the module documentation).
    pub fault_file: Option<PathBuf>,
    /// How long `on_start` blocks, in milliseconds: a device that takes that long to open
    /// (the harness must not take it for a stall).
    pub start_delay_ms: u64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            beams: 181,
            field_of_view_deg: 180.0,
            max_range_m: 8.0,
            rate_hz: 10.0,
            noise_m: 0.01,
            seed: None,
            fault_file: None,
            start_delay_ms: 0,
        }
    }
}

/// The room the synthetic sensor sees: walls at these distances from the sensor, in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Room {
    /// Distance to the wall ahead (+x).
    pub ahead_m: f64,
    /// Distance to the wall behind (-x).
    pub behind_m: f64,
    /// Distance to the wall on the left (+y).
    pub left_m: f64,
    /// Distance to the wall on the right (-y).
    pub right_m: f64,
}

impl Room {
    /// A 6 m by 4 m room, the sensor 2 m from the back wall, centred sideways.
    pub const DEFAULT: Self = Self {
        ahead_m: 4.0,
        behind_m: 2.0,
        left_m: 2.0,
        right_m: 2.0,
    };

    /// The distance to the nearest wall along bearing `bearing_rad` (counter-clockwise from
    /// ahead).
    #[must_use]
    pub fn range_at(&self, bearing_rad: f64) -> f64 {
        let (dy, dx) = bearing_rad.sin_cos();
        let along = |d: f64, wall_plus: f64, wall_minus: f64| {
            if d > 1e-12 {
                wall_plus / d
            } else if d < -1e-12 {
                wall_minus / -d
            } else {
                f64::INFINITY
            }
        };
        along(dx, self.ahead_m, self.behind_m).min(along(dy, self.left_m, self.right_m))
    }
}

/// The synthetic sensor: its geometry and the room it sees.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticScanner {
    beams: u32,
    first_bearing_rad: f64,
    separation_rad: f64,
    max_range_m: f64,
    noise_m: f64,
    room: Room,
}

/// Sectors of the Distance publication.
pub const SECTORS: usize = 8;

impl SyntheticScanner {
    /// A scanner with `params`' geometry in `room`.
    #[must_use]
    pub fn new(params: &Params, room: Room) -> Self {
        let beams = params.beams.max(1);
        let fov = params.field_of_view_deg.clamp(0.0, 360.0).to_radians();
        let separation_rad = if (fov - TAU).abs() < 1e-9 {
            fov / f64::from(beams)
        } else if beams > 1 {
            fov / f64::from(beams - 1)
        } else {
            0.0
        };
        Self {
            beams,
            first_bearing_rad: -fov / 2.0,
            separation_rad,
            max_range_m: params.max_range_m,
            noise_m: params.noise_m,
            room,
        }
    }

    /// The bearing of beam `i`.
    #[must_use]
    pub fn bearing(&self, i: u32) -> f64 {
        self.first_bearing_rad + f64::from(i) * self.separation_rad
    }

    /// One scan: the range along every beam, noisy, clamped to `[0, max_range_m]`.
    pub fn ranges(&self, rng: &mut Rng) -> Vec<f64> {
        (0..self.beams)
            .map(|i| {
                let truth = self.room.range_at(self.bearing(i));
                let noisy = if self.noise_m > 0.0 {
                    truth + rng.normal(0.0, self.noise_m)
                } else {
                    truth
                };
                noisy.clamp(0.0, self.max_range_m)
            })
            .collect()
    }

    /// The RangeFinder publication of a scan (header left to the context).
    #[must_use]
    pub fn range_finder(&self, ranges: Vec<f64>) -> RangeFinder {
        let count = i32::try_from(ranges.len()).unwrap_or(i32::MAX);
        RangeFinder {
            range_count: count,
            sensor_positions: (0..self.beams)
                .map(|i| Pose3D {
                    theta: self.bearing(i),
                    ..Pose3D::default()
                })
                .collect(),
            ranges,
            max_range: self.max_range_m,
            uniform: true,
            theta_offset: self.first_bearing_rad,
            theta_separation: self.separation_rad,
            ..RangeFinder::default()
        }
    }

    /// The Distance publication of a scan: the nearest reading in each of [`SECTORS`]
    /// sectors around the robot, sector 0 centred behind it.
    #[must_use]
    pub fn distance(&self, ranges: &[f64]) -> Distance {
        let width = TAU / SECTORS as f64;
        let first = -PI + width / 2.0;
        let mut sectors = vec![self.max_range_m; SECTORS];
        let mut min = (self.max_range_m, 0.0);
        for (i, &range) in (0..self.beams).zip(ranges) {
            let bearing = self.bearing(i);
            let offset = (bearing - (first - width / 2.0)).rem_euclid(TAU);
            // `offset / width` is in [0, SECTORS): the cast cannot truncate a valid index.
            let sector = ((offset / width) as usize).min(SECTORS - 1);
            sectors[sector] = sectors[sector].min(range);
            if range < min.0 {
                min = (range, bearing);
            }
        }
        Distance {
            sector_count: i32::try_from(SECTORS).unwrap_or(i32::MAX),
            sector_distances: sectors,
            first_sector_angle: first,
            sector_width: width,
            max_range: self.max_range_m,
            min_distance: min.0,
            min_bearing: min.1,
            ..Distance::default()
        }
    }
}

/// What the fault file asks for: a fault of the service ([`FAULT_FILE_FAULTS`] of the one
/// fault vocabulary), `None` to work normally.
pub type Fault = Option<ServiceFault>;

/// The fault a file's text names (an empty file is no fault).
///
/// # Errors
/// When the word is none of the file's, naming the words it takes.
pub fn parse_fault(text: &str) -> Result<Fault, UnknownFaultWord> {
    match text.trim() {
        "" => Ok(None),
        word => FAULT_FILE_FAULTS.parse(word),
    }
}

/// The `test-range` service.
#[derive(Debug)]
pub struct TestRange {
    params: Params,
    scanner: SyntheticScanner,
    period_ns: i64,
    provides_distance: bool,
    provides_range_finder: bool,
    /// The readings a `frozen` fault repeats, taken at its first tick.
    frozen: Option<Vec<f64>>,
    /// Ticks since the service started (a `slow` fault publishes on one in three).
    ticks: u64,
}

/// Builds a `test-range` service from its robot-file entry.
///
/// # Errors
/// When a parameter is unknown or out of range.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: Params = config.parameters()?;
    let invalid = |reason: &str| BuildError::Parameters {
        service: config.name().to_owned(),
        reason: reason.to_owned(),
    };
    if !(params.rate_hz.is_finite() && (1e-3..=10_000.0).contains(&params.rate_hz)) {
        return Err(invalid("rate_hz must be in [0.001, 10000]"));
    }
    if !(params.max_range_m.is_finite() && params.max_range_m > 0.0) {
        return Err(invalid("max_range_m must be positive"));
    }
    if params.beams == 0 {
        return Err(invalid("beams must be at least 1"));
    }
    // 1e9 / rate fits an i64 for any rate in range.
    let period_ns = (1e9 / params.rate_hz).round() as i64;
    let provides = |name: &str| config.spec.provides.iter().any(|p| p.interface == name);
    Ok(Box::new(TestRange {
        scanner: SyntheticScanner::new(&params, Room::DEFAULT),
        provides_distance: provides("Distance"),
        provides_range_finder: provides("RangeFinder"),
        params,
        period_ns,
        frozen: None,
        ticks: 0,
    }))
}

impl TestRange {
    fn fault(&self, ctx: &mut Context<'_>) -> Fault {
        let Some(path) = &self.params.fault_file else {
            return None;
        };
        match std::fs::read_to_string(path) {
            Ok(text) => parse_fault(&text).unwrap_or_else(|unknown| {
                ctx.warn(&format!(
                    "fault file {} says `{}`: expected {}{}",
                    path.display(),
                    unknown.word,
                    unknown.expected,
                    unknown.did_you_mean()
                ));
                None
            }),
            Err(_) => None,
        }
    }
}

impl Service for TestRange {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(self.period_ns)
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        if self.params.start_delay_ms > 0 {
            ctx.info(&format!(
                "opening the device takes {} ms",
                self.params.start_delay_ms
            ));
            // A device being opened and probed: on_start may block (the startup deadline
            // covers it), which is what this stands in for.
            std::thread::sleep(std::time::Duration::from_millis(self.params.start_delay_ms));
        }
        Ok(())
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        let fault = self.fault(ctx);
        match fault {
            Some(ServiceFault::Crash) => {
                ctx.warn("fault file says crash: aborting");
                std::process::abort();
            }
            Some(ServiceFault::Stall) => {
                ctx.warn("fault file says stall: hanging");
                // A stall is a hang: nothing more from this process until it is killed.
                loop {
                    std::thread::park();
                }
            }
            Some(ServiceFault::OutOfService) => {
                ctx.set_health(Health::OutOfService(
                    "fault file says out-of-service".into(),
                ));
                return;
            }
            Some(ServiceFault::Degraded) => {
                ctx.set_health(Health::Degraded("fault file says degraded".into()));
            }
            // The faults of other places (a stuck loop, a lost host) are not in the file's
            // words: the parser never gives them.
            _ => ctx.set_health(Health::Ok),
        }
        self.ticks = self.ticks.wrapping_add(1);
        let mut ranges = self.scanner.ranges(ctx.rng());
        match fault {
            Some(ServiceFault::Slow) if !self.ticks.is_multiple_of(3) => return,
            Some(ServiceFault::Nan) => {
                for r in ranges.iter_mut().step_by(7) {
                    *r = f64::NAN;
                }
            }
            Some(ServiceFault::Frozen) => {
                ranges.clone_from(self.frozen.get_or_insert(ranges.clone()));
            }
            _ => {}
        }
        if fault != Some(ServiceFault::Frozen) {
            self.frozen = None;
        }
        if fault == Some(ServiceFault::Garbage) {
            // Junk as a broken driver sends it, in a well-formed message (the harness
            // refuses to publish one whose counts disagree): readings far beyond the
            // maximum range and negative ones.
            let junk = self.params.max_range_m * 1e6;
            for (i, r) in ranges.iter_mut().enumerate() {
                *r = if i % 2 == 0 { *r + junk } else { -*r - 1.0 };
            }
            if self.provides_range_finder {
                let mut scan = self.scanner.range_finder(ranges);
                if let Err(e) = ctx.publish(&mut scan) {
                    ctx.warn(&format!("cannot publish RangeFinder: {e}"));
                }
            }
            return;
        }
        if self.provides_distance {
            let mut distance = self.scanner.distance(&ranges);
            if let Err(e) = ctx.publish(&mut distance) {
                ctx.warn(&format!("cannot publish Distance: {e}"));
            }
        }
        if self.provides_range_finder {
            let mut scan = self.scanner.range_finder(ranges);
            if let Err(e) = ctx.publish(&mut scan) {
                ctx.warn(&format!("cannot publish RangeFinder: {e}"));
            }
        }
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        match command.interface {
            "RangeFinder" => match command.decode::<RangeFinder>()? {
                RangeFinderCommand::GetGeometry(_) => Ok(ctx.reply(RangeFinderGetGeometryReply {
                    range_count: i32::try_from(self.params.beams).unwrap_or(i32::MAX),
                    max_range: self.params.max_range_m,
                    rate: self.params.rate_hz,
                    ..RangeFinderGetGeometryReply::default()
                })),
            },
            "Distance" => match command.decode::<Distance>()? {
                DistanceCommand::SetSectorCount(set) => {
                    if usize::try_from(set.sector_count).ok() == Some(SECTORS) {
                        Ok(ctx.reply(DistanceSetSectorCountReply {
                            sector_count: set.sector_count,
                            ..DistanceSetSectorCountReply::default()
                        }))
                    } else {
                        Err(CommandError::new(format!(
                            "test-range has {SECTORS} sectors, not {}",
                            set.sector_count
                        )))
                    }
                }
            },
            other => Err(CommandError::new(format!(
                "test-range does not serve {other}"
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use lewis_interfaces::Struct;

    use super::*;

    #[test]
    fn the_room_gives_the_distance_to_the_nearest_wall() {
        fn check(bearing_deg: f64, expected_m: f64) {
            let got = Room::DEFAULT.range_at(bearing_deg.to_radians());
            assert!(
                (got - expected_m).abs() < 1e-9,
                "{bearing_deg} deg: {got} m, expected {expected_m} m"
            );
        }
        check(0.0, 4.0);
        check(90.0, 2.0);
        check(-90.0, 2.0);
        check(180.0, 2.0);
        check(45.0, 2.0 * 2f64.sqrt());
    }

    #[test]
    fn a_noiseless_scan_sees_the_room_and_its_sectors() {
        let params = Params {
            beams: 5,
            field_of_view_deg: 180.0,
            noise_m: 0.0,
            ..Params::default()
        };
        let scanner = SyntheticScanner::new(&params, Room::DEFAULT);
        let ranges = scanner.ranges(&mut Rng::new(1));
        let expected = [2.0, 2.0 * 2f64.sqrt(), 4.0, 2.0 * 2f64.sqrt(), 2.0];
        for (got, want) in ranges.iter().zip(expected) {
            assert!((got - want).abs() < 1e-9, "{ranges:?}");
        }
        let scan = scanner.range_finder(ranges.clone());
        assert_eq!(scan.check_sizes(), Ok(()));
        let distance = scanner.distance(&ranges);
        assert_eq!(distance.check_sizes(), Ok(()));
        assert!((distance.min_distance - 2.0).abs() < 1e-9);
        // Behind the robot the 180-degree scanner sees nothing.
        assert_eq!(distance.sector_distances[0], params.max_range_m);
    }

    #[test]
    fn fault_words_are_read_and_unknown_ones_refused() {
        fn check(text: &str, expected: Option<Fault>) {
            assert_eq!(parse_fault(text).ok(), expected, "{text:?}");
        }
        check("crash\n", Some(Some(ServiceFault::Crash)));
        check("stall", Some(Some(ServiceFault::Stall)));
        check(" out-of-service ", Some(Some(ServiceFault::OutOfService)));
        check("", Some(None));
        check("ok", Some(None));
        check("degraded", Some(Some(ServiceFault::Degraded)));
        check("garbage", Some(Some(ServiceFault::Garbage)));
        check("nan", Some(Some(ServiceFault::Nan)));
        check("frozen\n", Some(Some(ServiceFault::Frozen)));
        check("slow", Some(Some(ServiceFault::Slow)));
        check("explode", None);
        check("stuck", None);
        assert_eq!(
            parse_fault("frozn").unwrap_err().to_string(),
            "unknown fault `frozn`: expected ok, degraded, out-of-service, stall, crash, garbage, nan, frozen or slow; did you mean `frozen`?"
        );
    }

    #[test]
    fn noise_is_the_same_for_the_same_seed() {
        let scanner = SyntheticScanner::new(&Params::default(), Room::DEFAULT);
        assert_eq!(
            scanner.ranges(&mut Rng::new(3)),
            scanner.ranges(&mut Rng::new(3))
        );
        assert_ne!(
            scanner.ranges(&mut Rng::new(3)),
            scanner.ranges(&mut Rng::new(4))
        );
    }
}
