//! Reports from the base to the host.

use super::{
    Axis, DIO_REPORT, MOT_SYSTEM_REPORT, PORT_DIO, PORT_MOT, PORT_SONAR, PORT_SYS, RflexError,
    RflexPacket, SONAR_REPORT, SYS_STATUS, be_u32, exact_len,
};

/// Sonar units per metre: metres = value / 1476.
pub const SONAR_UNITS_PER_M: f64 = 1476.0;
/// Transducers on the B21r's ring (index = bank * 16 + k).
pub const SONAR_COUNT: usize = 48;

const ODOMETRY_LEN: usize = 25;
const SONAR_HEADER_LEN: usize = 8;
const SONAR_ECHO_LEN: usize = 3;
const DIO_LEN: usize = 7;
const SYS_STATUS_LEN: usize = 9;

fn at_least(what: &'static str, data: &[u8], needed: usize) -> Result<(), RflexError> {
    if data.len() >= needed {
        Ok(())
    } else {
        Err(RflexError::DataLength {
            what,
            got: data.len(),
            expected: format!("at least {needed}"),
        })
    }
}

/// `MOT 33` (SYSTEM_REPORT): the state of one axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct OdometryReport {
    /// The first u32 (packet offset 6), meaning unknown (Player calls it `rv`).
    pub word0: u32,
    /// The base's timestamp (packet offset 10; unit unknown).
    pub timestamp: u32,
    /// The axis: translation reports the distance, rotation the bearing.
    pub axis: Axis,
    /// The encoder position, wrapping (offset 15).
    pub position: i32,
    /// The velocity in RFlex units (offset 19).
    pub velocity: i32,
    /// The acceleration (offset 23).
    pub acceleration: u32,
    /// The torque (offset 27).
    pub torque: u32,
}

impl OdometryReport {
    fn decode(data: &[u8]) -> Result<Self, RflexError> {
        exact_len("odometry report", data, ODOMETRY_LEN)?;
        Ok(Self {
            word0: be_u32(data, 0),
            timestamp: be_u32(data, 4),
            axis: Axis::from_number(data[8])?,
            position: be_u32(data, 9) as i32,
            velocity: be_u32(data, 13) as i32,
            acceleration: be_u32(data, 17),
            torque: be_u32(data, 21),
        })
    }

    fn data(&self) -> Vec<u8> {
        let mut data = Vec::with_capacity(ODOMETRY_LEN);
        data.extend_from_slice(&self.word0.to_be_bytes());
        data.extend_from_slice(&self.timestamp.to_be_bytes());
        data.push(self.axis.number());
        data.extend_from_slice(&self.position.to_be_bytes());
        data.extend_from_slice(&self.velocity.to_be_bytes());
        data.extend_from_slice(&self.acceleration.to_be_bytes());
        data.extend_from_slice(&self.torque.to_be_bytes());
        data
    }
}

/// One echo of a sonar report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SonarEcho {
    /// The transducer: bank * 16 + k.
    pub id: u8,
    /// The raw range: metres = range / [`SONAR_UNITS_PER_M`].
    pub range: u16,
}

impl SonarEcho {
    /// The range in metres, for `units_per_m` (normally [`SONAR_UNITS_PER_M`]).
    pub fn range_m(self, units_per_m: f64) -> f64 {
        f64::from(self.range) / units_per_m
    }
}

/// `SONAR 2` (REPORT): echoes of some transducers.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct SonarReport {
    /// The first u32, meaning unknown.
    pub word0: u32,
    /// The base's timestamp.
    pub timestamp: u32,
    /// The echoes, at most 82 per packet.
    pub echoes: Vec<SonarEcho>,
}

impl SonarReport {
    /// The ranges in metres by transducer index (`count` of them); `None` where this report
    /// has no echo, and ids at or beyond `count` ignored.
    pub fn ranges_m(&self, count: usize, units_per_m: f64) -> Vec<Option<f64>> {
        let mut ranges = vec![None; count];
        for echo in &self.echoes {
            if let Some(slot) = ranges.get_mut(usize::from(echo.id)) {
                *slot = Some(echo.range_m(units_per_m));
            }
        }
        ranges
    }

