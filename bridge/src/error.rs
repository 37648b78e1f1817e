//! Why a host's bridge could not run.

use std::path::PathBuf;

use lewis_runtime::ipc::IpcError;

/// Why a host's bridge could not run.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// The robot file has no such host.
    #[error("the robot has no host `{host}`{hint}: its hosts are {hosts}")]
    UnknownHost {
        /// The host asked for.
        host: String,
        /// A did-you-mean, or nothing.
        hint: String,
        /// The hosts it has.
        hosts: String,
    },
    /// The key file cannot be used.
    #[error("key file {}: {reason}", path.display())]
    Key {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A file of `[network.tls]` cannot be used.
    #[error("TLS file {}: {reason}", path.display())]
    Tls {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A file of the run's own could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Scratch {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// Zenoh refused a setting.
    #[error("zenoh refuses setting {key}: {reason}")]
    Config {
        /// The setting.
        key: String,
        /// What Zenoh said.
        reason: String,
    },
    /// The session could not be opened (an endpoint it cannot listen on, ...).
    #[error("host {host} cannot open its Zenoh session: {reason}")]
    Session {
        /// The host.
        host: String,
        /// What Zenoh said.
        reason: String,
    },
    /// A key could not be declared.
    #[error("cannot declare the Zenoh key of {what}: {reason}")]
    Zenoh {
        /// The channel or key.
        what: String,
        /// What Zenoh said.
        reason: String,
    },
    /// A channel could not be opened.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// A thread or socket could not be made.
    #[error("cannot start the bridge's thread: {0}")]
    Thread(std::io::Error),
}

impl BridgeError {
    /// The error of a Zenoh declaration of `what` (a channel, a key) that failed.
    pub(crate) fn zenoh(what: &str) -> impl FnOnce(zenoh::Error) -> Self + '_ {
        move |e| Self::Zenoh {
            what: what.to_owned(),
            reason: e.to_string(),
        }
    }
}
