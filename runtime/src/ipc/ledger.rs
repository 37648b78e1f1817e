//! The publication ledger: how many samples each publisher of a process has sent, kept in
//! a small memory-mapped file that outlives the process.
//!
//! A subscriber sees a gap in a publisher's numbers only when a later sample arrives. The
//! samples a provider sent just before it was killed have no later sample: whatever was
//! still unread in the subscriber's buffer when the publisher's memory went is gone, and
//! nothing would say so. So every publisher notes its next sequence number in its process's
//! ledger with one atomic store per publication (stores to a shared file mapping survive
//! SIGKILL: they are already in the page cache). A reader (the recorder) looks at the
//! ledgers of processes that have died and compares what each publisher sent with what it
//! received ([`super::Subscriber::publisher_ended`]).
//!
//! One file per [`super::Ipc`], `PID.N` in a folder of the namespace's in `/dev/shm`
//! (`lewis.NS.ledgers/`): a reader lists only its namespace's ledgers, and the folder goes
//! with the rest of a dead namespace ([`super::wipe_stale`]). The layout, all
//! little-endian:
//!
//! | bytes | what |
//! |---|---|
//! | 0..8 | [`MAGIC`] |
//! | 64.. | [`SLOTS`] slots of [`SLOT_LEN`] bytes, one per publisher |
//!
//! A slot: `0..8` the length of its channel name, written last (0: unused); `8..16` the
//! publisher's next sequence number (the samples it sent, its first being 0); `16..32` the
//! publisher's id; `32..40` when the publisher was made (ns since 1970); `40..` the
//! channel's name.

use std::collections::HashSet;
use std::ffi::OsString;
use std::fs::OpenOptions;
use std::num::NonZeroUsize;
use std::os::fd::AsFd;
use std::path::{Path, PathBuf};
use std::ptr::NonNull;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

use nix::sys::mman::{MapFlags, ProtFlags, mmap, munmap};

use super::Namespace;
use crate::clock::wall_ns;

/// Where the ledgers' folders live: memory, not disk.
const ROOT: &str = "/dev/shm";
/// The first bytes of a ledger.
pub const MAGIC: [u8; 8] = *b"LWLEDG01";
/// The size of a ledger file: one page.
const FILE_LEN: usize = 4096;
/// Where the first slot starts.
const SLOTS_AT: usize = 64;
/// The size of one slot.
pub const SLOT_LEN: usize = 128;
/// Where a slot's channel name starts.
const NAME_AT: usize = 40;
/// The publishers one ledger holds; a process's further publishers are not noted (their
/// losses at a crash stay unseen, as before the ledger).
pub const SLOTS: usize = (FILE_LEN - SLOTS_AT) / SLOT_LEN;

/// The folder of `namespace`'s ledgers under `root`.
fn folder(root: &Path, namespace: &Namespace) -> PathBuf {
    root.join(format!("{}ledgers", namespace.iceoryx2_prefix()))
}

/// A ledger file, mapped for writing, shared by the publishers of one [`super::Ipc`].
#[derive(Debug)]
pub(crate) struct LedgerFile {
    map: NonNull<u8>,
    next_slot: Mutex<usize>,
}

// SAFETY: the mapping is only written through atomics (counters, slot claims) or, for a
// slot's id and name, by the one publisher that claimed the slot under `next_slot`'s lock
// before publishing its length; it lives until the last `Arc` goes.
unsafe impl Send for LedgerFile {}
// SAFETY: as above.
unsafe impl Sync for LedgerFile {}

impl Drop for LedgerFile {
    fn drop(&mut self) {
        // SAFETY: `map` is the start of a mapping of `FILE_LEN` bytes made in `create` and
        // not unmapped elsewhere; no slot outlives the file (each holds an `Arc` of it).
        let _ = unsafe { munmap(self.map.cast(), FILE_LEN) };
    }
}

impl LedgerFile {
    /// Creates this process's next ledger in `namespace`. `None` when it cannot (no
    /// `/dev/shm`): publishing goes on without one, its losses at a crash unseen.
    pub(crate) fn create(namespace: &Namespace) -> Option<Arc<Self>> {
        static FILES: AtomicUsize = AtomicUsize::new(0);
        let n = FILES.fetch_add(1, Ordering::Relaxed);
        let dir = folder(Path::new(ROOT), namespace);
        let path = dir.join(format!("{}.{n}", std::process::id()));
        match std::fs::create_dir_all(&dir).and_then(|()| Self::create_at(&path)) {
            Ok(file) => Some(Arc::new(file)),
            Err(e) => {
                tracing::debug!("no publication ledger at {}: {e}", path.display());
                None
            }
        }
    }

