//! What can go wrong when a recording is turned into a Rerun recording.

use std::path::PathBuf;

/// Why [`crate::view`] stopped. A recording that is damaged part-way is not an error: what
/// could be read is shown and the damage is reported in [`crate::ViewReport::damage`].
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// An input file cannot be opened or read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// An input file does not start like an MCAP file.
    #[error("{} is not an MCAP file ({detail}); `lewis view` reads MCAP recordings", path.display())]
    NotMcap {
        /// The file.
        path: PathBuf,
        /// What the reader met instead of an MCAP header.
        detail: String,
    },
    /// The .rrd file cannot be written.
    #[error("cannot write {}: {detail}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What failed.
        detail: String,
    },
    /// The Rerun viewer cannot be started.
    #[error(
        "cannot start the Rerun viewer: {detail}; install it with `pip install rerun-sdk=={}` \
         or write a file with `--save OUT.rrd`",
        crate::RERUN_SDK_PIP_VERSION
    )]
    Spawn {
        /// What failed.
        detail: String,
    },
    /// The Rerun viewer at an address cannot be reached.
    #[error("cannot send to the Rerun viewer at {address}: {detail}; is `rerun` running there?")]
    Connect {
        /// The address given.
        address: String,
        /// What failed.
        detail: String,
    },
    /// Rerun refused data the viewer built (a bug of the viewer, not of the recording).
    #[error("cannot build the Rerun data of entity {entity}: {detail}")]
    Build {
        /// The entity path.
        entity: String,
        /// Rerun's error.
        detail: String,
    },
}
