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
            _ if is_disk_full(&source) => Self::DiskFull {
                path,
                closed_valid: false,
            },
            _ => Self::Io { path, source },
        }
    }

    /// Classifies an error of the MCAP writer on `path`.
    pub(crate) fn writing(path: &Path, source: mcap::McapError) -> Self {
        match source {
            mcap::McapError::Io(io) if is_disk_full(&io) => Self::DiskFull {
                path: path.to_path_buf(),
                closed_valid: false,
            },
            mcap::McapError::Io(source) => Self::Io {
                path: path.to_path_buf(),
                source,
            },
            source => Self::Mcap {
                path: path.to_path_buf(),
                source,
            },
        }
    }
}

/// Whether the system said that the disk (or the user's quota) is full.
pub(crate) fn is_disk_full(error: &io::Error) -> bool {
    matches!(
        error.kind(),
        io::ErrorKind::StorageFull | io::ErrorKind::QuotaExceeded | io::ErrorKind::FileTooLarge
    )
}
