//! Capture from a V4L2 video device (a USB camera, `/dev/video0`) by memory-mapped
//! streaming, and its camera controls, with direct ioctls ([`sys`]).
//!
//! Why direct ioctls: the Rust V4L2 crates (`v4l`, `v4l2-sys-mit`) generate their bindings
//! with bindgen, which needs libclang on every machine that builds Lewis; capture needs a
//! dozen ioctls and eight structures, laid out in [`sys`] and checked by size. nix (already
//! a dependency) provides the ioctl wrappers and mmap.
//!
//! The device is opened non-blocking: [`VideoDevice::fd`] becomes readable when a frame is
//! ready, which the live harness waits on; [`VideoDevice::read_frame`] dequeues it, converts
//! it to RGB8 ([`super::pixel_format`]) and gives the buffer back to the driver.

pub mod sys;

use std::fs::{File, OpenOptions};
use std::num::NonZeroUsize;
use std::os::fd::{AsFd, AsRawFd, BorrowedFd};
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::ptr::NonNull;

use nix::errno::Errno;
use nix::libc::{O_NONBLOCK, c_int, c_void};
use nix::sys::mman::{MapFlags, ProtFlags, mmap, munmap};

use super::pixel_format::{ConvertError, PixelFormat, fourcc_name, mjpeg_to_rgb, yuyv_to_rgb};

/// How many buffers the driver fills in turn.
const BUFFER_COUNT: u32 = 4;

/// Why a video device cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    /// The device file cannot be opened.
    #[error("cannot open video device {path}: {source}")]
    Open {
        /// The device.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// An ioctl failed.
    #[error("video device {path}: {call} failed: {errno}{hint}")]
    Ioctl {
        /// The device.
        path: PathBuf,
        /// The ioctl.
        call: &'static str,
        /// What the driver said.
        errno: Errno,
        /// What it probably means.
        hint: &'static str,
    },
    /// The device cannot capture video by streaming.
    #[error("{path} ({card}) cannot stream video capture (capabilities {capabilities:#010x})")]
    NotCapture {
        /// The device.
        path: PathBuf,
        /// Its name.
        card: String,
        /// Its capability bits.
        capabilities: u32,
    },
    /// The device offers no format that Lewis converts.
    #[error("{path} offers {offered}, not YUYV or MJPG")]
    Format {
        /// The device.
        path: PathBuf,
        /// What it offered instead.
        offered: String,
    },
    /// A frame could not be converted.
    #[error("video device {path}: {source}")]
    Convert {
        /// The device.
        path: PathBuf,
        /// Why.
        source: ConvertError,
    },
}

/// What to ask of a device; the driver may give something close instead.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaptureRequest {
    /// Width, in px.
    pub width_px: u32,
    /// Height, in px.
    pub height_px: u32,
    /// Frames per second.
    pub rate_hz: f64,
}

/// One frame read from the device.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameInfo {
    /// Width, in px.
    pub width_px: u32,
    /// Height, in px.
    pub height_px: u32,
    /// The driver's frame counter (gaps are frames it dropped).
    pub sequence: u32,
}

/// The range of a camera control, in the device's units.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ControlRange {
    /// Smallest value.
    pub minimum: i32,
    /// Largest value.
    pub maximum: i32,
}

impl ControlRange {
    /// `value` brought into the range.
    #[must_use]
    pub fn clamp(self, value: i32) -> i32 {
        value.clamp(self.minimum, self.maximum.max(self.minimum))
    }
}

/// One buffer mapped into this process.
struct Mapped {
    ptr: NonNull<c_void>,
    length: usize,
}

/// A video capture device, streaming.
pub struct VideoDevice {
    path: PathBuf,
    file: File,
    buffers: Vec<Mapped>,
    format: PixelFormat,
    width_px: u32,
    height_px: u32,
    bytes_per_line: u32,
    card: String,
}

impl std::fmt::Debug for VideoDevice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VideoDevice")
            .field("path", &self.path)
            .field("card", &self.card)
            .field("format", &self.format)
            .field("width_px", &self.width_px)
            .field("height_px", &self.height_px)
            .finish_non_exhaustive()
    }
}

