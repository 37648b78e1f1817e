//! Replies from the scanner to the host: `reply_code | data | status`.

use super::scan::SCAN_REPLY;
use super::telegram::{MAX_PAYLOAD_LEN, SCANNER_ADDRESS, encode_telegram};
use super::{RangeUnit, Scan, SickError};

const MODE_CHANGE_REPLY: u8 = 0xA0;
const NACK_REPLY: u8 = 0x92;
const TYPE_REPLY: u8 = 0xBA;
const LAYOUT_REPLY: u8 = 0xBB;
const STATUS_REPLY: u8 = 0xB1;
const CONFIG_REPLY: u8 = 0xF4;
const SET_CONFIG_REPLY: u8 = 0xF7;

/// The index of the unit byte in a configuration block (payload byte 7 of F4 and 77, counting
/// the reply or command byte as 0).
const CONFIG_UNIT_INDEX: usize = 6;
const CONFIG_UNIT_CM: u8 = 0;
const CONFIG_UNIT_MM: u8 = 1;

/// A scanner configuration block, as F4 returns it and 77 sends it back. Opaque except the
/// unit byte; get it, change the unit, set it back. Its usual length (32 bytes on the LMS2xx)
/// is guessed from sicktoolbox.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SickConfig {
    bytes: Vec<u8>,
}

impl SickConfig {
    /// The largest block: a 77 command or F7 reply must fit one telegram.
    pub const MAX_LEN: usize = MAX_PAYLOAD_LEN - 3;

    /// A block from its bytes; it must hold the unit byte and fit a telegram.
    pub fn new(bytes: Vec<u8>) -> Result<Self, SickError> {
        if bytes.len() <= CONFIG_UNIT_INDEX {
            return Err(SickError::Truncated {
                what: "configuration block",
                needed: CONFIG_UNIT_INDEX + 1,
                got: bytes.len(),
            });
        }
        if bytes.len() > Self::MAX_LEN {
            return Err(SickError::PayloadTooLong {
                len: bytes.len(),
                max: Self::MAX_LEN,
            });
        }
        Ok(Self { bytes })
    }

    /// A zeroed block of the LMS2xx's length (32 bytes, guessed) selecting `unit`
    /// (decimetres give centimetres): the emulator's power-up block.
    pub fn zeroed(unit: RangeUnit) -> Self {
        let mut bytes = vec![0; 32];
        bytes[CONFIG_UNIT_INDEX] = match unit {
            RangeUnit::Millimetre => CONFIG_UNIT_MM,
            RangeUnit::Centimetre | RangeUnit::Decimetre => CONFIG_UNIT_CM,
        };
        Self { bytes }
    }

    /// The block's bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The range unit the block selects (byte 7 of the F4 payload: 1 mm, 0 cm).
    pub fn unit(&self) -> Result<RangeUnit, SickError> {
        match self.bytes[CONFIG_UNIT_INDEX] {
            CONFIG_UNIT_CM => Ok(RangeUnit::Centimetre),
            CONFIG_UNIT_MM => Ok(RangeUnit::Millimetre),
            code => Err(SickError::UnknownUnit { code }),
        }
    }

    /// The same block selecting `unit`; decimetres cannot be set through the config.
    pub fn with_unit(mut self, unit: RangeUnit) -> Result<Self, SickError> {
        self.bytes[CONFIG_UNIT_INDEX] = match unit {
            RangeUnit::Centimetre => CONFIG_UNIT_CM,
            RangeUnit::Millimetre => CONFIG_UNIT_MM,
            RangeUnit::Decimetre => {
                return Err(SickError::UnknownUnit {
                    code: unit.scan_bits(),
                });
            }
        };
        Ok(self)
    }
}

/// What a reply says, without its status byte.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ReplyBody {
    /// `A0 result`: answer to every `20 xx` command. Result 0 is success; 1 (bad password)
    /// and 2 (scanner error) are guessed from sicktoolbox.
    ModeChange {
        /// The result byte.
        result: u8,
    },
    /// `92 data`: the scanner did not accept a telegram (layout of the data guessed).
    Nack {
        /// Whatever follows the code.
        data: Vec<u8>,
    },
    /// `BA ascii`: the type string, e.g. `LMS200;30106`.
    Type {
        /// The type string.
        name: String,
    },
    /// `BB accepted w_lo w_hi r_lo r_hi`: answer to `3B`; `accepted` is false when byte 1 is 0.
    Layout {
        /// Whether the scanner took the new angle and resolution.
        accepted: bool,
        /// Width in degrees.
        width_deg: u16,
        /// Resolution in hundredths of a degree.
        resolution_cdeg: u16,
    },
    /// `F4 config`: the configuration.
    Config(SickConfig),
    /// `F7 accepted config`: answer to `77` (layout guessed from sicktoolbox: byte 1 is 1
    /// when accepted, then the configuration in force).
    SetConfig {
        /// Whether the scanner took the configuration.
        accepted: bool,
        /// The configuration in force after the command.
        config: SickConfig,
    },
    /// `B1 data`: the status block (uninterpreted).
    Status {
        /// The status block.
        data: Vec<u8>,
    },
    /// `B0 count values`: a scan.
    Scan(Scan),
    /// Any other reply code, kept whole.
    Other {
        /// The reply code.
        code: u8,
        /// The bytes between the code and the status byte.
        data: Vec<u8>,
    },
}

