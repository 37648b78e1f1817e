//! The part of the V4L2 kernel interface (`linux/videodev2.h`) that capture by memory
//! mapping and a few camera controls need: the structures, laid out as the kernel lays them
//! out (checked by size below, since the size is part of every ioctl's number), and the
//! ioctls, through nix's ioctl macros.
//!
//! Everything here is `unsafe` to call: the caller passes a file descriptor of a V4L2
//! device and a pointer to a structure of the right type that lives for the call.

#![allow(
    missing_docs,
    reason = "the kernel's names and fields, documented in videodev2.h"
)]

use nix::libc::{c_int, c_ulong, c_void, timeval};

/// `V4L2_BUF_TYPE_VIDEO_CAPTURE`.
pub const BUF_TYPE_VIDEO_CAPTURE: u32 = 1;
/// `V4L2_MEMORY_MMAP`.
pub const MEMORY_MMAP: u32 = 1;
/// `V4L2_FIELD_NONE` (progressive frames).
pub const FIELD_NONE: u32 = 1;
/// `V4L2_CAP_VIDEO_CAPTURE`.
pub const CAP_VIDEO_CAPTURE: u32 = 0x0000_0001;
/// `V4L2_CAP_STREAMING`.
pub const CAP_STREAMING: u32 = 0x0400_0000;
/// `V4L2_CAP_DEVICE_CAPS`: `device_caps` is filled in.
pub const CAP_DEVICE_CAPS: u32 = 0x8000_0000;
/// `V4L2_CTRL_FLAG_DISABLED`.
pub const CTRL_FLAG_DISABLED: u32 = 0x0001;

/// `V4L2_CID_CAMERA_CLASS_BASE`.
const CID_CAMERA_CLASS_BASE: u32 = 0x009a_0900;
/// `V4L2_CID_EXPOSURE_AUTO` (menu: 1 is manual).
pub const CID_EXPOSURE_AUTO: u32 = CID_CAMERA_CLASS_BASE + 1;
/// `V4L2_EXPOSURE_MANUAL`.
pub const EXPOSURE_MANUAL: i32 = 1;
/// `V4L2_CID_EXPOSURE_ABSOLUTE`, in 100 µs.
pub const CID_EXPOSURE_ABSOLUTE: u32 = CID_CAMERA_CLASS_BASE + 2;
/// `V4L2_CID_PAN_ABSOLUTE`, in arc seconds.
pub const CID_PAN_ABSOLUTE: u32 = CID_CAMERA_CLASS_BASE + 8;
/// `V4L2_CID_TILT_ABSOLUTE`, in arc seconds.
pub const CID_TILT_ABSOLUTE: u32 = CID_CAMERA_CLASS_BASE + 9;
/// `V4L2_CID_FOCUS_ABSOLUTE` (UVC: mm).
pub const CID_FOCUS_ABSOLUTE: u32 = CID_CAMERA_CLASS_BASE + 10;
/// `V4L2_CID_FOCUS_AUTO` (boolean).
pub const CID_FOCUS_AUTO: u32 = CID_CAMERA_CLASS_BASE + 12;
/// `V4L2_CID_ZOOM_ABSOLUTE` (device units).
pub const CID_ZOOM_ABSOLUTE: u32 = CID_CAMERA_CLASS_BASE + 13;

#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct Capability {
    pub driver: [u8; 16],
    pub card: [u8; 32],
    pub bus_info: [u8; 32],
    pub version: u32,
    pub capabilities: u32,
    pub device_caps: u32,
    pub reserved: [u32; 3],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct PixFormat {
    pub width: u32,
    pub height: u32,
    pub pixelformat: u32,
    pub field: u32,
    pub bytesperline: u32,
    pub sizeimage: u32,
    pub colorspace: u32,
    pub private: u32,
    pub flags: u32,
    pub ycbcr_enc: u32,
    pub quantization: u32,
    pub xfer_func: u32,
}

/// The kernel's `fmt` union: its largest member is 200 bytes, and one member holds
/// pointers, which gives it a pointer's alignment.
#[repr(C)]
#[derive(Clone, Copy)]
pub union FormatUnion {
    pub pix: PixFormat,
    pub raw_data: [u8; 200],
    pub alignment: *mut c_void,
}

#[repr(C)]
#[derive(Clone, Copy)]
pub struct Format {
    pub kind: u32,
    pub fmt: FormatUnion,
}

impl Format {
    /// A capture format request.
    #[must_use]
    pub fn capture(pix: PixFormat) -> Self {
        let mut fmt = FormatUnion { raw_data: [0; 200] };
        fmt.pix = pix;
        Self {
            kind: BUF_TYPE_VIDEO_CAPTURE,
            fmt,
        }
    }

