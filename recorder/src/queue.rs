//! The bounded queue between the tap (which sees every publication) and the writer
//! thread (which owns the [`Recorder`]).
//!
//! **Policy**: the tap never waits. [`Tap::try_record`] (or [`TapBatch::record`], for many
//! messages in a row) copies the bytes and queues them for the writer if the queue has room
//! for one more message *and* for its bytes; otherwise the message is dropped, counted per
//! channel, and `Err(Dropped)` returned. Messages the tap
//! never received (its IPC buffer overflowed) are counted the same way
//! ([`Tap::count_missed`]): `dropped` is everything the recorder itself failed to take. A
//! dropped message also shows in the file as a gap in its channel's sequence numbers, which
//! is what the recorder counts as lost. The bounds ([`QueueOptions`]) cap the recorder's
//! memory whatever the length of the run: about `capacity_bytes` plus one chunk.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

use thiserror::Error;

use crate::channel::{ChannelId, ChannelSpec, Sample};
use crate::error::RecordError;
use crate::options::RobotDescription;
use crate::recorder::{Recorder, RecordingReport};

/// How long the writer thread waits for a message before it lets time pass
/// ([`Recorder::tick`]): flushes and stats keep their period when traffic stops.
const IDLE_TICK: Duration = Duration::from_millis(100);

/// Messages written between two updates of the drop counts.
const DROP_SWEEP_EVERY: u32 = 1024;

/// The bounds of the queue.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct QueueOptions {
    /// Messages it holds at most.
    pub capacity_messages: usize,
    /// Bytes of message data it holds at most (one message larger than this still goes
    /// through an empty queue).
    pub capacity_bytes: usize,
    /// A pause of the writer thread after each message it writes: zero, except to test a
    /// slow disk (the publishers' rate must not change, the losses must be counted).
    pub write_delay: Duration,
}

impl Default for QueueOptions {
    /// 65536 messages and 48 MiB: more than a second of the stress mix (20 channels at
    /// 1 kHz and a 640x480 RGB stream at 30 Hz, about 30 MB/s).
    fn default() -> Self {
        Self {
            capacity_messages: 65_536,
            capacity_bytes: 48 * 1024 * 1024,
            write_delay: Duration::ZERO,
        }
    }
}

/// Why [`Tap::try_record`] did not queue a message. Either way it was counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum Dropped {
    /// The queue was full: the writer is behind.
    #[error("the recorder's queue is full: the message was dropped and counted")]
    QueueFull,
    /// The writer thread has stopped (closed, or an error such as a full disk).
    #[error("the recorder has stopped: the message was dropped and counted")]
    Stopped,
}

struct Registered {
    spec: ChannelSpec,
    dropped: AtomicU64,
    /// Samples its provider sent before it died that never arrived ([`Tap::count_lost_at_exit`]).
    lost_at_exit: AtomicU64,
}

impl Registered {
    fn new(spec: ChannelSpec) -> Arc<Self> {
        Arc::new(Self {
            spec,
            dropped: AtomicU64::new(0),
            lost_at_exit: AtomicU64::new(0),
        })
    }
}

struct Shared {
    channels: Mutex<Vec<Arc<Registered>>>,
    /// A robot description found after the start, for the writer to store.
    robot: Mutex<Option<RobotDescription>>,
    queued_bytes: AtomicUsize,
    capacity_bytes: usize,
    queued_messages: AtomicUsize,
    capacity_messages: usize,
    dropped: AtomicU64,
    /// Emptied batches, for the tap to fill again.
    pool: Mutex<Vec<Batch>>,
}

impl Shared {
    fn channels(&self) -> std::sync::MutexGuard<'_, Vec<Arc<Registered>>> {
        // A panic while holding this lock leaves the list valid: keep using it.
        self.channels.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn release(&self, bytes: usize, messages: usize) {
        self.queued_bytes.fetch_sub(bytes, Ordering::AcqRel);
        self.queued_messages.fetch_sub(messages, Ordering::AcqRel);
    }

    fn take_batch(&self) -> Batch {
        self.pool
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .pop()
            .unwrap_or_default()
    }

