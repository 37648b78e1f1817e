//! The RFlex base behind a pseudo-terminal: [`RflexDevice`] at 115200 baud, its reports due
//! as time passes, its sonar from a [`SonarSource`], and its true pose shared with a world-backed
//! laser when asked: in the same process ([`SharedPose`]) or in another ([`PoseFile`]).

use std::path::Path;

use super::{Emulated, FakeDevice, FakeDeviceError, HostRates};
use lewis_drivers::rflex::{RflexDevice, RflexDeviceConfig, SonarSource};
use lewis_geometry::Pose2;

use crate::clock::MonotonicClock;
use crate::pose_file::PoseFile;
use crate::world_source::SharedPose;

/// The RFlex's only rate.
pub const RFLEX_BAUD_BPS: u32 = 115_200;

/// An emulated RFlex base on a pseudo-terminal.
pub type FakeRflex = FakeDevice<RflexEmulation>;

/// Where the emulated base stands in a world, and who is told its pose.
#[derive(Debug, Clone, Default)]
pub struct RflexEmulatorOptions {
    /// The world pose of the base's odometry origin (where it was powered up).
    pub origin: Pose2,
    /// Set to the base's true world pose as it moves (a world-backed laser reads it).
    pub shared_pose: Option<SharedPose>,
    /// Written with the base's true world pose whenever it moves (a laser emulator in
    /// another process reads it).
    pub pose_file: Option<PoseFile>,
}

/// The base as the emulator thread drives it.
pub struct RflexEmulation {
    device: RflexDevice,
    sonar: Box<dyn SonarSource + Send>,
    options: RflexEmulatorOptions,
    /// The pose last written to the pose file.
    written: Option<Pose2>,
}

impl RflexEmulation {
    /// A base powered up at `now_ns`, its sonar from `sonar`.
    pub fn new(
        config: RflexDeviceConfig,
        sonar: impl SonarSource + Send + 'static,
        options: RflexEmulatorOptions,
        now_ns: i64,
    ) -> Self {
        let mut emulation = Self {
            device: RflexDevice::new(config, now_ns),
            sonar: Box::new(sonar),
            options,
            written: None,
        };
        emulation.publish_pose();
        emulation
    }

    fn publish_pose(&mut self) {
        let pose = self.options.origin.compose(self.device.true_pose());
        if let Some(shared) = &self.options.shared_pose {
            shared.set(pose);
        }
        if let Some(file) = &self.options.pose_file
            && self.written != Some(pose)
        {
            // A failed write is tried again at the next step; the reader keeps the last
            // pose meanwhile (`lewis fake-device` checks the directory at start).
            if file.write(pose).is_ok() {
                self.written = Some(pose);
            }
        }
    }
}

impl Emulated for RflexEmulation {
    type Device = RflexDevice;

    fn device(&mut self) -> &mut RflexDevice {
        &mut self.device
    }

    fn line_bps(&self) -> u32 {
        RFLEX_BAUD_BPS
    }

    fn receive(&mut self, host: HostRates, bytes: &[u8], now_ns: i64) -> Vec<u8> {
        if !host.includes(RFLEX_BAUD_BPS) {
            // Bytes at another rate are garbage to the base; it hears nothing.
            return Vec::new();
        }
        let reply = self.device.receive(bytes, now_ns);
        self.publish_pose();
        reply
    }

    fn tick(&mut self, now_ns: i64) -> Vec<u8> {
        let reports = self.device.tick(now_ns, self.sonar.as_mut());
        self.publish_pose();
        reports
    }

    fn next_event_ns(&self) -> Option<i64> {
        self.device.next_event_ns()
    }

    /// A cable pulled and put back: the base kept its power and its state.
    fn replugged(&mut self, _now_ns: i64) {}
}

impl FakeDevice<RflexEmulation> {
    /// Starts an emulated base powered up per `config` (brake engaged, no reports), its sonar
    /// from `sonar`, on a new pseudo-terminal linked at `link` if given.
    pub fn start(
        config: RflexDeviceConfig,
        sonar: impl SonarSource + Send + 'static,
        options: RflexEmulatorOptions,
        link: Option<&Path>,
    ) -> Result<Self, FakeDeviceError> {
        let clock = MonotonicClock::new();
        let emulation = RflexEmulation::new(config, sonar, options, clock.now_ns());
        Self::spawn(clock, emulation, link)
    }
}
