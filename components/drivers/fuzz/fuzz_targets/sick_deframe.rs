//! Arbitrary bytes through the SICK deframers (both directions), the reply and command parsers,
//! and the emulated scanner: nothing may panic, and buffers stay bounded.
#![no_main]

use lewis_drivers::sick::{
    BaudRate, MAX_TELEGRAM_LEN, ScanLayout, SickCommand, SickDeframer, SickDevice,
    SickDeviceConfig, SickFraming, SickReply, telegram_payload,
};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&chunk, bytes)) = data.split_first() else {
        return;
    };
    let chunk = usize::from(chunk).max(1);
    let mut scanner_side = SickDeframer::new(SickFraming::from_scanner());
    let mut host_side = SickDeframer::new(SickFraming::from_host());
    let mut device = SickDevice::new(SickDeviceConfig::default());
    let mut ranges = |layout: ScanLayout| vec![1.5; layout.value_count()];
    for piece in bytes.chunks(chunk) {
        for telegram in scanner_side.push(piece) {
            let (_, payload) = telegram_payload(&telegram).expect("deframed telegrams pass");
            let _ = SickReply::decode(payload);
        }
        for telegram in host_side.push(piece) {
            let (_, payload) = telegram_payload(&telegram).expect("deframed telegrams pass");
            let _ = SickCommand::decode(payload);
        }
        let rate = device.baud();
        let _ = device.receive(rate, piece);
        let _ = device.receive(BaudRate::B500000, piece);
        let _ = device.scan_telegram(&mut ranges);
        assert!(scanner_side.buffered_len() <= MAX_TELEGRAM_LEN);
        assert!(host_side.buffered_len() <= MAX_TELEGRAM_LEN);
    }
    let _ = SickReply::decode(bytes);
    let _ = SickCommand::decode(bytes);
});