    fn recycle(&self, mut batch: Batch) {
        // An empty buffer saves nothing; a large one would keep its memory.
        if batch.bytes.capacity() == 0 || batch.bytes.capacity() > RECYCLED_BYTES {
            return;
        }
        batch.clear();
        let mut pool = self.pool.lock().unwrap_or_else(PoisonError::into_inner);
        if pool.len() < POOL_BATCHES {
            pool.push(batch);
        }
    }

    fn take_robot(&self) -> Option<RobotDescription> {
        self.robot
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take()
    }
}

/// Where one message of a [`Batch`] is and what it is.
struct Meta {
    channel: ChannelId,
    seq: u64,
    publish_time_ns: i64,
    log_time_ns: i64,
    /// Where its bytes end in [`Batch::bytes`] (they start where the previous one's end).
    end: usize,
}

/// Messages copied one after the other into one buffer and handed to the writer together:
/// one queue operation, one allocation (recycled) and sequential reads for many messages,
/// instead of one of each per message.
#[derive(Default)]
struct Batch {
    messages: Vec<Meta>,
    bytes: Vec<u8>,
}

impl Batch {
    fn iter(&self) -> impl Iterator<Item = Sample<'_>> {
        let mut start = 0;
        self.messages.iter().map(move |m| {
            let data = &self.bytes[start..m.end];
            start = m.end;
            Sample {
                channel: m.channel,
                seq: m.seq,
                publish_time_ns: m.publish_time_ns,
                log_time_ns: m.log_time_ns,
                data,
            }
        })
    }

    fn clear(&mut self) {
        self.messages.clear();
        self.bytes.clear();
    }
}

/// A batch holds at most this many messages...
const BATCH_MESSAGES: usize = 256;
/// ...and this many bytes, unless its only message is longer.
const BATCH_BYTES: usize = 256 * 1024;
/// Emptied batches kept for reuse; one whose buffer grew past `RECYCLED_BYTES` (a large
/// message) is freed instead, so that the pool stays small.
const POOL_BATCHES: usize = 16;
const RECYCLED_BYTES: usize = 2 * BATCH_BYTES;

enum Entry {
    Batch(Batch),
    Stop,
}

/// The publishing side: cheap to clone, never blocks.
#[derive(Clone)]
pub struct Tap {
    shared: Arc<Shared>,
    sender: SyncSender<Entry>,
}

impl Tap {
    /// Registers a channel (it appears in the file even before its first message).
    #[must_use]
    pub fn register(&self, spec: ChannelSpec) -> ChannelId {
        let mut channels = self.shared.channels();
        channels.push(Registered::new(spec));
        ChannelId(u32::try_from(channels.len() - 1).unwrap_or(u32::MAX))
    }

    /// Hands the writer a robot description found after the recording started; it is
    /// stored in the file before the first message of any channel registered after this
    /// call. Never waits.
    pub fn set_robot_description(&self, robot: RobotDescription) {
        *self
            .shared
            .robot
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = Some(robot);
    }

    /// Queues a copy of the message for the writer thread, or drops and counts it.
    ///
    /// # Errors
    /// [`Dropped`] when the queue is full or the writer has stopped.
    pub fn try_record(&self, sample: &Sample<'_>) -> Result<(), Dropped> {
        let mut batch = self.batch();
        batch.record(sample)?;
        batch.flush()
    }

