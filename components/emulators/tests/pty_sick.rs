//! The SICK driver against the emulated scanner over real pseudo-terminals: probing, rate
//! switch, streaming, resynchronisation, health and reconnection.

#![allow(clippy::unwrap_used)]

use crate::pty_common;

use std::f64::consts::FRAC_PI_2;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use lewis_drivers::faults::Faults;
use lewis_drivers::io::{
    DriverHealth, LaserScan, LineParity, SetupStep, SickDriver, SickDriverConfig, SickReader,
    SickReaderStatus, StatusReport, open_port,
};
use lewis_drivers::sick::{
    AngularResolution, BaudRate, RangeUnit, ScanLayout, ScanWidth, SickDeviceConfig,
};
use lewis_emulators::{FakeSick, SharedPose, WorldLaserSource};
use lewis_geometry::Pose2;
use lewis_sim::{LaserConfig, SimLaser};
use pty_common::{WATCHDOG, await_some, conference_world, next_news};

const ONE_DEGREE: ScanLayout = ScanLayout {
    width: ScanWidth::Deg180,
    resolution: AngularResolution::OneDegree,
};

/// The stop-streaming probe, `20 25`, with the CRC of PROTOCOLS.md's test vector.
const STOP_STREAMING: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08];
/// The switch to 38400 baud, `20 40`, likewise.
const SWITCH_TO_38400: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x40, 0x50, 0x08];

/// The millimetre values of every scan the emulator was asked for, in order.
#[derive(Clone, Default)]
struct Sent(Arc<Mutex<Vec<Vec<u16>>>>);

impl Sent {
    /// A deterministic source: value i of scan k is 500 + 7 i + 13 k millimetres.
    fn source(&self) -> impl FnMut(ScanLayout) -> Vec<f64> + Send + 'static {
        let sent = self.clone();
        move |layout: ScanLayout| {
            let mut scans = sent.0.lock().unwrap();
            let k = scans.len();
            let values: Vec<u16> = (0..layout.value_count())
                .map(|i| u16::try_from(500 + 7 * i + 13 * k).unwrap())
                .collect();
            let ranges = values.iter().map(|&mm| f64::from(mm) / 1000.0).collect();
            scans.push(values);
            ranges
        }
    }

    fn scans(&self) -> Vec<Vec<u16>> {
        self.0.lock().unwrap().clone()
    }
}

fn config(path: &Path) -> SickDriverConfig {
    SickDriverConfig {
        layout: ONE_DEGREE,
        unit: RangeUnit::Millimetre,
        baud: BaudRate::B38400,
        reply_timeout: Duration::from_millis(500),
        config_timeout: Duration::from_millis(600),
        scan_deadline: Duration::from_millis(600),
        reconnect_interval: Duration::from_millis(50),
        ..SickDriverConfig::new(path)
    }
}

/// The stop-streaming probes the host's bytes start with, and the bytes after them.
fn leading_probes(host: &[u8]) -> (usize, &[u8]) {
    let mut rest = host;
    let mut probes = 0;
    while let Some(after) = rest.strip_prefix(&STOP_STREAMING[..]) {
        probes += 1;
        rest = after;
    }
    (probes, rest)
}

fn raw(scan: &LaserScan) -> Vec<u16> {
    scan.scan.values.iter().map(|value| value.range()).collect()
}

fn read_scans(driver: &mut SickDriver, count: usize) -> Vec<LaserScan> {
    (0..count)
        .map(|_| {
            await_some(
                "a scan",
                driver,
                |driver| driver.read_scan(Duration::from_millis(100)),
                |driver| format!("{:?} {:?}", driver.stats(), driver.health()),
            )
        })
        .collect()
}

fn pump_until_health(driver: &mut SickDriver, what: &str, done: impl Fn(&DriverHealth) -> bool) {
    await_some(
        what,
        driver,
        |driver| {
            driver.read_scan(Duration::from_millis(20));
            done(&driver.health()).then_some(())
        },
        |driver| format!("{:?}", driver.health()),
    );
}

struct Bench {
    _dir: tempfile::TempDir,
    link: std::path::PathBuf,
    sent: Sent,
    fake: FakeSick,
}

fn bench() -> Bench {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("ttySICK");
    let sent = Sent::default();
    let fake = FakeSick::start(SickDeviceConfig::default(), sent.source(), Some(&link)).unwrap();
    Bench {
        _dir: dir,
        link,
        sent,
        fake,
    }
}

