//! Lewis recorder: everything the robot publishes, into MCAP files that every MCAP tool
//! reads. This crate is the one place of the project that writes MCAP for the robot.
//!
//! The core does not know where messages come from: a tap registers channels and offers
//! messages; the core owns what happens next. [`live`] is the tap of a running robot: it
//! subscribes to the robot's IPC channels (through `lewis-runtime`) and offers every sample.
//!
//! - [`Recorder`]: the core, on one thread, with no clock of its own. Channels in
//!   ([`ChannelSpec`]: topic, ros2msg schema, provider, interface and version), messages
//!   in ([`Sample`]: the CDR bytes exactly as they travelled, the header's publish time,
//!   the receive time, the header's sequence number). Files out: profile `ros2`, message
//!   encoding `cdr`, schema encoding `ros2msg`, chunked (zstd by default, lz4 or none)
//!   with message indexes, chunk indexes, statistics and a summary.
//! - File metadata: `lewis.interfaces` (every interface XML and `types.xml`, keyed by file
//!   name), `lewis.robot` (the robot description TOML, keyed by its file name),
//!   `lewis.recording` (recorder version, part number, and which versions of the recording
//!   format, of Lewis and of the interfaces wrote it: `lewis_mcap::format::WrittenBy`), and
//!   at close `lewis.loss` (lost messages per topic). The names are `lewis_mcap::format`'s,
//!   shared with the tools that read them. Metadata rather than attachments: they are small texts that
//!   tools list with the summary (`pymcap-cli info`, Foxglove's metadata panel) without
//!   reading the data section.
//! - Loss accounting ([`loss`]): sequence gaps per channel, a restart at 1 being a new run;
//!   written about every second on [`STATS_TOPIC`] (interface `RecorderStats`) and as
//!   `lewis.loss` at close.
//! - Crash safety: a chunk is closed and handed to the system when it reaches
//!   `chunk_size_bytes` and when `flush_period_ns` of receive time has passed (then the
//!   file is also synced); [`recover`] repairs a file whose writer died.
//! - Rotation by size or duration, with a parts index ([`index`]).
//! - A full disk: a reserve of space beside the file is given back so that the file is
//!   closed valid; other errors name the path ([`RecordError`]).
//! - Companion channels ([`companion`], an option): ROS 2's standard messages (LaserScan,
//!   Odometry, tf, markers) beside the robot's own, so that Foxglove draws the robot.
//! - [`spawn`]: the bounded queue and writer thread; the tap calls [`Tap::try_record`] or
//!   records into a [`TapBatch`], which never block (drop and count when full).

mod channel;
pub mod companion;
mod error;
pub mod index;
pub mod live;
pub mod loss;
mod options;
mod part;
mod queue;
mod recorder;
mod recover;
mod sink;
pub mod stress;
mod syncer;

pub use channel::{
    ChannelId, ChannelSpec, MESSAGE_ENCODING, META_INTERFACE, META_INTERFACE_VERSION,
    META_NUMBERING, META_PROVIDER, NUMBERED_PER_PUBLISHER, SCHEMA_ENCODING, Sample,
};
pub use error::RecordError;
pub use loss::ChannelCounts;
pub use options::{Compression, RecorderOptions, RobotDescription, SECOND_NS, UnknownCompression};
pub use part::PROFILE;
pub use queue::{Dropped, QueueOptions, Tap, TapBatch, WriterThread, spawn};
pub use recorder::{
    INTERFACES_METADATA, LOSS_METADATA, RECORDING_METADATA, ROBOT_METADATA, Recorder,
    RecordingReport, STATS_TOPIC,
};
pub use recover::{RecoverError, RecoverReport, recover};
