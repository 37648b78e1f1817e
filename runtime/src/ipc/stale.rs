//! A namespace's leftovers from runs that died: removed before a robot starts in it.
//!
//! A process killed while it creates a channel (the demo kills the laser again after every
//! restart, sometimes in the middle of its start) leaves that channel half made; iceoryx2
//! then refuses it to every later process (`HangsInCreation`), and cleaning the dead nodes
//! does not remove it. So when no process of the namespace is alive, everything under its
//! prefix is left over and is removed: iceoryx2's files (`/tmp/iceoryx2`) and its shared
//! memory (`/dev/shm`). While any node of the namespace lives, nothing is touched.
//!
//! A process may be joining the namespace at the moment it is looked at (a test or a tool
//! opening its node while `lewis up` starts): its node is not yet alive, so it is not seen,
//! yet its files are being written. Entries changed in the last [`JOINING`] are therefore
//! left alone: a leftover is older than that.

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use iceoryx2::node::{Node, NodeState};
use iceoryx2::prelude::{CallbackProgression, ipc};

use super::Namespace;

/// Where iceoryx2 keeps its files and its shared memory on Linux.
pub(super) const ROOTS: [&str; 2] = ["/tmp/iceoryx2", "/dev/shm"];

/// How recently changed an entry must be to belong to a process joining right now.
const JOINING: Duration = Duration::from_secs(1);

/// What [`wipe_stale`] did.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct WipeReport {
    /// Files and folders of the namespace removed.
    pub removed: usize,
    /// Whether a live process of the namespace kept it untouched.
    pub in_use: bool,
}

/// Removes what dead runs left in `namespace`, unless one of its processes lives, and says
/// how much it removed when it removed anything.
#[must_use]
pub fn wipe_stale(namespace: &Namespace) -> WipeReport {
    let report = wipe_stale_under(namespace, &ROOTS.map(PathBuf::from));
    if report.removed > 0 {
        tracing::info!(
            "removed {} leftovers of earlier runs in namespace {namespace}",
            report.removed
        );
    }
    report
}

/// Removes everything of `namespace` once the run that owned it has ended (every process
/// of it stopped), unless one of its processes still lives: a run leaves nothing behind in
/// `/dev/shm` or `/tmp/iceoryx2`. Unlike [`wipe_stale`] it keeps no recent entries for a
/// process joining: nothing joins a run that has ended, and its last files are seconds old.
#[must_use]
pub fn wipe_ended(namespace: &Namespace) -> WipeReport {
    let report = wipe_under(namespace, &ROOTS.map(PathBuf::from), Duration::ZERO);
    tracing::debug!("the run's namespace {namespace} wiped: {report:?}");
    report
}

pub(super) fn wipe_stale_under(namespace: &Namespace, roots: &[PathBuf]) -> WipeReport {
    wipe_under(namespace, roots, JOINING)
}

/// Removes `namespace`'s entries under `roots` changed more than `joining` ago, unless a
/// node of the namespace lives.
fn wipe_under(namespace: &Namespace, roots: &[PathBuf], joining: Duration) -> WipeReport {
    let Ok(config) = namespace.iceoryx2_config() else {
        return WipeReport::default();
    };
    // Taken before the nodes are listed: a node made after this is never mistaken for a
    // leftover, whether or not the listing saw it.
    let young_from = ago(joining);
    let mut in_use = false;
    let listed = Node::<ipc::Service>::list(&config, |state| {
        // Only a live process holds its node's lock. A node whose files are incomplete was
        // most likely killed while it was made (and stays so): it does not count.
        in_use |= matches!(state, NodeState::Alive(_));
        CallbackProgression::Continue
    });
    if in_use || listed.is_err() {
        return WipeReport {
            removed: 0,
            in_use: true,
        };
    }
    let prefix = namespace.iceoryx2_prefix();
    let removed = roots
        .iter()
        .map(|root| remove_prefixed(root, &prefix, young_from))
        .sum();
    WipeReport {
        removed,
        in_use: false,
    }
}

