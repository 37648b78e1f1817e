//! Commands from the host to the base.

use super::{
    DIO_REPORTS_REQ, MOT_AXIS_SET_DIR, MOT_BRAKE_RELEASE, MOT_BRAKE_SET, MOT_SET_DEFAULTS,
    MOT_SYSTEM_REPORT_REQ, OdometryConversion, PORT_DIO, PORT_MOT, PORT_SONAR, PORT_SYS,
    RflexError, RflexPacket, SONAR_RUN, SYS_STATUS, be_u32, exact_len,
};

/// The id byte Player and CARMEN put on sonar commands (guessed meaning; copied behaviour).
const SONAR_ID: u8 = 4;

/// A drive axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Axis {
    /// Axis 0: forward motion; its position is the distance travelled.
    Translation,
    /// Axis 1: turning; its position is the bearing.
    Rotation,
}

impl Axis {
    /// The axis byte.
    pub fn number(self) -> u8 {
        match self {
            Self::Translation => 0,
            Self::Rotation => 1,
        }
    }

    /// The axis of an axis byte.
    pub fn from_number(axis: u8) -> Result<Self, RflexError> {
        match axis {
            0 => Ok(Self::Translation),
            1 => Ok(Self::Rotation),
            axis => Err(RflexError::UnknownAxis { axis }),
        }
    }
}

/// `MOT 7` (AXIS_SET_DIR): the velocity of one axis, in RFlex units (m/s or rad/s times the
/// axis's conversion factor).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct VelocityCommand {
    /// The axis.
    pub axis: Axis,
    /// The absolute velocity.
    pub speed: u32,
    /// The acceleration to reach it.
    pub acceleration: u32,
    /// The torque limit.
    pub torque: u32,
    /// The direction: true (byte 1) for velocity >= 0.
    pub forward: bool,
}

impl VelocityCommand {
    /// A command from SI units: `velocity` in m/s (translation) or rad/s (rotation), the
    /// acceleration likewise per second, scaled by the axis's conversion factor and rounded.
    /// The speed is passed through [`avoid_escape_bytes`].
    pub fn from_si(
        axis: Axis,
        velocity: f64,
        acceleration: f64,
        torque: u32,
        conversion: &OdometryConversion,
    ) -> Self {
        let factor = conversion.units_per(axis);
        Self {
            axis,
            speed: avoid_escape_bytes(to_units(velocity.abs() * factor)),
            acceleration: to_units(acceleration.abs() * factor),
            torque,
            forward: velocity >= 0.0 || velocity.is_nan(),
        }
    }

    /// A zero-velocity command (the start-up sequence sends one per axis).
    pub fn stop(axis: Axis, acceleration: u32) -> Self {
        Self {
            axis,
            speed: 0,
            acceleration,
            torque: 0,
            forward: false,
        }
    }

    /// The signed velocity in RFlex units.
    pub fn velocity(&self) -> i64 {
        let speed = i64::from(self.speed);
        if self.forward { speed } else { -speed }
    }

    fn data(&self) -> Vec<u8> {
        let mut data = Vec::with_capacity(14);
        data.push(self.axis.number());
        data.extend_from_slice(&self.speed.to_be_bytes());
        data.extend_from_slice(&self.acceleration.to_be_bytes());
        data.extend_from_slice(&self.torque.to_be_bytes());
        data.push(u8::from(self.forward));
        data
    }

    fn decode(data: &[u8]) -> Result<Self, RflexError> {
        exact_len("AXIS_SET_DIR command", data, 14)?;
        Ok(Self {
            axis: Axis::from_number(data[0])?,
            speed: be_u32(data, 1),
            acceleration: be_u32(data, 5),
            torque: be_u32(data, 9),
            forward: data[13] != 0,
        })
    }
}

fn to_units(value: f64) -> u32 {
    // `as` saturates, and NaN gives 0: both are the safe reading of a bad request.
    value.round() as u32
}

/// Nudges a velocity so that neither its top byte nor its second-lowest byte is `0x1B`.
///
/// Player's rflex driver does this to dodge a firmware bug (cause unknown, guessed to be the
/// `1B` of the packet markers); copied as behaviour, unverified. The value moves to the nearest
/// value whose byte is `1A` or `1C`.
pub fn avoid_escape_bytes(speed: u32) -> u32 {
    let mut speed = speed;
    if (speed >> 8) & 0xFF == 0x1B {
        speed = if speed & 0xFF > 127 {
            (speed & 0xFFFF_0000) | 0x1C00
        } else {
            (speed & 0xFFFF_0000) | 0x1AFF
        };
    }
    if speed >> 24 == 0x1B {
        speed = if (speed >> 16) & 0xFF > 127 {
            0x1C00_0000 | (speed & 0x0000_FFFF)
        } else {
            0x1AFF_0000 | (speed & 0x0000_FFFF)
        };
    }
    speed
}

