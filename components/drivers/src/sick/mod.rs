//! The SICK LMS2xx / PLS laser's serial protocol (PROTOCOLS.md, "SICK"): the CRC, telegram
//! framing in both directions, a resynchronising deframer, typed commands and replies, B0 scan
//! decoding and encoding, and [`SickDevice`], the scanner's side used by the emulator.
//!
//! Facts not in PROTOCOLS.md are marked "guessed" where they are defined; test them on the
//! real scanner before relying on them.

#[cfg(test)]
mod codec_tests;
mod command;
#[cfg(test)]
mod conversation_tests;
mod crc;
mod device;
mod reply;
mod scan;
mod telegram;

pub use command::{DEFAULT_PASSWORD, SickCommand};
pub use crc::crc16;
pub use device::{RangeSource, SickDevice, SickDeviceConfig};
pub use reply::{ReplyBody, SickConfig, SickReply};
pub use scan::{
    AngularResolution, MAX_SCAN_VALUES, RangeUnit, Scan, ScanLayout, ScanValue, ScanWidth,
};
pub use telegram::{
    HOST_ADDRESS, MAX_PAYLOAD_LEN, MAX_TELEGRAM_LEN, SCANNER_ADDRESS, STX, SickDeframer,
    SickFraming, encode_telegram, telegram_payload,
};

/// Errors of the SICK codecs: a malformed telegram or payload, or a value that cannot be sent.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SickError {
    /// Fewer bytes than a header and a CRC.
    #[error("SICK telegram of {len} bytes is too short to hold a header and a CRC")]
    TelegramTooShort {
        /// The telegram's length.
        len: usize,
    },
    /// The first byte is not STX.
    #[error("SICK telegram starts with {found:#04x} instead of STX 0x02")]
    NoStx {
        /// The first byte.
        found: u8,
    },
    /// The length field disagrees with the bytes present.
    #[error("SICK telegram declares {declared} payload bytes but carries {actual}")]
    LengthMismatch {
        /// The length field.
        declared: usize,
        /// The payload bytes present.
        actual: usize,
    },
    /// The CRC does not match.
    #[error("SICK telegram CRC is {found:#06x} but its bytes give {expected:#06x}")]
    Crc {
        /// The CRC computed over the bytes.
        expected: u16,
        /// The CRC carried by the telegram.
        found: u16,
    },
    /// A payload too long for one telegram.
    #[error("SICK payload of {len} bytes exceeds the largest legal payload ({max} bytes)")]
    PayloadTooLong {
        /// The payload's length.
        len: usize,
        /// The largest legal payload.
        max: usize,
    },
    /// A payload without even a command or reply byte.
    #[error("SICK payload is empty: a command or reply byte is needed")]
    EmptyPayload,
    /// A payload shorter than its kind requires.
    #[error("SICK {what} is truncated: {needed} bytes needed, {got} present")]
    Truncated {
        /// What was being decoded.
        what: &'static str,
        /// Bytes needed.
        needed: usize,
        /// Bytes present.
        got: usize,
    },
    /// A payload longer than its kind allows.
    #[error("SICK {what} has {extra} unexpected trailing bytes")]
    TrailingBytes {
        /// What was being decoded.
        what: &'static str,
        /// Bytes left over.
        extra: usize,
    },
    /// A command byte this codec does not know.
    #[error("unknown SICK command byte {code:#04x}")]
    UnknownCommand {
        /// The command byte.
        code: u8,
    },
    /// A `20 xx` operating mode this codec does not know.
    #[error("unknown SICK operating mode {mode:#04x} after command 0x20")]
    UnknownMode {
        /// The mode byte.
        mode: u8,
    },
    /// A unit code that is none of cm, mm, dm.
    #[error("unknown SICK range unit code {code}")]
    UnknownUnit {
        /// The two unit bits, or the config's unit byte.
        code: u8,
    },
    /// A scan whose count field disagrees with its values.
    #[error("SICK scan declares {declared} values but carries {actual}")]
    ScanCountMismatch {
        /// The count field's low 10 bits.
        declared: usize,
        /// The values present.
        actual: usize,
    },
    /// More values than fit a telegram.
    #[error("SICK scan has {count} values; at most {max} fit one telegram")]
    TooManyValues {
        /// Values given.
        count: usize,
        /// The most that fit.
        max: usize,
    },
    /// A type string with non-ASCII bytes.
    #[error("SICK type string is not ASCII")]
    NotAscii,
    /// An angle and resolution the scanners do not offer.
    #[error(
        "SICK scan of {width_deg} deg at {resolution_cdeg}/100 deg is not offered: use 180 deg at 1 or 0.5 deg, or 100 deg at 1, 0.5 or 0.25 deg"
    )]
    UnsupportedLayout {
        /// The requested width in degrees.
        width_deg: u16,
        /// The requested resolution in hundredths of a degree.
        resolution_cdeg: u16,
    },
    /// A baud rate the scanners do not offer.
    #[error("{bits_per_second} baud is not a SICK rate: use 9600, 19200, 38400 or 500000")]
    UnsupportedBaud {
        /// The requested rate.
        bits_per_second: u32,
    },
}

