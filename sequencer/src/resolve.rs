//! Finding the program of a state: a path relative to the script's folder when it has a
//! `/`, otherwise a name looked up in `PATH`, as `execvp` would.
//!
//! Resolution is behind [`ProgramResolver`] so the checker can be tested without depending
//! on what is installed, and so a recorded mission can be re-checked on another machine.

use std::path::{Path, PathBuf};

/// Why a program cannot be run.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ResolveError {
    /// Nothing by that name where it was looked for.
    #[error("not found")]
    NotFound {
        /// The places looked at: the path itself, or the folders of `PATH`.
        searched: Vec<PathBuf>,
    },
    /// The file exists but has no execute permission.
    #[error("`{}` is not executable", path.display())]
    NotExecutable {
        /// The file.
        path: PathBuf,
    },
    /// The path names a folder.
    #[error("`{}` is a folder", path.display())]
    IsFolder {
        /// The folder.
        path: PathBuf,
    },
}

/// Turns a program as written in a script into the path to execute.
pub trait ProgramResolver {
    /// Resolves `program`, written in a script file that lives in `folder`.
    ///
    /// # Errors
    /// When there is no executable file to run.
    fn resolve(&self, program: &str, folder: &Path) -> Result<PathBuf, ResolveError>;
}

impl<F> ProgramResolver for F
where
    F: Fn(&str, &Path) -> Result<PathBuf, ResolveError>,
{
    fn resolve(&self, program: &str, folder: &Path) -> Result<PathBuf, ResolveError> {
        self(program, folder)
    }
}

/// Resolves programs on this machine's file system, to absolute paths.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SystemResolver {
    search_path: Vec<PathBuf>,
}

impl SystemResolver {
    /// Looks names up in the folders of the `PATH` environment variable.
    #[must_use]
    pub fn from_env() -> Self {
        let search_path = std::env::var_os("PATH")
            .map(|path| std::env::split_paths(&path).collect())
            .unwrap_or_default();
        Self::with_search_path(search_path)
    }

    /// Looks names up in `folders`, in order (an empty entry is the current folder, as in
    /// `PATH`).
    #[must_use]
    pub fn with_search_path(folders: Vec<PathBuf>) -> Self {
        let search_path = folders
            .into_iter()
            .map(|f| {
                if f.as_os_str().is_empty() {
                    PathBuf::from(".")
                } else {
                    f
                }
            })
            .collect();
        Self { search_path }
    }
}

impl ProgramResolver for SystemResolver {
    fn resolve(&self, program: &str, folder: &Path) -> Result<PathBuf, ResolveError> {
        if program.contains('/') {
            let path = folder.join(program);
            inspect(&path)?;
            return Ok(std::path::absolute(&path).unwrap_or(path));
        }
        let mut not_executable = None;
        for dir in &self.search_path {
            let candidate = dir.join(program);
            match inspect(&candidate) {
                Ok(()) => return Ok(std::path::absolute(&candidate).unwrap_or(candidate)),
                // Like `execvp`, go on looking, but report this one if nothing else is found.
                Err(error @ ResolveError::NotExecutable { .. }) => {
                    not_executable.get_or_insert(error);
                }
                Err(_) => {}
            }
        }
        Err(not_executable.unwrap_or_else(|| ResolveError::NotFound {
            searched: self.search_path.clone(),
        }))
    }
}

/// Checks that `path` is an executable file.
fn inspect(path: &Path) -> Result<(), ResolveError> {
    let metadata = std::fs::metadata(path).map_err(|_| ResolveError::NotFound {
        searched: vec![path.to_owned()],
    })?;
    if metadata.is_dir() {
        return Err(ResolveError::IsFolder {
            path: path.to_owned(),
        });
    }
    if !is_executable(&metadata) {
        return Err(ResolveError::NotExecutable {
            path: path.to_owned(),
        });
    }
    Ok(())
}

#[cfg(unix)]
fn is_executable(metadata: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::PermissionsExt;
    metadata.permissions().mode() & 0o111 != 0
}

#[cfg(not(unix))]
fn is_executable(_metadata: &std::fs::Metadata) -> bool {
    true
}

/// Resolves programs without looking at the disk: paths with a `/` are joined to the
/// script's folder, names are kept for `PATH` lookup when run. For re-deciding a recorded
/// mission where the programs are not installed, and for tests of the FSM.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TrustingResolver;

impl ProgramResolver for TrustingResolver {
    fn resolve(&self, program: &str, folder: &Path) -> Result<PathBuf, ResolveError> {
        if program.contains('/') {
            Ok(folder.join(program))
        } else {
            Ok(PathBuf::from(program))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    fn file(path: &Path, mode: u32) {
        std::fs::write(path, "#!/bin/sh\n").unwrap();
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
    }

    #[test]
    fn a_path_with_a_slash_is_relative_to_the_script_folder() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("bin")).unwrap();
        file(&dir.path().join("bin/door"), 0o755);
        let resolver = SystemResolver::with_search_path(vec![]);
        assert_eq!(
            resolver.resolve("bin/door", dir.path()),
            Ok(dir.path().join("bin/door"))
        );
        assert_eq!(
            resolver.resolve("bin/sign", dir.path()),
            Err(ResolveError::NotFound {
                searched: vec![dir.path().join("bin/sign")]
            })
        );
    }

    #[test]
    fn folders_and_files_without_execute_permission_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        file(&dir.path().join("plain"), 0o644);
        let resolver = SystemResolver::with_search_path(vec![]);
        assert_eq!(
            resolver.resolve("./plain", dir.path()),
            Err(ResolveError::NotExecutable {
                path: dir.path().join("./plain")
            })
        );
        assert_eq!(
            resolver.resolve("./", dir.path()),
            Err(ResolveError::IsFolder {
                path: dir.path().join("./")
            })
        );
    }

    #[test]
    fn a_bare_name_is_looked_up_in_the_search_path_in_order() {
        let dir = tempfile::tempdir().unwrap();
        let (first, second) = (dir.path().join("first"), dir.path().join("second"));
        std::fs::create_dir(&first).unwrap();
        std::fs::create_dir(&second).unwrap();
        file(&first.join("tool"), 0o644);
        file(&second.join("tool"), 0o755);
        let resolver = SystemResolver::with_search_path(vec![first.clone(), second.clone()]);
        assert_eq!(
            resolver.resolve("tool", Path::new("/elsewhere")),
            Ok(second.join("tool"))
        );

        let only_first = SystemResolver::with_search_path(vec![first.clone()]);
        assert_eq!(
            only_first.resolve("tool", Path::new("/elsewhere")),
            Err(ResolveError::NotExecutable {
                path: first.join("tool")
            })
        );
        assert_eq!(
            only_first.resolve("missing", Path::new("/elsewhere")),
            Err(ResolveError::NotFound {
                searched: vec![first]
            })
        );
    }
}