    /// A batch for many messages in a row (what a tap takes in one go): each is queued as
    /// by [`Tap::try_record`], with the same bounds and accounting, but they reach the
    /// writer together, when the batch fills, on [`TapBatch::flush`] or when it is dropped.
    #[must_use]
    pub fn batch(&self) -> TapBatch<'_> {
        TapBatch {
            tap: self,
            batch: Batch::default(),
            dropped: 0,
        }
    }

    /// Makes room in the queue's bounds for one message of `len` bytes, or counts it
    /// dropped.
    fn reserve(&self, channel: ChannelId, len: usize) -> Result<(), Dropped> {
        let before = self.shared.queued_bytes.fetch_add(len, Ordering::AcqRel);
        let messages = self.shared.queued_messages.fetch_add(1, Ordering::AcqRel);
        if (before > 0 && before + len > self.shared.capacity_bytes)
            || messages >= self.shared.capacity_messages
        {
            self.shared.release(len, 1);
            self.count_dropped(channel, 1);
            return Err(Dropped::QueueFull);
        }
        Ok(())
    }

    /// Messages dropped so far on `channel`.
    #[must_use]
    pub fn dropped(&self, channel: ChannelId) -> u64 {
        self.registered(channel)
            .map_or(0, |c| c.dropped.load(Ordering::Relaxed))
    }

    /// Messages dropped so far, on all channels.
    #[must_use]
    pub fn dropped_total(&self) -> u64 {
        self.shared.dropped.load(Ordering::Relaxed)
    }

    /// Counts `count` messages of `channel` that the tap never received: the IPC buffer in
    /// front of it overflowed while it was not scheduled. They are dropped by the recorder
    /// like those its full queue refuses, and show as gaps like them.
    pub fn count_missed(&self, channel: ChannelId, count: u64) {
        if count > 0 {
            self.count_dropped(channel, count);
        }
    }

    /// Counts `count` messages of `channel` that its provider sent before it died and that
    /// never arrived (see `lewis_runtime::ipc::LedgerReader`): no later message shows them
    /// as a gap, so they are counted as lost here.
    pub fn count_lost_at_exit(&self, channel: ChannelId, count: u64) {
        if let Some(registered) = self.registered(channel) {
            registered.lost_at_exit.fetch_add(count, Ordering::Relaxed);
        }
    }

    fn count_dropped(&self, channel: ChannelId, count: u64) {
        self.shared.dropped.fetch_add(count, Ordering::Relaxed);
        if let Some(registered) = self.registered(channel) {
            registered.dropped.fetch_add(count, Ordering::Relaxed);
        }
    }

    /// The registration of `channel`, if it is one of the tap's.
    fn registered(&self, channel: ChannelId) -> Option<Arc<Registered>> {
        usize::try_from(channel.0)
            .ok()
            .and_then(|i| self.shared.channels().get(i).cloned())
    }
}

/// Messages on their way to the writer together (from [`Tap::batch`]); what it holds is
/// handed over when it is dropped.
pub struct TapBatch<'t> {
    tap: &'t Tap,
    batch: Batch,
    dropped: u64,
}

impl TapBatch<'_> {
    /// Copies the message into the batch, or drops and counts it; hands the batch to the
    /// writer when it is full.
    ///
    /// # Errors
    /// [`Dropped`] when the queue is full or the writer has stopped.
    pub fn record(&mut self, sample: &Sample<'_>) -> Result<(), Dropped> {
        let len = sample.data.len();
        if !self.batch.messages.is_empty()
            && self.batch.bytes.len() + len > BATCH_BYTES
            && let Err(dropped) = self.flush()
        {
            self.tap.count_dropped(sample.channel, 1);
            self.dropped += 1;
            return Err(dropped);
        }
        if let Err(dropped) = self.tap.reserve(sample.channel, len) {
            self.dropped += 1;
            return Err(dropped);
        }
        if self.batch.messages.is_empty() && self.batch.bytes.capacity() == 0 {
            self.batch = self.tap.shared.take_batch();
        }
        self.batch.bytes.extend_from_slice(sample.data);
        self.batch.messages.push(Meta {
            channel: sample.channel,
            seq: sample.seq,
            publish_time_ns: sample.publish_time_ns,
            log_time_ns: sample.log_time_ns,
            end: self.batch.bytes.len(),
        });
        if self.batch.messages.len() >= BATCH_MESSAGES || self.batch.bytes.len() >= BATCH_BYTES {
            return self.flush();
        }
        Ok(())
    }

    /// Messages this batch dropped (and counted) so far.
    #[must_use]
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Hands what the batch holds to the writer.
    ///
    /// # Errors
    /// [`Dropped::Stopped`] when the writer has stopped: the messages it held are dropped
    /// and counted.
    pub fn flush(&mut self) -> Result<(), Dropped> {
        if self.batch.messages.is_empty() {
            return Ok(());
        }
        // The next message takes a recycled buffer.
        let batch = std::mem::take(&mut self.batch);
        // The reservations bound the messages queued to the channel's capacity, so it is
        // never full; only a stopped writer refuses.
        match self.tap.sender.try_send(Entry::Batch(batch)) {
            Ok(()) => Ok(()),
            Err(error) => {
                let (reason, entry) = match error {
                    TrySendError::Full(entry) => (Dropped::QueueFull, entry),
                    TrySendError::Disconnected(entry) => (Dropped::Stopped, entry),
                };
                if let Entry::Batch(batch) = entry {
                    self.tap
                        .shared
                        .release(batch.bytes.len(), batch.messages.len());
                    for m in &batch.messages {
                        self.tap.count_dropped(m.channel, 1);
                    }
                    self.dropped += batch.messages.len() as u64;
                    self.tap.shared.recycle(batch);
                }
                Err(reason)
            }
        }
    }
}

