//! Round trips of every RFlex message, and the deframer against garbage, splits and damage.

use proptest::prelude::*;

use super::*;

fn decode_reports(deframer: &mut RflexDeframer, bytes: &[u8]) -> Vec<RflexReport> {
    deframer
        .push(bytes)
        .iter()
        .map(|packet| RflexReport::decode(packet).unwrap())
        .collect()
}

fn sample_reports() -> Vec<RflexReport> {
    vec![
        RflexReport::Odometry(OdometryReport {
            word0: 0,
            timestamp: 1000,
            axis: Axis::Translation,
            position: 0x1B02_1B03,
            velocity: -5,
            acceleration: 7,
            torque: 9,
        }),
        RflexReport::Sonar(SonarReport {
            word0: 0,
            timestamp: 1001,
            echoes: (0..48).map(|id| SonarEcho { id, range: 0x1B03 }).collect(),
        }),
        RflexReport::SysStatus(SysStatus {
            timestamp: 1002,
            voltage_raw: 2650,
            brake: 1,
        }),
    ]
}

#[test]
fn a_stream_split_at_every_byte_boundary_gives_the_same_reports() {
    let reports = sample_reports();
    let stream: Vec<u8> = reports.iter().flat_map(|r| r.encode().unwrap()).collect();
    for split in 0..=stream.len() {
        let mut deframer = RflexDeframer::new(RflexFraming);
        let mut decoded = decode_reports(&mut deframer, &stream[..split]);
        decoded.extend(decode_reports(&mut deframer, &stream[split..]));
        assert_eq!(decoded, reports, "split at {split}");
        assert_eq!(deframer.stats().bytes_skipped, 0);
    }
}

#[test]
fn garbage_prefixes_are_skipped_and_counted() {
    let packet = RflexCommand::BrakeRelease.encode();
    let prefixes: [&[u8]; 4] = [&[0x00], &[0x1B], &[0x1B, 0x1B], &[0x03, 0x1B, 0x03, 0xFF]];
    for prefix in prefixes {
        let mut deframer = RflexDeframer::new(RflexFraming);
        let mut stream = prefix.to_vec();
        stream.extend_from_slice(&packet);
        assert_eq!(
            deframer.push(&stream),
            vec![packet.clone()],
            "{prefix:02X?}"
        );
        assert_eq!(deframer.stats().bytes_skipped, prefix.len() as u64);
    }
}

#[test]
fn a_bad_checksum_or_trailer_is_counted_and_the_next_packet_is_decoded() {
    let good = RflexCommand::BrakeSet.encode();
    let mut bad_checksum = RflexCommand::SetDefaults.encode();
    let index = bad_checksum.len() - 3;
    bad_checksum[index] ^= 0x40;
    let mut bad_trailer = RflexCommand::SetDefaults.encode();
    let index = bad_trailer.len() - 1;
    bad_trailer[index] = 0x04;
    let mut stream = bad_checksum.clone();
    stream.extend_from_slice(&bad_trailer);
    stream.extend_from_slice(&good);
    let mut deframer = RflexDeframer::new(RflexFraming);
    assert_eq!(deframer.push(&stream), vec![good]);
    let stats = deframer.stats();
    assert_eq!(stats.checksum_errors, 1);
    assert_eq!(stats.trailer_errors, 1);
    assert_eq!(stats.frames_ok, 1);
    assert_eq!(
        stats.bytes_skipped,
        (bad_checksum.len() + bad_trailer.len()) as u64
    );
}

#[test]
fn undecodable_commands_give_error_values() {
    let packet = |port, opcode, data: Vec<u8>| RflexPacket {
        port,
        id: 0,
        opcode,
        data,
    };
    assert_eq!(
        RflexCommand::from_packet(&packet(9, 9, vec![])),
        Err(RflexError::UnknownCommand { port: 9, opcode: 9 })
    );
    let mut velocity = RflexCommand::AxisSetDir(VelocityCommand::stop(Axis::Rotation, 0))
        .to_packet()
        .data;
    velocity[0] = 2;
    assert_eq!(
        RflexCommand::from_packet(&packet(PORT_MOT, MOT_AXIS_SET_DIR, velocity)),
        Err(RflexError::UnknownAxis { axis: 2 })
    );
    assert!(matches!(
        RflexCommand::from_packet(&packet(PORT_MOT, MOT_BRAKE_SET, vec![1])),
        Err(RflexError::DataLength { got: 1, .. })
    ));
}

fn axis() -> impl Strategy<Value = Axis> {
    prop::sample::select(vec![Axis::Translation, Axis::Rotation])
}

fn velocity() -> impl Strategy<Value = VelocityCommand> {
    (
        axis(),
        any::<u32>(),
        any::<u32>(),
        any::<u32>(),
        any::<bool>(),
    )
        .prop_map(
            |(axis, speed, acceleration, torque, forward)| VelocityCommand {
                axis,
                speed,
                acceleration,
                torque,
                forward,
            },
        )
}

