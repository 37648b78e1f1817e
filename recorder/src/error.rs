//! Why recording stopped: every variant names the file or folder concerned and says
//! what to do.

use std::io;
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::channel::ChannelId;

/// Why the recorder could not open, write or close a file.
#[derive(Debug, Error)]
pub enum RecordError {
    /// The folder of the output does not exist.
    #[error(
        "cannot record into {}: the folder {} does not exist; create it or choose another output path",
        path.display(),
        folder.display()
    )]
    MissingFolder {
        /// The file that was to be written.
        path: PathBuf,
        /// Its folder, which is missing.
        folder: PathBuf,
    },
    /// The folder (or file system) of the output cannot be written.
    #[error(
        "cannot record into {}: the folder is read-only or not writable ({source}); choose another output path",
        path.display()
    )]
    ReadOnly {
        /// The file that was to be written.
        path: PathBuf,
        /// What the system said.
        source: io::Error,
    },
    /// The output already exists; the recorder never overwrites a recording.
    #[error("{} already exists: the recorder does not overwrite recordings; remove it or choose another output path", path.display())]
    AlreadyExists {
        /// The existing file.
        path: PathBuf,
    },
    /// The disk filled up.
    #[error("{}: the disk is full; {}", path.display(), if *closed_valid {
        "the file was closed valid up to its last complete chunk; free some space and record again"
    } else {
        "the file could not be closed: run `lewis recover` on it once there is space"
    })]
    DiskFull {
        /// The file being written.
        path: PathBuf,
        /// Whether the file was closed with its summary (true), or is left truncated.
        closed_valid: bool,
    },
    /// The file reached the largest size allowed: the process's file size limit (`ulimit
    /// -f`, `LimitFSIZE=`) or its file system's.
    #[error("{}: the file reached the largest size allowed (the process's file size limit, `ulimit -f`, or its file system's); {}", path.display(), if *closed_valid {
        "the file was closed valid up to its last complete chunk; record with --split-size below the limit"
    } else {
        "the file could not be closed: run `lewis recover` on it, and record with --split-size below the limit"
    })]
    FileTooLarge {
        /// The file being written.
        path: PathBuf,
        /// Whether the file was closed with its summary (true), or is left truncated.
        closed_valid: bool,
    },
    /// Any other input/output error.
    #[error("cannot write {}: {source}; the file is readable up to its last complete chunk (`lewis recover` repairs it)", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// What the system said.
        source: io::Error,
    },
    /// The MCAP writer refused (too many channels, ...).
    #[error("cannot write {}: {source}", path.display())]
    Mcap {
        /// The file concerned.
        path: PathBuf,
        /// What the MCAP writer said.
        source: mcap::McapError,
    },
    /// A message named a channel that was never registered.
    #[error(
        "{channel} was never registered with the recorder; register it before its first message"
    )]
    UnknownChannel {
        /// The channel named.
        channel: ChannelId,
    },
    /// The recorder already stopped after an error, or was closed.
    #[error("the recorder of {} has stopped after an earlier error; start a new recording", path.display())]
    Stopped {
        /// The last file it wrote.
        path: PathBuf,
    },
    /// The writer thread panicked (a bug).
    #[error("the recorder's writer thread panicked while writing {}", path.display())]
    WriterPanicked {
        /// The file it was writing.
        path: PathBuf,
    },
}

impl RecordError {
    /// The file (or, for a missing folder, the file that was to be written) concerned.
    #[must_use]
    pub fn path(&self) -> Option<&Path> {
        match self {
            Self::MissingFolder { path, .. }
            | Self::ReadOnly { path, .. }
            | Self::AlreadyExists { path }
            | Self::DiskFull { path, .. }
            | Self::FileTooLarge { path, .. }
            | Self::Io { path, .. }
            | Self::Mcap { path, .. }
            | Self::Stopped { path }
            | Self::WriterPanicked { path } => Some(path),
            Self::UnknownChannel { .. } => None,
        }
    }

    /// Classifies an error of the system while opening `path` for writing.
    pub(crate) fn opening(path: &Path, source: io::Error) -> Self {
        let path = path.to_path_buf();
        match source.kind() {
            io::ErrorKind::NotFound => {
                let folder = path
                    .parent()
                    .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
                Self::MissingFolder { path, folder }
            }
            io::ErrorKind::AlreadyExists => Self::AlreadyExists { path },
            io::ErrorKind::PermissionDenied | io::ErrorKind::ReadOnlyFilesystem => {
                Self::ReadOnly { path, source }
            }
            _ => match no_room(&source) {
                Some(why) => Self::no_room(why, path, false),
                None => Self::Io { path, source },
            },
        }
    }

    /// The error for a file that has no more room, for `why`.
    pub(crate) fn no_room(why: NoRoom, path: PathBuf, closed_valid: bool) -> Self {
        match why {
            NoRoom::DiskFull => Self::DiskFull { path, closed_valid },
            NoRoom::FileSizeLimit => Self::FileTooLarge { path, closed_valid },
        }
    }

    /// Why the file has no more room, when that is the error.
    pub(crate) fn no_room_reason(&self) -> Option<NoRoom> {
        match self {
            Self::DiskFull { .. } => Some(NoRoom::DiskFull),
            Self::FileTooLarge { .. } => Some(NoRoom::FileSizeLimit),
            _ => None,
        }
    }

    /// Classifies an error of the MCAP writer on `path`.
    pub(crate) fn writing(path: &Path, source: mcap::McapError) -> Self {
        match source {
            mcap::McapError::Io(source) => match no_room(&source) {
                Some(why) => Self::no_room(why, path.to_path_buf(), false),
                None => Self::Io {
                    path: path.to_path_buf(),
                    source,
                },
            },
            source => Self::Mcap {
                path: path.to_path_buf(),
                source,
            },
        }
    }
}

/// Why a file has no more room.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NoRoom {
    /// The disk (or the user's quota) is full.
    DiskFull,
    /// The file reached the process's file size limit or its file system's largest file.
    FileSizeLimit,
}

/// Whether the system said that the file has no more room, and why.
pub(crate) fn no_room(error: &io::Error) -> Option<NoRoom> {
    match error.kind() {
        io::ErrorKind::StorageFull | io::ErrorKind::QuotaExceeded => Some(NoRoom::DiskFull),
        io::ErrorKind::FileTooLarge => Some(NoRoom::FileSizeLimit),
        _ => None,
    }
}