/// `SONAR 0` (RUN): starts (mode 2) or stops (mode 0) the sonar ring.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SonarRun {
    /// Echo delay (Player's B21r: 30000).
    pub echo_delay: u32,
    /// Ping delay (Player: 0).
    pub ping_delay: u32,
    /// Set delay (Player: 0).
    pub set_delay: u32,
    /// 2 on, 0 off.
    pub mode: u8,
}

impl SonarRun {
    /// Stops the ring.
    pub const OFF: Self = Self {
        echo_delay: 0,
        ping_delay: 0,
        set_delay: 0,
        mode: 0,
    };

    /// Player's and CARMEN's B21r settings: echo delay 30000, no ping or set delay, mode 2.
    pub const B21R_ON: Self = Self {
        echo_delay: 30_000,
        ping_delay: 0,
        set_delay: 0,
        mode: 2,
    };

    /// Whether this turns the ring on.
    pub fn is_on(&self) -> bool {
        self.mode != 0
    }
}

/// A command to the base.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RflexCommand {
    /// `MOT 34 period:u32 mask:u32`: odometry reports every `period` (microseconds, guessed:
    /// the sources disagree) for the axes in `mask` (3: both; 0 with period 0: off).
    SystemReportRequest {
        /// The report period.
        period: u32,
        /// The axes, one bit each.
        mask: u32,
    },
    /// `DIO 0 period:u32`: digital I/O (bumper) reports every `period` (unit as above).
    DioReportsRequest {
        /// The report period; 0 stops them.
        period: u32,
    },
    /// `MOT 10`: motion parameters to defaults.
    SetDefaults,
    /// `MOT 7`: one axis's velocity.
    AxisSetDir(VelocityCommand),
    /// `SONAR 0`: start or stop the ring.
    SonarRun(SonarRun),
    /// `MOT 12`: release the brake (the robot can move).
    BrakeRelease,
    /// `MOT 11`: engage the brake.
    BrakeSet,
    /// `SYS 1`: ask for a status report (voltage, brake).
    SysStatusRequest,
}

impl RflexCommand {
    /// The command as a packet.
    pub fn to_packet(&self) -> RflexPacket {
        let (port, id, opcode, data) = match self {
            Self::SystemReportRequest { period, mask } => {
                let mut data = period.to_be_bytes().to_vec();
                data.extend_from_slice(&mask.to_be_bytes());
                (PORT_MOT, 0, MOT_SYSTEM_REPORT_REQ, data)
            }
            Self::DioReportsRequest { period } => {
                (PORT_DIO, 0, DIO_REPORTS_REQ, period.to_be_bytes().to_vec())
            }
            Self::SetDefaults => (PORT_MOT, 0, MOT_SET_DEFAULTS, vec![]),
            Self::AxisSetDir(velocity) => (PORT_MOT, 0, MOT_AXIS_SET_DIR, velocity.data()),
            Self::SonarRun(run) => {
                let mut data = run.echo_delay.to_be_bytes().to_vec();
                data.extend_from_slice(&run.ping_delay.to_be_bytes());
                data.extend_from_slice(&run.set_delay.to_be_bytes());
                data.push(run.mode);
                (PORT_SONAR, SONAR_ID, SONAR_RUN, data)
            }
            Self::BrakeRelease => (PORT_MOT, 0, MOT_BRAKE_RELEASE, vec![]),
            Self::BrakeSet => (PORT_MOT, 0, MOT_BRAKE_SET, vec![]),
            Self::SysStatusRequest => (PORT_SYS, 0, SYS_STATUS, vec![]),
        };
        RflexPacket {
            port,
            id,
            opcode,
            data,
        }
    }

    /// The command on the wire.
    pub fn encode(&self) -> Vec<u8> {
        // Command data is at most 14 bytes, far below the one-byte length limit.
        self.to_packet().encode().unwrap_or_default()
    }

