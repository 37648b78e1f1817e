//! Arbitrary bytes through the RFlex deframer, the packet, command and report parsers, and the
//! emulated base: nothing may panic, and buffers stay bounded.
#![no_main]

use lewis_drivers::rflex::{
    MAX_PACKET_LEN, OdometryConversion, OdometryIntegrator, RflexCommand, RflexDeframer,
    RflexDevice, RflexDeviceConfig, RflexFraming, RflexPacket, RflexReport,
};
use lewis_geometry::Pose2;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&chunk, bytes)) = data.split_first() else {
        return;
    };
    let chunk = usize::from(chunk).max(1);
    let mut deframer = RflexDeframer::new(RflexFraming);
    let mut odometry = OdometryIntegrator::new(OdometryConversion::B21R);
    let mut device = RflexDevice::new(RflexDeviceConfig::default(), 0);
    let mut sonar = |_: &Pose2| vec![2.0; 48];
    let mut now_ns = 0;
    for piece in bytes.chunks(chunk) {
        for frame in deframer.push(piece) {
            let packet = RflexPacket::decode(&frame).expect("deframed packets pass");
            let _ = RflexCommand::from_packet(&packet);
            if let Ok(RflexReport::Odometry(report)) = RflexReport::from_packet(packet) {
                let pose = odometry.update(&report);
                assert!(pose.heading_rad.is_finite());
            }
        }
        now_ns += 7_000_000;
        let _ = device.receive(piece, now_ns);
        let _ = device.tick(now_ns, &mut sonar);
        assert!(deframer.buffered_len() <= MAX_PACKET_LEN);
    }
    let _ = RflexReport::decode(bytes);
});
