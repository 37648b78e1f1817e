//! The host's side of each byte stream, without the port: bytes in, telegrams or packets out,
//! with the checksum error window the drivers' health is judged on. Pure (no port, no clock),
//! so that arbitrary bytes can be thrown at exactly what the drivers run.

use super::health::ErrorWindow;
use crate::framing::DeframerStats;
use crate::rflex::{RflexDeframer, RflexFraming, RflexReport};
use crate::sick::{
    ReplyBody, Scan, ScanLayout, SickDeframer, SickFraming, SickReply, telegram_payload,
};

/// What the scanner sent, decoded.
#[derive(Debug, Clone, PartialEq)]
pub enum SickReceived {
    /// A scan of the expected layout.
    Scan(Scan),
    /// Any other reply.
    Reply(SickReply),
}

/// The host's side of the SICK stream: finds telegrams after garbage, checks their CRCs,
/// tells scans of the expected layout from other replies.
#[derive(Debug, Clone)]
pub struct SickReceiver {
    deframer: SickDeframer,
    window: ErrorWindow,
    layout: ScanLayout,
    undecodable: u64,
}

impl SickReceiver {
    /// A receiver expecting scans of `layout`, judging CRC errors over `window` telegrams.
    #[must_use]
    pub fn new(layout: ScanLayout, window: usize) -> Self {
        Self {
            deframer: SickDeframer::new(SickFraming::from_scanner()),
            window: ErrorWindow::new(window),
            layout,
            undecodable: 0,
        }
    }

    /// Takes bytes as they came; returns what they completed.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<SickReceived> {
        if bytes.is_empty() {
            return Vec::new();
        }
        let before = self.deframer.stats();
        let frames = self.deframer.push(bytes);
        let after = self.deframer.stats();
        self.window.record(
            after.frames_ok - before.frames_ok,
            after.checksum_errors - before.checksum_errors,
        );
        let mut received = Vec::new();
        for frame in frames {
            match telegram_payload(&frame).and_then(|(_, payload)| SickReply::decode(payload)) {
                Ok(SickReply {
                    body: ReplyBody::Scan(scan),
                    ..
                }) => {
                    // A scan of another layout (set by another program, or left over from
                    // before the setup) cannot be given angles reliably.
                    if scan.values.len() == self.layout.value_count() {
                        received.push(SickReceived::Scan(scan));
                    } else {
                        self.undecodable += 1;
                    }
                }
                Ok(reply) => received.push(SickReceived::Reply(reply)),
                Err(_) => self.undecodable += 1,
            }
        }
        received
    }

    /// Forgets a partial telegram (the line's rate changed).
    pub fn reset(&mut self) {
        self.deframer.reset();
    }

    /// Forgets the CRC errors seen so far (a fresh setup).
    pub fn clear_errors(&mut self) {
        self.window.clear();
    }

    /// The fraction of bad CRCs among the recent telegrams (0 while too few were seen).
    #[must_use]
    pub fn error_rate(&self) -> f64 {
        self.window.error_rate()
    }

    /// Telegrams with a good CRC that could not be decoded, or scans of another layout.
    #[must_use]
    pub fn undecodable(&self) -> u64 {
        self.undecodable
    }

    /// The deframer's counters.
    #[must_use]
    pub fn frames(&self) -> DeframerStats {
        self.deframer.stats()
    }

    /// Bytes held for a telegram not complete yet.
    #[must_use]
    pub fn buffered_len(&self) -> usize {
        self.deframer.buffered_len()
    }
}

/// The host's side of the RFlex stream: finds packets after garbage, checks their checksums,
/// decodes reports.
#[derive(Debug, Clone)]
pub struct RflexReceiver {
    deframer: RflexDeframer,
    window: ErrorWindow,
    undecodable: u64,
}

impl RflexReceiver {
    /// A receiver judging checksum errors over `window` packets.
    #[must_use]
    pub fn new(window: usize) -> Self {
        Self {
            deframer: RflexDeframer::new(RflexFraming),
            window: ErrorWindow::new(window),
            undecodable: 0,
        }
    }

    /// Takes bytes as they came; returns the reports they completed.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<RflexReport> {
        if bytes.is_empty() {
            return Vec::new();
        }
        let before = self.deframer.stats();
        let frames = self.deframer.push(bytes);
        let after = self.deframer.stats();
        self.window.record(
            after.frames_ok - before.frames_ok,
            after.checksum_errors - before.checksum_errors,
        );
        let mut reports = Vec::new();
        for frame in frames {
            match RflexReport::decode(&frame) {
                Ok(report) => reports.push(report),
                Err(_) => self.undecodable += 1,
            }
        }
        reports
    }

    /// Forgets a partial packet (the port was reopened).
    pub fn reset(&mut self) {
        self.deframer.reset();
    }

    /// Forgets the checksum errors seen so far.
    pub fn clear_errors(&mut self) {
        self.window.clear();
    }

    /// The fraction of bad checksums among the recent packets (0 while too few were seen).
    #[must_use]
    pub fn error_rate(&self) -> f64 {
        self.window.error_rate()
    }

    /// Packets with a good checksum that could not be decoded.
    #[must_use]
    pub fn undecodable(&self) -> u64 {
        self.undecodable
    }

    /// The deframer's counters.
    #[must_use]
    pub fn frames(&self) -> DeframerStats {
        self.deframer.stats()
    }

    /// Bytes held for a packet not complete yet.
    #[must_use]
    pub fn buffered_len(&self) -> usize {
        self.deframer.buffered_len()
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::rflex::MAX_PACKET_LEN;
    use crate::sick::{MAX_TELEGRAM_LEN, RangeUnit, ScanValue};

    fn scan_telegram(count: usize) -> Vec<u8> {
        SickReply {
            body: ReplyBody::Scan(Scan {
                unit: RangeUnit::Millimetre,
                count_flags: 0,
                values: vec![ScanValue::new(1234, 0); count],
            }),
            status: 0x10,
        }
        .telegram()
        .unwrap()
    }

    #[test]
    fn scans_of_the_expected_layout_come_out_and_others_are_counted() {
        let layout = ScanLayout::WIDE_HALF_DEGREE;
        let mut receiver = SickReceiver::new(layout, 20);
        let mut stream = vec![0x55, 0x02, 0x80];
        stream.extend(scan_telegram(361));
        stream.extend(scan_telegram(181));
        let received = receiver.push(&stream);
        assert_eq!(received.len(), 1);
        assert!(matches!(&received[0], SickReceived::Scan(scan) if scan.values.len() == 361));
        assert_eq!(receiver.undecodable(), 1);
        assert!(receiver.frames().bytes_skipped >= 1);
    }

    proptest! {
        #[test]
        fn arbitrary_bytes_never_panic_the_host_receivers(
            bytes in prop::collection::vec(any::<u8>(), 0..4096),
            chunk in 1usize..700,
        ) {
            let mut sick = SickReceiver::new(ScanLayout::WIDE_HALF_DEGREE, 20);
            let mut rflex = RflexReceiver::new(40);
            for piece in bytes.chunks(chunk) {
                let _ = sick.push(piece);
                let _ = rflex.push(piece);
                prop_assert!(sick.buffered_len() <= MAX_TELEGRAM_LEN);
                prop_assert!(rflex.buffered_len() <= MAX_PACKET_LEN);
                prop_assert!((0.0..=1.0).contains(&sick.error_rate()));
                prop_assert!((0.0..=1.0).contains(&rflex.error_rate()));
            }
        }
    }
}