    fn decode(data: &[u8]) -> Result<Self, RflexError> {
        at_least("sonar report", data, SONAR_HEADER_LEN)?;
        let entries = &data[SONAR_HEADER_LEN..];
        if !entries.len().is_multiple_of(SONAR_ECHO_LEN) {
            return Err(RflexError::DataLength {
                what: "sonar report",
                got: data.len(),
                expected: "8 plus a multiple of 3".to_owned(),
            });
        }
        Ok(Self {
            word0: be_u32(data, 0),
            timestamp: be_u32(data, 4),
            echoes: entries
                .chunks_exact(SONAR_ECHO_LEN)
                .map(|entry| SonarEcho {
                    id: entry[0],
                    range: u16::from_be_bytes([entry[1], entry[2]]),
                })
                .collect(),
        })
    }

    fn data(&self) -> Vec<u8> {
        let mut data = Vec::with_capacity(SONAR_HEADER_LEN + SONAR_ECHO_LEN * self.echoes.len());
        data.extend_from_slice(&self.word0.to_be_bytes());
        data.extend_from_slice(&self.timestamp.to_be_bytes());
        for echo in &self.echoes {
            data.push(echo.id);
            data.extend_from_slice(&echo.range.to_be_bytes());
        }
        data
    }
}

/// `DIO 1` (REPORT): the value at one digital I/O address; the bumpers report here.
/// Layout guessed from Player: `timestamp:u32 address:u8 value:u16`, extra bytes ignored.
/// Which addresses are bumpers is the robot file's business.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DioReport {
    /// The base's timestamp.
    pub timestamp: u32,
    /// The I/O address.
    pub address: u8,
    /// The value (for bumpers, one bit per panel).
    pub value: u16,
}

impl DioReport {
    fn decode(data: &[u8]) -> Result<Self, RflexError> {
        at_least("digital I/O report", data, DIO_LEN)?;
        Ok(Self {
            timestamp: be_u32(data, 0),
            address: data[4],
            value: u16::from_be_bytes([data[5], data[6]]),
        })
    }

    fn data(self) -> Vec<u8> {
        let mut data = self.timestamp.to_be_bytes().to_vec();
        data.push(self.address);
        data.extend_from_slice(&self.value.to_be_bytes());
        data
    }
}

/// `SYS 1` (STATUS) report: battery voltage and brake. Layout guessed from Player:
/// `timestamp:u32 voltage:u32 brake:u8`, extra bytes ignored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SysStatus {
    /// The base's timestamp.
    pub timestamp: u32,
    /// The raw voltage: hundredths of a volt before the calibration offset.
    pub voltage_raw: u32,
    /// The brake byte (nonzero: engaged, guessed).
    pub brake: u8,
}

impl SysStatus {
    /// The battery voltage: raw / 100 plus the robot's calibration offset (Player's rule);
    /// 0 when the raw reading is 0 (no reading).
    pub fn voltage_v(&self, offset_v: f64) -> f64 {
        if self.voltage_raw == 0 {
            0.0
        } else {
            f64::from(self.voltage_raw) / 100.0 + offset_v
        }
    }

    /// Whether the brake is engaged.
    pub fn brake_engaged(&self) -> bool {
        self.brake != 0
    }

    fn decode(data: &[u8]) -> Result<Self, RflexError> {
        at_least("system status report", data, SYS_STATUS_LEN)?;
        Ok(Self {
            timestamp: be_u32(data, 0),
            voltage_raw: be_u32(data, 4),
            brake: data[8],
        })
    }

    fn data(&self) -> Vec<u8> {
        let mut data = self.timestamp.to_be_bytes().to_vec();
        data.extend_from_slice(&self.voltage_raw.to_be_bytes());
        data.push(self.brake);
        data
    }
}

/// A packet from the base.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum RflexReport {
    /// `MOT 33`.
    Odometry(OdometryReport),
    /// `SONAR 2`.
    Sonar(SonarReport),
    /// `DIO 1`.
    Dio(DioReport),
    /// `SYS 1`.
    SysStatus(SysStatus),
    /// Anything else (LCD dumps, joystick, IR), kept whole.
    Other(RflexPacket),
}

