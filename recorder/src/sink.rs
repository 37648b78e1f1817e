//! The file under the MCAP writer: it keeps a reserve of disk space beside the recording,
//! and gives it back the moment the disk is full, so that the recorder can still close the
//! file with its summary (the one thing a full disk must not cost).

use std::fs::{self, File, OpenOptions};
use std::io::{self, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use crate::error::{RecordError, is_disk_full};

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

/// The output file of one part, as the MCAP writer sees it.
#[derive(Debug)]
pub(crate) struct PartFile {
    file: File,
    reserve: Option<Reserve>,
    disk_full: Arc<AtomicBool>,
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
            disk_full: Arc::new(AtomicBool::new(false)),
            position: 0,
            size: Arc::new(AtomicU64::new(0)),
        })
    }

    /// Set once the disk was found full (the reserve has then been given back).
    pub(crate) fn disk_full_flag(&self) -> Arc<AtomicBool> {
        Arc::clone(&self.disk_full)
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
        self.disk_full.store(true, Ordering::Release);
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
        let written = match self.file.write(buf) {
            Err(error) if is_disk_full(&error) => {
                self.on_full(error)?;
                self.file.write(buf)?
            }
            result => result?,
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

/// `DIR/.NAME.reserve` for `DIR/NAME`.
fn reserve_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.reserve"))
}