    fn create_at(path: &Path) -> std::io::Result<Self> {
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(path)?;
        file.set_len(FILE_LEN as u64)?;
        let len = NonZeroUsize::new(FILE_LEN).unwrap_or(NonZeroUsize::MIN);
        // SAFETY: a fresh shared mapping of a file of `FILE_LEN` bytes that only this
        // module touches; the file may be closed once mapped.
        let map = unsafe {
            mmap(
                None,
                len,
                ProtFlags::PROT_READ | ProtFlags::PROT_WRITE,
                MapFlags::MAP_SHARED,
                file.as_fd(),
                0,
            )
        }
        .map_err(std::io::Error::from)?;
        let ledger = Self {
            map: map.cast(),
            next_slot: Mutex::new(0),
        };
        ledger.bytes_at(0, 8).copy_from_slice(&MAGIC);
        Ok(ledger)
    }

    /// The `len` bytes at `at`, for writing.
    #[allow(clippy::mut_from_ref)]
    fn bytes_at(&self, at: usize, len: usize) -> &mut [u8] {
        debug_assert!(at + len <= FILE_LEN);
        // SAFETY: within the mapping (checked by the callers' constants); each range is
        // written by one party only (the header at creation, a slot's fields by the
        // publisher that claimed it, before it is published with its length).
        unsafe { std::slice::from_raw_parts_mut(self.map.as_ptr().add(at), len) }
    }

    /// The atomic at `at` (8-aligned: the mapping is page-aligned).
    fn atomic_at(&self, at: usize) -> &AtomicU64 {
        debug_assert!(at.is_multiple_of(8) && at + 8 <= FILE_LEN);
        // SAFETY: in bounds and aligned as above; `AtomicU64` has the layout of `u64`, and
        // every access to these bytes after the slot's claim is atomic.
        unsafe { AtomicU64::from_ptr(self.map.as_ptr().add(at).cast()) }
    }

    /// Claims a slot for the publisher `id` of `channel`; `None` when the ledger is full or
    /// the name does not fit.
    pub(crate) fn slot(self: &Arc<Self>, channel: &str, id: u128) -> Option<LedgerSlot> {
        let name = channel.as_bytes();
        if name.is_empty() || name.len() > SLOT_LEN - NAME_AT {
            return None;
        }
        let mut next = self
            .next_slot
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        if *next >= SLOTS {
            return None;
        }
        let at = SLOTS_AT + *next * SLOT_LEN;
        *next += 1;
        self.atomic_at(at + 8).store(0, Ordering::Relaxed);
        self.bytes_at(at + 16, 16)
            .copy_from_slice(&id.to_le_bytes());
        self.bytes_at(at + 32, 8)
            .copy_from_slice(&wall_ns().to_le_bytes());
        self.bytes_at(at + NAME_AT, name.len())
            .copy_from_slice(name);
        // Last: a reader takes a slot with a length as whole.
        self.atomic_at(at)
            .store(name.len() as u64, Ordering::Release);
        Some(LedgerSlot {
            file: Arc::clone(self),
            sent_at: at + 8,
        })
    }
}

/// One publisher's line in its process's ledger.
pub(crate) struct LedgerSlot {
    file: Arc<LedgerFile>,
    sent_at: usize,
}

impl LedgerSlot {
    /// Notes that the publisher's next sequence number is `next_seq`.
    pub(crate) fn note(&self, next_seq: u64) {
        self.file
            .atomic_at(self.sent_at)
            .store(next_seq, Ordering::Release);
    }
}

/// What a publisher of a process that has died had sent.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EndedPublisher {
    /// The channel it published on.
    pub channel: String,
    /// Its id, as subscribers see it ([`super::Received::publisher_id`]).
    pub publisher_id: u128,
    /// Its next sequence number when it died: it sent samples `0..sent`.
    pub sent: u64,
    /// When it was made, in ns since 1970.
    pub created_ns: i64,
}

/// Finds the ledgers of a namespace's processes as they die, each once.
#[derive(Debug)]
pub struct LedgerReader {
    dir: PathBuf,
    /// Ledgers already read (their process dead).
    read: HashSet<OsString>,
}

impl LedgerReader {
    /// A reader of `namespace`'s ledgers. The processes already dead are passed over: what
    /// they lost was lost before this reader was there to be owed it.
    #[must_use]
    pub fn new(namespace: &Namespace) -> Self {
        Self::new_in(Path::new(ROOT), namespace)
    }

    fn new_in(root: &Path, namespace: &Namespace) -> Self {
        let mut reader = Self {
            dir: folder(root, namespace),
            read: HashSet::new(),
        };
        let _ = reader.ended();
        reader
    }

    /// The publishers of the processes that died since the last call.
    pub fn ended(&mut self) -> Vec<EndedPublisher> {
        let Ok(entries) = std::fs::read_dir(&self.dir) else {
            return Vec::new();
        };
        let mut ended = Vec::new();
        for entry in entries.flatten() {
            let name = entry.file_name();
            let Some(pid) = name
                .to_str()
                .and_then(|n| n.split('.').next())
                .and_then(|pid| pid.parse::<u32>().ok())
            else {
                continue;
            };
            if self.read.contains(&name) || is_alive(pid) {
                continue;
            }
            // The writer is dead: the file no longer changes, a plain read is whole.
            if let Ok(bytes) = std::fs::read(entry.path()) {
                ended.extend(parse(&bytes));
            }
            self.read.insert(name);
        }
        ended
    }
}

