//! The SICK scanner behind a pseudo-terminal: [`SickDevice`] answering the host at the rate it
//! listens at, and streaming scans from a [`RangeSource`] at the period its baud rate and
//! resolution allow.

use std::path::Path;

use super::{Emulated, FakeDevice, FakeDeviceError, HostRates};
use lewis_drivers::sick::{BaudRate, RangeSource, SickDevice, SickDeviceConfig};

use crate::clock::MonotonicClock;

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

    fn receive(&mut self, host: HostRates, bytes: &[u8], now_ns: i64) -> Vec<u8> {
        let reply = self
            .device
            .receive(heard_at(self.device.baud(), host), bytes);
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

/// The rate the scanner hears the host at: its own when the host may have sent at it, else
/// another one (the bytes are garbage to it).
fn heard_at(scanner: BaudRate, host: HostRates) -> BaudRate {
    if host.includes(scanner.bits_per_second()) {
        return scanner;
    }
    BaudRate::ALL
        .into_iter()
        .find(|&rate| rate != scanner)
        .unwrap_or(BaudRate::B9600)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lewis_drivers::sick::SickCommand;

    fn probe() -> Vec<u8> {
        SickCommand::StopStreaming.telegram().unwrap()
    }

    fn emulation() -> SickEmulation {
        SickEmulation::new(SickDeviceConfig::default(), |_| Vec::new())
    }

    /// The scanner's answer (true) or silence (false) to a probe read with `host`.
    fn check(host: HostRates, expected_answer: bool) {
        let mut emulation = emulation();
        let reply = emulation.receive(host, &probe(), 0);
        assert_eq!(!reply.is_empty(), expected_answer, "{host:?}");
    }

    #[test]
    fn a_probe_is_heard_when_the_host_may_have_sent_it_at_the_scanners_rate() {
        let at = |before, now| HostRates {
            before_bps: before,
            now_bps: now,
        };
        check(HostRates::steady(9_600), true);
        check(HostRates::steady(38_400), false);
        // Read late, after the host moved on to the next candidate rate: still heard.
        check(at(Some(9_600), Some(19_200)), true);
        // Sent at the new rate, right after the host came to the scanner's.
        check(at(Some(38_400), Some(9_600)), true);
        check(at(Some(19_200), Some(38_400)), false);
        check(at(None, None), false);
        check(at(None, Some(57_600)), false);
    }
}
