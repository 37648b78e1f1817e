//! Packets: `1B 02 | port | id | opcode | dlen | data[dlen] | chk | 1B 03`, chk the XOR of the
//! bytes from port through data. No byte stuffing: packets are framed by length.

use super::RflexError;
use crate::framing::{Deframer, FrameFault, Framing};

const ESC: u8 = 0x1B;
const STX: u8 = 0x02;
const ETX: u8 = 0x03;
const HEADER_LEN: usize = 6;
/// Bytes around the data: sync, port, id, opcode, dlen, checksum, trailer.
const OVERHEAD: usize = 9;
/// The most data one packet carries (one-byte length field).
pub const MAX_DATA_LEN: usize = 255;
/// The longest packet.
pub const MAX_PACKET_LEN: usize = MAX_DATA_LEN + OVERHEAD;

/// The XOR of `bytes` (port through the end of data).
pub fn checksum(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |acc, byte| acc ^ byte)
}

/// One packet, in either direction.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct RflexPacket {
    /// The port (`PORT_*`).
    pub port: u8,
    /// The id byte (0 for most packets; 4 for the sonar commands of Player, guessed).
    pub id: u8,
    /// The opcode within the port.
    pub opcode: u8,
    /// The data, at most [`MAX_DATA_LEN`] bytes.
    pub data: Vec<u8>,
}

impl RflexPacket {
    /// The packet on the wire.
    pub fn encode(&self) -> Result<Vec<u8>, RflexError> {
        let dlen = u8::try_from(self.data.len()).map_err(|_| RflexError::DataTooLong {
            len: self.data.len(),
            max: MAX_DATA_LEN,
        })?;
        let mut packet = Vec::with_capacity(self.data.len() + OVERHEAD);
        packet.extend_from_slice(&[ESC, STX, self.port, self.id, self.opcode, dlen]);
        packet.extend_from_slice(&self.data);
        packet.push(checksum(&packet[2..]));
        packet.extend_from_slice(&[ESC, ETX]);
        Ok(packet)
    }

    /// Checks a whole packet (sync, length, trailer, checksum) and decodes it.
    pub fn decode(packet: &[u8]) -> Result<Self, RflexError> {
        if packet.len() < OVERHEAD {
            return Err(RflexError::PacketTooShort { len: packet.len() });
        }
        if packet[..2] != [ESC, STX] {
            return Err(RflexError::NoSync);
        }
        let declared = usize::from(packet[5]);
        let actual = packet.len() - OVERHEAD;
        if declared != actual {
            return Err(RflexError::LengthMismatch { declared, actual });
        }
        if packet[packet.len() - 2..] != [ESC, ETX] {
            return Err(RflexError::NoTrailer);
        }
        let checked = &packet[2..packet.len() - 3];
        let expected = checksum(checked);
        let found = packet[packet.len() - 3];
        if expected != found {
            return Err(RflexError::Checksum { expected, found });
        }
        Ok(Self {
            port: packet[2],
            id: packet[3],
            opcode: packet[4],
            data: packet[HEADER_LEN..packet.len() - 3].to_vec(),
        })
    }
}

/// RFlex framing for the [`Deframer`]: sync `1B 02`, `dlen + 9` bytes, trailer and checksum.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RflexFraming;

impl Framing for RflexFraming {
    fn sync(&self) -> [u8; 2] {
        [ESC, STX]
    }

    fn header_len(&self) -> usize {
        HEADER_LEN
    }

    fn max_frame_len(&self) -> usize {
        MAX_PACKET_LEN
    }

    fn frame_len(&self, header: &[u8]) -> Option<usize> {
        header.get(5).map(|&dlen| usize::from(dlen) + OVERHEAD)
    }

    fn check(&self, frame: &[u8]) -> Result<(), FrameFault> {
        let Some((body, [chk, esc, etx])) = frame.split_last_chunk::<3>() else {
            return Err(FrameFault::Trailer);
        };
        if [*esc, *etx] != [ESC, ETX] {
            return Err(FrameFault::Trailer);
        }
        match body.get(2..) {
            Some(checked) if checksum(checked) == *chk => Ok(()),
            _ => Err(FrameFault::Checksum),
        }
    }
}

/// A deframer of RFlex packets (the same framing in both directions).
pub type RflexDeframer = Deframer<RflexFraming>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_brake_release_packet_has_the_documented_bytes() {
        let packet = RflexPacket {
            port: 2,
            id: 0,
            opcode: 12,
            data: vec![],
        };
        // chk = 02 ^ 00 ^ 0C ^ 00 = 0E
        assert_eq!(
            packet.encode().unwrap(),
            vec![0x1B, 0x02, 0x02, 0x00, 0x0C, 0x00, 0x0E, 0x1B, 0x03]
        );
    }

    #[test]
    fn damaged_packets_are_reported() {
        let good = RflexPacket {
            port: 4,
            id: 4,
            opcode: 0,
            data: vec![1, 2, 3],
        }
        .encode()
        .unwrap();
        assert!(RflexPacket::decode(&good).is_ok());
        let check = |bytes: &[u8], expected: RflexError| {
            assert_eq!(RflexPacket::decode(bytes), Err(expected), "{bytes:02X?}");
        };
        check(&good[..8], RflexError::PacketTooShort { len: 8 });
        let mut bad = good.clone();
        bad[1] = 0x03;
        check(&bad, RflexError::NoSync);
        let mut bad = good.clone();
        bad[5] = 2;
        check(
            &bad,
            RflexError::LengthMismatch {
                declared: 2,
                actual: 3,
            },
        );
        let mut bad = good.clone();
        let last = bad.len() - 1;
        bad[last] = 0x04;
        check(&bad, RflexError::NoTrailer);
        let mut bad = good.clone();
        bad[6] ^= 0xFF;
        check(
            &bad,
            RflexError::Checksum {
                expected: good[good.len() - 3] ^ 0xFF,
                found: good[good.len() - 3],
            },
        );
        let too_long = RflexPacket {
            port: 1,
            id: 0,
            opcode: 0,
            data: vec![0; 256],
        };
        assert_eq!(
            too_long.encode(),
            Err(RflexError::DataTooLong { len: 256, max: 255 })
        );
    }
}