/// Where iceoryx2 keeps the static configuration of each service (channel).
pub(super) const SERVICES: &str = "/tmp/iceoryx2/services";

/// How long a channel may stay half made before it counts as abandoned: its maker writes
/// and finalises it within milliseconds.
const ABANDONED: Duration = Duration::from_secs(1);

/// Removes the channels of `namespace` that a process killed while it made them left
/// half made, and returns how many went.
///
/// iceoryx2 writes a channel's static configuration with its owner's write permission
/// and drops that permission once the channel is whole; a file still writable long after
/// it was last changed was abandoned, and iceoryx2 refuses the channel to every later
/// process (`HangsInCreation`) until it goes. The broker calls this before it starts a
/// service, so that a service killed during its start (by a fault, or the demo) can be
/// started again later; the channel's shared memory goes with it.
#[must_use]
pub fn remove_abandoned_channels(namespace: &Namespace) -> usize {
    remove_abandoned_under(
        namespace,
        Path::new(SERVICES),
        &ROOTS.map(PathBuf::from),
        ago(ABANDONED),
    )
}

/// Removes the shared memory of `namespace` that a process killed while it made it left
/// empty (created, never sized), and returns how many went.
///
/// iceoryx2's cleanup of a dead node opens each of the node's connections, and it waits
/// without end for an empty one to be sized: a cleanup pass after a laser killed at that
/// moment never ended, and nothing after it was cleaned. A memory still empty long after
/// it was made was abandoned; once it is gone the open fails and the cleanup goes on.
#[must_use]
pub fn remove_abandoned_memory(namespace: &Namespace) -> usize {
    remove_empty_under(namespace, Path::new(ROOTS[1]), ago(ABANDONED))
}

fn remove_empty_under(namespace: &Namespace, shm: &Path, before: SystemTime) -> usize {
    let mut removed = 0;
    for (entry, _, metadata) in entries_of(shm, &namespace.iceoryx2_prefix()) {
        let abandoned = metadata.modified().is_ok_and(|changed| changed < before);
        if metadata.is_file()
            && metadata.len() == 0
            && abandoned
            && std::fs::remove_file(entry.path()).is_ok()
        {
            removed += 1;
            tracing::info!(
                "removed shared memory {}, left empty by a process killed while it made it",
                entry.file_name().to_string_lossy()
            );
        }
    }
    removed
}

/// The entries of `dir` whose names start with `prefix`: each with the rest of its name
/// and its metadata (an entry whose metadata cannot be read is left out).
fn entries_of(dir: &Path, prefix: &str) -> Vec<(std::fs::DirEntry, String, std::fs::Metadata)> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    entries
        .flatten()
        .filter_map(|entry| {
            let rest = entry
                .file_name()
                .to_string_lossy()
                .strip_prefix(prefix)?
                .to_owned();
            let metadata = entry.metadata().ok()?;
            Some((entry, rest, metadata))
        })
        .collect()
}

/// The moment `age` ago: entries changed since are taken as a live process's.
fn ago(age: Duration) -> SystemTime {
    SystemTime::now()
        .checked_sub(age)
        .unwrap_or(SystemTime::UNIX_EPOCH)
}

fn remove_abandoned_under(
    namespace: &Namespace,
    services: &Path,
    roots: &[PathBuf],
    before: SystemTime,
) -> usize {
    use std::os::unix::fs::PermissionsExt as _;

    let prefix = namespace.iceoryx2_prefix();
    let mut removed = 0;
    for (entry, rest, metadata) in entries_of(services, &prefix) {
        let Some(stem) = rest.strip_suffix(".service") else {
            continue;
        };
        let unfinished = metadata.permissions().mode() & 0o222 != 0;
        let abandoned = metadata.modified().is_ok_and(|changed| changed < before);
        if !(metadata.is_file() && unfinished && abandoned) {
            continue;
        }
        if std::fs::remove_file(entry.path()).is_ok() {
            removed += 1;
            tracing::info!(
                "removed channel {stem} of namespace {namespace}, left half made by a killed process"
            );
            let own = format!("{prefix}{stem}");
            removed += roots
                .iter()
                .map(|root| remove_prefixed(root, &own, before))
                .sum::<usize>();
        }
    }
    removed
}

