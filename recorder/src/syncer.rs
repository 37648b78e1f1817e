//! Syncing a part's file to the disk on a thread of its own. The writer hands each closed
//! chunk to the system and goes on; the disk catches up behind it. An `fsync` of a second
//! of the stress mix (30 MB) can take hundreds of milliseconds on a slow disk: done by the
//! writer, it would stall the writer that long and fill the queue in front of it.
//!
//! A request never waits: while one is pending, it already covers everything written
//! before the next one is taken. A failed sync is handed back at the next request (or at
//! the end), so the recorder stops on it as on any write error.

use std::fs::File;
use std::io;
use std::sync::mpsc::{self, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;

/// The background syncer of one file.
#[derive(Debug)]
pub(crate) struct Syncer {
    file: File,
    requests: Option<SyncSender<()>>,
    thread: Option<JoinHandle<()>>,
    failed: Arc<Mutex<Option<io::Error>>>,
}

impl Syncer {
    /// Starts the thread that syncs `file` (a handle on the file being written).
    pub(crate) fn start(file: File) -> io::Result<Self> {
        let (requests, incoming) = mpsc::sync_channel::<()>(1);
        let failed = Arc::new(Mutex::new(None));
        let thread_file = file.try_clone()?;
        let thread_failed = Arc::clone(&failed);
        let thread = std::thread::Builder::new()
            .name("lewis-recorder-sync".to_owned())
            .spawn(move || {
                for () in incoming {
                    if let Err(error) = thread_file.sync_data() {
                        let mut slot = thread_failed.lock().unwrap_or_else(PoisonError::into_inner);
                        slot.get_or_insert(error);
                    }
                }
            })?;
        Ok(Self {
            file,
            requests: Some(requests),
            thread: Some(thread),
            failed,
        })
    }

    /// Asks for everything written so far to reach the disk, without waiting.
    ///
    /// # Errors
    /// The failure of an earlier sync.
    pub(crate) fn request(&self) -> io::Result<()> {
        self.take_failure()?;
        if let Some(requests) = &self.requests {
            match requests.try_send(()) {
                // Full: the pending request covers this one.
                Ok(()) | Err(TrySendError::Full(())) => {}
                Err(TrySendError::Disconnected(())) => {
                    return Err(io::Error::other("the sync thread of the recording ended"));
                }
            }
        }
        Ok(())
    }

    /// Stops the thread and syncs the whole file (data and size) before returning.
    ///
    /// # Errors
    /// The failure of a background sync or of this one.
    pub(crate) fn finish(mut self) -> io::Result<()> {
        self.stop();
        self.take_failure()?;
        self.file.sync_all()
    }

    fn stop(&mut self) {
        self.requests = None;
        if let Some(thread) = self.thread.take() {
            // The thread only syncs: it cannot panic but through the standard library.
            let _ = thread.join();
        }
    }

    fn take_failure(&self) -> io::Result<()> {
        match self
            .failed
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take()
        {
            Some(error) => Err(error),
            None => Ok(()),
        }
    }
}

impl Drop for Syncer {
    fn drop(&mut self) {
        self.stop();
    }
}

#[cfg(test)]
mod tests {
    use std::io::Write as _;

    use super::*;

    #[test]
    fn requests_never_wait_and_finish_syncs_everything() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        let mut file = File::create(&path).unwrap();
        let syncer = Syncer::start(file.try_clone().unwrap()).unwrap();
        for _ in 0..100 {
            file.write_all(&[7; 1000]).unwrap();
            syncer.request().unwrap();
        }
        syncer.finish().unwrap();
        assert_eq!(std::fs::metadata(&path).unwrap().len(), 100_000);
    }
}
