//! A file written whole or not at all (`lewis import`, `lewis export`): written under a
//! temporary name beside its own, renamed to it once complete, removed on any failure, so
//! that nothing half-written is ever left under the output's name.

use std::path::{Path, PathBuf};

/// The finished file could not be moved to its name.
#[derive(Debug, thiserror::Error)]
#[error("cannot rename {} to {}: {source}", from.display(), to.display())]
pub struct RenameError {
    /// The temporary file.
    pub from: PathBuf,
    /// The output.
    pub to: PathBuf,
    /// Why.
    pub source: std::io::Error,
}

/// The temporary file written for `output`, beside it.
#[must_use]
pub fn temporary_path(output: &Path) -> PathBuf {
    let name = output
        .file_name()
        .map_or_else(|| "output".to_owned(), |f| f.to_string_lossy().into_owned());
    output.with_file_name(format!(".{name}.importing.mcap"))
}

/// Runs `write` on the temporary path of `output`, then renames its file to `output`.
///
/// # Errors
/// What `write` returns, or a [`RenameError`]; either way the temporary file is removed.
pub fn write_whole<T, E: From<RenameError>>(
    output: &Path,
    write: impl FnOnce(&Path) -> Result<T, E>,
) -> Result<T, E> {
    let temporary = temporary_path(output);
    // A temporary file left by a run that was killed is ours to replace.
    let _ = std::fs::remove_file(&temporary);
    let written = match write(&temporary) {
        Ok(written) => written,
        Err(e) => {
            let _ = std::fs::remove_file(&temporary);
            return Err(e);
        }
    };
    if let Err(source) = std::fs::rename(&temporary, output) {
        let _ = std::fs::remove_file(&temporary);
        return Err(RenameError {
            from: temporary,
            to: output.to_owned(),
            source,
        }
        .into());
    }
    Ok(written)
}