#[test]
fn the_laser_is_probed_at_9600_switched_to_38400_and_streams_what_the_emulator_sent() {
    let bench = bench();
    let mut driver = SickDriver::open(config(&bench.link)).unwrap();
    assert_eq!(driver.baud(), Some(BaudRate::B38400));
    let host = bench.fake.host_bytes();
    let (probes, rest) = leading_probes(&host);
    assert!(probes >= 1, "the probe comes first");
    assert_eq!(&rest[..8], &SWITCH_TO_38400, "then the switch");
    bench.fake.with_device(|device| {
        assert_eq!(device.baud(), BaudRate::B38400);
        assert!(device.is_streaming());
        assert_eq!(device.layout(), ONE_DEGREE);
        assert_eq!(device.unit(), RangeUnit::Millimetre);
    });
    assert_eq!(bench.fake.stats().host_baud_bps, Some(38_400));

    let scans = read_scans(&mut driver, 5);
    let sent = bench.sent.scans();
    for (k, scan) in scans.iter().enumerate() {
        assert_eq!(raw(scan), sent[k], "scan {k}");
        assert_eq!(scan.layout, ONE_DEGREE);
        let ranges_m = scan.ranges_m();
        assert!((ranges_m[3] - f64::from(sent[k][3]) / 1000.0).abs() < 1e-12);
    }
    assert!((scans[0].angle_rad(0) + FRAC_PI_2).abs() < 1e-12);
    assert!((scans[0].angle_rad(180) - FRAC_PI_2).abs() < 1e-12);
    assert!((scans[0].max_range_m() - 8.191).abs() < 1e-12);
    let stats = driver.stats();
    assert_eq!(stats.scans, 5);
    assert_eq!(stats.frames.checksum_errors, 0);
    assert_eq!(driver.health(), DriverHealth::Ok);
}

#[test]
fn a_driver_restarted_while_the_scanner_runs_at_38400_finds_it_by_probing() {
    let bench = bench();
    let mut first = SickDriver::open(config(&bench.link)).unwrap();
    read_scans(&mut first, 1);
    drop(first);
    assert!(
        bench
            .fake
            .wait_for(WATCHDOG, |device| !device.is_streaming()),
        "a driver going away stops the stream"
    );
    bench.fake.clear_host_bytes();

    let mut second = SickDriver::open(config(&bench.link)).unwrap();
    let host = bench.fake.host_bytes();
    // Two unanswered probes at 9600 (two attempts), then at least one at 38400, and no switch.
    let (probes, _) = leading_probes(&host);
    assert!(probes >= 3, "{probes} probes");
    assert!(!host.windows(8).any(|window| window == SWITCH_TO_38400));
    assert_eq!(second.baud(), Some(BaudRate::B38400));
    read_scans(&mut second, 2);
}

#[test]
fn a_probe_read_late_after_the_host_moved_on_is_still_heard_at_the_rate_it_was_sent() {
    use std::io::Write;

    use serialport::SerialPort;

    let bench = bench();
    let mut host = open_port(&bench.link, 9_600, LineParity::None).unwrap();
    // Holding the device holds the emulator thread: it can only look at the termios after
    // the host has written its probe at 9600 and moved on to 19200, as a thread held up by
    // the scheduler for longer than the host's reply timeout would.
    bench.fake.with_device(|_| {
        host.write_all(&STOP_STREAMING).unwrap();
        host.set_baud_rate(19_200).unwrap();
    });
    assert!(
        bench
            .fake
            .wait_for(WATCHDOG, |device| device.host_stats().frames_ok == 1),
        "the scanner at 9600 hears the probe sent at 9600"
    );
    assert_eq!(bench.fake.stats().host_baud_bps, Some(19_200));
}