impl VideoDevice {
    /// Opens a device, sets its format (YUYV, else MJPEG) and rate, maps its buffers and
    /// starts streaming.
    ///
    /// # Errors
    /// When the device is missing, is not a V4L2 capture device, offers no format Lewis
    /// converts, or refuses a step.
    pub fn open(path: &Path, request: CaptureRequest) -> Result<Self, DeviceError> {
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(O_NONBLOCK)
            .open(path)
            .map_err(|source| DeviceError::Open {
                path: path.to_path_buf(),
                source,
            })?;
        let mut device = Self {
            path: path.to_path_buf(),
            file,
            buffers: Vec::new(),
            format: PixelFormat::Yuyv,
            width_px: 0,
            height_px: 0,
            bytes_per_line: 0,
            card: String::new(),
        };
        device.check_capabilities()?;
        device.set_format(request)?;
        device.set_rate(request.rate_hz);
        device.map_buffers()?;
        device.stream(true)?;
        Ok(device)
    }

    /// The file descriptor to wait on: readable when a frame is ready.
    #[must_use]
    pub fn fd(&self) -> BorrowedFd<'_> {
        self.file.as_fd()
    }

    /// The device's name (`card`), as its driver gives it.
    #[must_use]
    pub fn card(&self) -> &str {
        &self.card
    }

    /// The pixel format frames come in.
    #[must_use]
    pub fn pixel_format(&self) -> PixelFormat {
        self.format
    }

    /// Takes the next ready frame, converted to RGB8 into `rgb`; `None` when none is ready.
    ///
    /// # Errors
    /// When dequeuing fails (the device was unplugged) or the frame does not convert (the
    /// buffer is given back to the driver either way).
    pub fn read_frame(&mut self, rgb: &mut Vec<u8>) -> Result<Option<FrameInfo>, DeviceError> {
        let mut buffer = sys::Buffer::mmap_capture(0);
        // SAFETY: a V4L2 device's descriptor and a Buffer that lives for the call.
        match unsafe { sys::vidioc_dqbuf(self.raw(), &raw mut buffer) } {
            Ok(_) => {}
            Err(Errno::EAGAIN) => return Ok(None),
            Err(errno) => return Err(self.ioctl_error("VIDIOC_DQBUF", errno)),
        }
        let converted = self.convert(&buffer, rgb);
        // SAFETY: as above; the buffer is one the driver gave us, handed back.
        let requeued = unsafe { sys::vidioc_qbuf(self.raw(), &raw mut buffer) };
        let info = converted?;
        requeued.map_err(|errno| self.ioctl_error("VIDIOC_QBUF", errno))?;
        Ok(Some(FrameInfo {
            sequence: buffer.sequence,
            ..info
        }))
    }

    fn convert(&self, buffer: &sys::Buffer, rgb: &mut Vec<u8>) -> Result<FrameInfo, DeviceError> {
        let bytes = self.buffer_bytes(buffer);
        let convert_error = |source| DeviceError::Convert {
            path: self.path.clone(),
            source,
        };
        let (width_px, height_px) = match self.format {
            PixelFormat::Yuyv => {
                yuyv_to_rgb(
                    self.width_px,
                    self.height_px,
                    self.bytes_per_line,
                    bytes,
                    rgb,
                )
                .map_err(|e| convert_error(e.into()))?;
                (self.width_px, self.height_px)
            }
            PixelFormat::Mjpeg => {
                let (width, height, pixels) = mjpeg_to_rgb(bytes).map_err(convert_error)?;
                *rgb = pixels;
                (width, height)
            }
        };
        Ok(FrameInfo {
            width_px,
            height_px,
            sequence: 0,
        })
    }

    /// The bytes the driver filled in a dequeued buffer.
    fn buffer_bytes(&self, buffer: &sys::Buffer) -> &[u8] {
        let Some(mapped) = usize::try_from(buffer.index)
            .ok()
            .and_then(|i| self.buffers.get(i))
        else {
            return &[];
        };
        let used =
            usize::try_from(buffer.bytesused).map_or(mapped.length, |n| n.min(mapped.length));
        // SAFETY: the mapping is `length` bytes, readable, alive until Drop; the driver
        // does not write into a buffer between DQBUF and QBUF.
        unsafe { std::slice::from_raw_parts(mapped.ptr.as_ptr().cast::<u8>(), used) }
    }

    /// The range of a control, if the device has it (and it is not disabled).
    #[must_use]
    pub fn control_range(&self, id: u32) -> Option<ControlRange> {
        let mut query = sys::QueryControl {
            id,
            ..sys::QueryControl::default()
        };
        // SAFETY: a V4L2 device's descriptor and a QueryControl that lives for the call.
        unsafe { sys::vidioc_queryctrl(self.raw(), &raw mut query) }.ok()?;
        (query.flags & sys::CTRL_FLAG_DISABLED == 0).then_some(ControlRange {
            minimum: query.minimum,
            maximum: query.maximum,
        })
    }

    /// Sets a control; returns the value the device now reports.
    ///
    /// # Errors
    /// When the device refuses it.
    pub fn set_control(&self, id: u32, value: i32) -> Result<i32, DeviceError> {
        let mut control = sys::Control { id, value };
        // SAFETY: a V4L2 device's descriptor and a Control that lives for the call.
        unsafe { sys::vidioc_s_ctrl(self.raw(), &raw mut control) }
            .map_err(|errno| self.ioctl_error("VIDIOC_S_CTRL", errno))?;
        Ok(self.control(id).unwrap_or(value))
    }

    /// The current value of a control.
    #[must_use]
    pub fn control(&self, id: u32) -> Option<i32> {
        let mut control = sys::Control { id, value: 0 };
        // SAFETY: a V4L2 device's descriptor and a Control that lives for the call.
        unsafe { sys::vidioc_g_ctrl(self.raw(), &raw mut control) }.ok()?;
        Some(control.value)
    }

    fn raw(&self) -> c_int {
        self.file.as_raw_fd()
    }

    fn ioctl_error(&self, call: &'static str, errno: Errno) -> DeviceError {
        let hint = match errno {
            Errno::ENOTTY | Errno::EINVAL if call == "VIDIOC_QUERYCAP" => {
                ": it is not a V4L2 device"
            }
            Errno::EBUSY => ": another program is using it",
            Errno::ENODEV => ": it was unplugged",
            _ => "",
        };
        DeviceError::Ioctl {
            path: self.path.clone(),
            call,
            errno,
            hint,
        }
    }

    fn check_capabilities(&mut self) -> Result<(), DeviceError> {
        let mut caps = sys::Capability::default();
        // SAFETY: a descriptor and a Capability that lives for the call.
        unsafe { sys::vidioc_querycap(self.raw(), &raw mut caps) }
            .map_err(|errno| self.ioctl_error("VIDIOC_QUERYCAP", errno))?;
        let name_end = caps.card.iter().position(|&b| b == 0).unwrap_or(32);
        self.card = String::from_utf8_lossy(&caps.card[..name_end]).into_owned();
        let capabilities = if caps.capabilities & sys::CAP_DEVICE_CAPS != 0 {
            caps.device_caps
        } else {
            caps.capabilities
        };
        let needed = sys::CAP_VIDEO_CAPTURE | sys::CAP_STREAMING;
        if capabilities & needed != needed {
            return Err(DeviceError::NotCapture {
                path: self.path.clone(),
                card: self.card.clone(),
                capabilities,
            });
        }
        Ok(())
    }

    /// Asks for YUYV, then MJPEG, at the requested size; keeps what the driver sets.
    fn set_format(&mut self, request: CaptureRequest) -> Result<(), DeviceError> {
        let mut offered = 0;
        for wanted in [PixelFormat::Yuyv, PixelFormat::Mjpeg] {
            let mut format = sys::Format::capture(sys::PixFormat {
                width: request.width_px,
                height: request.height_px,
                pixelformat: wanted.fourcc(),
                field: sys::FIELD_NONE,
                ..sys::PixFormat::default()
            });
            // SAFETY: a V4L2 device's descriptor and a Format that lives for the call.
            unsafe { sys::vidioc_s_fmt(self.raw(), &raw mut format) }
                .map_err(|errno| self.ioctl_error("VIDIOC_S_FMT", errno))?;
            let pix = format.pix();
            offered = pix.pixelformat;
            if let Some(got) = PixelFormat::from_fourcc(pix.pixelformat) {
                self.format = got;
                self.width_px = pix.width;
                self.height_px = pix.height;
                self.bytes_per_line = pix.bytesperline.max(pix.width.saturating_mul(2));
                return Ok(());
            }
        }
        Err(DeviceError::Format {
            path: self.path.clone(),
            offered: fourcc_name(offered),
        })
    }

    /// Asks for a frame period of 1/`rate_hz`; drivers that cannot keep their own rate
    /// (the camera service drops frames to slow down anyway).
    fn set_rate(&self, rate_hz: f64) {
        // Frames per second as a fraction with a millisecond's precision.
        let per_thousand_s = (rate_hz * 1000.0).round().clamp(1.0, 1e9) as u32;
        let mut parm = sys::StreamParm {
            kind: sys::BUF_TYPE_VIDEO_CAPTURE,
            parm: sys::StreamParmUnion { raw_data: [0; 200] },
        };
        parm.parm.capture = sys::CaptureParm {
            timeperframe: sys::Fraction {
                numerator: 1000,
                denominator: per_thousand_s,
            },
            ..sys::CaptureParm::default()
        };
        // SAFETY: a V4L2 device's descriptor and a StreamParm that lives for the call.
        let _ = unsafe { sys::vidioc_s_parm(self.raw(), &raw mut parm) };
    }

    fn map_buffers(&mut self) -> Result<(), DeviceError> {
        let mut request = sys::RequestBuffers {
            count: BUFFER_COUNT,
            kind: sys::BUF_TYPE_VIDEO_CAPTURE,
            memory: sys::MEMORY_MMAP,
            ..sys::RequestBuffers::default()
        };
        // SAFETY: a V4L2 device's descriptor and a RequestBuffers that lives for the call.
        unsafe { sys::vidioc_reqbufs(self.raw(), &raw mut request) }
            .map_err(|errno| self.ioctl_error("VIDIOC_REQBUFS", errno))?;
        for index in 0..request.count {
            let mut buffer = sys::Buffer::mmap_capture(index);
            // SAFETY: as above, with a Buffer.
            unsafe { sys::vidioc_querybuf(self.raw(), &raw mut buffer) }
                .map_err(|errno| self.ioctl_error("VIDIOC_QUERYBUF", errno))?;
            let length = usize::try_from(buffer.length).unwrap_or(0);
            let Some(size) = NonZeroUsize::new(length) else {
                return Err(self.ioctl_error("VIDIOC_QUERYBUF", Errno::EINVAL));
            };
            // SAFETY: a shared read-only mapping of the driver's buffer at the offset it
            // gave; it is unmapped in Drop, after streaming stops.
            let ptr = unsafe {
                mmap(
                    None,
                    size,
                    ProtFlags::PROT_READ,
                    MapFlags::MAP_SHARED,
                    &self.file,
                    nix::libc::off_t::from(buffer.offset()),
                )
            }
            .map_err(|errno| self.ioctl_error("mmap", errno))?;
            self.buffers.push(Mapped { ptr, length });
            // SAFETY: as above.
            unsafe { sys::vidioc_qbuf(self.raw(), &raw mut buffer) }
                .map_err(|errno| self.ioctl_error("VIDIOC_QBUF", errno))?;
        }
        Ok(())
    }

    fn stream(&self, on: bool) -> Result<(), DeviceError> {
        let kind = sys::BUF_TYPE_VIDEO_CAPTURE as c_int;
        // SAFETY: a V4L2 device's descriptor and an int that lives for the call.
        let result = unsafe {
            if on {
                sys::vidioc_streamon(self.raw(), &raw const kind)
            } else {
                sys::vidioc_streamoff(self.raw(), &raw const kind)
            }
        };
        result.map(drop).map_err(|errno| {
            self.ioctl_error(
                if on {
                    "VIDIOC_STREAMON"
                } else {
                    "VIDIOC_STREAMOFF"
                },
                errno,
            )
        })
    }
}