/// Removes every entry under `dir` whose name starts with `prefix` and which was last
/// changed before `young_from`, and every folder left empty by that; returns how many
/// entries went.
fn remove_prefixed(dir: &Path, prefix: &str, young_from: SystemTime) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        let ours = name.to_string_lossy().starts_with(prefix);
        let is_dir = entry.file_type().is_ok_and(|t| t.is_dir());
        // An entry whose age cannot be read counts as young: keeping a leftover is the
        // safe mistake.
        let old = entry
            .metadata()
            .and_then(|m| m.modified())
            .is_ok_and(|changed| changed < young_from);
        if ours && !old {
            continue;
        }
        if ours {
            let gone = if is_dir {
                std::fs::remove_dir_all(&path)
            } else {
                std::fs::remove_file(&path)
            };
            removed += usize::from(gone.is_ok());
        } else if is_dir {
            let inner = remove_prefixed(&path, prefix, young_from);
            removed += inner;
            // A node's folder holds only that node's files: gone with them.
            if inner > 0 && std::fs::read_dir(&path).is_ok_and(|mut d| d.next().is_none()) {
                let _ = std::fs::remove_dir(&path);
            }
        }
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leftovers_of_a_dead_namespace_go_and_other_namespaces_stay() {
        let namespace = Namespace::unique("wipe");
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let prefix = namespace.iceoryx2_prefix();
        let node = dir.path().join("nodes").join("1234");
        std::fs::create_dir_all(&node).unwrap_or_else(|e| panic!("{e}"));
        let ours = [
            dir.path().join(format!("{prefix}abc.event")),
            node.join(format!("{prefix}def.service_tag")),
        ];
        let theirs = dir.path().join("lewis.other.abc.event");
        for file in ours.iter().chain([&theirs]) {
            write_old(file);
        }
        let report = wipe_stale_under(&namespace, &[dir.path().to_path_buf()]);
        assert_eq!(
            report,
            WipeReport {
                removed: 2,
                in_use: false
            }
        );
        assert!(ours.iter().all(|f| !f.exists()));
        assert!(!node.exists(), "the emptied node folder goes too");
        assert!(theirs.exists());
    }

    /// Writes an empty file last changed a minute ago: a leftover of a run that died.
    fn write_old(path: &Path) {
        let file = std::fs::File::create(path).unwrap_or_else(|e| panic!("{e}"));
        let minute_ago = SystemTime::now() - Duration::from_secs(60);
        file.set_modified(minute_ago)
            .unwrap_or_else(|e| panic!("{e}"));
    }

    #[test]
    fn files_of_a_process_joining_now_stay_while_old_ones_go() {
        let namespace = Namespace::unique("wipe-joining");
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let prefix = namespace.iceoryx2_prefix();
        let old = dir.path().join(format!("{prefix}old.event"));
        let joining = dir.path().join(format!("{prefix}new.event"));
        write_old(&old);
        std::fs::write(&joining, b"").unwrap_or_else(|e| panic!("{e}"));
        let report = wipe_stale_under(&namespace, &[dir.path().to_path_buf()]);
        assert_eq!(report.removed, 1);
        assert!(!old.exists());
        assert!(
            joining.exists(),
            "a file just written belongs to a live process"
        );
    }

    /// Writes a channel's static configuration, whole (read-only) or half made, last
    /// changed a minute ago unless `young`.
    fn write_channel(path: &Path, whole: bool, young: bool) {
        use std::os::unix::fs::PermissionsExt as _;
        if young {
            std::fs::write(path, b"config").unwrap_or_else(|e| panic!("{e}"));
        } else {
            write_old(path);
        }
        let mode = if whole { 0o400 } else { 0o600 };
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
            .unwrap_or_else(|e| panic!("{e}"));
    }

    #[test]
    fn only_old_empty_memory_of_the_namespace_is_removed() {
        let namespace = Namespace::unique("empty-memory");
        let other = Namespace::unique("empty-memory-other");
        let shm = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let prefix = namespace.iceoryx2_prefix();
        let abandoned = shm.path().join(format!("{prefix}aaaa.connection"));
        let sized = shm.path().join(format!("{prefix}bbbb.connection"));
        let being_made = shm.path().join(format!("{prefix}cccc.connection"));
        let theirs = shm
            .path()
            .join(format!("{}dddd.connection", other.iceoryx2_prefix()));
        write_old(&abandoned);
        write_old(&theirs);
        std::fs::write(&being_made, b"").unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(&sized, b"memory").unwrap_or_else(|e| panic!("{e}"));
        let minute_ago = SystemTime::now() - Duration::from_secs(60);
        std::fs::File::options()
            .write(true)
            .open(&sized)
            .and_then(|f| f.set_modified(minute_ago))
            .unwrap_or_else(|e| panic!("{e}"));
        let removed = remove_empty_under(&namespace, shm.path(), SystemTime::now() - JOINING);
        assert_eq!(removed, 1);
        assert!(!abandoned.exists());
        assert!(sized.exists(), "memory in use has a size");
        assert!(being_made.exists(), "memory being made now stays");
        assert!(theirs.exists(), "another namespace's memory stays");
    }

    #[test]
    fn only_channels_abandoned_half_made_are_removed_with_their_memory() {
        let namespace = Namespace::unique("abandoned");
        let other = Namespace::unique("abandoned-other");
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let services = dir.path().join("services");
        let shm = dir.path().join("shm");
        for folder in [&services, &shm] {
            std::fs::create_dir_all(folder).unwrap_or_else(|e| panic!("{e}"));
        }
        let prefix = namespace.iceoryx2_prefix();
        let abandoned = services.join(format!("{prefix}aaaa.service"));
        let memory = shm.join(format!("{prefix}aaaa.dynamic"));
        let whole = services.join(format!("{prefix}bbbb.service"));
        let being_made = services.join(format!("{prefix}cccc.service"));
        let theirs = services.join(format!("{}dddd.service", other.iceoryx2_prefix()));
        write_channel(&abandoned, false, false);
        write_old(&memory);
        write_channel(&whole, true, false);
        write_channel(&being_made, false, true);
        write_channel(&theirs, false, false);
        let before = SystemTime::now() - JOINING;
        let removed =
            remove_abandoned_under(&namespace, &services, std::slice::from_ref(&shm), before);
        assert_eq!(removed, 2);
        assert!(!abandoned.exists() && !memory.exists());
        assert!(whole.exists(), "a whole channel stays");
        assert!(being_made.exists(), "a channel being made now stays");
        assert!(theirs.exists(), "another namespace's channel stays");
    }

    #[test]
    fn a_namespace_with_a_live_process_is_left_alone() {
        let namespace = Namespace::unique("wipe-live");
        let _ipc = super::super::Ipc::open(&namespace, "alive").unwrap_or_else(|e| panic!("{e}"));
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let file = dir
            .path()
            .join(format!("{}abc.event", namespace.iceoryx2_prefix()));
        std::fs::write(&file, b"").unwrap_or_else(|e| panic!("{e}"));
        let report = wipe_stale_under(&namespace, &[dir.path().to_path_buf()]);
        assert!(report.in_use);
        assert!(file.exists());
    }
}
