//! The SICK scanner behind a pseudo-terminal: [`SickDevice`] answering the host at the rate it
//! listens at, and streaming scans from a [`RangeSource`] at the period its baud rate and
//! resolution allow.

use std::path::Path;

use super::{Emulated, FakeDevice, FakeDeviceError};
use crate::drivers::io::clock::MonotonicClock;
use crate::drivers::sick::{BaudRate, RangeSource, SickDevice, SickDeviceConfig};

/// An emulated SICK scanner on a pseudo-terminal.
pub type FakeSick = FakeDevice<SickEmulation>;

/// The scanner as the emulator thread drives it.
pub struct SickEmulation {
    device: SickDevice,
    source: Box<dyn RangeSource + Send>,
    next_scan_ns: Option<i64>,
}

impl SickEmulation {
    /// A scanner just powered up, whose scans come from `source`.
    pub fn new(config: SickDeviceConfig, source: impl RangeSource + Send + 'static) -> Self {
        Self {
            device: SickDevice::new(config),
            source: Box::new(source),
            next_scan_ns: None,
        }
    }

    fn schedule(&mut self, now_ns: i64) {
        if !self.device.is_streaming() {
            self.next_scan_ns = None;
        } else if self.next_scan_ns.is_none() {
            self.next_scan_ns = Some(now_ns + self.device.scan_period_ns());
        }
    }
}

impl Emulated for SickEmulation {
    type Device = SickDevice;

    fn device(&mut self) -> &mut SickDevice {
        &mut self.device
    }

    fn line_bps(&self) -> u32 {
        self.device.baud().bits_per_second()
    }

    fn receive(&mut self, host_bps: Option<u32>, bytes: &[u8], now_ns: i64) -> Vec<u8> {
        let heard_at = host_bps
            .and_then(|bps| BaudRate::from_bits_per_second(bps).ok())
            .unwrap_or_else(|| {
                // The host is at a rate no SICK offers: its bytes are garbage to the scanner.
                // Any rate but the scanner's says so to the state machine.
                BaudRate::ALL
                    .into_iter()
                    .find(|&rate| rate != self.device.baud())
                    .unwrap_or(BaudRate::B9600)
            });
        let reply = self.device.receive(heard_at, bytes);
        self.schedule(now_ns);
        reply
    }

    fn tick(&mut self, now_ns: i64) -> Vec<u8> {
        self.schedule(now_ns);
        let Some(due_ns) = self.next_scan_ns else {
            return Vec::new();
        };
        if due_ns > now_ns {
            return Vec::new();
        }
        let period_ns = self.device.scan_period_ns();
        // Late by more than a period (the thread was held up): the next scan comes a period
        // from now, never a burst.
        let next_ns = due_ns + period_ns;
        self.next_scan_ns = Some(if next_ns <= now_ns {
            now_ns + period_ns
        } else {
            next_ns
        });
        self.device
            .scan_telegram(self.source.as_mut())
            .unwrap_or_default()
    }

    fn next_event_ns(&self) -> Option<i64> {
        self.next_scan_ns
    }

    /// The scanner's power goes with its cable: back to 9600 baud, not streaming.
    fn replugged(&mut self, _now_ns: i64) {
        self.device.power_cycle();
        self.next_scan_ns = None;
    }
}

impl FakeDevice<SickEmulation> {
    /// Starts an emulated scanner powered up per `config` (9600 baud, not streaming), its
    /// scans from `source`, on a new pseudo-terminal linked at `link` if given.
    pub fn start(
        config: SickDeviceConfig,
        source: impl RangeSource + Send + 'static,
        link: Option<&Path>,
    ) -> Result<Self, FakeDeviceError> {
        Self::spawn(
            MonotonicClock::new(),
            SickEmulation::new(config, source),
            link,
        )
    }
}