fn command() -> impl Strategy<Value = RflexCommand> {
    prop_oneof![
        (any::<u32>(), any::<u32>())
            .prop_map(|(period, mask)| RflexCommand::SystemReportRequest { period, mask }),
        any::<u32>().prop_map(|period| RflexCommand::DioReportsRequest { period }),
        Just(RflexCommand::SetDefaults),
        velocity().prop_map(RflexCommand::AxisSetDir),
        (any::<u32>(), any::<u32>(), any::<u32>(), any::<u8>()).prop_map(
            |(echo_delay, ping_delay, set_delay, mode)| RflexCommand::SonarRun(SonarRun {
                echo_delay,
                ping_delay,
                set_delay,
                mode,
            })
        ),
        Just(RflexCommand::BrakeRelease),
        Just(RflexCommand::BrakeSet),
        Just(RflexCommand::SysStatusRequest),
    ]
}

const REPORT_KINDS: [(u8, u8); 4] = [
    (PORT_MOT, MOT_SYSTEM_REPORT),
    (PORT_SONAR, SONAR_REPORT),
    (PORT_DIO, DIO_REPORT),
    (PORT_SYS, SYS_STATUS),
];

fn report() -> impl Strategy<Value = RflexReport> {
    prop_oneof![
        (
            any::<u32>(),
            any::<u32>(),
            axis(),
            any::<i32>(),
            any::<i32>(),
            any::<u32>(),
            any::<u32>()
        )
            .prop_map(
                |(word0, timestamp, axis, position, velocity, acceleration, torque)| {
                    RflexReport::Odometry(OdometryReport {
                        word0,
                        timestamp,
                        axis,
                        position,
                        velocity,
                        acceleration,
                        torque,
                    })
                }
            ),
        (
            any::<u32>(),
            any::<u32>(),
            prop::collection::vec(
                (any::<u8>(), any::<u16>()).prop_map(|(id, range)| SonarEcho { id, range }),
                0..=82
            )
        )
            .prop_map(
                |(word0, timestamp, echoes)| RflexReport::Sonar(SonarReport {
                    word0,
                    timestamp,
                    echoes
                })
            ),
        (any::<u32>(), any::<u8>(), any::<u16>()).prop_map(|(timestamp, address, value)| {
            RflexReport::Dio(DioReport {
                timestamp,
                address,
                value,
            })
        }),
        (any::<u32>(), any::<u32>(), any::<u8>()).prop_map(|(timestamp, voltage_raw, brake)| {
            RflexReport::SysStatus(SysStatus {
                timestamp,
                voltage_raw,
                brake,
            })
        }),
        (
            any::<u8>(),
            any::<u8>(),
            any::<u8>(),
            prop::collection::vec(any::<u8>(), 0..=255)
        )
            .prop_filter("a known kind decodes as itself", |(port, _, opcode, _)| {
                !REPORT_KINDS.contains(&(*port, *opcode))
            })
            .prop_map(|(port, id, opcode, data)| RflexReport::Other(RflexPacket {
                port,
                id,
                opcode,
                data
            })),
    ]
}

proptest! {
    #[test]
    fn every_command_round_trips_through_a_packet(command in command()) {
        let packet = RflexPacket::decode(&command.encode()).unwrap();
        prop_assert_eq!(RflexCommand::from_packet(&packet).unwrap(), command);
    }

    #[test]
    fn every_report_round_trips_through_a_packet(report in report()) {
        let bytes = report.encode().unwrap();
        prop_assert_eq!(RflexReport::decode(&bytes).unwrap(), report);
    }

    #[test]
    fn speeds_never_carry_an_escape_byte_where_the_firmware_chokes(speed in any::<u32>()) {
        let safe = avoid_escape_bytes(speed);
        prop_assert_ne!((safe >> 8) & 0xFF, 0x1B);
        prop_assert_ne!(safe >> 24, 0x1B);
        prop_assert!(safe.abs_diff(speed) <= 0x0100_0000);
    }

    #[test]
    fn a_packet_after_any_garbage_is_found(
        garbage in prop::collection::vec(any::<u8>(), 0..300),
        report in report(),
        chunk in 1usize..64,
    ) {
        let packet = report.encode().unwrap();
        let mut stream = garbage;
        stream.extend_from_slice(&packet);
        stream.extend(std::iter::repeat_n(0u8, MAX_PACKET_LEN));
        let mut deframer = RflexDeframer::new(RflexFraming);
        let frames: Vec<Vec<u8>> = stream.chunks(chunk).flat_map(|piece| deframer.push(piece)).collect();
        prop_assert!(frames.contains(&packet));
    }

    #[test]
    fn arbitrary_bytes_never_panic_the_deframer_or_parsers(
        bytes in prop::collection::vec(any::<u8>(), 0..4096),
        chunk in 1usize..512,
    ) {
        let mut deframer = RflexDeframer::new(RflexFraming);
        for piece in bytes.chunks(chunk) {
            for frame in deframer.push(piece) {
                let packet = RflexPacket::decode(&frame).unwrap();
                let _ = RflexCommand::from_packet(&packet);
                let _ = RflexReport::from_packet(packet);
            }
            prop_assert!(deframer.buffered_len() <= MAX_PACKET_LEN);
        }
        let _ = RflexReport::decode(&bytes);
        let _ = RflexPacket::decode(&bytes);
    }
}
