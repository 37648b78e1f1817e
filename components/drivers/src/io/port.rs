//! Opening a serial port for a driver: 8 data bits, one stop bit, no flow control, raw, with
//! errors that name the port and say what to check.

use std::path::{Path, PathBuf};
use std::time::Duration;

use serialport::{DataBits, FlowControl, Parity, SerialPort, StopBits, TTYPort};

/// The parity of the line: none (8N1) for the LMS and the RFlex, even (8E1) for the PLS.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum LineParity {
    /// 8N1.
    #[default]
    None,
    /// 8E1.
    Even,
}

impl LineParity {
    /// Bits on the wire per byte: start, 8 data, parity if any, stop.
    pub fn bits_per_byte(self) -> u32 {
        match self {
            Self::None => 10,
            Self::Even => 11,
        }
    }
}

/// Why a serial port could not be opened or used.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PortError {
    /// Nothing at the path.
    #[error(
        "serial port {path} does not exist: check the device path (ls -l /dev/serial/by-id), that the adapter is plugged in, and the port in the robot file"
    )]
    NotFound {
        /// The port's path.
        path: PathBuf,
    },
    /// The user may not open it.
    #[error(
        "no permission to open serial port {path}: add your user to the `dialout` group (sudo usermod -aG dialout $USER, then log in again) or check the device's owner and mode (ls -l {path})"
    )]
    PermissionDenied {
        /// The port's path.
        path: PathBuf,
    },
    /// Another program holds it (exclusive mode or lock).
    #[error(
        "serial port {path} is held by another program: stop it (fuser -v {path} shows who) or stop the other driver using this port"
    )]
    Busy {
        /// The port's path.
        path: PathBuf,
    },
    /// The path is not a terminal device.
    #[error(
        "{path} is not a serial port (not a terminal device): check the device path in the robot file"
    )]
    NotATerminal {
        /// The path.
        path: PathBuf,
    },
    /// The path is not valid UTF-8, which the serial library needs.
    #[error("serial port path {path} is not valid UTF-8: use a path made of UTF-8 characters")]
    NotUtf8 {
        /// The path.
        path: PathBuf,
    },
    /// Anything else the system reported.
    #[error("cannot {operation} serial port {path}: {message}: check the device and its driver")]
    Other {
        /// The port's path.
        path: PathBuf,
        /// What was being done.
        operation: &'static str,
        /// The system's description.
        message: String,
    },
}

/// Opens `path` at `baud_bps` with `parity`, 8 data bits, 1 stop bit, no flow control, raw, in
/// exclusive mode (a second opener gets [`PortError::Busy`]).
pub fn open_port(path: &Path, baud_bps: u32, parity: LineParity) -> Result<TTYPort, PortError> {
    let Some(name) = path.to_str() else {
        return Err(PortError::NotUtf8 {
            path: path.to_path_buf(),
        });
    };
    // The library's errors do not tell a missing file from a dangling link, nor a regular
    // file from a terminal: look first.
    match std::fs::metadata(path) {
        Err(error) if error.kind() == std::io::ErrorKind::NotFound => {
            return Err(PortError::NotFound {
                path: path.to_path_buf(),
            });
        }
        Ok(metadata) if !is_char_device(&metadata) => {
            return Err(PortError::NotATerminal {
                path: path.to_path_buf(),
            });
        }
        _ => {}
    }
    serialport::new(name, baud_bps)
        .data_bits(DataBits::Eight)
        .stop_bits(StopBits::One)
        .flow_control(FlowControl::None)
        .parity(match parity {
            LineParity::None => Parity::None,
            LineParity::Even => Parity::Even,
        })
        .timeout(Duration::ZERO)
        .open_native()
        .map_err(|error| port_error(path, "open", &error))
}

/// Sets the speed of an open port.
pub(crate) fn set_baud(port: &mut TTYPort, path: &Path, baud_bps: u32) -> Result<(), PortError> {
    port.set_baud_rate(baud_bps)
        .map_err(|error| port_error(path, "set the baud rate of", &error))
}

fn is_char_device(metadata: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::FileTypeExt;
    metadata.file_type().is_char_device()
}

/// Maps the library's error to ours.
pub(crate) fn port_error(
    path: &Path,
    operation: &'static str,
    error: &serialport::Error,
) -> PortError {
    let path = path.to_path_buf();
    match error.kind() {
        serialport::ErrorKind::NoDevice => PortError::Busy { path },
        serialport::ErrorKind::Io(std::io::ErrorKind::NotFound) => PortError::NotFound { path },
        serialport::ErrorKind::Io(std::io::ErrorKind::PermissionDenied) => {
            PortError::PermissionDenied { path }
        }
        _ if error.description.contains("Inappropriate ioctl") => PortError::NotATerminal { path },
        _ => PortError::Other {
            path,
            operation,
            message: error.description.clone(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(kind: serialport::ErrorKind, description: &str, expected: &PortError) {
        let error = serialport::Error::new(kind, description);
        assert_eq!(
            &port_error(Path::new("/dev/ttyS9"), "open", &error),
            expected
        );
    }

    #[test]
    fn library_errors_map_to_what_the_user_must_check() {
        let path = PathBuf::from("/dev/ttyS9");
        check(
            serialport::ErrorKind::Io(std::io::ErrorKind::PermissionDenied),
            "Permission denied",
            &PortError::PermissionDenied { path: path.clone() },
        );
        check(
            serialport::ErrorKind::NoDevice,
            "Unable to acquire exclusive lock on serial port",
            &PortError::Busy { path: path.clone() },
        );
        check(
            serialport::ErrorKind::Io(std::io::ErrorKind::NotFound),
            "No such file or directory",
            &PortError::NotFound { path: path.clone() },
        );
        check(
            serialport::ErrorKind::Unknown,
            "Inappropriate ioctl for device",
            &PortError::NotATerminal { path: path.clone() },
        );
        check(
            serialport::ErrorKind::Unknown,
            "Input/output error",
            &PortError::Other {
                path,
                operation: "open",
                message: "Input/output error".to_owned(),
            },
        );
    }

    #[test]
    fn the_permission_message_names_the_port_and_the_dialout_group() {
        let message = PortError::PermissionDenied {
            path: PathBuf::from("/dev/ttyUSB0"),
        }
        .to_string();
        assert!(message.contains("/dev/ttyUSB0"), "{message}");
        assert!(message.contains("dialout"), "{message}");
    }
}