/// Whether the process `pid` still runs (a zombie does not: it publishes nothing more).
fn is_alive(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        // The state follows the command name in parentheses, which may hold anything.
        Ok(stat) => stat
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.trim_start().chars().next())
            .is_some_and(|state| !matches!(state, 'Z' | 'X')),
        Err(_) => false,
    }
}

/// The slots of a ledger's bytes; nothing for bytes that are not a ledger.
fn parse(bytes: &[u8]) -> Vec<EndedPublisher> {
    if bytes.len() < FILE_LEN || bytes[..8] != MAGIC {
        return Vec::new();
    }
    let u64_at = |at: usize| {
        let mut word = [0; 8];
        word.copy_from_slice(&bytes[at..at + 8]);
        u64::from_le_bytes(word)
    };
    (0..SLOTS)
        .map(|i| SLOTS_AT + i * SLOT_LEN)
        .filter_map(|at| {
            let len = usize::try_from(u64_at(at)).ok()?;
            if len == 0 || len > SLOT_LEN - NAME_AT {
                return None;
            }
            let mut id = [0; 16];
            id.copy_from_slice(&bytes[at + 16..at + 32]);
            Some(EndedPublisher {
                channel: String::from_utf8_lossy(&bytes[at + NAME_AT..at + NAME_AT + len])
                    .into_owned(),
                publisher_id: u128::from_le_bytes(id),
                sent: u64_at(at + 8),
                created_ns: i64::from_le_bytes(u64_at(at + 32).to_le_bytes()),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ledger_reads_back_what_its_publishers_noted() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("1.0");
        let file = Arc::new(LedgerFile::create_at(&path).unwrap());
        let laser = file.slot("/laser/RangeFinder", 11).unwrap();
        let health = file.slot("/lewis/health/laser", 12).unwrap();
        laser.note(41);
        health.note(3);
        laser.note(42);
        let read = parse(&std::fs::read(&path).unwrap());
        let got: Vec<_> = read
            .iter()
            .map(|e| (e.channel.as_str(), e.publisher_id, e.sent))
            .collect();
        assert_eq!(
            got,
            [
                ("/laser/RangeFinder", 11, 42),
                ("/lewis/health/laser", 12, 3)
            ]
        );
        assert!(read.iter().all(|e| e.created_ns > 0));
    }

    #[test]
    fn a_full_ledger_or_a_long_name_gets_no_slot() {
        let dir = tempfile::tempdir().unwrap();
        let file = Arc::new(LedgerFile::create_at(&dir.path().join("l")).unwrap());
        assert!(file.slot(&"x".repeat(SLOT_LEN), 1).is_none());
        let slots: Vec<_> = (0..SLOTS + 3)
            .filter_map(|i| file.slot(&format!("/c{i}"), i as u128))
            .collect();
        assert_eq!(slots.len(), SLOTS);
    }

    #[test]
    fn the_reader_returns_each_dead_process_once_and_never_a_live_one() {
        let dir = tempfile::tempdir().unwrap();
        let namespace = Namespace::unique("ledger-reader");
        // A process id that is not running (above the kernel's limit) and this one.
        let dead = 4_194_305_u32;
        let alive = std::process::id();
        let ours = folder(dir.path(), &namespace);
        std::fs::create_dir_all(&ours).unwrap();
        let write = |pid: u32, n: u32, sent: u64| {
            let path = ours.join(format!("{pid}.{n}"));
            let file = Arc::new(LedgerFile::create_at(&path).unwrap());
            file.slot("/laser/RangeFinder", u128::from(n))
                .unwrap()
                .note(sent);
            file
        };
        let _before = write(dead, 0, 5);
        let mut reader = LedgerReader::new_in(dir.path(), &namespace);
        // Another namespace's ledger and a file that is not one are not read.
        let other = folder(dir.path(), &Namespace::unique("other"));
        std::fs::create_dir_all(&other).unwrap();
        std::fs::write(other.join(format!("{dead}.0")), MAGIC).unwrap();
        std::fs::write(ours.join(format!("{dead}.junk")), b"not a ledger").unwrap();
        let _live = write(alive, 1, 9);
        let _after = write(dead, 2, 7);
        let ended = reader.ended();
        assert_eq!(
            ended
                .iter()
                .map(|e| (e.publisher_id, e.sent))
                .collect::<Vec<_>>(),
            [(2, 7)]
        );
        assert!(reader.ended().is_empty());
    }

    #[test]
    fn bytes_that_are_not_a_ledger_give_nothing() {
        assert!(parse(b"").is_empty());
        assert!(parse(&[0; FILE_LEN]).is_empty());
        let mut bad = vec![0xff; FILE_LEN];
        bad[..8].copy_from_slice(&MAGIC);
        assert!(parse(&bad).is_empty());
    }
}