/// A reply telegram's payload: body and status byte.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SickReply {
    /// What the reply says.
    pub body: ReplyBody,
    /// The scanner's status byte, last in every reply (0x10 seen from healthy LMS2xx, guessed).
    pub status: u8,
}

impl SickReply {
    /// The reply code of the body.
    pub fn code(&self) -> u8 {
        match &self.body {
            ReplyBody::ModeChange { .. } => MODE_CHANGE_REPLY,
            ReplyBody::Nack { .. } => NACK_REPLY,
            ReplyBody::Type { .. } => TYPE_REPLY,
            ReplyBody::Layout { .. } => LAYOUT_REPLY,
            ReplyBody::Config(_) => CONFIG_REPLY,
            ReplyBody::SetConfig { .. } => SET_CONFIG_REPLY,
            ReplyBody::Status { .. } => STATUS_REPLY,
            ReplyBody::Scan(_) => SCAN_REPLY,
            ReplyBody::Other { code, .. } => *code,
        }
    }

    /// The payload: code, data, status.
    pub fn payload(&self) -> Result<Vec<u8>, SickError> {
        let mut payload = vec![self.code()];
        match &self.body {
            ReplyBody::ModeChange { result } => payload.push(*result),
            ReplyBody::Nack { data }
            | ReplyBody::Status { data }
            | ReplyBody::Other { data, .. } => payload.extend_from_slice(data),
            ReplyBody::Type { name } => payload.extend_from_slice(name.as_bytes()),
            ReplyBody::Layout {
                accepted,
                width_deg,
                resolution_cdeg,
            } => {
                payload.push(u8::from(*accepted));
                payload.extend_from_slice(&width_deg.to_le_bytes());
                payload.extend_from_slice(&resolution_cdeg.to_le_bytes());
            }
            ReplyBody::Config(config) => payload.extend_from_slice(config.bytes()),
            ReplyBody::SetConfig { accepted, config } => {
                payload.push(u8::from(*accepted));
                payload.extend_from_slice(config.bytes());
            }
            ReplyBody::Scan(scan) => scan.encode_data(&mut payload)?,
        }
        payload.push(self.status);
        Ok(payload)
    }

    /// The whole scanner telegram (the emulator's side).
    pub fn telegram(&self) -> Result<Vec<u8>, SickError> {
        encode_telegram(SCANNER_ADDRESS, &self.payload()?)
    }

    /// Decodes a scanner telegram's payload.
    pub fn decode(payload: &[u8]) -> Result<Self, SickError> {
        let [code, data @ .., status] = payload else {
            return Err(SickError::Truncated {
                what: "reply",
                needed: 2,
                got: payload.len(),
            });
        };
        let exact = |what: &'static str, needed: usize| -> Result<(), SickError> {
            match data.len().cmp(&needed) {
                std::cmp::Ordering::Less => Err(SickError::Truncated {
                    what,
                    needed,
                    got: data.len(),
                }),
                std::cmp::Ordering::Greater => Err(SickError::TrailingBytes {
                    what,
                    extra: data.len() - needed,
                }),
                std::cmp::Ordering::Equal => Ok(()),
            }
        };
        let body = match *code {
            MODE_CHANGE_REPLY => {
                exact("A0 reply", 1)?;
                ReplyBody::ModeChange { result: data[0] }
            }
            NACK_REPLY => ReplyBody::Nack {
                data: data.to_vec(),
            },
            TYPE_REPLY => {
                if !data.is_ascii() {
                    return Err(SickError::NotAscii);
                }
                ReplyBody::Type {
                    name: data.iter().map(|&byte| char::from(byte)).collect(),
                }
            }
            LAYOUT_REPLY => {
                exact("BB reply", 5)?;
                ReplyBody::Layout {
                    accepted: data[0] != 0,
                    width_deg: u16::from_le_bytes([data[1], data[2]]),
                    resolution_cdeg: u16::from_le_bytes([data[3], data[4]]),
                }
            }
            CONFIG_REPLY => ReplyBody::Config(SickConfig::new(data.to_vec())?),
            SET_CONFIG_REPLY => {
                let Some((&accepted, config)) = data.split_first() else {
                    return Err(SickError::Truncated {
                        what: "F7 reply",
                        needed: 1,
                        got: 0,
                    });
                };
                ReplyBody::SetConfig {
                    accepted: accepted != 0,
                    config: SickConfig::new(config.to_vec())?,
                }
            }
            STATUS_REPLY => ReplyBody::Status {
                data: data.to_vec(),
            },
            SCAN_REPLY => ReplyBody::Scan(Scan::decode_data(data)?),
            code => ReplyBody::Other {
                code,
                data: data.to_vec(),
            },
        };
        Ok(Self {
            body,
            status: *status,
        })
    }
}
