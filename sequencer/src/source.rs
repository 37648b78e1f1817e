//! Where script text comes from: the file system, or memory for tests and fuzzing.

use std::collections::BTreeMap;
use std::io::{self, Read};
use std::path::{Component, Path, PathBuf};

/// The largest script file read; anything larger is surely not a script.
pub const MAX_SCRIPT_BYTES: u64 = 1 << 20;

/// A file's text and the identity that tells whether two paths are the same file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LoadedSource {
    /// The same for every path that reaches this file (the canonical path on disk).
    pub identity: PathBuf,
    /// The file's text.
    pub text: String,
}

/// Reads script files, so the parser can run on disk or on files held in memory.
pub trait SourceLoader {
    /// Reads the script at `path`.
    ///
    /// # Errors
    /// When the file cannot be read as UTF-8 text of at most [`MAX_SCRIPT_BYTES`].
    fn load(&self, path: &Path) -> io::Result<LoadedSource>;
}

/// Reads scripts from the file system.
#[derive(Debug, Clone, Copy, Default)]
pub struct FileSystem;

impl SourceLoader for FileSystem {
    fn load(&self, path: &Path) -> io::Result<LoadedSource> {
        let identity = path.canonicalize()?;
        let file = std::fs::File::open(&identity)?;
        if file.metadata()?.is_dir() {
            return Err(io::Error::other("it is a folder"));
        }
        let mut text = String::new();
        // `take` bounds reads of endless files such as `/dev/zero`.
        file.take(MAX_SCRIPT_BYTES + 1).read_to_string(&mut text)?;
        if text.len() as u64 > MAX_SCRIPT_BYTES {
            return Err(io::Error::other(format!(
                "it is larger than {MAX_SCRIPT_BYTES} bytes"
            )));
        }
        Ok(LoadedSource { identity, text })
    }
}

/// Scripts held in memory, by path; paths are compared after removing `.` and `..`.
#[derive(Debug, Clone, Default)]
pub struct MemorySources {
    files: BTreeMap<PathBuf, String>,
}

impl MemorySources {
    /// No files.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds (or replaces) the file at `path`.
    #[must_use]
    pub fn with(mut self, path: impl AsRef<Path>, text: impl Into<String>) -> Self {
        self.insert(path, text);
        self
    }

    /// Adds (or replaces) the file at `path`.
    pub fn insert(&mut self, path: impl AsRef<Path>, text: impl Into<String>) {
        self.files.insert(normalize(path.as_ref()), text.into());
    }
}

impl SourceLoader for MemorySources {
    fn load(&self, path: &Path) -> io::Result<LoadedSource> {
        let identity = normalize(path);
        match self.files.get(&identity) {
            Some(text) => Ok(LoadedSource {
                identity,
                text: text.clone(),
            }),
            None => Err(io::Error::from(io::ErrorKind::NotFound)),
        }
    }
}

/// `path` without `.` components and with `..` applied where it can be.
fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for component in path.components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir => {
                if matches!(out.components().next_back(), Some(Component::Normal(_))) {
                    out.pop();
                } else {
                    out.push("..");
                }
            }
            other => out.push(other),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_paths_are_compared_after_normalising() {
        let sources = MemorySources::new().with("missions/a.seq", "start x");
        let loaded = sources.load(Path::new("./missions/sub/../a.seq")).unwrap();
        assert_eq!(loaded.identity, PathBuf::from("missions/a.seq"));
        assert_eq!(loaded.text, "start x");
        let missing = sources.load(Path::new("b.seq")).unwrap_err();
        assert_eq!(missing.kind(), io::ErrorKind::NotFound);
    }

    #[test]
    fn the_file_system_refuses_folders_and_oversized_files() {
        let dir = tempfile::tempdir().unwrap();
        let error = FileSystem.load(dir.path()).unwrap_err();
        assert_eq!(error.to_string(), "it is a folder");

        let big = dir.path().join("big.seq");
        std::fs::write(&big, vec![b'#'; (MAX_SCRIPT_BYTES + 1) as usize]).unwrap();
        let error = FileSystem.load(&big).unwrap_err();
        assert_eq!(
            error.to_string(),
            format!("it is larger than {MAX_SCRIPT_BYTES} bytes")
        );
    }
}
