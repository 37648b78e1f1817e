//! The namespaces of runs that have ended, found by the process id in their names and
//! wiped, so that `/dev/shm` does not fill up run after run.
//!
//! Every test makes namespaces of its own ([`Namespace::unique`]: `TAG-PID-COUNT-HEX`), and
//! nothing removes them when the test process ends, killed or not: `lewis up` wipes only
//! the namespace it starts in. The process that made a namespace is not the only one that
//! may use it, though: a `lewis up` it started may outlive it. So the maker's death only
//! picks the namespaces to look at, and each is wiped by [`wipe_stale`], which leaves
//! alone a namespace with a live node; a namespace whose maker still runs (another test
//! executable running now) is not looked at.
//!
//! [`wipe_stale`]: super::wipe_stale

use std::collections::BTreeSet;
use std::path::PathBuf;

use nix::sys::signal::kill;
use nix::unistd::Pid;

use super::Namespace;
use super::stale::{ROOTS, SERVICES, wipe_stale_under};

/// What [`wipe_orphaned_namespaces`] did.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct OrphanReport {
    /// Namespaces whose maker had ended and whose leftovers were removed.
    pub wiped: usize,
    /// Namespaces whose maker had ended but which a live process still uses.
    pub in_use: usize,
    /// Files and folders removed, all namespaces together.
    pub removed: usize,
}

/// Removes what the namespaces made by [`Namespace::unique`] in processes that have since
/// ended left in `/dev/shm` and `/tmp/iceoryx2` (iceoryx2's files and the publication
/// ledgers), except in a namespace some live process still uses: for test harnesses, once
/// per run, so that each run cleans up after the runs before it.
///
/// Costs a few directory listings (one per node folder) when there is nothing to remove.
/// Namespaces of other shapes (`default`, a robot's) are never touched: their leftovers are
/// wiped by the `lewis up` that starts in them next.
#[must_use]
pub fn wipe_orphaned_namespaces() -> OrphanReport {
    let roots = ROOTS.map(PathBuf::from);
    // The services folder and each node's too: a channel's static configuration, or the
    // tags a node left of its ports, may be all that is left of a namespace.
    let nodes = std::fs::read_dir(NODES)
        .into_iter()
        .flatten()
        .flatten()
        .map(|entry| entry.path())
        .filter(|path| path.is_dir());
    let listed: Vec<PathBuf> = roots
        .iter()
        .cloned()
        .chain([SERVICES.into(), NODES.into()])
        .chain(nodes)
        .collect();
    wipe_orphaned_under(&listed, &roots)
}

/// Where iceoryx2 keeps a folder of files for each node.
const NODES: &str = "/tmp/iceoryx2/nodes";

/// As [`wipe_orphaned_namespaces`], finding namespaces in the entries of `listed` and
/// removing their leftovers under `roots`.
fn wipe_orphaned_under(listed: &[PathBuf], roots: &[PathBuf]) -> OrphanReport {
    let mut report = OrphanReport::default();
    for namespace in namespaces_in(listed) {
        if namespace.unique_maker().is_none_or(is_running) {
            continue;
        }
        let wiped = wipe_stale_under(&namespace, roots);
        if wiped.in_use {
            report.in_use += 1;
        } else {
            report.wiped += 1;
            report.removed += wiped.removed;
        }
    }
    if report.removed > 0 {
        tracing::info!(
            "removed {} leftovers of {} namespaces whose runs have ended",
            report.removed,
            report.wiped
        );
    }
    report
}

/// The namespaces that own an entry of one of `dirs`, each once.
fn namespaces_in(dirs: &[PathBuf]) -> BTreeSet<Namespace> {
    dirs.iter()
        .filter_map(|dir| std::fs::read_dir(dir).ok())
        .flatten()
        .flatten()
        .filter_map(|entry| Namespace::of_file_name(entry.file_name().to_str()?))
        .collect()
}