impl Drop for VideoDevice {
    fn drop(&mut self) {
        if !self.buffers.is_empty() {
            let _ = self.stream(false);
        }
        for mapped in self.buffers.drain(..) {
            // SAFETY: a mapping made in map_buffers, unmapped once.
            let _ = unsafe { munmap(mapped.ptr, mapped.length) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request() -> CaptureRequest {
        CaptureRequest {
            width_px: 640,
            height_px: 480,
            rate_hz: 10.0,
        }
    }

    #[test]
    fn a_missing_device_cannot_be_opened_and_says_which() {
        let err = VideoDevice::open(Path::new("/dev/lewis-no-such-video"), request())
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("cannot open video device /dev/lewis-no-such-video:"),
            "{err}"
        );
    }

    #[test]
    fn a_file_that_is_not_a_video_device_is_refused_by_the_kernel() {
        // /dev/null answers VIDIOC_QUERYCAP with ENOTTY: the real ioctl path, no camera.
        let err = VideoDevice::open(Path::new("/dev/null"), request())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("VIDIOC_QUERYCAP failed") && err.contains("it is not a V4L2 device"),
            "{err}"
        );
    }

    #[test]
    fn control_ranges_clamp_even_when_reversed() {
        let range = ControlRange {
            minimum: 100,
            maximum: 500,
        };
        assert_eq!(range.clamp(50), 100);
        assert_eq!(range.clamp(900), 500);
        let empty = ControlRange {
            minimum: 5,
            maximum: 1,
        };
        assert_eq!(empty.clamp(9), 5);
    }
}
