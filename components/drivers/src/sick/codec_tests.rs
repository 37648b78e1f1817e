//! Round trips of every SICK message, and the deframer against garbage, splits and damage.

use proptest::prelude::*;

use super::*;

fn reply(body: ReplyBody) -> SickReply {
    SickReply { body, status: 0x10 }
}

fn scanner_telegram(body: ReplyBody) -> Vec<u8> {
    reply(body).telegram().unwrap()
}

fn decode_all(deframer: &mut SickDeframer, bytes: &[u8]) -> Vec<SickReply> {
    deframer
        .push(bytes)
        .iter()
        .map(|telegram| {
            let (address, payload) = telegram_payload(telegram).unwrap();
            assert_eq!(address, SCANNER_ADDRESS);
            SickReply::decode(payload).unwrap()
        })
        .collect()
}

fn sample_stream() -> (Vec<u8>, Vec<SickReply>) {
    let replies = vec![
        reply(ReplyBody::ModeChange { result: 0 }),
        reply(ReplyBody::Type {
            name: "LMS200;30106".to_owned(),
        }),
        reply(ReplyBody::Scan(Scan {
            unit: RangeUnit::Millimetre,
            count_flags: 0,
            values: (0..361).map(|i| ScanValue::new(i * 20, 0)).collect(),
        })),
    ];
    let stream = replies
        .iter()
        .flat_map(|reply| reply.telegram().unwrap())
        .collect();
    (stream, replies)
}

#[test]
fn a_stream_split_at_every_byte_boundary_gives_the_same_replies() {
    let (stream, replies) = sample_stream();
    for split in 0..=stream.len() {
        let mut deframer = SickDeframer::new(SickFraming::from_scanner());
        let mut decoded = decode_all(&mut deframer, &stream[..split]);
        decoded.extend(decode_all(&mut deframer, &stream[split..]));
        assert_eq!(decoded, replies, "split at {split}");
        assert_eq!(deframer.stats().bytes_skipped, 0);
    }
}

#[test]
fn a_stream_fed_byte_by_byte_gives_the_same_replies() {
    let (stream, replies) = sample_stream();
    let mut deframer = SickDeframer::new(SickFraming::from_scanner());
    let decoded: Vec<SickReply> = stream
        .iter()
        .flat_map(|byte| decode_all(&mut deframer, std::slice::from_ref(byte)))
        .collect();
    assert_eq!(decoded, replies);
}

#[test]
fn garbage_prefixes_are_skipped_and_counted() {
    let telegram = scanner_telegram(ReplyBody::ModeChange { result: 0 });
    let prefixes: [&[u8]; 5] = [
        &[0x06],
        &[0x15, 0x00, 0xFF],
        &[0x02, 0x02, 0x80],
        &[0x80, 0x02],
        &[0x02],
    ];
    for prefix in prefixes {
        let mut deframer = SickDeframer::new(SickFraming::from_scanner());
        let mut stream = prefix.to_vec();
        stream.extend_from_slice(&telegram);
        assert_eq!(
            deframer.push(&stream),
            vec![telegram.clone()],
            "{prefix:02X?}"
        );
        assert_eq!(deframer.stats().bytes_skipped, prefix.len() as u64);
        assert_eq!(deframer.stats().frames_ok, 1);
    }
}

#[test]
fn a_bad_crc_is_counted_and_the_next_telegram_is_decoded() {
    let mut bad = scanner_telegram(ReplyBody::ModeChange { result: 0 });
    let last = bad.len() - 1;
    bad[last] ^= 0x55;
    let good = scanner_telegram(ReplyBody::Type {
        name: "PLS101-316".to_owned(),
    });
    let mut deframer = SickDeframer::new(SickFraming::from_scanner());
    let mut stream = bad.clone();
    stream.extend_from_slice(&good);
    assert_eq!(deframer.push(&stream), vec![good]);
    let stats = deframer.stats();
    assert_eq!(stats.checksum_errors, 1);
    assert_eq!(stats.frames_ok, 1);
    assert_eq!(stats.bytes_skipped, bad.len() as u64);
}

