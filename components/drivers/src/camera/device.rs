//! The `camera` service's video device: frames from a [`VideoDevice`] and its CameraControl
//! commands mapped onto V4L2 controls, where the device has them.
//!
//! | command | V4L2 control | units |
//! |---|---|---|
//! | `set_zoom` | `ZOOM_ABSOLUTE` | the device's range mapped linearly onto zoom 1..=`max_zoom` |
//! | `set_focus` | `FOCUS_AUTO` off, `FOCUS_ABSOLUTE` | mm (UVC) |
//! | `set_exposure` | `EXPOSURE_AUTO` manual, `EXPOSURE_ABSOLUTE` | 100 µs (the shutter; iris and gain are kept and reported) |
//! | `set_pan_tilt` | `PAN_ABSOLUTE`, `TILT_ABSOLUTE` | arc seconds |
//!
//! A command for a control the device lacks is refused, naming the control.

use std::f64::consts::PI;
use std::os::fd::BorrowedFd;
use std::path::Path;

use lewis_interfaces::msg::{
    CameraControl, CameraControlCommand, CameraControlSetExposureReply, CameraControlSetFocusReply,
    CameraControlSetPanTiltReply, CameraControlSetZoomReply,
};
use lewis_service::{CommandError, Context, Reply};

use super::v4l2::{CaptureRequest, ControlRange, DeviceError, FrameInfo, VideoDevice, sys};

/// Arc seconds per radian.
const ARCSEC_PER_RAD: f64 = 180.0 * 3600.0 / PI;

/// A video device with the state of its controls.
#[derive(Debug)]
pub(super) struct DeviceSource {
    device: VideoDevice,
    max_zoom: f64,
    control: CameraControl,
}

impl DeviceSource {
    /// Opens the device and reads its controls.
    pub(super) fn open(
        path: &Path,
        request: CaptureRequest,
        max_zoom: f64,
    ) -> Result<Self, DeviceError> {
        let device = VideoDevice::open(path, request)?;
        let mut source = Self {
            device,
            max_zoom,
            control: CameraControl {
                zoom: 1.0,
                iris: 1.0,
                ..CameraControl::default()
            },
        };
        source.read_controls();
        Ok(source)
    }

    /// What the log says about it.
    pub(super) fn describe(&self) -> String {
        format!("{} ({:?})", self.device.card(), self.device.pixel_format())
    }

    /// The descriptor to wait on.
    pub(super) fn fd(&self) -> BorrowedFd<'_> {
        self.device.fd()
    }

    /// The next ready frame, as RGB8 in `rgb`.
    pub(super) fn read_frame(
        &mut self,
        rgb: &mut Vec<u8>,
    ) -> Result<Option<FrameInfo>, DeviceError> {
        self.device.read_frame(rgb)
    }

    /// The CameraControl publication.
    pub(super) fn control(&self) -> CameraControl {
        self.control.clone()
    }

    fn read_controls(&mut self) {
        let read = |id| {
            let range = self.device.control_range(id)?;
            Some((range, self.device.control(id)?))
        };
        if let Some((range, value)) = read(sys::CID_ZOOM_ABSOLUTE) {
            self.control.zoom = zoom_of(range, value, self.max_zoom);
        }
        if let Some((_, value)) = read(sys::CID_FOCUS_ABSOLUTE) {
            self.control.focus = f64::from(value) / 1000.0;
        }
        if let Some((_, value)) = read(sys::CID_EXPOSURE_ABSOLUTE) {
            self.control.shutter = f64::from(value) * 1e-4;
        }
        if let Some((_, value)) = read(sys::CID_PAN_ABSOLUTE) {
            self.control.pan = f64::from(value) / ARCSEC_PER_RAD;
        }
        if let Some((_, value)) = read(sys::CID_TILT_ABSOLUTE) {
            self.control.tilt = f64::from(value) / ARCSEC_PER_RAD;
        }
    }

    /// The range of a control the command needs, or the refusal naming it.
    fn range(&self, id: u32, name: &str) -> Result<ControlRange, CommandError> {
        self.device.control_range(id).ok_or_else(|| {
            CommandError::new(format!(
                "{} has no {name} control (V4L2_CID_{name}_ABSOLUTE)",
                self.device.card()
            ))
        })
    }

    fn set(&self, id: u32, value: i32) -> Result<i32, CommandError> {
        self.device
            .set_control(id, value)
            .map_err(|e| CommandError::new(e.to_string()))
    }

    /// Carries out a CameraControl command.
    pub(super) fn command(
        &mut self,
        ctx: &mut Context<'_>,
        command: CameraControlCommand,
    ) -> Result<Reply, CommandError> {
        let finite = |what: &str, v: f64| {
            if v.is_finite() {
                Ok(v)
            } else {
                Err(CommandError::new(format!("{what} {v} is not a number")))
            }
        };
        Ok(match command {
            CameraControlCommand::SetZoom(c) => {
                let range = self.range(sys::CID_ZOOM_ABSOLUTE, "ZOOM")?;
                let value = zoom_value(range, finite("zoom", c.zoom)?, self.max_zoom);
                let got = self.set(sys::CID_ZOOM_ABSOLUTE, value)?;
                self.control.zoom = zoom_of(range, got, self.max_zoom);
                ctx.reply(CameraControlSetZoomReply {
                    zoom: self.control.zoom,
                    ..CameraControlSetZoomReply::default()
                })
            }
            CameraControlCommand::SetFocus(c) => {
                let range = self.range(sys::CID_FOCUS_ABSOLUTE, "FOCUS")?;
                if self.device.control_range(sys::CID_FOCUS_AUTO).is_some() {
                    self.set(sys::CID_FOCUS_AUTO, 0)?;
                }
                let got = self.set(
                    sys::CID_FOCUS_ABSOLUTE,
                    range.clamp(to_units(finite("focus", c.focus)?, 1000.0)),
                )?;
                self.control.focus = f64::from(got) / 1000.0;
                ctx.reply(CameraControlSetFocusReply {
                    focus: self.control.focus,
                    ..CameraControlSetFocusReply::default()
                })
            }
            CameraControlCommand::SetExposure(c) => {
                let range = self.range(sys::CID_EXPOSURE_ABSOLUTE, "EXPOSURE")?;
                if self.device.control_range(sys::CID_EXPOSURE_AUTO).is_some() {
                    self.set(sys::CID_EXPOSURE_AUTO, sys::EXPOSURE_MANUAL)?;
                }
                let got = self.set(
                    sys::CID_EXPOSURE_ABSOLUTE,
                    range.clamp(to_units(finite("shutter", c.shutter)?, 1e4)),
                )?;
                self.control.shutter = f64::from(got) * 1e-4;
                self.control.iris = finite("iris", c.iris)?;
                self.control.gain = finite("gain", c.gain)?;
                ctx.reply(CameraControlSetExposureReply::default())
            }
            CameraControlCommand::SetPanTilt(c) => {
                let pan = self.range(sys::CID_PAN_ABSOLUTE, "PAN")?;
                let tilt = self.range(sys::CID_TILT_ABSOLUTE, "TILT")?;
                let got_pan = self.set(
                    sys::CID_PAN_ABSOLUTE,
                    pan.clamp(to_units(finite("pan", c.pan)?, ARCSEC_PER_RAD)),
                )?;
                let got_tilt = self.set(
                    sys::CID_TILT_ABSOLUTE,
                    tilt.clamp(to_units(finite("tilt", c.tilt)?, ARCSEC_PER_RAD)),
                )?;
                self.control.pan = f64::from(got_pan) / ARCSEC_PER_RAD;
                self.control.tilt = f64::from(got_tilt) / ARCSEC_PER_RAD;
                ctx.reply(CameraControlSetPanTiltReply::default())
            }
        })
    }
}

