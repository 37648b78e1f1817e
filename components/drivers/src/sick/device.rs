//! The scanner's side of the protocol, for the emulator: a state machine that takes the host's
//! bytes and returns the scanner's, and produces B0 scans from a [`RangeSource`].
//!
//! No port and no clock: the I/O layer tells it the host's baud rate with every read (bytes
//! sent at another rate are garbage to a real scanner and are dropped), writes what it returns
//! at the rate that was in force before the call, and then sets the port to [`SickDevice::baud`]
//! (a rate switch is answered at the old rate). It paces scans with
//! [`SickDevice::scan_period_ns`].

use super::reply::{ReplyBody, SickReply};
use super::telegram::{SickDeframer, SickFraming, telegram_payload};
use super::{
    BaudRate, DEFAULT_PASSWORD, RangeUnit, Scan, ScanLayout, ScanValue, SickCommand, SickConfig,
};
use crate::faults::{FaultInjector, Faults};
use crate::framing::DeframerStats;

/// The mirror's period: 75 turns per second (LMS2xx data sheet figure, guessed).
const MIRROR_TURN_NS: i64 = 13_333_333;
const MODE_CHANGE_OK: u8 = 0;
const MODE_CHANGE_BAD_PASSWORD: u8 = 1;

/// Gives the ranges of one scan: one value per angle of the layout, in metres, in angular
/// order. Non-finite, negative or too-long ranges are sent as the largest value; missing ones
/// too, extra ones are dropped.
pub trait RangeSource {
    /// The ranges for one scan with `layout`.
    fn ranges_m(&mut self, layout: ScanLayout) -> Vec<f64>;
}

impl<F: FnMut(ScanLayout) -> Vec<f64>> RangeSource for F {
    fn ranges_m(&mut self, layout: ScanLayout) -> Vec<f64> {
        self(layout)
    }
}

/// How the emulated scanner starts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SickDeviceConfig {
    /// The answer to `3A` (ASCII).
    pub type_name: String,
    /// Angle and resolution at power-up.
    pub layout: ScanLayout,
    /// Range unit at power-up (centimetres or millimetres; decimetres give centimetres).
    pub unit: RangeUnit,
    /// The status byte ending every reply.
    pub status: u8,
    /// Bits per byte on the wire: 10 for 8N1, 11 for the PLS's 8E1.
    pub bits_per_byte: u32,
    /// Injected faults.
    pub faults: Faults,
}

impl Default for SickDeviceConfig {
    fn default() -> Self {
        Self {
            type_name: "LMS200;30106".to_owned(),
            layout: ScanLayout::WIDE_HALF_DEGREE,
            unit: RangeUnit::Centimetre,
            status: 0x10,
            bits_per_byte: 10,
            faults: Faults::default(),
        }
    }
}

/// The emulated scanner.
#[derive(Debug, Clone)]
pub struct SickDevice {
    type_name: String,
    status: u8,
    bits_per_byte: u32,
    baud: BaudRate,
    streaming: bool,
    installation_mode: bool,
    layout: ScanLayout,
    config: SickConfig,
    deframer: SickDeframer,
    injector: FaultInjector,
    undecodable_commands: u64,
}

impl SickDevice {
    /// A scanner just powered up: 9600 baud, not streaming.
    pub fn new(config: SickDeviceConfig) -> Self {
        Self {
            type_name: config.type_name,
            status: config.status,
            bits_per_byte: config.bits_per_byte,
            baud: BaudRate::B9600,
            streaming: false,
            installation_mode: false,
            layout: config.layout,
            config: SickConfig::zeroed(config.unit),
            deframer: SickDeframer::new(SickFraming::from_host()),
            injector: FaultInjector::new(config.faults),
            undecodable_commands: 0,
        }
    }

    /// The rate the scanner listens and talks at.
    pub fn baud(&self) -> BaudRate {
        self.baud
    }

    /// Whether it streams scans.
    pub fn is_streaming(&self) -> bool {
        self.streaming
    }

    /// Whether it is in installation mode (accepts `77`).
    pub fn in_installation_mode(&self) -> bool {
        self.installation_mode
    }

    /// The current angle and resolution.
    pub fn layout(&self) -> ScanLayout {
        self.layout
    }

    /// The current range unit.
    pub fn unit(&self) -> RangeUnit {
        self.config.unit().unwrap_or(RangeUnit::Centimetre)
    }

    /// The injected faults.
    pub fn faults(&self) -> Faults {
        self.injector.faults()
    }

    /// Changes the injected faults.
    pub fn set_faults(&mut self, faults: Faults) {
        self.injector.set_faults(faults);
    }

    /// The fault injector's counters (noise bytes, corrupted telegrams sent).
    pub fn injector(&self) -> &FaultInjector {
        &self.injector
    }

    /// What the scanner's deframer saw of the host's bytes.
    pub fn host_stats(&self) -> DeframerStats {
        self.deframer.stats()
    }

    /// Well-framed host telegrams that were not a known command (each answered with a NACK).
    pub fn undecodable_commands(&self) -> u64 {
        self.undecodable_commands
    }

