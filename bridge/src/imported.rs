//! The shared-memory publishers of the channels a host imports from other hosts, written
//! from Zenoh's callbacks.
//!
//! A sample from another host goes into shared memory on the Zenoh thread that received
//! it. Handing it to the forwarding thread first cost a thread wake-up per sample: 8 to 15
//! µs more of one-way latency across the link, in the same run (`cargo bench -p
//! lewis-bridge --bench bridge`), and the forwarding thread's CPU for every camera frame.

use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use lewis_runtime::ipc::{Ipc, Namespace, Publisher};
use lewis_runtime::names;
use zenoh::bytes::ZBytes;

use crate::BridgeError;

/// The iceoryx2 node that publishes a host's imports.
const NODE: &str = "lewis-bridge-imports";

/// The publishers of a host's imported channels, by route index, usable from any thread.
#[derive(Clone)]
pub(crate) struct Imported(Arc<Mutex<Ports>>);

/// An iceoryx2 node and every port made from it.
struct Ports {
    publishers: Vec<Publisher>,
    // Dropped after its ports.
    _ipc: Ipc,
}

// SAFETY: iceoryx2's single-threaded ports differ from its thread-safe ones only in the
// reference counts they share with their node (`Rc` where the others have a mutex). Every
// value holding one of those counts (the node, its services and ports, a spare loaned
// sample) lives in `Ports` and is never handed out, and `Ports` is only reached through
// the mutex of `Imported`: so no two threads ever touch the counts at once, and each
// thread sees the last one's changes.
unsafe impl Send for Ports {}

impl Imported {
    /// A publisher in `namespace` for each of `channels`, in their order.
    ///
    /// # Errors
    /// When a channel cannot be opened.
    pub(crate) fn open<'a>(
        namespace: &Namespace,
        channels: impl IntoIterator<Item = &'a str>,
    ) -> Result<Self, BridgeError> {
        let ipc = Ipc::open(namespace, NODE)?;
        let publishers = channels
            .into_iter()
            .map(|channel| ipc.publisher(channel, &names::channel_config(channel)))
            .collect::<Result<_, _>>()?;
        Ok(Self(Arc::new(Mutex::new(Ports {
            publishers,
            _ipc: ipc,
        }))))
    }

    fn ports(&self) -> MutexGuard<'_, Ports> {
        self.0.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Publishes the bytes of a sample from another host on import `index`: straight from
    /// Zenoh's buffers into shared memory, one copy.
    pub(crate) fn publish(&self, index: usize, bytes: &ZBytes) {
        let copy = |buf: &mut [u8]| {
            let mut at = 0;
            for slice in bytes.slices() {
                buf[at..at + slice.len()].copy_from_slice(slice);
                at += slice.len();
            }
        };
        let mut ports = self.ports();
        if let Some(publisher) = ports.publishers.get_mut(index)
            && let Err(e) = publisher.publish_with(bytes.len(), copy)
        {
            tracing::debug!("cannot publish {} here: {e}", publisher.channel());
        }
    }

    /// How many processes of this host read import `index`.
    pub(crate) fn readers(&self, index: usize) -> usize {
        self.ports()
            .publishers
            .get(index)
            .map_or(0, Publisher::subscribers)
    }
}
