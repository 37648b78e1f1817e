//! Arbitrary bytes through what the host-side drivers run on every read (the SICK and RFlex
//! receivers: deframing, checksum windows, scan and report decoding), through odometry
//! integration of every report and the bumper panels of every digital I/O report: nothing
//! may panic, buffers stay bounded, poses stay finite, the panels keep their count.
#![no_main]

use lewis_drivers::io::{RflexReceiver, SickReceiver};
use lewis_drivers::rflex::{
    BumperLayout, BumperStyle, Bumpers, MAX_PACKET_LEN, OdometryConversion, OdometryIntegrator,
    RflexReport,
};
use lewis_drivers::sick::{MAX_TELEGRAM_LEN, ScanLayout};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&control, bytes)) = data.split_first() else {
        return;
    };
    let chunk = usize::from(control).max(1);
    let layout = ScanLayout::ALL[usize::from(control) % ScanLayout::ALL.len()];
    let mut sick = SickReceiver::new(layout, 20);
    let mut rflex = RflexReceiver::new(40);
    let mut odometry = OdometryIntegrator::new(OdometryConversion::B21R);
    let layout = BumperLayout {
        first_address: control,
        count: usize::from(control % 40),
        style: if control % 2 == 0 {
            BumperStyle::Address
        } else {
            BumperStyle::Bit
        },
    };
    let mut bumpers = Bumpers::new(layout);
    for piece in bytes.chunks(chunk) {
        let _ = sick.push(piece);
        for report in rflex.push(piece) {
            match report {
                RflexReport::Odometry(report) => {
                    let pose = odometry.update(&report);
                    assert!(pose.x_m.is_finite() && pose.y_m.is_finite());
                }
                RflexReport::Dio(report) => {
                    bumpers.update(&report);
                    assert_eq!(bumpers.pressed().len(), layout.count);
                }
                _ => {}
            }
        }
        assert!(sick.buffered_len() <= MAX_TELEGRAM_LEN);
        assert!(rflex.buffered_len() <= MAX_PACKET_LEN);
        assert!((0.0..=1.0).contains(&sick.error_rate()));
    }
});
