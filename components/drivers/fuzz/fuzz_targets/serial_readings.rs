//! Arbitrary bytes from the serial devices, through the receivers as the drivers run them,
//! and every reading they decode through what the `sick` and `rflex` services publish: a
//! scan to its RangeFinder and Distance, a configuration's range unit, a layout reply's
//! layout, the sonar ring's echoes to its RangeFinder and Distance, the status report's
//! voltage to Power. Nothing may panic; a published range is a number within the
//! message's maximum, a charge a fraction.
#![no_main]

use lewis_drivers::io::{RflexDriverConfig, RflexReceiver, SickReceived, SickReceiver};
use lewis_drivers::rflex::RflexReport;
use lewis_drivers::service::Mount;
use lewis_drivers::service::rflex::{Battery, SonarPublisher};
use lewis_drivers::service::sick::LaserPublisher;
use lewis_drivers::sick::{ReplyBody, ScanLayout};
use lewis_geometry::b21r_sonar_ring;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&control, bytes)) = data.split_first() else {
        return;
    };
    let chunk = usize::from(control).max(1);
    let layout = ScanLayout::ALL[usize::from(control) % ScanLayout::ALL.len()];
    let mut sick = SickReceiver::new(layout, 20);
    let mut rflex = RflexReceiver::new(40);
    // The drivers' defaults: the B21r's ring and calibration.
    let config = RflexDriverConfig::new("/dev/null");
    let laser = LaserPublisher::new(Mount::default(), 8);
    let sonar = SonarPublisher::new(b21r_sonar_ring(), 5.0, 8);
    let battery = Battery {
        full_voltage_v: 28.0,
        empty_voltage_v: 22.0,
        low_charge_fraction: 0.2,
    };
    for piece in bytes.chunks(chunk) {
        for received in sick.push(piece) {
            match received {
                SickReceived::Scan(scan) => {
                    let scan = lewis_drivers::io::LaserScan {
                        layout,
                        scan,
                        received_at: std::time::Instant::now(),
                    };
                    let reading = laser.range_finder(&scan);
                    assert_eq!(reading.ranges.len(), layout.value_count());
                    assert!(
                        reading
                            .ranges
                            .iter()
                            .all(|r| r.is_finite() && *r <= reading.max_range)
                    );
                    let _ = laser.distance(&reading);
                }
                SickReceived::Reply(reply) => match reply.body {
                    ReplyBody::Config(config) | ReplyBody::SetConfig { config, .. } => {
                        let _ = config.unit();
                    }
                    ReplyBody::Layout {
                        width_deg,
                        resolution_cdeg,
                        ..
                    } => {
                        let _ = ScanLayout::from_raw(width_deg, resolution_cdeg);
                    }
                    _ => {}
                },
            }
        }
        for report in rflex.push(piece) {
            match report {
                RflexReport::Sonar(report) => {
                    let ranges = report.ranges_m(config.sonar_count, config.sonar_units_per_m);
                    assert_eq!(ranges.len(), config.sonar_count);
                    let reading = sonar.range_finder(&ranges);
                    assert!(
                        reading
                            .ranges
                            .iter()
                            .all(|r| r.is_finite() && *r <= reading.max_range)
                    );
                    let _ = sonar.distance(&reading);
                }
                RflexReport::SysStatus(status) => {
                    let power = battery.power(status.voltage_v(config.voltage_offset_v));
                    assert!((0.0..=1.0).contains(&power.charge_fraction));
                }
                _ => {}
            }
        }
    }
});