/// The serial rates of the scanners. Power-up rate: 9600; 500000 needs RS-422.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum BaudRate {
    /// 9600 baud, the power-up rate.
    B9600,
    /// 19200 baud.
    B19200,
    /// 38400 baud.
    B38400,
    /// 500000 baud (RS-422 only).
    B500000,
}

impl BaudRate {
    /// Every rate, in the order a driver probes them (power-up rate first).
    pub const ALL: [BaudRate; 4] = [Self::B9600, Self::B38400, Self::B19200, Self::B500000];

    /// The rate in bits per second.
    pub fn bits_per_second(self) -> u32 {
        match self {
            Self::B9600 => 9600,
            Self::B19200 => 19200,
            Self::B38400 => 38400,
            Self::B500000 => 500_000,
        }
    }

    /// The rate for a number of bits per second.
    pub fn from_bits_per_second(bits_per_second: u32) -> Result<Self, SickError> {
        Self::ALL
            .into_iter()
            .find(|rate| rate.bits_per_second() == bits_per_second)
            .ok_or(SickError::UnsupportedBaud { bits_per_second })
    }

    /// The mode byte of the `20 xx` command that switches the scanner to this rate.
    /// 19200's `0x41` is guessed (sicktoolbox), not in PROTOCOLS.md.
    pub fn switch_mode(self) -> u8 {
        match self {
            Self::B9600 => 0x42,
            Self::B19200 => 0x41,
            Self::B38400 => 0x40,
            Self::B500000 => 0x48,
        }
    }

    /// The rate a `20 xx` mode byte switches to, if it is a rate switch.
    pub fn from_switch_mode(mode: u8) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|rate| rate.switch_mode() == mode)
    }

    /// Time to send `bytes` bytes at this rate with `bits_per_byte` bits on the wire per byte
    /// (10 for 8N1; 11 for the PLS's 8E1).
    pub fn transmit_time_ns(self, bytes: usize, bits_per_byte: u32) -> i64 {
        let bits = bytes as u128 * u128::from(bits_per_byte);
        let nanos = bits * 1_000_000_000 / u128::from(self.bits_per_second());
        i64::try_from(nanos).unwrap_or(i64::MAX)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_convert_from_bits_per_second_and_reject_others() {
        for rate in BaudRate::ALL {
            assert_eq!(
                BaudRate::from_bits_per_second(rate.bits_per_second()),
                Ok(rate)
            );
            assert_eq!(BaudRate::from_switch_mode(rate.switch_mode()), Some(rate));
        }
        assert_eq!(
            BaudRate::from_bits_per_second(115_200),
            Err(SickError::UnsupportedBaud {
                bits_per_second: 115_200
            })
        );
    }
}
