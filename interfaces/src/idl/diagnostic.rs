//! Errors in interface definitions, each pointing at a file, line and column: the one
//! diagnostic of Lewis ([`lewis_stdx::Diagnostic`]), labelled `error:`.

pub use lewis_stdx::{Diagnostic, Diagnostics, Position};

/// The one did-you-mean of Lewis.
pub(super) use lewis_stdx::closest;
