//! SICK's own 16-bit CRC (not a standard CRC-16): it mixes the previous byte into each step.

/// The CRC of a telegram's bytes from STX through the last payload byte; sent low byte first.
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0;
    let mut previous: u8 = 0;
    for &byte in bytes {
        crc = if crc & 0x8000 != 0 {
            ((crc & 0x7fff) << 1) ^ 0x8005
        } else {
            crc << 1
        };
        crc ^= u16::from_le_bytes([byte, previous]);
        previous = byte;
    }
    crc
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(frame: &[u8], expected_lo_hi: [u8; 2]) {
        assert_eq!(
            crc16(frame).to_le_bytes(),
            expected_lo_hi,
            "frame {frame:02X?}"
        );
    }

    #[test]
    fn protocol_test_vectors_match() {
        check(&[0x02, 0x00, 0x02, 0x00, 0x20, 0x24], [0x34, 0x08]);
        check(&[0x02, 0x00, 0x02, 0x00, 0x20, 0x25], [0x35, 0x08]);
        check(&[0x02, 0x00, 0x01, 0x00, 0x3A], [0x1E, 0x12]);
        check(&[0x02, 0x00, 0x02, 0x00, 0x20, 0x40], [0x50, 0x08]);
    }

    #[test]
    fn empty_input_has_crc_zero() {
        assert_eq!(crc16(&[]), 0);
    }
}