/// Whether a process `pid` exists. One that cannot be asked (another user's) counts as
/// running, and so does a zombie: keeping a namespace is the safe mistake.
fn is_running(pid: u32) -> bool {
    // 0 or a negative number would ask about process groups, not one process; no process
    // has an id beyond `i32`.
    match i32::try_from(pid) {
        Ok(pid) if pid > 0 => !matches!(kill(Pid::from_raw(pid), None), Err(nix::Error::ESRCH)),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;
    use std::time::{Duration, SystemTime};

    use super::*;

    /// Sets `path`'s last change a minute back: a leftover of a run that ended.
    fn age(path: &Path) {
        let minute_ago = SystemTime::now() - Duration::from_secs(60);
        std::fs::File::open(path)
            .and_then(|f| f.set_modified(minute_ago))
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }

    /// Makes `name` under `root` as a run leaves it: a ledger folder with a ledger in it
    /// for a name ending in `ledgers`, else an empty file; returns its path.
    fn leave(root: &Path, name: &str) -> PathBuf {
        let path = root.join(name);
        if name.ends_with(".ledgers") {
            std::fs::create_dir(&path).unwrap_or_else(|e| panic!("{e}"));
            let ledger = path.join("4242.0");
            std::fs::write(&ledger, b"LWLEDG01").unwrap_or_else(|e| panic!("{e}"));
            age(&ledger);
        } else {
            std::fs::write(&path, b"").unwrap_or_else(|e| panic!("{e}"));
        }
        age(&path);
        path
    }

    /// A process id no process can have: above the kernel's largest.
    fn dead_pid() -> u32 {
        let pid_max = std::fs::read_to_string("/proc/sys/kernel/pid_max")
            .ok()
            .and_then(|s| s.trim().parse::<u32>().ok())
            // The largest the kernel allows (`PID_MAX_LIMIT` on 64-bit).
            .unwrap_or(1 << 22);
        pid_max + 1
    }

    #[test]
    fn only_namespaces_whose_maker_has_ended_are_wiped() {
        let root = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let root = root.path();
        let pid = dead_pid();
        assert!(!is_running(pid), "pid {pid} is above pid_max");
        let dead =
            Namespace::new(&format!("orphan-{pid}-3-1f2e")).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(dead.unique_maker(), Some(pid));
        let live = Namespace::unique("orphan-live");
        assert!(is_running(std::process::id()));

        let gone = [
            leave(root, &format!("{}ledgers", dead.iceoryx2_prefix())),
            leave(
                root,
                &format!("{}9204dd18_node.0_10_0.global_mgmt", dead.iceoryx2_prefix()),
            ),
        ];
        let kept = [
            leave(root, &format!("{}ledgers", live.iceoryx2_prefix())),
            leave(root, &format!("{}abc.event", live.iceoryx2_prefix())),
            leave(root, "lewis.default.ledgers"),
            leave(root, "lewis.default.abc.event"),
            // Names of no namespace, or of no unique one: looked at, never touched.
            leave(root, &format!("lewis.orphan-{pid}-3-1f2e")),
            leave(root, &format!("lewis.orphan-{pid}-x-1f2e.abc")),
            leave(root, "lewis.orphan-0-3-1f2e.abc"),
            leave(root, "lewis..abc"),
            leave(root, "lewis."),
            leave(root, &format!("other.orphan-{pid}-3-1f2e.abc")),
        ];
        let listed = [root.to_path_buf()];

        let report = wipe_orphaned_under(&listed, &listed);

        assert_eq!(
            report,
            OrphanReport {
                wiped: 1,
                in_use: 0,
                removed: 2
            }
        );
        for path in &gone {
            assert!(!path.exists(), "{} is removed", path.display());
        }
        for path in &kept {
            assert!(path.exists(), "{} is kept", path.display());
        }
        assert!(
            kept[0].join("4242.0").exists(),
            "a live maker's ledgers stay"
        );
    }

    #[test]
    fn only_a_real_process_id_is_asked_about() {
        assert!(is_running(std::process::id()));
        assert!(!is_running(0), "0 would be this process's group");
        assert!(!is_running(u32::MAX), "-1 would be every process");
    }
}