/// `value * scale` rounded to the device's integer units (saturating).
fn to_units(value: f64, scale: f64) -> i32 {
    // Saturating float-to-int conversion: out-of-range values become i32::MIN/MAX, which
    // the control's range then clamps.
    (value * scale).round() as i32
}

/// The zoom control's value for a magnification: the device's range spread linearly over
/// 1..=`max_zoom`.
#[must_use]
pub(super) fn zoom_value(range: ControlRange, zoom: f64, max_zoom: f64) -> i32 {
    let span = f64::from(range.maximum) - f64::from(range.minimum);
    if max_zoom <= 1.0 || span <= 0.0 {
        return range.minimum;
    }
    let fraction = ((zoom - 1.0) / (max_zoom - 1.0)).clamp(0.0, 1.0);
    range.clamp(to_units(f64::from(range.minimum) + fraction * span, 1.0))
}

/// The magnification of a zoom control's value (the inverse of [`zoom_value`]).
#[must_use]
pub(super) fn zoom_of(range: ControlRange, value: i32, max_zoom: f64) -> f64 {
    let span = f64::from(range.maximum) - f64::from(range.minimum);
    if max_zoom <= 1.0 || span <= 0.0 {
        return 1.0;
    }
    let fraction = ((f64::from(value) - f64::from(range.minimum)) / span).clamp(0.0, 1.0);
    1.0 + fraction * (max_zoom - 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zoom_spreads_the_device_range_over_one_to_max_zoom() {
        let range = ControlRange {
            minimum: 100,
            maximum: 500,
        };
        fn check(range: ControlRange, zoom: f64, value: i32) {
            assert_eq!(zoom_value(range, zoom, 5.0), value, "zoom {zoom}");
        }
        check(range, 1.0, 100);
        check(range, 3.0, 300);
        check(range, 5.0, 500);
        check(range, 9.0, 500);
        check(range, 0.5, 100);
        check(range, f64::NAN, 100);
        assert!((zoom_of(range, 300, 5.0) - 3.0).abs() < 1e-12);
        assert!((zoom_of(range, 9999, 5.0) - 5.0).abs() < 1e-12);
        // A device without a usable range, or max_zoom 1: always 1.
        let flat = ControlRange {
            minimum: 7,
            maximum: 7,
        };
        assert_eq!(zoom_value(flat, 3.0, 5.0), 7);
        assert!((zoom_of(flat, 7, 5.0) - 1.0).abs() < 1e-12);
        assert_eq!(zoom_value(range, 3.0, 1.0), 100);
    }

    #[test]
    fn units_saturate_instead_of_wrapping() {
        assert_eq!(to_units(0.0125, 1e4), 125);
        assert_eq!(to_units(1e30, 1e4), i32::MAX);
        assert_eq!(to_units(-1e30, 1.0), i32::MIN);
        assert_eq!(to_units(1.0, ARCSEC_PER_RAD), 206_265);
    }
}
