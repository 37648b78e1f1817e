//! Reading definition files from disk.

use std::path::{Path, PathBuf};

use super::diagnostic::{Diagnostic, Diagnostics, Position};
use super::model::Idl;
use super::parse::parse_document;
use super::validate::{Parsed, validate};

/// Loads and validates every `*.xml` file of `dir` (not recursive), in name order.
///
/// # Errors
/// Every problem found, each with its file, line and column.
pub fn load_dir(dir: &Path) -> Result<Idl, Diagnostics> {
    let entries = std::fs::read_dir(dir).map_err(|err| {
        Diagnostics::from(Diagnostic::error(
            dir,
            Position::default(),
            format!("cannot read the folder: {err}"),
        ))
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml") && p.is_file())
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(
            Diagnostic::error(dir, Position::default(), "no .xml files in this folder")
                .with_hint("interface definitions are `NAME.xml` files beside a `types.xml`")
                .into(),
        );
    }
    load_files(&files)
}

/// Loads and validates the given definition files together.
///
/// # Errors
/// Every problem found, each with its file, line and column.
pub fn load_files(files: &[PathBuf]) -> Result<Idl, Diagnostics> {
    let mut sources = Vec::new();
    let mut errors = Vec::new();
    for file in files {
        match std::fs::read(file) {
            Ok(bytes) => match String::from_utf8(bytes) {
                Ok(text) => sources.push((file.clone(), text)),
                Err(err) => {
                    let offset = err.utf8_error().valid_up_to();
                    let valid =
                        String::from_utf8_lossy(err.as_bytes().get(..offset).unwrap_or_default())
                            .into_owned();
                    errors.push(Diagnostic::error(
                        file,
                        Position::of_offset(&valid, offset),
                        "the file is not valid UTF-8",
                    ));
                }
            },
            Err(err) => {
                errors.push(Diagnostic::error(
                    file,
                    Position::default(),
                    format!("cannot read the file: {err}"),
                ));
            }
        }
    }
    load_sources_with(&sources, errors)
}

/// Validates definitions given as text, each with the path it is known by (for
/// diagnostics, and to match `<types filename>` by file name).
///
/// # Errors
/// Every problem found, each with its file, line and column.
pub fn load_sources(sources: &[(PathBuf, String)]) -> Result<Idl, Diagnostics> {
    load_sources_with(sources, Vec::new())
}

fn load_sources_with(
    sources: &[(PathBuf, String)],
    mut errors: Vec<Diagnostic>,
) -> Result<Idl, Diagnostics> {
    let mut parsed = Vec::new();
    for (file, source) in sources {
        match parse_document(source, file) {
            Ok(document) => parsed.push(Parsed {
                file: file.clone(),
                source: source.clone(),
                document,
            }),
            Err(d) => errors.push(d),
        }
    }
    match validate(&parsed) {
        Ok(idl) if errors.is_empty() => Ok(idl),
        Ok(_) => {
            let mut d = Diagnostics(errors);
            d.sort();
            Err(d)
        }
        Err(mut more) => {
            more.0.extend(errors);
            more.sort();
            Err(more)
        }
    }
}