impl Drop for TapBatch<'_> {
    fn drop(&mut self) {
        // Counted if refused; nobody is left to tell.
        let _ = self.flush();
        let batch = std::mem::take(&mut self.batch);
        self.tap.shared.recycle(batch);
    }
}

/// The writer thread: owns the [`Recorder`] and drains the queue into it.
pub struct WriterThread {
    handle: JoinHandle<Result<RecordingReport, RecordError>>,
    sender: SyncSender<Entry>,
    path: PathBuf,
}

impl WriterThread {
    /// Whether the thread has ended (closed, or stopped by an error: [`Self::finish`]
    /// says which).
    #[must_use]
    pub fn is_finished(&self) -> bool {
        self.handle.is_finished()
    }

    /// Writes what is queued, closes the recording and reports. Messages offered after
    /// this are dropped ([`Dropped::Stopped`]).
    ///
    /// # Errors
    /// The error that stopped the writer, or the one closing the file met.
    pub fn finish(self) -> Result<RecordingReport, RecordError> {
        // The thread may have stopped on an error already; then there is no one to tell.
        let _ = self.sender.send(Entry::Stop);
        self.handle
            .join()
            .map_err(|_| RecordError::WriterPanicked { path: self.path })?
    }
}

/// Starts the writer thread for `recorder`. `clock` gives the current time on the clock
/// of the receive times; the thread reads it only when no message has come for a while,
/// to keep flushing and writing stats on time.
///
/// # Errors
/// [`RecordError::Io`] when the thread cannot be started.
pub fn spawn(
    recorder: Recorder,
    queue: QueueOptions,
    clock: impl FnMut() -> i64 + Send + 'static,
) -> Result<(Tap, WriterThread), RecordError> {
    let path = recorder.current_path().to_path_buf();
    let channels = recorder
        .channels()
        .map(|spec| Registered::new(spec.clone()))
        .collect();
    let shared = Arc::new(Shared {
        channels: Mutex::new(channels),
        robot: Mutex::new(None),
        queued_bytes: AtomicUsize::new(0),
        capacity_bytes: queue.capacity_bytes,
        queued_messages: AtomicUsize::new(0),
        capacity_messages: queue.capacity_messages.max(1),
        dropped: AtomicU64::new(0),
        pool: Mutex::new(Vec::new()),
    });
    let (sender, receiver) = mpsc::sync_channel(queue.capacity_messages.max(1));
    let thread_shared = Arc::clone(&shared);
    let handle = std::thread::Builder::new()
        .name("lewis-recorder".to_owned())
        .spawn(move || {
            drain(
                recorder,
                &receiver,
                &thread_shared,
                queue.write_delay,
                clock,
            )
        })
        .map_err(|source| RecordError::Io {
            path: path.clone(),
            source,
        })?;
    Ok((
        Tap {
            shared,
            sender: sender.clone(),
        },
        WriterThread {
            handle,
            sender,
            path,
        },
    ))
}