#[test]
fn garbage_and_bad_crcs_are_skipped_and_counted() {
    let bench = bench();
    let mut driver = SickDriver::open(config(&bench.link)).unwrap();
    read_scans(&mut driver, 1);
    let before = driver.stats();
    let faults = Faults {
        noise_bytes: 7,
        corrupt_checksum_every: 3,
        silent: false,
    };
    bench.fake.with_device(|device| device.set_faults(faults));

    let scans = read_scans(&mut driver, 8);
    let after = driver.stats();
    let sent = bench.sent.scans();
    // Every decoded scan is one the emulator sent, in order; the corrupted ones are missing.
    let mut positions = Vec::new();
    for scan in &scans {
        let values = raw(scan);
        let position = sent.iter().position(|sent| *sent == values).unwrap();
        positions.push(position);
    }
    assert!(
        positions.windows(2).all(|pair| pair[0] < pair[1]),
        "{positions:?}"
    );
    let last = *positions.last().unwrap();
    let first = positions[0];
    assert!(
        last - first + 1 > scans.len(),
        "some scans were dropped: {positions:?}"
    );
    assert!(after.frames.checksum_errors > before.frames.checksum_errors);
    assert!(after.frames.bytes_skipped >= before.frames.bytes_skipped + 7 * scans.len() as u64);
    assert_eq!(
        driver.health(),
        DriverHealth::Ok,
        "one in three is under the threshold"
    );
}

#[test]
fn a_crc_error_rate_over_the_threshold_is_reported() {
    let bench = bench();
    let mut driver = SickDriver::open(SickDriverConfig {
        scan_deadline: WATCHDOG * 2,
        ..config(&bench.link)
    })
    .unwrap();
    read_scans(&mut driver, 1);
    let faults = Faults {
        corrupt_checksum_every: 1,
        ..Faults::default()
    };
    bench.fake.with_device(|device| device.set_faults(faults));
    pump_until_health(&mut driver, "the CRC error health", |health| {
        matches!(health, DriverHealth::ChecksumErrors { .. })
    });
    let DriverHealth::ChecksumErrors {
        path, error_rate, ..
    } = driver.health()
    else {
        unreachable!()
    };
    assert_eq!(path, bench.link);
    assert!(error_rate > 0.5);
}

/// How late after its deadline the reader may notice a silence: the thread wakes at the
/// deadline, so this is only the scheduling of one thread on a loaded machine, with room.
const NOTICE_MARGIN: Duration = Duration::from_millis(500);

/// Takes the reader's news until `pick` accepts a status; the scans seen meanwhile come too.
fn await_status<T>(
    reader: &SickReader,
    scans: &mut Vec<LaserScan>,
    mut pick: impl FnMut(&StatusReport) -> Option<T>,
) -> T {
    loop {
        let news = next_news(reader);
        scans.extend(news.scans);
        if let Some(picked) = news.statuses.iter().find_map(&mut pick) {
            return picked;
        }
    }
}

#[test]
fn silence_makes_the_driver_report_no_data_within_its_deadline() {
    let bench = bench();
    let reader = SickReader::spawn(config(&bench.link)).unwrap();
    let mut scans = Vec::new();
    await_status(&reader, &mut scans, |report| {
        matches!(report.status, SickReaderStatus::Streaming(BaudRate::B38400)).then_some(())
    });
    while scans.is_empty() {
        scans.extend(next_news(&reader).scans);
    }
    let faults = Faults {
        silent: true,
        ..Faults::default()
    };
    bench.fake.with_device(|device| device.set_faults(faults));
    let report = await_status(&reader, &mut scans, |report| match &report.status {
        SickReaderStatus::Trouble(health @ DriverHealth::NoData { deadline, .. }) => {
            Some((report.at, health.clone(), *deadline))
        }
        SickReaderStatus::Streaming(_) => None,
        other => panic!("silence is no data, not {other:?}"),
    });
    let (noticed_at, health, deadline) = report;
    assert_eq!(deadline, Duration::from_millis(600));
    assert!(health.reason().unwrap().contains("no valid data"));
    // Judged by the driver's own clock: its last scan, and when its reader said so.
    let last_scan = scans.last().expect("scans came before the silence");
    let late_by = noticed_at.duration_since(last_scan.received_at);
    assert!(
        late_by >= deadline,
        "reported {late_by:?} after the last scan, before the deadline"
    );
    assert!(
        late_by <= deadline + NOTICE_MARGIN,
        "reported {late_by:?} after the last scan: the deadline is {deadline:?}"
    );

    bench
        .fake
        .with_device(|device| device.set_faults(Faults::default()));
    await_status(&reader, &mut scans, |report| {
        matches!(report.status, SickReaderStatus::Streaming(_)).then_some(())
    });
    let before = scans.len();
    while scans.len() == before {
        scans.extend(next_news(&reader).scans);
    }
}

