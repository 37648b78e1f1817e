//! Ports that cannot be used give errors that name them and say what to check.

#![allow(clippy::unwrap_used)]

use std::path::PathBuf;

use lewis_drivers::io::{
    PortError, RflexDriver, RflexDriverConfig, RflexDriverError, SickDriver, SickDriverConfig,
    SickDriverError,
};
use lewis_drivers::sick::SickDeviceConfig;
use lewis_emulators::FakeSick;

#[test]
fn a_port_that_does_not_exist_gives_an_error_naming_it_and_what_to_check() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ttyUSB7");
    let error = SickDriver::open(SickDriverConfig::new(&path)).unwrap_err();
    assert_eq!(
        error,
        SickDriverError::Port(PortError::NotFound { path: path.clone() })
    );
    let message = error.to_string();
    assert!(message.contains(&*path.to_string_lossy()), "{message}");
    assert!(message.contains("check the device path"), "{message}");

    let error = RflexDriver::open(RflexDriverConfig::new(&path)).unwrap_err();
    assert_eq!(error, RflexDriverError::Port(PortError::NotFound { path }));
}

#[test]
fn a_dangling_link_is_a_missing_port() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ttySICK");
    std::os::unix::fs::symlink("/dev/pts/lewis-gone", &path).unwrap();
    let error = SickDriver::open(SickDriverConfig::new(&path)).unwrap_err();
    assert_eq!(error, SickDriverError::Port(PortError::NotFound { path }));
}

#[test]
fn a_regular_file_is_not_a_serial_port() {
    let file = tempfile::NamedTempFile::new().unwrap();
    let path = PathBuf::from(file.path());
    let error = RflexDriver::open(RflexDriverConfig::new(&path)).unwrap_err();
    assert_eq!(
        error,
        RflexDriverError::Port(PortError::NotATerminal { path })
    );
    assert!(error.to_string().contains("not a serial port"));
}

#[test]
fn a_port_held_by_another_driver_is_reported_busy() {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("ttySICK");
    let _fake = FakeSick::start(SickDeviceConfig::default(), |_| Vec::new(), Some(&link)).unwrap();
    let _first = RflexDriver::open(RflexDriverConfig::new(&link)).unwrap();
    let error = SickDriver::open(SickDriverConfig::new(&link)).unwrap_err();
    assert_eq!(error, SickDriverError::Port(PortError::Busy { path: link }));
    assert!(error.to_string().contains("another program"));
}