    /// Power loss: back to 9600 baud, not streaming, partial input dropped; angle, resolution
    /// and unit are kept (they live in the scanner's EEPROM).
    pub fn power_cycle(&mut self) {
        self.baud = BaudRate::B9600;
        self.streaming = false;
        self.installation_mode = false;
        self.deframer.reset();
    }

    /// Takes bytes the host sent at `host_rate` and returns the bytes to send back.
    pub fn receive(&mut self, host_rate: BaudRate, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        if self.injector.faults().silent {
            return out;
        }
        if host_rate != self.baud {
            self.deframer.reset();
            return out;
        }
        for telegram in self.deframer.push(bytes) {
            if self.baud != host_rate {
                // The rest was sent at the old rate, which the scanner no longer listens at.
                break;
            }
            let reply = match telegram_payload(&telegram).and_then(|(_, p)| SickCommand::decode(p))
            {
                Ok(command) => self.execute(command),
                Err(_) => {
                    self.undecodable_commands += 1;
                    let code = telegram.get(4).copied().unwrap_or_default();
                    ReplyBody::Nack { data: vec![code] }
                }
            };
            self.send(reply, &mut out);
        }
        out
    }

    /// The next B0 telegram when streaming (faults applied), or `None`.
    pub fn scan_telegram(&mut self, ranges: &mut dyn RangeSource) -> Option<Vec<u8>> {
        if !self.streaming || self.injector.faults().silent {
            return None;
        }
        let unit = self.unit();
        let count = self.layout.value_count();
        let mut ranges_m = ranges.ranges_m(self.layout);
        ranges_m.resize(count, f64::INFINITY);
        let values = ranges_m
            .iter()
            .map(|&range_m| ScanValue::new(to_unit(range_m, unit), 0))
            .collect();
        let scan = Scan {
            unit,
            count_flags: 0,
            values,
        };
        let mut out = Vec::new();
        self.send(ReplyBody::Scan(scan), &mut out);
        Some(out)
    }

    /// The time between scans when streaming: the longer of the telegram's transmit time at
    /// the current rate and the mirror turns the resolution needs (75 Hz mirror, so 37.5 Hz at
    /// 0.5 degree; 361 values at 38400 baud are limited by the line to about 5 Hz).
    pub fn scan_period_ns(&self) -> i64 {
        let telegram_len = 4 + 4 + 2 * self.layout.value_count() + 2;
        let line = self.baud.transmit_time_ns(telegram_len, self.bits_per_byte);
        let mirror = MIRROR_TURN_NS * i64::from(self.layout.resolution.turns_per_scan());
        line.max(mirror)
    }

    fn execute(&mut self, command: SickCommand) -> ReplyBody {
        let ok = ReplyBody::ModeChange {
            result: MODE_CHANGE_OK,
        };
        match command {
            SickCommand::StopStreaming => {
                self.streaming = false;
                self.installation_mode = false;
                ok
            }
            SickCommand::StartStreaming => {
                self.streaming = true;
                self.installation_mode = false;
                ok
            }
            SickCommand::SwitchBaud(rate) => {
                self.baud = rate;
                ok
            }
            SickCommand::InstallationMode { password } => {
                if password == DEFAULT_PASSWORD {
                    self.installation_mode = true;
                    self.streaming = false;
                    ok
                } else {
                    ReplyBody::ModeChange {
                        result: MODE_CHANGE_BAD_PASSWORD,
                    }
                }
            }
            SickCommand::GetType => ReplyBody::Type {
                name: self.type_name.clone(),
            },
            SickCommand::SetLayout {
                width_deg,
                resolution_cdeg,
            } => {
                let accepted = match ScanLayout::from_raw(width_deg, resolution_cdeg) {
                    Ok(layout) => {
                        self.layout = layout;
                        true
                    }
                    Err(_) => false,
                };
                ReplyBody::Layout {
                    accepted,
                    width_deg,
                    resolution_cdeg,
                }
            }
            SickCommand::GetConfig => ReplyBody::Config(self.config.clone()),
            SickCommand::SetConfig(config) => {
                let accepted = self.installation_mode
                    && config.bytes().len() == self.config.bytes().len()
                    && config.unit().is_ok();
                if accepted {
                    self.config = config;
                }
                ReplyBody::SetConfig {
                    accepted,
                    config: self.config.clone(),
                }
            }
            SickCommand::GetStatus => ReplyBody::Status {
                data: self.type_name.as_bytes().to_vec(),
            },
        }
    }

    fn send(&mut self, body: ReplyBody, out: &mut Vec<u8>) {
        let reply = SickReply {
            body,
            status: self.status,
        };
        // Every body the device builds fits a telegram; a failure would be a bug here, and
        // sending nothing is what a confused scanner does.
        if let Ok(telegram) = reply.telegram() {
            let crc_index = telegram.len() - 1;
            self.injector.emit(&telegram, crc_index, out);
        }
    }
}

fn to_unit(range_m: f64, unit: RangeUnit) -> u16 {
    let value = range_m / unit.metres();
    if value.is_finite() && value >= 0.0 && value < f64::from(ScanValue::MAX_RANGE) {
        value.round() as u16
    } else {
        ScanValue::MAX_RANGE
    }
}