    /// The pixel format of a capture format.
    #[must_use]
    pub fn pix(&self) -> PixFormat {
        // SAFETY: every bit pattern is a valid PixFormat (plain integers), and the union
        // was initialised in full (raw_data) before.
        unsafe { self.fmt.pix }
    }
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct Fraction {
    pub numerator: u32,
    pub denominator: u32,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct CaptureParm {
    pub capability: u32,
    pub capturemode: u32,
    pub timeperframe: Fraction,
    pub extendedmode: u32,
    pub readbuffers: u32,
    pub reserved: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy)]
pub union StreamParmUnion {
    pub capture: CaptureParm,
    pub raw_data: [u8; 200],
}

#[repr(C)]
#[derive(Clone, Copy)]
pub struct StreamParm {
    pub kind: u32,
    pub parm: StreamParmUnion,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct RequestBuffers {
    pub count: u32,
    pub kind: u32,
    pub memory: u32,
    pub capabilities: u32,
    pub flags: u8,
    pub reserved: [u8; 3],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct Timecode {
    pub kind: u32,
    pub flags: u32,
    pub frames: u8,
    pub seconds: u8,
    pub minutes: u8,
    pub hours: u8,
    pub userbits: [u8; 4],
}

#[repr(C)]
#[derive(Clone, Copy)]
pub union BufferLocation {
    pub offset: u32,
    pub userptr: c_ulong,
    pub planes: *mut c_void,
    pub fd: i32,
}

#[repr(C)]
#[derive(Clone, Copy)]
pub struct Buffer {
    pub index: u32,
    pub kind: u32,
    pub bytesused: u32,
    pub flags: u32,
    pub field: u32,
    pub timestamp: timeval,
    pub timecode: Timecode,
    pub sequence: u32,
    pub memory: u32,
    pub m: BufferLocation,
    pub length: u32,
    pub reserved2: u32,
    pub request_fd: i32,
}

impl Buffer {
    /// A capture buffer of memory-mapped kind, `index`, everything else zero.
    #[must_use]
    pub fn mmap_capture(index: u32) -> Self {
        Self {
            index,
            kind: BUF_TYPE_VIDEO_CAPTURE,
            bytesused: 0,
            flags: 0,
            field: 0,
            timestamp: timeval {
                tv_sec: 0,
                tv_usec: 0,
            },
            timecode: Timecode::default(),
            sequence: 0,
            memory: MEMORY_MMAP,
            m: BufferLocation { userptr: 0 },
            length: 0,
            reserved2: 0,
            request_fd: 0,
        }
    }

    /// Where the buffer is in the device's memory (for mmap), as QUERYBUF filled it in.
    #[must_use]
    pub fn offset(&self) -> u32 {
        // SAFETY: `userptr` (the widest integer member) was written in full at creation;
        // the kernel writes `offset` for MMAP buffers. Any bit pattern is a valid u32.
        unsafe { self.m.offset }
    }
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct Control {
    pub id: u32,
    pub value: i32,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct QueryControl {
    pub id: u32,
    pub kind: u32,
    pub name: [u8; 32],
    pub minimum: i32,
    pub maximum: i32,
    pub step: i32,
    pub default_value: i32,
    pub flags: u32,
    pub reserved: [u32; 2],
}

// The sizes are part of the ioctl numbers: a wrong layout would be refused by the kernel
// (ENOTTY), so check them where the kernel's are known.
#[cfg(target_pointer_width = "64")]
const _: () = {
    assert!(size_of::<Capability>() == 104);
    assert!(size_of::<PixFormat>() == 48);
    assert!(size_of::<Format>() == 208);
    assert!(size_of::<StreamParm>() == 204);
    assert!(size_of::<RequestBuffers>() == 20);
    assert!(size_of::<Buffer>() == 88);
    assert!(size_of::<Control>() == 8);
    assert!(size_of::<QueryControl>() == 68);
};

nix::ioctl_read!(vidioc_querycap, b'V', 0, Capability);
nix::ioctl_readwrite!(vidioc_s_fmt, b'V', 5, Format);
nix::ioctl_readwrite!(vidioc_reqbufs, b'V', 8, RequestBuffers);
nix::ioctl_readwrite!(vidioc_querybuf, b'V', 9, Buffer);
nix::ioctl_readwrite!(vidioc_qbuf, b'V', 15, Buffer);
nix::ioctl_readwrite!(vidioc_dqbuf, b'V', 17, Buffer);
nix::ioctl_write_ptr!(vidioc_streamon, b'V', 18, c_int);
nix::ioctl_write_ptr!(vidioc_streamoff, b'V', 19, c_int);
nix::ioctl_readwrite!(vidioc_s_parm, b'V', 22, StreamParm);
nix::ioctl_readwrite!(vidioc_g_ctrl, b'V', 27, Control);
nix::ioctl_readwrite!(vidioc_s_ctrl, b'V', 28, Control);
nix::ioctl_readwrite!(vidioc_queryctrl, b'V', 36, QueryControl);