impl RflexReport {
    /// Decodes a packet from the base; unknown ports and opcodes give [`RflexReport::Other`].
    pub fn from_packet(packet: RflexPacket) -> Result<Self, RflexError> {
        let data = packet.data.as_slice();
        Ok(match (packet.port, packet.opcode) {
            (PORT_MOT, MOT_SYSTEM_REPORT) => Self::Odometry(OdometryReport::decode(data)?),
            (PORT_SONAR, SONAR_REPORT) => Self::Sonar(SonarReport::decode(data)?),
            (PORT_DIO, DIO_REPORT) => Self::Dio(DioReport::decode(data)?),
            (PORT_SYS, SYS_STATUS) => Self::SysStatus(SysStatus::decode(data)?),
            _ => Self::Other(packet),
        })
    }

    /// Checks and decodes a whole packet from the wire.
    pub fn decode(bytes: &[u8]) -> Result<Self, RflexError> {
        Self::from_packet(RflexPacket::decode(bytes)?)
    }

    /// The report as a packet (the emulator's side; id 0).
    pub fn to_packet(&self) -> RflexPacket {
        let (port, opcode, data) = match self {
            Self::Odometry(report) => (PORT_MOT, MOT_SYSTEM_REPORT, report.data()),
            Self::Sonar(report) => (PORT_SONAR, SONAR_REPORT, report.data()),
            Self::Dio(report) => (PORT_DIO, DIO_REPORT, report.data()),
            Self::SysStatus(report) => (PORT_SYS, SYS_STATUS, report.data()),
            Self::Other(packet) => return packet.clone(),
        };
        RflexPacket {
            port,
            id: 0,
            opcode,
            data,
        }
    }

    /// The report on the wire; fails only for a sonar report of more than 82 echoes or an
    /// oversized [`RflexReport::Other`].
    pub fn encode(&self) -> Result<Vec<u8>, RflexError> {
        self.to_packet().encode()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odometry_fields_are_at_the_documented_packet_offsets() {
        let report = OdometryReport {
            word0: 0x0102_0304,
            timestamp: 0x0A0B_0C0D,
            axis: Axis::Rotation,
            position: -2,
            velocity: 0x1122_3344,
            acceleration: 0x5566_7788,
            torque: 0x99AA_BBCC,
        };
        let bytes = RflexReport::Odometry(report).encode().unwrap();
        assert_eq!(bytes.len(), 25 + 9);
        assert_eq!(bytes[5], 25);
        assert_eq!(&bytes[6..10], &[1, 2, 3, 4]);
        assert_eq!(&bytes[10..14], &[0x0A, 0x0B, 0x0C, 0x0D]);
        assert_eq!(bytes[14], 1);
        assert_eq!(&bytes[15..19], &[0xFF, 0xFF, 0xFF, 0xFE]);
        assert_eq!(&bytes[19..23], &[0x11, 0x22, 0x33, 0x44]);
        assert_eq!(&bytes[23..27], &[0x55, 0x66, 0x77, 0x88]);
        assert_eq!(&bytes[27..31], &[0x99, 0xAA, 0xBB, 0xCC]);
    }

    #[test]
    fn sonar_values_convert_to_metres_by_transducer() {
        let report = SonarReport {
            word0: 0,
            timestamp: 7,
            echoes: vec![
                SonarEcho { id: 0, range: 1476 },
                SonarEcho { id: 47, range: 738 },
                SonarEcho { id: 60, range: 1 },
            ],
        };
        let ranges = report.ranges_m(SONAR_COUNT, SONAR_UNITS_PER_M);
        assert_eq!(ranges[0], Some(1.0));
        assert_eq!(ranges[47], Some(0.5));
        assert_eq!(ranges.iter().flatten().count(), 2);
    }

    #[test]
    fn a_sonar_report_with_a_partial_entry_is_an_error() {
        let packet = RflexPacket {
            port: PORT_SONAR,
            id: 0,
            opcode: SONAR_REPORT,
            data: vec![0; 10],
        };
        assert!(matches!(
            RflexReport::from_packet(packet),
            Err(RflexError::DataLength { got: 10, .. })
        ));
    }

    #[test]
    fn system_status_gives_volts_with_the_offset() {
        let status = SysStatus {
            timestamp: 0,
            voltage_raw: 4710,
            brake: 1,
        };
        assert!((status.voltage_v(1.2) - 48.3).abs() < 1e-9);
        assert!(status.brake_engaged());
        assert_eq!(
            SysStatus {
                voltage_raw: 0,
                ..status
            }
            .voltage_v(1.2),
            0.0
        );
    }
}
