//! The iRobot RFlex base protocol (PROTOCOLS.md, "RFlex"): packets with an XOR checksum, a
//! resynchronising deframer, typed commands (start-up, velocity, brake, sonar) and reports
//! (odometry, sonar, digital I/O, system status), an odometry integrator, the bumper panels
//! read from digital I/O reports, and [`RflexDevice`], the base's side used by the emulator.
//!
//! Facts not in PROTOCOLS.md come from Player's and CARMEN's rflex drivers and are marked
//! "guessed" where they are defined; test them on the real base before relying on them.
//! One of them deserves care: a public ROS reader of the protocol treats `1B 00` and `1B 01`
//! inside packets as escape sequences, which PROTOCOLS.md (no byte stuffing) does not.

mod bumpers;
#[cfg(test)]
mod codec_tests;
mod command;
#[cfg(test)]
mod conversation_tests;
mod device;
mod odometry;
mod packet;
mod report;

pub use bumpers::{BumperLayout, BumperStyle, Bumpers};
pub use command::{
    Axis, RflexCommand, SonarRun, StartupParams, VelocityCommand, avoid_escape_bytes,
    startup_sequence,
};
pub use device::{RflexDevice, RflexDeviceConfig, SonarSource};
pub use odometry::{OdometryConversion, OdometryIntegrator};
pub use packet::{
    MAX_DATA_LEN, MAX_PACKET_LEN, RflexDeframer, RflexFraming, RflexPacket, checksum,
};
pub use report::{
    DioReport, OdometryReport, RflexReport, SONAR_COUNT, SONAR_UNITS_PER_M, SonarEcho, SonarReport,
    SysStatus,
};

/// System port: LCD, status (power, brake).
pub const PORT_SYS: u8 = 1;
/// Motor port: velocities, brake, odometry.
pub const PORT_MOT: u8 = 2;
/// Joystick port.
pub const PORT_JSTK: u8 = 3;
/// Sonar port.
pub const PORT_SONAR: u8 = 4;
/// Digital I/O port (bumpers).
pub const PORT_DIO: u8 = 5;
/// Infrared port.
pub const PORT_IR: u8 = 6;

/// MOT: set velocity, acceleration and torque of one axis.
pub const MOT_AXIS_SET_DIR: u8 = 7;
/// MOT: set the position of one axis (unused here).
pub const MOT_AXIS_SET_POS: u8 = 8;
/// MOT: reset motion parameters to their defaults.
pub const MOT_SET_DEFAULTS: u8 = 10;
/// MOT: engage the brake.
pub const MOT_BRAKE_SET: u8 = 11;
/// MOT: release the brake.
pub const MOT_BRAKE_RELEASE: u8 = 12;
/// MOT: an odometry report of one axis.
pub const MOT_SYSTEM_REPORT: u8 = 33;
/// MOT: ask for odometry reports every period.
pub const MOT_SYSTEM_REPORT_REQ: u8 = 34;
/// SONAR: start or stop the sonar ring.
pub const SONAR_RUN: u8 = 0;
/// SONAR: ask for an update.
pub const SONAR_GET_UPDATE: u8 = 1;
/// SONAR: a report of echoes.
pub const SONAR_REPORT: u8 = 2;
/// DIO: ask for reports every period.
pub const DIO_REPORTS_REQ: u8 = 0;
/// DIO: a report of one address (bumpers).
pub const DIO_REPORT: u8 = 1;
/// SYS: an LCD dump.
pub const SYS_LCD_DUMP: u8 = 0;
/// SYS: the status request and its report.
pub const SYS_STATUS: u8 = 1;

/// Errors of the RFlex codecs: a malformed packet, or data that does not fit its opcode.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RflexError {
    /// Fewer bytes than an empty packet.
    #[error("RFlex packet of {len} bytes is shorter than the 9 bytes of an empty packet")]
    PacketTooShort {
        /// The packet's length.
        len: usize,
    },
    /// The packet does not start with `1B 02`.
    #[error("RFlex packet does not start with 1B 02")]
    NoSync,
    /// The packet does not end with `1B 03`.
    #[error("RFlex packet does not end with 1B 03")]
    NoTrailer,
    /// The length field disagrees with the bytes present.
    #[error("RFlex packet declares {declared} data bytes but carries {actual}")]
    LengthMismatch {
        /// The dlen field.
        declared: usize,
        /// The data bytes present.
        actual: usize,
    },
    /// The XOR checksum does not match.
    #[error("RFlex packet checksum is {found:#04x} but its bytes give {expected:#04x}")]
    Checksum {
        /// The checksum computed over the bytes.
        expected: u8,
        /// The checksum carried by the packet.
        found: u8,
    },
    /// More data than the one-byte length field can say.
    #[error("RFlex data of {len} bytes exceeds the {max}-byte limit of one packet")]
    DataTooLong {
        /// The data's length.
        len: usize,
        /// The limit.
        max: usize,
    },
    /// Data of the wrong length for its port and opcode.
    #[error("RFlex {what} has {got} data bytes, expected {expected}")]
    DataLength {
        /// What was being decoded.
        what: &'static str,
        /// The data bytes present.
        got: usize,
        /// What the message needs (exact, or "at least" as the message says).
        expected: String,
    },
    /// An axis number that is neither 0 (translation) nor 1 (rotation).
    #[error("RFlex axis {axis} is neither 0 (translation) nor 1 (rotation)")]
    UnknownAxis {
        /// The axis byte.
        axis: u8,
    },
    /// A port and opcode this codec does not know as a command.
    #[error("RFlex port {port} opcode {opcode} is not a known command")]
    UnknownCommand {
        /// The port byte.
        port: u8,
        /// The opcode byte.
        opcode: u8,
    },
}

/// Reads a big-endian u32 at `offset`; the caller has checked the length.
fn be_u32(data: &[u8], offset: usize) -> u32 {
    let mut bytes = [0; 4];
    bytes.copy_from_slice(&data[offset..offset + 4]);
    u32::from_be_bytes(bytes)
}

/// Checks that `data` has exactly `expected` bytes.
fn exact_len(what: &'static str, data: &[u8], expected: usize) -> Result<(), RflexError> {
    if data.len() == expected {
        Ok(())
    } else {
        Err(RflexError::DataLength {
            what,
            got: data.len(),
            expected: expected.to_string(),
        })
    }
}
