//! The host talking to the emulated scanner, as the driver will over a pseudo-terminal.

use super::*;
use crate::faults::Faults;

/// The host's side: sends commands at a rate and decodes what comes back.
struct Host {
    rate: BaudRate,
    deframer: SickDeframer,
}

impl Host {
    fn new() -> Self {
        Self {
            rate: BaudRate::B9600,
            deframer: SickDeframer::new(SickFraming::from_scanner()),
        }
    }

    fn decode(&mut self, bytes: &[u8]) -> Vec<SickReply> {
        self.deframer
            .push(bytes)
            .iter()
            .map(|telegram| SickReply::decode(telegram_payload(telegram).unwrap().1).unwrap())
            .collect()
    }

    fn ask(&mut self, device: &mut SickDevice, command: &SickCommand) -> Vec<SickReply> {
        let bytes = device.receive(self.rate, &command.telegram().unwrap());
        self.decode(&bytes)
    }

    fn ask_one(&mut self, device: &mut SickDevice, command: &SickCommand) -> ReplyBody {
        let mut replies = self.ask(device, command);
        assert_eq!(replies.len(), 1, "{command:?} got {replies:?}");
        let reply = replies.remove(0);
        assert_eq!(reply.status, 0x10);
        reply.body
    }
}

const ACK: ReplyBody = ReplyBody::ModeChange { result: 0 };

#[test]
fn a_probe_at_the_wrong_rate_gets_nothing_and_at_the_right_rate_an_ack() {
    let mut device = SickDevice::new(SickDeviceConfig::default());
    let mut host = Host::new();
    host.rate = BaudRate::B38400;
    assert!(
        host.ask(&mut device, &SickCommand::StopStreaming)
            .is_empty()
    );
    host.rate = BaudRate::B9600;
    assert_eq!(host.ask_one(&mut device, &SickCommand::StopStreaming), ACK);
}

#[test]
fn a_baud_switch_is_acked_at_the_old_rate_then_only_the_new_rate_is_heard() {
    let mut device = SickDevice::new(SickDeviceConfig::default());
    let mut host = Host::new();
    assert_eq!(
        host.ask_one(&mut device, &SickCommand::SwitchBaud(BaudRate::B38400)),
        ACK
    );
    assert_eq!(device.baud(), BaudRate::B38400);
    assert!(
        host.ask(&mut device, &SickCommand::StopStreaming)
            .is_empty()
    );
    host.rate = BaudRate::B38400;
    assert_eq!(host.ask_one(&mut device, &SickCommand::StopStreaming), ACK);
}

#[test]
fn telegrams_after_a_baud_switch_in_the_same_read_are_not_heard() {
    let mut device = SickDevice::new(SickDeviceConfig::default());
    let mut host = Host::new();
    let mut bytes = SickCommand::SwitchBaud(BaudRate::B500000)
        .telegram()
        .unwrap();
    bytes.extend(SickCommand::GetType.telegram().unwrap());
    let replies = host.decode(&device.receive(BaudRate::B9600, &bytes));
    assert_eq!(replies.len(), 1);
    assert_eq!(replies[0].body, ACK);
}

