//! Arbitrary bytes, at arbitrary host rates and times, through the I/O layer's device
//! emulations (the scanner and the base as the pseudo-terminal emulator drives them), and
//! arbitrary text through the fault list parser: nothing may panic.
#![no_main]

use lewis_drivers::rflex::RflexDeviceConfig;
use lewis_drivers::sick::{ScanLayout, SickDeviceConfig};
use lewis_emulators::{
    Emulated, HostRates, RflexEmulation, RflexEmulatorOptions, SickEmulation, parse_faults,
};
use lewis_geometry::Pose2;
use libfuzzer_sys::fuzz_target;

/// Rates a host may be at: the SICK's, the RFlex's, others, and unknown.
const RATES: [Option<u32>; 7] = [
    Some(9_600),
    Some(19_200),
    Some(38_400),
    Some(500_000),
    Some(115_200),
    Some(57_600),
    None,
];

fuzz_target!(|data: &[u8]| {
    let Some((&control, bytes)) = data.split_first() else {
        return;
    };
    if let Ok(text) = std::str::from_utf8(bytes) {
        let _ = parse_faults(text);
    }
    let chunk = usize::from(control >> 2).max(1);
    let mut sick = SickEmulation::new(SickDeviceConfig::default(), |layout: ScanLayout| {
        vec![2.5; layout.value_count()]
    });
    let mut rflex = RflexEmulation::new(
        RflexDeviceConfig::default(),
        |_: &Pose2| vec![1.0; 48],
        RflexEmulatorOptions::default(),
        0,
    );
    let mut now_ns = 0i64;
    for (k, piece) in bytes.chunks(chunk).enumerate() {
        let pick = usize::from(piece[0]) + k;
        let host = HostRates {
            before_bps: RATES[pick % RATES.len()],
            now_bps: RATES[(pick / RATES.len()) % RATES.len()],
        };
        now_ns += i64::from(control) * 1_000_000;
        let _ = sick.receive(host, piece, now_ns);
        let _ = sick.tick(now_ns);
        let _ = sick.next_event_ns();
        let _ = rflex.receive(host, piece, now_ns);
        let _ = rflex.tick(now_ns);
        if piece[0] == 0xFF {
            sick.replugged(now_ns);
            rflex.replugged(now_ns);
        }
    }
});
