//! `lewis fake-device sick|rflex [--pty PATH]`: a device emulator on a pseudo-terminal, for
//! pointing a robot file's `port` at when the robot is not there. Prints the device's path
//! (the link when given), then runs until Ctrl-C or SIGTERM, which close the port and remove
//! the link.

use std::os::fd::AsFd;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args, ValueEnum};
use lewis_emulators::{DeviceKind, Standalone, StandaloneOptions, parse_faults};
use lewis_geometry::Pose2;
use lewis_runtime::live::StopSignals;
use nix::poll::{PollFd, PollFlags, PollTimeout, poll};

/// Arguments of `lewis fake-device`.
#[derive(Debug, Args)]
#[command(after_help = FAULT_HELP)]
pub struct FakeDeviceArgs {
    /// The device to emulate.
    pub device: Device,
    /// Where the pseudo-terminal appears: a symbolic link to it is made at this path
    /// (replaced if it is a link already); without it, the /dev/pts path is printed.
    #[arg(long = "pty", alias = "link", value_name = "PATH")]
    pub pty: Option<PathBuf>,
    /// Faults, comma-separated: noise=N, bad-crc-every=N, silent, unplug@T1-T2, unplug@T1,
    /// none (see below).
    #[arg(long, default_value = "none", value_name = "SPEC")]
    pub fault: String,
    /// A world folder of the simulator for the device to see (default: a plain 6 m by 4 m
    /// room).
    #[arg(long, value_name = "DIR")]
    pub world: Option<PathBuf>,
    /// Where the robot stands in the world: x_m,y_m,heading_deg.
    #[arg(long, default_value = "0,0,0", value_parser = parse_pose)]
    pub start: Pose2,
    /// A directory shared by the `rflex` and `sick` emulators of one robot (give both the
    /// same): the base writes its true pose there as it drives, the laser renders its
    /// scans from it, so the ranges follow the drive. Needs --world.
    #[arg(long, value_name = "DIR")]
    pub robot_state: Option<PathBuf>,
    /// Seed of the simulated noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// The fault syntax, after the options in `--help`.
const FAULT_HELP: &str = "\
Faults (--fault), comma-separated, later ones overriding earlier ones:
  noise=N           N garbage bytes before every frame the device sends
  bad-crc-every=N   every N-th frame with a corrupted checksum (1: all of them)
  silent            no answers and no streaming, as if the cable were cut
  unplug@T1-T2      the pseudo-terminal is closed T1 after the start (the driver sees a
                    hang-up and the link disappears) and comes back at T2 at the same path,
                    as a cable pulled and put back; unplug@T1 pulls it for good; times as
                    5s, 1.5s or 500ms; several windows may be given
  none              no fault
Examples:
  lewis fake-device sick --pty /tmp/ttySICK --fault noise=8,bad-crc-every=10
  lewis fake-device rflex --pty /tmp/ttyRFLEX --fault unplug@5s-8s
Both emulators of one robot in a world, sharing the base's pose:
  lewis fake-device rflex --pty /tmp/ttyRFLEX --world W --start 3,12.5,0 --robot-state D &
  lewis fake-device sick --pty /tmp/ttySICK --world W --start 3,12.5,0 --robot-state D";

/// The devices `lewis fake-device` emulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Device {
    /// The SICK LMS2xx laser (9600 baud at power-up).
    Sick,
    /// The B21r's RFlex base (115200 baud).
    Rflex,
}

fn parse_pose(text: &str) -> Result<Pose2, String> {
    let numbers: Vec<f64> = text
        .split(',')
        .map(|part| part.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("`{text}`: {e}: give x_m,y_m,heading_deg"))?;
    match numbers[..] {
        [x, y, heading_deg] if numbers.iter().all(|n| n.is_finite()) => {
            Ok(Pose2::new(x, y, heading_deg.to_radians()))
        }
        _ => Err(format!("`{text}`: give three numbers x_m,y_m,heading_deg")),
    }
}

/// Runs `lewis fake-device`.
pub fn run(args: &FakeDeviceArgs) -> anyhow::Result<ExitCode> {
    let faults = parse_faults(&args.fault).context("--fault")?;
    let kind = match args.device {
        Device::Sick => DeviceKind::Sick,
        Device::Rflex => DeviceKind::Rflex,
    };
    // Installed before the emulator's thread starts, so that Ctrl-C always finds a handler
    // and the link is removed on the way out.
    let signals = StopSignals::install().context("cannot catch SIGTERM and SIGINT")?;
    let options = StandaloneOptions {
        link: args.pty.clone(),
        faults,
        world: args.world.clone(),
        start: args.start,
        robot_state: args.robot_state.clone(),
        seed: args.seed,
    };
    let fake = Standalone::start(kind, &options)?;
    #[allow(clippy::print_stdout)]
    {
        // The one line a script reads: the path to put in the robot file.
        println!("{}", fake.path().display());
    }
    loop {
        let mut fds = [PollFd::new(signals.as_fd(), PollFlags::POLLIN)];
        // Woken by a signal; once a second to notice an emulator that stopped on an error.
        match poll(&mut fds, PollTimeout::from(1000u16)) {
            Ok(_) | Err(nix::errno::Errno::EINTR) => {}
            Err(errno) => anyhow::bail!("cannot wait for a stop signal: {errno}"),
        }
        if signals.take() {
            break;
        }
        if let Some(failure) = fake.failure() {
            anyhow::bail!("the emulator stopped: {failure}");
        }
    }
    fake.stop()?;
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn start_poses_are_three_numbers() {
        let pose = parse_pose("3, 12.5, 90").unwrap();
        assert!((pose.x_m - 3.0).abs() < 1e-12 && (pose.y_m - 12.5).abs() < 1e-12);
        assert!((pose.heading_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!(parse_pose("1,2").unwrap_err().contains("three numbers"));
        assert!(
            parse_pose("1,x,2")
                .unwrap_err()
                .contains("x_m,y_m,heading_deg")
        );
    }
}