#[test]
fn a_length_beyond_the_largest_telegram_is_garbage_not_waited_for() {
    let good = scanner_telegram(ReplyBody::ModeChange { result: 0 });
    let mut stream = vec![0x02, 0x80, 0xFF, 0x7F];
    stream.extend_from_slice(&good);
    let mut deframer = SickDeframer::new(SickFraming::from_scanner());
    assert_eq!(deframer.push(&stream), vec![good]);
    assert_eq!(deframer.stats().length_errors, 1);
    assert_eq!(deframer.buffered_len(), 0);
}

#[test]
fn host_telegrams_are_not_taken_for_scanner_telegrams() {
    let command = SickCommand::GetType.telegram().unwrap();
    let mut deframer = SickDeframer::new(SickFraming::from_scanner());
    assert!(deframer.push(&command).is_empty());
    let mut host_side = SickDeframer::new(SickFraming::from_host());
    assert_eq!(host_side.push(&command), vec![command]);
}

#[test]
fn undecodable_payloads_give_error_values() {
    let check = |payload: &[u8], expected: SickError| {
        assert_eq!(SickReply::decode(payload), Err(expected), "{payload:02X?}");
    };
    check(
        &[0xA0],
        SickError::Truncated {
            what: "reply",
            needed: 2,
            got: 1,
        },
    );
    check(
        &[0xA0, 0, 1, 0x10],
        SickError::TrailingBytes {
            what: "A0 reply",
            extra: 1,
        },
    );
    check(&[0xBA, 0xFF, 0x10], SickError::NotAscii);
    check(
        &[0xF4, 0, 0, 0x10],
        SickError::Truncated {
            what: "configuration block",
            needed: 7,
            got: 2,
        },
    );
    assert_eq!(SickCommand::decode(&[]), Err(SickError::EmptyPayload));
    assert_eq!(
        SickCommand::decode(&[0x20, 0x99]),
        Err(SickError::UnknownMode { mode: 0x99 })
    );
    assert_eq!(
        SickCommand::decode(&[0x55]),
        Err(SickError::UnknownCommand { code: 0x55 })
    );
}

#[test]
fn config_units_are_read_and_changed_at_payload_byte_7() {
    let config = SickConfig::zeroed(RangeUnit::Centimetre);
    assert_eq!(config.unit(), Ok(RangeUnit::Centimetre));
    let millimetres = config.with_unit(RangeUnit::Millimetre).unwrap();
    let payload = reply(ReplyBody::Config(millimetres.clone()))
        .payload()
        .unwrap();
    assert_eq!(payload[0], 0xF4);
    assert_eq!(payload[7], 1);
    assert_eq!(millimetres.unit(), Ok(RangeUnit::Millimetre));
}

fn baud() -> impl Strategy<Value = BaudRate> {
    prop::sample::select(BaudRate::ALL.to_vec())
}

fn config() -> impl Strategy<Value = SickConfig> {
    prop::collection::vec(any::<u8>(), 7..64).prop_map(|bytes| SickConfig::new(bytes).unwrap())
}

fn command() -> impl Strategy<Value = SickCommand> {
    prop_oneof![
        Just(SickCommand::StopStreaming),
        Just(SickCommand::StartStreaming),
        baud().prop_map(SickCommand::SwitchBaud),
        any::<[u8; 8]>().prop_map(|password| SickCommand::InstallationMode { password }),
        Just(SickCommand::GetType),
        (any::<u16>(), any::<u16>()).prop_map(|(width_deg, resolution_cdeg)| {
            SickCommand::SetLayout {
                width_deg,
                resolution_cdeg,
            }
        }),
        Just(SickCommand::GetConfig),
        config().prop_map(SickCommand::SetConfig),
        Just(SickCommand::GetStatus),
    ]
}

fn unit() -> impl Strategy<Value = RangeUnit> {
    prop::sample::select(vec![
        RangeUnit::Centimetre,
        RangeUnit::Millimetre,
        RangeUnit::Decimetre,
    ])
}

fn scan() -> impl Strategy<Value = Scan> {
    (
        unit(),
        0u8..16,
        prop::collection::vec(any::<u16>().prop_map(ScanValue), 0..=MAX_SCAN_VALUES),
    )
        .prop_map(|(unit, count_flags, values)| Scan {
            unit,
            count_flags,
            values,
        })
}

