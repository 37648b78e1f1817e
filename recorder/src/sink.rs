//! The file under the MCAP writer: it keeps a reserve of disk space beside the recording,
//! and gives it back the moment the disk is full, so that the recorder can still close the
//! file with its summary (the one thing a full disk must not cost).
//!
//! A process may also have a file size limit (`ulimit -f`, systemd's `LimitFSIZE=`): past
//! it, `write` fails with `EFBIG` and nothing can be added to the file. So the same
//! reserve is kept as headroom below the limit: a file that reaches the limit minus the
//! reserve is treated as a full disk while its end still fits.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, AtomicU64, Ordering};

use crate::error::{NoRoom, RecordError, no_room};

/// Bytes written at a time into the reserve file.
const RESERVE_BLOCK_BYTES: usize = 64 * 1024;

/// Space held in a hidden file beside the recording, released when the disk is full.
#[derive(Debug)]
struct Reserve {
    path: PathBuf,
}

impl Reserve {
    /// Writes `bytes` of zeros (real blocks, not a sparse file) at `path`.
    fn create(path: PathBuf, bytes: u64) -> io::Result<Self> {
        let mut file = OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(&path)?;
        let reserve = Self { path };
        let block = vec![0_u8; RESERVE_BLOCK_BYTES];
        let mut left = bytes;
        while left > 0 {
            let n = usize::try_from(left).map_or(block.len(), |l| l.min(block.len()));
            file.write_all(&block[..n])?;
            left -= n as u64;
        }
        file.sync_data()?;
        Ok(reserve)
    }

    fn release(self) {
        // Nothing to do if it is already gone: the space is free either way.
        let _ = fs::remove_file(&self.path);
    }
}

/// Why a part has no more room, shared with the writer's owner: 0 while it has room.
#[derive(Debug, Clone, Default)]
pub(crate) struct RoomFlag(Arc<AtomicU8>);

impl RoomFlag {
    fn set(&self, why: NoRoom) {
        let value = match why {
            NoRoom::DiskFull => 1,
            NoRoom::FileSizeLimit => 2,
        };
        // The first reason stays.
        let _ = self
            .0
            .compare_exchange(0, value, Ordering::AcqRel, Ordering::Acquire);
    }

    /// Why the part has no more room, once it has none.
    pub(crate) fn get(&self) -> Option<NoRoom> {
        match self.0.load(Ordering::Acquire) {
            1 => Some(NoRoom::DiskFull),
            2 => Some(NoRoom::FileSizeLimit),
            _ => None,
        }
    }
}

/// The output file of one part, as the MCAP writer sees it.
#[derive(Debug)]
pub(crate) struct PartFile {
    file: File,
    reserve: Option<Reserve>,
    /// Where the file counts as full below the process's file size limit.
    size_cap: Option<u64>,
    room: RoomFlag,
    position: u64,
    size: Arc<AtomicU64>,
}

impl PartFile {
    /// Creates `path` (never overwriting) and, when `reserve_bytes > 0`, its reserve.
    pub(crate) fn create(path: &Path, reserve_bytes: u64) -> Result<Self, RecordError> {
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)
            .map_err(|e| RecordError::opening(path, e))?;
        let size_cap = if reserve_bytes == 0 {
            None
        } else {
            file_size_limit().map(|limit| limit.saturating_sub(reserve_bytes))
        };
        let reserve = if reserve_bytes == 0 {
            None
        } else {
            let reserve_path = reserve_path(path);
            match Reserve::create(reserve_path.clone(), reserve_bytes) {
                Ok(reserve) => Some(reserve),
                Err(error) => {
                    let _ = fs::remove_file(&reserve_path);
                    let _ = fs::remove_file(path);
                    return Err(RecordError::opening(path, error));
                }
            }
        };
        Ok(Self {
            file,
            reserve,
            size_cap,
            room: RoomFlag::default(),
            position: 0,
            size: Arc::new(AtomicU64::new(0)),
        })
    }

    /// Set once the file has no more room: the disk was found full (the reserve has then
    /// been given back), or the file reached its headroom below the file size limit.
    pub(crate) fn room_flag(&self) -> RoomFlag {
        self.room.clone()
    }

    /// The size of the file as written so far (bytes handed to the system).
    pub(crate) fn size_handle(&self) -> Arc<AtomicU64> {
        Arc::clone(&self.size)
    }

    /// A second handle on the file, to sync it while the writer owns this one.
    pub(crate) fn sync_handle(&self) -> io::Result<File> {
        self.file.try_clone()
    }

    /// Gives the reserve back: the file is closed.
    pub(crate) fn release_reserve(&mut self) {
        if let Some(reserve) = self.reserve.take() {
            reserve.release();
        }
    }

    fn on_full(&mut self, error: io::Error) -> io::Result<()> {
        self.room.set(NoRoom::DiskFull);
        match self.reserve.take() {
            Some(reserve) => {
                reserve.release();
                Ok(())
            }
            None => Err(error),
        }
    }
}

impl Drop for PartFile {
    fn drop(&mut self) {
        self.release_reserve();
    }
}

impl Write for PartFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if self
            .size_cap
            .is_some_and(|cap| self.position + buf.len() as u64 > cap)
        {
            // The write still fits below the limit: the headroom takes the file's end.
            self.room.set(NoRoom::FileSizeLimit);
        }
        let written = match self.file.write(buf) {
            Err(error) if no_room(&error) == Some(NoRoom::DiskFull) => {
                self.on_full(error)?;
                self.file.write(buf)?
            }
            Err(error) => {
                if let Some(why) = no_room(&error) {
                    self.room.set(why);
                }
                return Err(error);
            }
            Ok(written) => written,
        };
        self.position += written as u64;
        self.size.fetch_max(self.position, Ordering::Relaxed);
        Ok(written)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

impl Seek for PartFile {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.position = self.file.seek(pos)?;
        Ok(self.position)
    }
}

/// The process's file size limit in bytes (the soft limit of `RLIMIT_FSIZE`, as
/// `/proc/self/limits` says it), when it has one.
fn file_size_limit() -> Option<u64> {
    let limits = fs::read_to_string("/proc/self/limits").ok()?;
    parse_file_size_limit(&limits)
}

/// The soft `Max file size` of a `/proc/PID/limits` text; `None` when unlimited.
fn parse_file_size_limit(limits: &str) -> Option<u64> {
    limits
        .lines()
        .find_map(|l| l.strip_prefix("Max file size"))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// `DIR/.NAME.reserve` for `DIR/NAME`.
fn reserve_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.reserve"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_file_size_limit_is_read_from_the_process_limits() {
        fn check(limits: &str, expected: Option<u64>) {
            assert_eq!(parse_file_size_limit(limits), expected, "{limits}");
        }
        let header = "Limit                     Soft Limit           Hard Limit           Units\n";
        check(
            &format!(
                "{header}Max cpu time              unlimited            unlimited            seconds\n\
                 Max file size             unlimited            unlimited            bytes\n"
            ),
            None,
        );
        check(
            &format!(
                "{header}Max file size             6291456              6291456              bytes\n"
            ),
            Some(6_291_456),
        );
        check("", None);
        // The limit of this very process reads without error.
        let _ = file_size_limit();
    }
}