#[test]
fn a_mute_scanner_is_probed_at_every_rate_in_the_reader_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("ttySICK");
    let mute = SickDeviceConfig {
        faults: Faults {
            silent: true,
            ..Faults::default()
        },
        ..SickDeviceConfig::default()
    };
    let _fake = FakeSick::start(mute, |_| Vec::new(), Some(&link)).unwrap();
    let reader = SickReader::spawn(SickDriverConfig {
        reply_timeout: Duration::from_millis(100),
        attempts: 1,
        ..config(&link)
    })
    .unwrap();
    // Every step comes as news while the reader waits; the service's thread never does.
    let mut steps = Vec::new();
    let trouble = await_status(&reader, &mut Vec::new(), |report| match &report.status {
        SickReaderStatus::SettingUp(step) => {
            steps.push(*step);
            None
        }
        SickReaderStatus::Trouble(health) => Some(health.clone()),
        SickReaderStatus::Streaming(_) => panic!("a mute scanner does not stream"),
    });
    let probes: Vec<BaudRate> = steps
        .iter()
        .filter_map(|step| match step {
            SetupStep::Probing(rate) => Some(*rate),
            _ => None,
        })
        .collect();
    assert_eq!(probes, BaudRate::ALL, "{steps:?}");
    let DriverHealth::NotSetUp { reason } = &trouble else {
        panic!("a mute scanner is not set up: {trouble:?}");
    };
    assert!(
        reason.contains("no SICK scanner answered")
            && reason.contains(&*link.to_string_lossy())
            && reason.contains("9600, 38400, 19200, 500000"),
        "{reason}"
    );
}

#[test]
fn unplugging_and_replugging_the_scanner_reconnects_the_driver() {
    let bench = bench();
    let mut driver = SickDriver::open(config(&bench.link)).unwrap();
    read_scans(&mut driver, 1);
    bench.fake.unplug().unwrap();
    pump_until_health(&mut driver, "the disconnected health", |health| {
        matches!(health, DriverHealth::Disconnected { .. })
    });
    assert!(driver.fd().is_none());

    bench.fake.replug().unwrap();
    bench
        .fake
        .with_device(|device| assert_eq!(device.baud(), BaudRate::B9600, "power-cycled"));
    read_scans(&mut driver, 2);
    assert_eq!(driver.stats().reconnects, 1);
    assert_eq!(driver.health(), DriverHealth::Ok);
    bench
        .fake
        .with_device(|device| assert_eq!(device.baud(), BaudRate::B38400));
}

#[test]
fn the_scanner_streams_at_500000_baud() {
    let bench = bench();
    let mut driver = SickDriver::open(SickDriverConfig {
        baud: BaudRate::B500000,
        ..config(&bench.link)
    })
    .unwrap();
    assert_eq!(bench.fake.stats().host_baud_bps, Some(500_000));
    let scans = read_scans(&mut driver, 3);
    assert_eq!(raw(&scans[2]), bench.sent.scans()[2]);
}

#[test]
fn a_world_backed_scanner_sees_what_the_simulated_laser_sees() {
    let world = Arc::new(conference_world());
    let pose = Pose2::new(3.0, 12.5, 0.0);
    let laser = LaserConfig {
        range_noise_std_m: 0.0,
        dropout_probability: 0.0,
        ..LaserConfig::default()
    };
    let source = WorldLaserSource::new(Arc::clone(&world), laser, 7, SharedPose::new(pose));
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("ttySICK");
    let _fake = FakeSick::start(SickDeviceConfig::default(), source, Some(&link)).unwrap();
    let mut driver = SickDriver::open(config(&link)).unwrap();
    let scan = read_scans(&mut driver, 1).remove(0);

    let expected_laser = SimLaser::new(
        LaserConfig {
            beam_count: 181,
            ..laser
        },
        7,
    )
    .unwrap();
    let mut expected = Vec::new();
    expected_laser.true_ranges(&world, pose, &mut expected);
    let got = scan.ranges_m();
    assert_eq!(got.len(), expected.len());
    for (index, (got, expected)) in got.iter().zip(&expected).enumerate() {
        assert!(
            (got - expected).abs() <= 0.0005 + 1e-9,
            "beam {index}: {got} against {expected}"
        );
    }
    assert!(
        expected.iter().any(|&range| range < 8.0),
        "the lobby has walls in view"
    );
}