const KNOWN_REPLY_CODES: [u8; 8] = [0xA0, 0x92, 0xBA, 0xBB, 0xF4, 0xF7, 0xB1, 0xB0];

fn body() -> impl Strategy<Value = ReplyBody> {
    let bytes = || prop::collection::vec(any::<u8>(), 0..100);
    prop_oneof![
        any::<u8>().prop_map(|result| ReplyBody::ModeChange { result }),
        bytes().prop_map(|data| ReplyBody::Nack { data }),
        "[ -~]{0,40}".prop_map(|name| ReplyBody::Type { name }),
        (any::<bool>(), any::<u16>(), any::<u16>()).prop_map(
            |(accepted, width_deg, resolution_cdeg)| ReplyBody::Layout {
                accepted,
                width_deg,
                resolution_cdeg,
            }
        ),
        config().prop_map(ReplyBody::Config),
        (any::<bool>(), config())
            .prop_map(|(accepted, config)| ReplyBody::SetConfig { accepted, config }),
        bytes().prop_map(|data| ReplyBody::Status { data }),
        scan().prop_map(ReplyBody::Scan),
        (any::<u8>(), bytes())
            .prop_filter("a known code decodes as its own kind", |(code, _)| {
                !KNOWN_REPLY_CODES.contains(code)
            })
            .prop_map(|(code, data)| ReplyBody::Other { code, data }),
    ]
}

proptest! {
    #[test]
    fn every_command_round_trips_through_a_telegram(command in command()) {
        let telegram = command.telegram().unwrap();
        let (address, payload) = telegram_payload(&telegram).unwrap();
        prop_assert_eq!(address, HOST_ADDRESS);
        prop_assert_eq!(SickCommand::decode(payload).unwrap(), command);
    }

    #[test]
    fn every_reply_round_trips_through_a_telegram(body in body(), status in any::<u8>()) {
        let reply = SickReply { body, status };
        let telegram = reply.telegram().unwrap();
        let (address, payload) = telegram_payload(&telegram).unwrap();
        prop_assert_eq!(address, SCANNER_ADDRESS);
        prop_assert_eq!(SickReply::decode(payload).unwrap(), reply);
    }

    #[test]
    fn a_telegram_after_any_garbage_is_found(
        garbage in prop::collection::vec(any::<u8>(), 0..300),
        body in body(),
        chunk in 1usize..64,
    ) {
        let telegram = scanner_telegram(body);
        let mut stream = garbage;
        stream.extend_from_slice(&telegram);
        // Garbage can fake a header whose length reaches past the telegram: the filler (which
        // holds no sync) completes that false frame so that its CRC fails and the scan resumes.
        stream.extend(std::iter::repeat_n(0u8, MAX_TELEGRAM_LEN));
        let mut deframer = SickDeframer::new(SickFraming::from_scanner());
        let frames: Vec<Vec<u8>> = stream.chunks(chunk).flat_map(|piece| deframer.push(piece)).collect();
        prop_assert!(frames.contains(&telegram));
        prop_assert!(deframer.buffered_len() <= MAX_TELEGRAM_LEN);
    }

    #[test]
    fn arbitrary_bytes_never_panic_the_deframers_or_parsers(
        bytes in prop::collection::vec(any::<u8>(), 0..4096),
        chunk in 1usize..1024,
    ) {
        let mut scanner_side = SickDeframer::new(SickFraming::from_scanner());
        let mut host_side = SickDeframer::new(SickFraming::from_host());
        for piece in bytes.chunks(chunk) {
            for telegram in scanner_side.push(piece) {
                if let Ok((_, payload)) = telegram_payload(&telegram) {
                    let _ = SickReply::decode(payload);
                }
            }
            for telegram in host_side.push(piece) {
                if let Ok((_, payload)) = telegram_payload(&telegram) {
                    let _ = SickCommand::decode(payload);
                }
            }
            prop_assert!(scanner_side.buffered_len() <= MAX_TELEGRAM_LEN);
        }
        let _ = SickReply::decode(&bytes);
        let _ = SickCommand::decode(&bytes);
        let _ = telegram_payload(&bytes);
    }
}
