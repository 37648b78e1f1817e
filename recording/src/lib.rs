//! Lewis recordings read back, for every command that reads a run: replay, export, the
//! viewer, tuning, `lewis info` and `lewis play`.
//!
//! - The crate root: a recording's files, robot and messages in one total order
//!   ([`RecordingFiles`], [`Recording`], [`expand_inputs`]).
//! - [`info`]: what a recording holds (`lewis info`); [`json`]: decoded values as JSON.
//! - [`play`]: `lewis play`, a recording published into live IPC at its recorded pace.

pub mod info;
pub mod json;
pub mod play;
mod read;

pub use info::{InfoError, InfoOptions, InfoReport, inspect};
pub use json::JsonValue;
pub use read::{
    Messages, ROBOT_METADATA, ReadAhead, RecordedMessage, Recording, RecordingError,
    RecordingFiles, Topic, expand_inputs,
};
