//! Removing what dead processes left in a namespace, on a thread of its own.
//!
//! iceoryx2's cleanup of a dead node walks every service of the namespace and took
//! 140-220 ms after a service's exit on a loaded 2-core machine. Done in the broker's
//! loop, it held up everything behind it: heartbeats, clients asking for a provider, the
//! start of an on-demand replacement. Here a request never waits; the broker waits only
//! before starting the same service again, so that it never meets its dead predecessor's
//! ports, a publisher or server slot still taken ([`NodeCleaner::wait_for`]).

use std::sync::mpsc::{self, SyncSender};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::{Ipc, IpcError, Namespace};

/// How long a pass may run at shutdown before memory left empty by a killed process is
/// taken for what holds it (a pass took 140-220 ms on a loaded machine; the memory counts
/// as abandoned after a second).
const STUCK_AFTER: Duration = Duration::from_millis(1500);

/// How long the shutdown waits for a pass in all.
const STOP_WAIT_LIMIT: Duration = Duration::from_secs(5);

/// How often the shutdown looks whether the pass has ended (a thread's end cannot be waited
/// for with a time limit).
const STOP_POLL: Duration = Duration::from_millis(10);

/// How far the requests and the passes have come.
#[derive(Debug, Default)]
struct Progress {
    /// Requests made so far.
    requested: u64,
    /// Every request up to this one has had a whole pass after it.
    done: u64,
    /// Dead nodes removed, in all passes.
    cleaned: u64,
}

/// What the thread and its owner share.
#[derive(Debug, Default)]
struct Shared {
    progress: Mutex<Progress>,
    changed: Condvar,
}

impl Shared {
    fn lock(&self) -> std::sync::MutexGuard<'_, Progress> {
        self.progress.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// A background cleaner of the dead nodes of one namespace, with an iceoryx2 node of its
/// own (a node belongs to the thread that made it).
#[derive(Debug)]
pub struct NodeCleaner {
    namespace: Namespace,
    requests: Option<SyncSender<()>>,
    thread: Option<JoinHandle<()>>,
    shared: Arc<Shared>,
}

impl NodeCleaner {
    /// Starts the cleaner's thread with a node named `node_name` in `namespace`.
    ///
    /// # Errors
    /// When the thread cannot start or its node cannot be opened.
    pub fn start(namespace: &Namespace, node_name: &str) -> Result<Self, IpcError> {
        let (requests, incoming) = mpsc::sync_channel::<()>(1);
        let (opened_tx, opened) = mpsc::channel::<Result<(), IpcError>>();
        let shared = Arc::new(Shared::default());
        let thread_shared = Arc::clone(&shared);
        let thread_error = |reason: String| IpcError::Node {
            node: node_name.to_owned(),
            namespace: namespace.to_string(),
            reason,
        };
        let (thread_namespace, node_name) = (namespace.clone(), node_name.to_owned());
        let thread = std::thread::Builder::new()
            .name("lewis-ipc-cleaner".to_owned())
            .spawn(move || {
                let ipc = match Ipc::open(&thread_namespace, &node_name) {
                    Ok(ipc) => {
                        let _ = opened_tx.send(Ok(()));
                        ipc
                    }
                    Err(e) => {
                        let _ = opened_tx.send(Err(e));
                        return;
                    }
                };
                for () in incoming {
                    // Every request made before this pass starts is covered by it.
                    let covers = thread_shared.lock().requested;
                    let started = Instant::now();
                    let report = ipc.cleanup_dead_nodes();
                    tracing::debug!(
                        cleaned = report.cleaned,
                        failed = report.failed,
                        "IPC cleanup of dead nodes took {:?}",
                        started.elapsed()
                    );
                    let mut progress = thread_shared.lock();
                    progress.done = covers;
                    progress.cleaned += report.cleaned;
                    thread_shared.changed.notify_all();
                }
            })
            .map_err(|e| thread_error(format!("cannot start the cleaner's thread: {e}")))?;
        let mut cleaner = Self {
            namespace: namespace.clone(),
            requests: Some(requests),
            thread: Some(thread),
            shared,
        };
        match opened.recv() {
            Ok(Ok(())) => Ok(cleaner),
            Ok(Err(e)) => Err(e),
            Err(_) => {
                cleaner.stop();
                Err(thread_error(
                    "the cleaner's thread ended before opening its node".to_owned(),
                ))
            }
        }
    }

    /// Asks for a pass over the namespace's dead nodes, without waiting. While a pass is
    /// pending, it covers this request too. Returns the request's ticket, for
    /// [`NodeCleaner::wait_for`].
    pub fn request(&self) -> u64 {
        let ticket = {
            let mut progress = self.shared.lock();
            progress.requested += 1;
            progress.requested
        };
        if let Some(requests) = &self.requests {
            // Full: the pending pass covers this request. Disconnected: the thread is
            // gone (only at drop), and nothing is left to clean for.
            let _ = requests.try_send(());
        }
        ticket
    }

    /// Waits until the request with `ticket` has had its pass, at most `timeout`; whether
    /// it has.
    pub fn wait_for(&self, ticket: u64, timeout: Duration) -> bool {
        let deadline = Instant::now() + timeout;
        let mut progress = self.shared.lock();
        while progress.done < ticket {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() || self.requests.is_none() {
                return false;
            }
            progress = self
                .shared
                .changed
                .wait_timeout(progress, left)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
        true
    }

    /// Dead nodes removed so far.
    pub fn cleaned(&self) -> u64 {
        self.shared.lock().cleaned
    }

    /// Ends the thread. A pass stuck on memory a killed process left empty is freed by
    /// removing that memory once it is old enough to be abandoned; a pass still running
    /// after that is left to end with the process rather than hold up the shutdown.
    fn stop(&mut self) {
        self.requests = None;
        let Some(thread) = self.thread.take() else {
            return;
        };
        let mut removed_empty = false;
        let started = Instant::now();
        while !thread.is_finished() {
            let waited = started.elapsed();
            if waited >= STOP_WAIT_LIMIT {
                tracing::warn!(
                    "the IPC cleanup of namespace {} is still running after {waited:?}: left to end with the process",
                    self.namespace
                );
                return;
            }
            if !removed_empty && waited >= STUCK_AFTER {
                removed_empty = true;
                let _ = super::remove_abandoned_memory(&self.namespace);
            }
            std::thread::sleep(STOP_POLL);
        }
        // The thread only cleans: it cannot panic but through iceoryx2 itself.
        let _ = thread.join();
    }
}

impl Drop for NodeCleaner {
    fn drop(&mut self) {
        self.stop();
    }
}