#[test]
fn the_driver_sequence_configures_the_scanner_and_streams_millimetre_scans() {
    let mut device = SickDevice::new(SickDeviceConfig::default());
    let mut host = Host::new();
    assert_eq!(host.ask_one(&mut device, &SickCommand::StopStreaming), ACK);
    assert_eq!(
        host.ask_one(&mut device, &SickCommand::SwitchBaud(BaudRate::B38400)),
        ACK
    );
    host.rate = BaudRate::B38400;
    assert_eq!(
        host.ask_one(&mut device, &SickCommand::GetType),
        ReplyBody::Type {
            name: "LMS200;30106".to_owned()
        }
    );
    assert_eq!(
        host.ask_one(
            &mut device,
            &SickCommand::set_layout(ScanLayout::WIDE_HALF_DEGREE)
        ),
        ReplyBody::Layout {
            accepted: true,
            width_deg: 180,
            resolution_cdeg: 50
        }
    );
    assert_eq!(
        host.ask_one(
            &mut device,
            &SickCommand::InstallationMode {
                password: DEFAULT_PASSWORD
            }
        ),
        ACK
    );
    let ReplyBody::Config(config) = host.ask_one(&mut device, &SickCommand::GetConfig) else {
        panic!("F4 expected");
    };
    assert_eq!(config.unit(), Ok(RangeUnit::Centimetre));
    let millimetres = config.with_unit(RangeUnit::Millimetre).unwrap();
    assert_eq!(
        host.ask_one(&mut device, &SickCommand::SetConfig(millimetres.clone())),
        ReplyBody::SetConfig {
            accepted: true,
            config: millimetres
        }
    );
    assert_eq!(host.ask_one(&mut device, &SickCommand::StartStreaming), ACK);
    assert!(device.is_streaming());

    let mut ranges = |layout: ScanLayout| -> Vec<f64> {
        (0..layout.value_count())
            .map(|i| 0.5 + i as f64 * 0.01)
            .collect()
    };
    let expected: Vec<f64> = ranges(ScanLayout::WIDE_HALF_DEGREE);
    for _ in 0..3 {
        let bytes = device.scan_telegram(&mut ranges).unwrap();
        assert_eq!(bytes.len(), 732);
        let replies = host.decode(&bytes);
        let [
            SickReply {
                body: ReplyBody::Scan(scan),
                ..
            },
        ] = replies.as_slice()
        else {
            panic!("one B0 expected, got {replies:?}");
        };
        assert_eq!(scan.unit, RangeUnit::Millimetre);
        assert_eq!(scan.values.len(), 361);
        for (got, want) in scan.ranges_m().iter().zip(&expected) {
            assert!((got - want).abs() <= 0.0005, "{got} vs {want}");
        }
    }
    assert_eq!(host.ask_one(&mut device, &SickCommand::StopStreaming), ACK);
    assert_eq!(device.scan_telegram(&mut ranges), None);
}

#[test]
fn refused_requests_are_answered_as_refused() {
    let mut device = SickDevice::new(SickDeviceConfig::default());
    let mut host = Host::new();
    assert_eq!(
        host.ask_one(
            &mut device,
            &SickCommand::SetLayout {
                width_deg: 180,
                resolution_cdeg: 25
            }
        ),
        ReplyBody::Layout {
            accepted: false,
            width_deg: 180,
            resolution_cdeg: 25
        }
    );
    assert_eq!(device.layout(), ScanLayout::WIDE_HALF_DEGREE);
    let millimetres = SickConfig::zeroed(RangeUnit::Millimetre);
    let ReplyBody::SetConfig { accepted, config } =
        host.ask_one(&mut device, &SickCommand::SetConfig(millimetres))
    else {
        panic!("F7 expected");
    };
    assert!(!accepted, "77 outside installation mode");
    assert_eq!(config.unit(), Ok(RangeUnit::Centimetre));
    assert_eq!(
        host.ask_one(
            &mut device,
            &SickCommand::InstallationMode {
                password: *b"WRONGPWD"
            }
        ),
        ReplyBody::ModeChange { result: 1 }
    );
}

#[test]
fn an_unknown_command_gets_a_nack() {
    let mut device = SickDevice::new(SickDeviceConfig::default());
    let mut host = Host::new();
    let telegram = encode_telegram(HOST_ADDRESS, &[0x55]).unwrap();
    let replies = host.decode(&device.receive(BaudRate::B9600, &telegram));
    assert_eq!(replies[0].body, ReplyBody::Nack { data: vec![0x55] });
    assert_eq!(device.undecodable_commands(), 1);
}