/// The writer thread's loop.
fn drain(
    mut recorder: Recorder,
    receiver: &Receiver<Entry>,
    shared: &Shared,
    write_delay: Duration,
    mut clock: impl FnMut() -> i64,
) -> Result<RecordingReport, RecordError> {
    let mut ids = TapIds::of(&recorder);
    let mut drops_seen: Vec<Swept> = Vec::new();
    let mut since_sweep = 0_u32;
    loop {
        match receiver.recv_timeout(IDLE_TICK) {
            Ok(Entry::Batch(batch)) => {
                for sample in batch.iter() {
                    let channel = match ids.get(sample.channel) {
                        Some(id) => id,
                        None => {
                            ids.add_new(&mut recorder, shared)?;
                            // A channel the tap never registered: the recorder refuses it.
                            ids.get(sample.channel).unwrap_or(sample.channel)
                        }
                    };
                    recorder.write(&Sample { channel, ..sample })?;
                    if !write_delay.is_zero() {
                        std::thread::sleep(write_delay);
                    }
                    since_sweep += 1;
                    if since_sweep >= DROP_SWEEP_EVERY {
                        since_sweep = 0;
                        sweep_drops(&mut recorder, shared, &ids, &mut drops_seen);
                    }
                }
                shared.release(batch.bytes.len(), batch.messages.len());
                shared.recycle(batch);
            }
            Ok(Entry::Stop) | Err(RecvTimeoutError::Disconnected) => break,
            Err(RecvTimeoutError::Timeout) => {
                ids.add_new(&mut recorder, shared)?;
                sweep_drops(&mut recorder, shared, &ids, &mut drops_seen);
                recorder.tick(clock())?;
            }
        }
    }
    ids.add_new(&mut recorder, shared)?;
    sweep_drops(&mut recorder, shared, &ids, &mut drops_seen);
    recorder.close()
}

/// The recorder's id of each channel the tap registered, by the tap's id.
///
/// The two differ once the recorder adds channels of its own (the companions it derives
/// from messages), so a channel the tap registers after that gets a later id in the file.
struct TapIds(Vec<ChannelId>);

impl TapIds {
    /// The channels the recorder had when the tap was made: the tap registered them first,
    /// in the same order.
    fn of(recorder: &Recorder) -> Self {
        Self(
            (0..recorder.channel_count())
                .map(|i| ChannelId(u32::try_from(i).unwrap_or(u32::MAX)))
                .collect(),
        )
    }

    /// The recorder's id of the tap's `channel`, once the recorder has it.
    fn get(&self, channel: ChannelId) -> Option<ChannelId> {
        usize::try_from(channel.0)
            .ok()
            .and_then(|i| self.0.get(i))
            .copied()
    }

    /// Registers with the recorder the channels the tap registered since, after the robot
    /// description handed over before them.
    fn add_new(&mut self, recorder: &mut Recorder, shared: &Shared) -> Result<(), RecordError> {
        let new: Vec<ChannelSpec> = shared
            .channels()
            .iter()
            .skip(self.0.len())
            .map(|c| c.spec.clone())
            .collect();
        // Taken after the channels: a description handed over before a channel was
        // registered is seen with it.
        if let Some(robot) = shared.take_robot() {
            recorder.set_robot_description(robot)?;
        }
        for spec in new {
            self.0.push(recorder.add_channel(spec)?);
        }
        Ok(())
    }
}

/// The counts of one channel already passed to the recorder.
#[derive(Debug, Clone, Copy, Default)]
struct Swept {
    dropped: u64,
    lost_at_exit: u64,
}

/// Passes the tap's new drop and loss counts to the recorder.
fn sweep_drops(recorder: &mut Recorder, shared: &Shared, ids: &TapIds, seen: &mut Vec<Swept>) {
    let channels = shared.channels();
    // Counts of a channel the recorder does not know yet are passed once it does.
    seen.resize(ids.0.len().min(channels.len()), Swept::default());
    for ((&id, channel), seen) in ids.0.iter().zip(channels.iter()).zip(seen.iter_mut()) {
        let dropped = channel.dropped.load(Ordering::Relaxed);
        if dropped > seen.dropped {
            recorder.note_dropped(id, dropped - seen.dropped);
            seen.dropped = dropped;
        }
        let lost = channel.lost_at_exit.load(Ordering::Relaxed);
        if lost > seen.lost_at_exit {
            recorder.note_lost_at_exit(id, lost - seen.lost_at_exit);
            seen.lost_at_exit = lost;
        }
    }
}
