//! Telegram framing: `STX | addr | len_lo len_hi | payload[len] | crc_lo crc_hi`.

use super::{SickError, crc16};
use crate::framing::{Deframer, FrameFault, Framing};

/// Start of every telegram.
pub const STX: u8 = 0x02;
/// The address byte of telegrams from the host to the scanner.
pub const HOST_ADDRESS: u8 = 0x00;
/// The address byte of telegrams from the scanner to the host.
pub const SCANNER_ADDRESS: u8 = 0x80;
/// The largest legal payload (sicktoolbox's LMS2xx limit, guessed: the largest reply of
/// PROTOCOLS.md, a 361-value B0, has 726). A longer length field is garbage.
pub const MAX_PAYLOAD_LEN: usize = 812;
/// The largest legal telegram: header, payload and CRC.
pub const MAX_TELEGRAM_LEN: usize = HEADER_LEN + MAX_PAYLOAD_LEN + 2;

const HEADER_LEN: usize = 4;

/// Frames `payload` (command or reply byte, data, and for replies the status byte) into a
/// telegram for `address` ([`HOST_ADDRESS`] or [`SCANNER_ADDRESS`]).
pub fn encode_telegram(address: u8, payload: &[u8]) -> Result<Vec<u8>, SickError> {
    if payload.len() > MAX_PAYLOAD_LEN {
        return Err(SickError::PayloadTooLong {
            len: payload.len(),
            max: MAX_PAYLOAD_LEN,
        });
    }
    let mut telegram = Vec::with_capacity(HEADER_LEN + payload.len() + 2);
    telegram.push(STX);
    telegram.push(address);
    telegram.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    telegram.extend_from_slice(payload);
    let crc = crc16(&telegram);
    telegram.extend_from_slice(&crc.to_le_bytes());
    Ok(telegram)
}

/// Checks a whole telegram (STX, length, CRC) and returns its address and payload.
pub fn telegram_payload(telegram: &[u8]) -> Result<(u8, &[u8]), SickError> {
    let [stx, address, len_lo, len_hi, rest @ ..] = telegram else {
        return Err(SickError::TelegramTooShort {
            len: telegram.len(),
        });
    };
    if *stx != STX {
        return Err(SickError::NoStx { found: *stx });
    }
    let Some((payload, crc_bytes)) = rest.split_at_checked(rest.len().saturating_sub(2)) else {
        return Err(SickError::TelegramTooShort {
            len: telegram.len(),
        });
    };
    if crc_bytes.len() != 2 {
        return Err(SickError::TelegramTooShort {
            len: telegram.len(),
        });
    }
    let declared = usize::from(u16::from_le_bytes([*len_lo, *len_hi]));
    if declared != payload.len() {
        return Err(SickError::LengthMismatch {
            declared,
            actual: payload.len(),
        });
    }
    let expected = crc16(&telegram[..telegram.len() - 2]);
    let found = u16::from_le_bytes([crc_bytes[0], crc_bytes[1]]);
    if expected != found {
        return Err(SickError::Crc { expected, found });
    }
    Ok((*address, payload))
}

/// SICK framing for the [`Deframer`]: sync on `02 addr`, length from the header, CRC check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SickFraming {
    address: u8,
}

impl SickFraming {
    /// Framing of what the scanner sends (sync `02 80`): the driver's side.
    pub fn from_scanner() -> Self {
        Self {
            address: SCANNER_ADDRESS,
        }
    }

    /// Framing of what the host sends (sync `02 00`): the emulator's side.
    pub fn from_host() -> Self {
        Self {
            address: HOST_ADDRESS,
        }
    }
}

impl Framing for SickFraming {
    fn sync(&self) -> [u8; 2] {
        [STX, self.address]
    }

    fn header_len(&self) -> usize {
        HEADER_LEN
    }

    fn max_frame_len(&self) -> usize {
        MAX_TELEGRAM_LEN
    }

    fn frame_len(&self, header: &[u8]) -> Option<usize> {
        let len = usize::from(u16::from_le_bytes([*header.get(2)?, *header.get(3)?]));
        (1..=MAX_PAYLOAD_LEN)
            .contains(&len)
            .then_some(HEADER_LEN + len + 2)
    }

    fn check(&self, frame: &[u8]) -> Result<(), FrameFault> {
        let Some((body, crc)) = frame.split_last_chunk::<2>() else {
            return Err(FrameFault::Checksum);
        };
        if crc16(body) == u16::from_le_bytes(*crc) {
            Ok(())
        } else {
            Err(FrameFault::Checksum)
        }
    }
}

/// A deframer of SICK telegrams.
pub type SickDeframer = Deframer<SickFraming>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn host_telegrams_match_the_protocol_vectors() {
        let check = |payload: &[u8], expected: &[u8]| {
            assert_eq!(encode_telegram(HOST_ADDRESS, payload).unwrap(), expected);
        };
        check(
            &[0x20, 0x24],
            &[0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08],
        );
        check(
            &[0x20, 0x25],
            &[0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08],
        );
        check(&[0x3A], &[0x02, 0x00, 0x01, 0x00, 0x3A, 0x1E, 0x12]);
        check(
            &[0x20, 0x40],
            &[0x02, 0x00, 0x02, 0x00, 0x20, 0x40, 0x50, 0x08],
        );
    }

    #[test]
    fn payloads_round_trip_and_damage_is_reported() {
        let telegram = encode_telegram(SCANNER_ADDRESS, &[0xA0, 0x00, 0x10]).unwrap();
        assert_eq!(
            telegram_payload(&telegram),
            Ok((SCANNER_ADDRESS, &[0xA0, 0x00, 0x10][..]))
        );
        let mut bad_crc = telegram.clone();
        *bad_crc.last_mut().unwrap() ^= 1;
        assert!(matches!(
            telegram_payload(&bad_crc),
            Err(SickError::Crc { .. })
        ));
        assert!(matches!(
            telegram_payload(&telegram[..telegram.len() - 1]),
            Err(SickError::LengthMismatch { .. })
        ));
        assert_eq!(
            telegram_payload(&[0x02, 0x80, 0x00]),
            Err(SickError::TelegramTooShort { len: 3 })
        );
        assert_eq!(
            telegram_payload(&[0x02, 0x80, 0x00, 0x00, 0x00]),
            Err(SickError::TelegramTooShort { len: 5 })
        );
        assert_eq!(
            encode_telegram(HOST_ADDRESS, &[0; MAX_PAYLOAD_LEN + 1]),
            Err(SickError::PayloadTooLong {
                len: MAX_PAYLOAD_LEN + 1,
                max: MAX_PAYLOAD_LEN
            })
        );
    }
}
