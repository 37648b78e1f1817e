//! What a service is handed with each event: an input sample, a command, a reply.

use lewis_interfaces::cdr::{self, DecodeError};
use lewis_interfaces::msg::Header;
use lewis_interfaces::{Command, CommandDecodeError, CommandSet, Interface};

/// Identifies a [`Context::call`](super::Context::call), to match its reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct CallId(pub u64);

/// Why a sample or a reply could not be turned into the type asked for.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum InputError {
    /// The sample is of another interface than the type asked for.
    #[error("sample of {actual} decoded as {asked}: match on input.interface first")]
    WrongInterface {
        /// The interface of the sample.
        actual: String,
        /// The interface of the type asked for.
        asked: &'static str,
    },
    /// The bytes are not a valid message of that type.
    #[error("sample of {interface} from {provider} does not decode: {source}")]
    Decode {
        /// The interface.
        interface: String,
        /// Who sent it.
        provider: String,
        /// What is wrong.
        source: DecodeError,
    },
}

/// A sample of a required interface, as it arrived from its provider (the CDR bytes, not
/// yet decoded, so that a service that only forwards or counts pays nothing).
#[derive(Debug, Clone, Copy)]
pub struct Input<'a> {
    /// The interface.
    pub interface: &'a str,
    /// The service that provides it now.
    pub provider: &'a str,
    /// The channel it came on.
    pub channel: &'a str,
    /// The message, CDR-encoded.
    pub bytes: &'a [u8],
}

impl Input<'_> {
    /// Decodes the sample as the interface `T`.
    ///
    /// # Errors
    /// When the sample is of another interface or does not decode.
    pub fn decode<T: Interface>(&self) -> Result<T, InputError> {
        if self.interface != T::NAME {
            return Err(InputError::WrongInterface {
                actual: self.interface.to_owned(),
                asked: T::NAME,
            });
        }
        cdr::from_bytes(self.bytes).map_err(|source| InputError::Decode {
            interface: self.interface.to_owned(),
            provider: self.provider.to_owned(),
            source,
        })
    }

    /// The message's header alone (provider, sequence number, time, provenance).
    ///
    /// # Errors
    /// When the bytes do not start with a valid header.
    pub fn header(&self) -> Result<Header, DecodeError> {
        decode_header(self.bytes)
    }
}

/// Decodes the header at the start of a CDR message without decoding the rest (the header
/// is the first field of every message): interfaces' one header peek.
pub(crate) fn decode_header(bytes: &[u8]) -> Result<Header, DecodeError> {
    cdr::peek_header(bytes)
}

/// The header's sequence number of a CDR message, 0 when it has no valid header.
#[must_use]
pub fn decode_header_seq(bytes: &[u8]) -> u64 {
    decode_header(bytes).map_or(0, |h| h.seq)
}

/// A command sent to an interface this service provides.
#[derive(Debug, Clone, Copy)]
pub struct IncomingCommand<'a> {
    /// The interface it was sent to.
    pub interface: &'a str,
    /// The command's name.
    pub command: &'a str,
    /// The command message, CDR-encoded.
    pub bytes: &'a [u8],
}

impl IncomingCommand<'_> {
    /// Decodes the command as one of the commands of interface `T`.
    ///
    /// # Errors
    /// When it was sent to another interface, names no command of `T`, or does not decode.
    pub fn decode<T: Interface>(&self) -> Result<T::Command, CommandDecodeError> {
        if self.interface != T::NAME {
            return Err(CommandDecodeError::unknown::<T::Command>(&format!(
                "{}.{}",
                self.interface, self.command
            )));
        }
        <T::Command as CommandSet>::decode(self.command, self.bytes)
    }
}

/// The answer to a command, made by [`Context::reply`](super::Context::reply) (which fills
/// its header).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Reply {
    pub(crate) bytes: Vec<u8>,
}

impl Reply {
    /// The reply message, CDR-encoded.
    #[must_use]
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The reply message, CDR-encoded, taken out of the reply.
    #[must_use]
    pub fn into_bytes(self) -> Vec<u8> {
        self.bytes
    }
}

/// A command refused by the service that received it; the caller gets the text.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct CommandError(pub String);

impl CommandError {
    /// A refusal saying why.
    pub fn new(why: impl Into<String>) -> Self {
        Self(why.into())
    }
}

impl From<CommandDecodeError> for CommandError {
    fn from(e: CommandDecodeError) -> Self {
        Self(e.to_string())
    }
}

/// Why a call got no reply.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CallFailure {
    /// No reply within the call's timeout.
    #[error("no reply within {timeout_ns} ns")]
    Timeout {
        /// The timeout.
        timeout_ns: i64,
    },
    /// The interface has no provider now (not bound yet, or none left).
    #[error("{interface} has no provider now")]
    NoProvider {
        /// The interface.
        interface: String,
    },
    /// The service called an interface it does not require in the robot file.
    #[error("{interface} is not among the interfaces this service requires: add it to `requires`")]
    NotRequired {
        /// The interface.
        interface: String,
    },
    /// The provider refused the command.
    #[error("refused: {0}")]
    Refused(String),
    /// The IPC layer failed.
    #[error("{0}")]
    Transport(String),
}

/// The outcome of a [`Context::call`](super::Context::call).
#[derive(Debug, Clone)]
pub struct ReplyEvent<'a> {
    /// The call it answers.
    pub call: CallId,
    /// The interface called.
    pub interface: &'a str,
    /// The command called.
    pub command: &'a str,
    /// The reply message (CDR) or why there is none.
    pub result: Result<&'a [u8], CallFailure>,
}

impl ReplyEvent<'_> {
    /// Decodes the reply as the reply of command `C`.
    ///
    /// # Errors
    /// The call's failure, or a [`CallFailure::Transport`] when the reply does not decode
    /// as `C::Reply` (the reply is of another command).
    pub fn decode<C: Command>(&self) -> Result<C::Reply, CallFailure> {
        let bytes = self.result.clone()?;
        if self.command != C::NAME {
            return Err(CallFailure::Transport(format!(
                "reply to `{}` decoded as the reply to `{}`",
                self.command,
                C::NAME
            )));
        }
        cdr::from_bytes(bytes).map_err(|e| CallFailure::Transport(e.to_string()))
    }
}