#[test]
fn one_degree_scans_have_181_values() {
    let mut device = SickDevice::new(SickDeviceConfig::default());
    let mut host = Host::new();
    let one_degree = ScanLayout::from_raw(180, 100).unwrap();
    host.ask_one(&mut device, &SickCommand::set_layout(one_degree));
    host.ask_one(&mut device, &SickCommand::StartStreaming);
    let mut far = |layout: ScanLayout| vec![100.0; layout.value_count()];
    let replies = host.decode(&device.scan_telegram(&mut far).unwrap());
    let ReplyBody::Scan(scan) = &replies[0].body else {
        panic!("B0 expected");
    };
    assert_eq!(scan.values.len(), 181);
    assert!(
        scan.values
            .iter()
            .all(|value| value.range() == ScanValue::MAX_RANGE)
    );
}

#[test]
fn noise_and_bad_crcs_are_skipped_and_counted_by_the_host() {
    let faults = Faults {
        noise_bytes: 7,
        corrupt_checksum_every: 2,
        silent: false,
    };
    let mut device = SickDevice::new(SickDeviceConfig {
        faults,
        ..SickDeviceConfig::default()
    });
    let mut host = Host::new();
    // Replies are subject to faults too: the first (odd) telegram gets through.
    assert_eq!(host.ask_one(&mut device, &SickCommand::StartStreaming), ACK);
    let mut ranges = |layout: ScanLayout| vec![2.0; layout.value_count()];
    let mut scans = 0;
    for _ in 0..10 {
        let bytes = device.scan_telegram(&mut ranges).unwrap();
        scans += host.decode(&bytes).len();
    }
    assert_eq!(scans, 5);
    let stats = host.deframer.stats();
    assert_eq!(stats.checksum_errors, device.injector().frames_corrupted());
    assert_eq!(stats.checksum_errors, 5);
    assert!(stats.bytes_skipped >= 7 * 11);
}

#[test]
fn a_silent_scanner_neither_answers_nor_streams() {
    let mut device = SickDevice::new(SickDeviceConfig::default());
    let mut host = Host::new();
    host.ask_one(&mut device, &SickCommand::StartStreaming);
    device.set_faults(Faults {
        silent: true,
        ..Faults::default()
    });
    assert!(
        host.ask(&mut device, &SickCommand::StopStreaming)
            .is_empty()
    );
    assert_eq!(device.scan_telegram(&mut |_: ScanLayout| vec![1.0]), None);
}

#[test]
fn a_power_cycle_returns_to_9600_without_streaming() {
    let mut device = SickDevice::new(SickDeviceConfig::default());
    let mut host = Host::new();
    host.ask_one(&mut device, &SickCommand::SwitchBaud(BaudRate::B500000));
    host.rate = BaudRate::B500000;
    host.ask_one(&mut device, &SickCommand::StartStreaming);
    device.power_cycle();
    assert_eq!(device.baud(), BaudRate::B9600);
    assert!(!device.is_streaming());
}

#[test]
fn the_scan_period_follows_the_line_or_the_mirror_whichever_is_slower() {
    let mut device = SickDevice::new(SickDeviceConfig::default());
    let mut host = Host::new();
    let hz = |device: &SickDevice| 1e9 / device.scan_period_ns() as f64;
    host.ask_one(&mut device, &SickCommand::SwitchBaud(BaudRate::B38400));
    host.rate = BaudRate::B38400;
    // 732 bytes of 10 bits at 38400 baud.
    assert!((hz(&device) - 5.25).abs() < 0.05, "{}", hz(&device));
    host.ask_one(&mut device, &SickCommand::SwitchBaud(BaudRate::B500000));
    host.rate = BaudRate::B500000;
    // Two mirror turns at 75 Hz for 0.5 degree.
    assert!((hz(&device) - 37.5).abs() < 0.05, "{}", hz(&device));
    host.ask_one(
        &mut device,
        &SickCommand::set_layout(ScanLayout::from_raw(180, 100).unwrap()),
    );
    assert!((hz(&device) - 75.0).abs() < 0.05, "{}", hz(&device));
}
