//! Commands from the host to the scanner.

use super::telegram::{HOST_ADDRESS, encode_telegram};
use super::{BaudRate, ScanLayout, SickConfig, SickError};

/// The installation-mode password of the LMS2xx (PROTOCOLS.md: `20 00 'SICK_LMS'`).
pub const DEFAULT_PASSWORD: [u8; 8] = *b"SICK_LMS";

const MODE: u8 = 0x20;
const MODE_INSTALLATION: u8 = 0x00;
const MODE_STREAM: u8 = 0x24;
const MODE_STOP_STREAM: u8 = 0x25;
const GET_TYPE: u8 = 0x3A;
const SET_LAYOUT: u8 = 0x3B;
const GET_STATUS: u8 = 0x31;
const GET_CONFIG: u8 = 0x74;
const SET_CONFIG: u8 = 0x77;

/// A command to the scanner, as the payload of a host telegram.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SickCommand {
    /// `20 25`: stop streaming; answered at the scanner's rate, so drivers probe with it.
    StopStreaming,
    /// `20 24`: stream every scan continuously (B0 telegrams).
    StartStreaming,
    /// `20 42|41|40|48`: switch to a rate; the scanner replies A0 at the old rate first.
    SwitchBaud(BaudRate),
    /// `20 00 password[8]`: installation mode, needed before [`SickCommand::SetConfig`].
    InstallationMode {
        /// The password, normally [`DEFAULT_PASSWORD`].
        password: [u8; 8],
    },
    /// `3A`: ask for the type string (reply BA).
    GetType,
    /// `3B w_lo w_hi r_lo r_hi`: set angle and resolution (reply BB). The raw fields are kept
    /// so that a request the scanner must refuse can still be represented.
    SetLayout {
        /// Width in degrees (100 or 180).
        width_deg: u16,
        /// Resolution in hundredths of a degree (100, 50, 25).
        resolution_cdeg: u16,
    },
    /// `74`: ask for the configuration (reply F4).
    GetConfig,
    /// `77 config`: set the configuration (reply F7), in installation mode.
    SetConfig(SickConfig),
    /// `31`: ask for the status (reply B1).
    GetStatus,
}

impl SickCommand {
    /// The `3B` command for a layout the scanners offer.
    pub fn set_layout(layout: ScanLayout) -> Self {
        Self::SetLayout {
            width_deg: layout.width.degrees(),
            resolution_cdeg: layout.resolution.centidegrees(),
        }
    }

    /// The command's payload: command byte and data.
    pub fn payload(&self) -> Vec<u8> {
        match self {
            Self::StopStreaming => vec![MODE, MODE_STOP_STREAM],
            Self::StartStreaming => vec![MODE, MODE_STREAM],
            Self::SwitchBaud(rate) => vec![MODE, rate.switch_mode()],
            Self::InstallationMode { password } => {
                let mut payload = vec![MODE, MODE_INSTALLATION];
                payload.extend_from_slice(password);
                payload
            }
            Self::GetType => vec![GET_TYPE],
            Self::SetLayout {
                width_deg,
                resolution_cdeg,
            } => {
                let mut payload = vec![SET_LAYOUT];
                payload.extend_from_slice(&width_deg.to_le_bytes());
                payload.extend_from_slice(&resolution_cdeg.to_le_bytes());
                payload
            }
            Self::GetConfig => vec![GET_CONFIG],
            Self::SetConfig(config) => {
                let mut payload = vec![SET_CONFIG];
                payload.extend_from_slice(config.bytes());
                payload
            }
            Self::GetStatus => vec![GET_STATUS],
        }
    }

    /// The whole host telegram, ready to write to the port.
    pub fn telegram(&self) -> Result<Vec<u8>, SickError> {
        encode_telegram(HOST_ADDRESS, &self.payload())
    }

    /// The reply code that answers this command.
    pub fn reply_code(&self) -> u8 {
        self.payload()[0] | 0x80
    }

    /// Decodes a host telegram's payload (the emulator's side).
    pub fn decode(payload: &[u8]) -> Result<Self, SickError> {
        let Some((&code, data)) = payload.split_first() else {
            return Err(SickError::EmptyPayload);
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
        match code {
            MODE => {
                let Some(&mode) = data.first() else {
                    return Err(SickError::Truncated {
                        what: "20 mode command",
                        needed: 1,
                        got: 0,
                    });
                };
                if mode == MODE_INSTALLATION {
                    exact(
                        "20 00 installation mode command",
                        1 + DEFAULT_PASSWORD.len(),
                    )?;
                    let mut password = [0; 8];
                    password.copy_from_slice(&data[1..]);
                    return Ok(Self::InstallationMode { password });
                }
                exact("20 mode command", 1)?;
                match mode {
                    MODE_STREAM => Ok(Self::StartStreaming),
                    MODE_STOP_STREAM => Ok(Self::StopStreaming),
                    other => BaudRate::from_switch_mode(other)
                        .map(Self::SwitchBaud)
                        .ok_or(SickError::UnknownMode { mode: other }),
                }
            }
            GET_TYPE => exact("3A command", 0).map(|()| Self::GetType),
            SET_LAYOUT => {
                exact("3B command", 4)?;
                Ok(Self::SetLayout {
                    width_deg: u16::from_le_bytes([data[0], data[1]]),
                    resolution_cdeg: u16::from_le_bytes([data[2], data[3]]),
                })
            }
            GET_CONFIG => exact("74 command", 0).map(|()| Self::GetConfig),
            SET_CONFIG => SickConfig::new(data.to_vec()).map(Self::SetConfig),
            GET_STATUS => exact("31 command", 0).map(|()| Self::GetStatus),
            code => Err(SickError::UnknownCommand { code }),
        }
    }
}
