//! Finding the runs under the paths given: recordings (`.mcap`) and other robot software's
//! logs (`.log`, `.log.gz`), in folders searched whole, in a stable order.

use std::path::{Path, PathBuf};

/// The files under `path` that may be runs, sorted; `exclude` (the plan's folder, which
/// holds imports and replays) is never searched. A replay's output (`*.replay.mcap`) is
/// not a run.
///
/// # Errors
/// Why `path` cannot be searched (it does not exist, a folder cannot be read), for people.
pub fn find(path: &Path, exclude: &Path) -> Result<Vec<PathBuf>, String> {
    let meta = std::fs::metadata(path).map_err(|e| format!("cannot be read: {e}"))?;
    if meta.is_file() {
        return Ok(vec![path.to_path_buf()]);
    }
    let mut found = Vec::new();
    walk(path, same_file_key(exclude).as_deref(), &mut found)?;
    found.sort();
    Ok(found)
}

fn same_file_key(path: &Path) -> Option<PathBuf> {
    std::fs::canonicalize(path).ok()
}

fn walk(dir: &Path, exclude: Option<&Path>, found: &mut Vec<PathBuf>) -> Result<(), String> {
    if exclude.is_some() && same_file_key(dir).as_deref() == exclude {
        return Ok(());
    }
    let entries =
        std::fs::read_dir(dir).map_err(|e| format!("{} cannot be read: {e}", dir.display()))?;
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for path in paths {
        if path.is_dir() {
            walk(&path, exclude, found)?;
        } else if is_run(&path) {
            found.push(path);
        }
    }
    Ok(())
}

/// Whether a file's name says it may be a run.
fn is_run(path: &Path) -> bool {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    (name.ends_with(".mcap") && !name.ends_with(".replay.mcap"))
        || name.ends_with(".log")
        || name.ends_with(".log.gz")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recordings_and_logs_are_found_in_order_and_the_plan_folder_is_not_searched() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let root = dir.path();
        for file in [
            "b.mcap",
            "a/run.mcap",
            "a/run.replay.mcap",
            "a/notes.txt",
            "c.log.gz",
            "out/imported/x.mcap",
        ] {
            let path = root.join(file);
            std::fs::create_dir_all(path.parent().unwrap_or(root)).unwrap_or_default();
            std::fs::write(&path, "").unwrap_or_default();
        }
        let found = find(root, &root.join("out")).unwrap_or_default();
        let names: Vec<String> = found
            .iter()
            .map(|p| p.strip_prefix(root).unwrap_or(p).display().to_string())
            .collect();
        assert_eq!(names, ["a/run.mcap", "b.mcap", "c.log.gz"]);
        assert!(find(&root.join("nowhere"), root).is_err());
    }
}