    /// Decodes a packet from the host (the emulator's side); the id byte is not checked.
    pub fn from_packet(packet: &RflexPacket) -> Result<Self, RflexError> {
        let data = packet.data.as_slice();
        match (packet.port, packet.opcode) {
            (PORT_MOT, MOT_SYSTEM_REPORT_REQ) => {
                exact_len("SYSTEM_REPORT_REQ command", data, 8)?;
                Ok(Self::SystemReportRequest {
                    period: be_u32(data, 0),
                    mask: be_u32(data, 4),
                })
            }
            (PORT_DIO, DIO_REPORTS_REQ) => {
                exact_len("DIO REPORTS_REQ command", data, 4)?;
                Ok(Self::DioReportsRequest {
                    period: be_u32(data, 0),
                })
            }
            (PORT_MOT, MOT_SET_DEFAULTS) => {
                exact_len("SET_DEFAULTS command", data, 0).map(|()| Self::SetDefaults)
            }
            (PORT_MOT, MOT_AXIS_SET_DIR) => VelocityCommand::decode(data).map(Self::AxisSetDir),
            (PORT_SONAR, SONAR_RUN) => {
                exact_len("SONAR RUN command", data, 13)?;
                Ok(Self::SonarRun(SonarRun {
                    echo_delay: be_u32(data, 0),
                    ping_delay: be_u32(data, 4),
                    set_delay: be_u32(data, 8),
                    mode: data[12],
                }))
            }
            (PORT_MOT, MOT_BRAKE_RELEASE) => {
                exact_len("BRAKE_RELEASE command", data, 0).map(|()| Self::BrakeRelease)
            }
            (PORT_MOT, MOT_BRAKE_SET) => {
                exact_len("BRAKE_SET command", data, 0).map(|()| Self::BrakeSet)
            }
            (PORT_SYS, SYS_STATUS) => {
                exact_len("SYS STATUS command", data, 0).map(|()| Self::SysStatusRequest)
            }
            (port, opcode) => Err(RflexError::UnknownCommand { port, opcode }),
        }
    }
}

/// The parameters of the start-up sequence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StartupParams {
    /// Odometry report period (Player: 100000, microseconds as guessed).
    pub odometry_period: u32,
    /// Odometry axes mask (3: both).
    pub odometry_mask: u32,
    /// Digital I/O report period (Player: 100000).
    pub dio_period: u32,
    /// Acceleration of the zero-velocity translation command, RFlex units.
    pub translation_acceleration: u32,
    /// Acceleration of the zero-velocity rotation command, RFlex units.
    pub rotation_acceleration: u32,
    /// The sonar ring's settings.
    pub sonar: SonarRun,
}

impl Default for StartupParams {
    /// Player's B21r values where known; accelerations 0.7 m/s^2 and 1.0 rad/s^2 at the B21r
    /// conversions (guessed values).
    fn default() -> Self {
        Self {
            odometry_period: 100_000,
            odometry_mask: 3,
            dio_period: 100_000,
            translation_acceleration: 72_100,
            rotation_acceleration: 35_000,
            sonar: SonarRun::B21R_ON,
        }
    }
}

/// The start-up sequence of PROTOCOLS.md, in order: odometry reports on, DIO reports on,
/// motion defaults, zero velocity on both axes, sonar on, brake released.
pub fn startup_sequence(params: &StartupParams) -> Vec<RflexCommand> {
    vec![
        RflexCommand::SystemReportRequest {
            period: params.odometry_period,
            mask: params.odometry_mask,
        },
        RflexCommand::DioReportsRequest {
            period: params.dio_period,
        },
        RflexCommand::SetDefaults,
        RflexCommand::AxisSetDir(VelocityCommand::stop(
            Axis::Translation,
            params.translation_acceleration,
        )),
        RflexCommand::AxisSetDir(VelocityCommand::stop(
            Axis::Rotation,
            params.rotation_acceleration,
        )),
        RflexCommand::SonarRun(params.sonar),
        RflexCommand::BrakeRelease,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_velocity_command_has_the_documented_bytes() {
        let command = RflexCommand::AxisSetDir(VelocityCommand::from_si(
            Axis::Translation,
            -0.5,
            0.7,
            30_000,
            &OdometryConversion::B21R,
        ));
        let bytes = command.encode();
        assert_eq!(&bytes[..6], &[0x1B, 0x02, 2, 0, 7, 14]);
        // axis 0, |v| = 51500 = 0x0000C92C, accel 72100 = 0x000119A4, torque 30000, dir 0
        assert_eq!(
            &bytes[6..20],
            &[0, 0, 0, 0xC9, 0x2C, 0, 1, 0x19, 0xA4, 0, 0, 0x75, 0x30, 0]
        );
        assert_eq!(&bytes[21..], &[0x1B, 0x03]);
    }

    #[test]
    fn escape_bytes_are_avoided_in_velocities() {
        let check = |speed: u32, expected: u32| {
            assert_eq!(avoid_escape_bytes(speed), expected, "{speed:#010x}");
        };
        check(0x0000_1B10, 0x0000_1AFF);
        check(0x0000_1B90, 0x0000_1C00);
        check(0x1B10_0000, 0x1AFF_0000);
        check(0x1B90_0000, 0x1C00_0000);
        check(0x0000_C92C, 0x0000_C92C);
    }

    #[test]
    fn the_startup_sequence_is_in_protocol_order() {
        let opcodes: Vec<(u8, u8)> = startup_sequence(&StartupParams::default())
            .iter()
            .map(|command| {
                let packet = command.to_packet();
                (packet.port, packet.opcode)
            })
            .collect();
        assert_eq!(
            opcodes,
            vec![(2, 34), (5, 0), (2, 10), (2, 7), (2, 7), (4, 0), (2, 12)]
        );
    }
}
