//! Data channels: publish-subscribe of byte slices of any size in loaned shared memory,
//! each paired with an event service so that a subscriber can block until data arrives.

use std::fmt;
use std::ops::Deref;
use std::os::fd::BorrowedFd;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher as IoxPublisher;
use iceoryx2::port::subscriber::Subscriber as IoxSubscriber;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::port::{BackpressureAction, BackpressureInfo};
use iceoryx2::prelude::{AllocationStrategy, BackpressureStrategy, ZeroCopySend, ipc};
use iceoryx2::sample::Sample;
use iceoryx2::sample_mut::SampleMut;
use iceoryx2::service::port_factory::{PortFactory as _, event, publish_subscribe};

use lewis_interfaces::{Message, cdr};

use super::ledger::{EndedPublisher, LedgerFile, LedgerSlot};
use super::wait::{self, Waitable};
use super::{Ipc, IpcError, port_error, service_name};

/// The service family of data channels (`data/NAME`), apart from commands.
const FAMILY: &str = "data";

/// What a full subscriber buffer does to a new sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OverflowPolicy {
    /// The oldest unread sample is dropped to make room (iceoryx2's safe overflow). The
    /// publisher never waits; the subscriber counts the samples it missed
    /// ([`Subscriber::lost`]). For sensors, where only fresh data matters.
    DropOldest,
    /// The new sample is not delivered to the full subscriber. The publisher never waits;
    /// both sides count ([`Publisher::discarded`], [`Subscriber::lost`]).
    DropNewest,
    /// The publisher waits until the subscriber makes room, at most `max_wait` per
    /// subscriber, then drops the new sample for that subscriber and counts it like
    /// [`OverflowPolicy::DropNewest`]. For decisions and logs that must not be lost while
    /// the reader is merely slow; the bound keeps a stalled reader from stalling the writer.
    Block {
        /// The longest a publisher waits for one subscriber.
        max_wait: Duration,
    },
}

/// The settings of one data channel. Publisher and subscribers must use the same settings:
/// the first to open the channel fixes them and a mismatch is an [`IpcError::Service`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelConfig {
    /// Samples a subscriber can hold unread before the overflow policy applies.
    pub buffer: usize,
    /// The deepest buffer a subscriber of the channel may have (the recorder's, see
    /// [`ChannelConfig::deepest`]); below `buffer`, `buffer`. The publishers' shared memory
    /// is sized for every subscriber at this depth, but only samples in use take memory.
    pub max_buffer: usize,
    /// What happens when a subscriber's buffer is full.
    pub overflow: OverflowPolicy,
    /// Samples kept by the publisher and given to a subscriber that joins late.
    pub history: usize,
    /// Bytes preallocated per sample; longer messages grow the segment (powers of two).
    pub initial_max_len_bytes: usize,
    /// The longest message accepted; longer ones are refused with
    /// [`PublishError::TooLarge`].
    pub max_len_bytes: usize,
    /// Received samples a subscriber may hold at once (at least 2, for
    /// [`Subscriber::latest`]).
    pub max_held: usize,
    /// Subscribers the channel accepts.
    pub max_subscribers: usize,
    /// Publishers the channel accepts.
    pub max_publishers: usize,
}

impl ChannelConfig {
    /// A sensor stream: 4 samples of buffer, drop the oldest, the last sample kept for late
    /// joiners, `typical_len_bytes` preallocated per sample.
    pub fn sensor(typical_len_bytes: usize) -> Self {
        Self {
            buffer: 4,
            max_buffer: 0,
            overflow: OverflowPolicy::DropOldest,
            history: 1,
            initial_max_len_bytes: typical_len_bytes.max(1),
            max_len_bytes: 64 << 20,
            max_held: 4,
            max_subscribers: 16,
            max_publishers: 4,
        }
    }

    /// A stream where every message matters (decisions, health, logs): 64 samples of
    /// buffer, block the publisher up to 100 ms per slow subscriber, no history.
    pub fn reliable(typical_len_bytes: usize) -> Self {
        Self {
            buffer: 64,
            overflow: OverflowPolicy::Block {
                max_wait: Duration::from_millis(100),
            },
            history: 0,
            ..Self::sensor(typical_len_bytes)
        }
    }

    /// The same channel for a subscriber that takes the deepest buffer it allows: a reader
    /// that must not lose a sample while it is not scheduled for a while (the recorder).
    #[must_use]
    pub fn deepest(&self) -> Self {
        Self {
            buffer: self.service_buffer(),
            ..self.clone()
        }
    }

    /// The deepest buffer the channel allows, as iceoryx2 is told.
    fn service_buffer(&self) -> usize {
        self.buffer.max(self.max_buffer).max(1)
    }

    fn max_nodes(&self) -> usize {
        self.max_subscribers + self.max_publishers
    }
}

impl Default for ChannelConfig {
    /// [`ChannelConfig::sensor`] with 4 KiB per sample.
    fn default() -> Self {
        Self::sensor(4096)
    }
}

/// The header iceoryx2 carries next to every payload: a per-publisher sequence number, from
/// which subscribers count lost samples whatever the overflow policy.
#[derive(Debug, Default, Clone, Copy, ZeroCopySend)]
#[repr(C)]
pub(crate) struct FrameHeader {
    seq: u64,
}

type PubSubFactory = publish_subscribe::PortFactory<ipc::Service, [u8], FrameHeader>;

/// Why a message could not be published.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PublishError {
    /// The message is longer than the channel's `max_len_bytes`.
    #[error(
        "message of {len_bytes} bytes on channel `{channel}` exceeds its limit of {max_len_bytes} bytes: raise max_len_bytes in its ChannelConfig"
    )]
    TooLarge {
        /// The channel.
        channel: String,
        /// The message length.
        len_bytes: usize,
        /// The channel's limit.
        max_len_bytes: usize,
    },
    /// No shared memory could be loaned (out of memory or too many loans).
    #[error("cannot loan {len_bytes} bytes of shared memory on channel `{channel}`: {reason}")]
    Loan {
        /// The channel.
        channel: String,
        /// The message length.
        len_bytes: usize,
        /// What iceoryx2 said.
        reason: String,
    },
    /// The sample could not be delivered to every subscriber.
    #[error("cannot deliver on channel `{channel}`: {reason}")]
    Send {
        /// The channel.
        channel: String,
        /// What iceoryx2 said.
        reason: String,
    },
    /// The sample was delivered but subscribers blocked in a wait may not be woken.
    #[error("sample sent on channel `{channel}` but its subscribers could not be woken: {reason}")]
    Notify {
        /// The channel.
        channel: String,
        /// What iceoryx2 said.
        reason: String,
    },
}

/// Why a sample could not be received.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ReceiveError {
    /// The subscriber already holds `max_held` samples: drop some [`Received`] first.
    #[error(
        "subscriber of channel `{channel}` already holds {max_held} samples: drop some before receiving more, or raise max_held"
    )]
    TooManyHeld {
        /// The channel.
        channel: String,
        /// The channel's `max_held`.
        max_held: usize,
    },
    /// The connection to a publisher failed.
    #[error("subscriber of channel `{channel}` lost a publisher connection: {reason}")]
    Connection {
        /// The channel.
        channel: String,
        /// What iceoryx2 said.
        reason: String,
    },
}

/// The result of a publication.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Published {
    /// The sequence number the sample carried (0 for a publisher's first sample).
    pub seq: u64,
    /// How many subscribers received it.
    pub delivered_to: usize,
}

/// A loaned sample of the channel, written and not yet sent.
type Loan = SampleMut<ipc::Service, [u8], FrameHeader>;

/// The sending end of a data channel.
pub struct Publisher {
    channel: String,
    /// The channel itself, which knows who is attached to it.
    service: PubSubFactory,
    port: IoxPublisher<ipc::Service, [u8], FrameHeader>,
    notifier: Notifier<ipc::Service>,
    next_seq: u64,
    max_len_bytes: usize,
    discarded: Arc<AtomicU64>,
    /// The length of the last publication.
    last_len: usize,
    /// A sample of `last_len` bytes loaned after the last publication, when the two before
    /// it had the same length: the next publication of that length writes into it, so the
    /// loan (its pass over the subscribers' returned samples and the pool) is not on the
    /// way from the message to its subscribers.
    spare: Option<Loan>,
    /// Where it notes what it sent, for a reader after a crash ([`super::ledger`]).
    ledger: Option<LedgerSlot>,
}

impl fmt::Debug for Publisher {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Publisher")
            .field("channel", &self.channel)
            .field("next_seq", &self.next_seq)
            .finish_non_exhaustive()
    }
}

impl Publisher {
    /// How many subscribers the channel has now, in every process of the namespace: a
    /// bridge forwards a channel from another host only while someone here reads it.
    #[must_use]
    pub fn subscribers(&self) -> usize {
        self.service.dynamic_config().number_of_subscribers()
    }

    /// Publishes a message of exactly `len_bytes` bytes: `encode` writes it in place into
    /// loaned shared memory (no copy), then it is sent and the subscribers are woken.
    pub fn publish_with<F: FnOnce(&mut [u8])>(
        &mut self,
        len_bytes: usize,
        encode: F,
    ) -> Result<Published, PublishError> {
        if len_bytes > self.max_len_bytes {
            return Err(PublishError::TooLarge {
                channel: self.channel.clone(),
                len_bytes,
                max_len_bytes: self.max_len_bytes,
            });
        }
        // A spare of another length goes back to the pool before the new loan.
        let spare = self.spare.take().filter(|s| s.payload().len() == len_bytes);
        let mut sample = match spare {
            Some(spare) => spare,
            None => self.loan(len_bytes)?,
        };
        let seq = self.next_seq;
        sample.user_header_mut().seq = seq;
        encode(sample.payload_mut());
        // A failed send still consumes the number: subscribers then count it as lost.
        self.next_seq += 1;
        let delivered_to = sample.send().map_err(|e| PublishError::Send {
            channel: self.channel.clone(),
            reason: e.to_string(),
        })?;
        if let Some(ledger) = &self.ledger {
            ledger.note(self.next_seq);
        }
        self.notifier.notify().map_err(|e| PublishError::Notify {
            channel: self.channel.clone(),
            reason: e.to_string(),
        })?;
        // A stream of one length (a sensor's) gets its next loan now, after its subscribers
        // have this sample. Only after two publications of one length in a row: a stream
        // whose length changes every time would return every spare unused.
        if len_bytes == self.last_len {
            self.spare = self.loan(len_bytes).ok();
        }
        self.last_len = len_bytes;
        Ok(Published { seq, delivered_to })
    }

    fn loan(&self, len_bytes: usize) -> Result<Loan, PublishError> {
        let sample = self
            .port
            .loan_slice_uninit(len_bytes)
            .map_err(|e| PublishError::Loan {
                channel: self.channel.clone(),
                len_bytes,
                reason: e.to_string(),
            })?;
        // SAFETY: the payload is `u8`s in a shared-memory segment that iceoryx2 maps with
        // mmap: fresh pages are zero-filled by the kernel and recycled chunks hold the bytes
        // of an earlier payload, so every byte already holds a valid `u8`. Only `u8` payloads
        // are ever written to these segments (the payload type is fixed to `[u8]`). Skipping
        // the zero-fill keeps a 1 MiB publication at one write of the payload.
        Ok(unsafe { sample.assume_init() })
    }

    /// Publishes `message` as CDR written in place, its header stamped first: sent by
    /// `provider`, its `seq`-th publication, at `publish_time_ns`. The framework's own
    /// channels (broker decisions, CPU measurements, heartbeats, command logs, unanswered
    /// calls) publish through here, so that a reader sees who sent each message, in which
    /// order, and when.
    pub fn publish_stamped<M: Message>(
        &mut self,
        message: &mut M,
        provider: &str,
        seq: u64,
        publish_time_ns: i64,
    ) -> Result<Published, PublishError> {
        let header = message.header_mut();
        provider.clone_into(&mut header.provider);
        header.seq = seq;
        header.publish_time_ns = publish_time_ns;
        // The buffer is exactly `encoded_len` long, so encoding into it cannot fail.
        self.publish_with(cdr::encoded_len(&*message), |buf| {
            let _ = cdr::encode_into(&*message, buf);
        })
    }

    /// Publishes a copy of `bytes`.
    pub fn publish(&mut self, bytes: &[u8]) -> Result<Published, PublishError> {
        self.publish_with(bytes.len(), |buf| buf.copy_from_slice(bytes))
    }

    /// Connects the subscribers that joined since the last publication, hands them the
    /// channel's history and wakes them. Publishing does this by itself; a publisher that
    /// publishes rarely calls it now and then (on its ticks) so that late joiners get the
    /// history without waiting for the next sample.
    pub fn update_connections(&self) -> Result<(), PublishError> {
        self.port
            .update_connections()
            .map_err(|e| PublishError::Send {
                channel: self.channel.clone(),
                reason: format!("{e:?}"),
            })?;
        self.notifier.notify().map_err(|e| PublishError::Notify {
            channel: self.channel.clone(),
            reason: e.to_string(),
        })?;
        Ok(())
    }

    /// The channel name.
    pub fn channel(&self) -> &str {
        &self.channel
    }

    /// Deliveries dropped because a subscriber's buffer was full
    /// ([`OverflowPolicy::DropNewest`] and [`OverflowPolicy::Block`]; always 0 with
    /// [`OverflowPolicy::DropOldest`], where subscribers count instead).
    pub fn discarded(&self) -> u64 {
        self.discarded.load(Ordering::Relaxed)
    }
}

/// The receiving end of a data channel.
pub struct Subscriber {
    channel: String,
    port: IoxSubscriber<ipc::Service, [u8], FrameHeader>,
    listener: Listener<ipc::Service>,
    max_held: usize,
    /// The last sequence number seen from each publisher, most recently seen last; bounded
    /// to `tracked_publishers` entries (the oldest is forgotten).
    last_seq: Vec<(u128, u64)>,
    tracked_publishers: usize,
    lost: u64,
    /// When it was made, in ns since 1970: a publisher made later owed it every sample.
    created_ns: i64,
}

impl fmt::Debug for Subscriber {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Subscriber")
            .field("channel", &self.channel)
            .field("lost", &self.lost)
            .finish_non_exhaustive()
    }
}

impl Subscriber {
    /// Takes the oldest unread sample, if any, without copying it.
    pub fn receive(&mut self) -> Result<Option<Received>, ReceiveError> {
        match self.port.receive() {
            Ok(Some(sample)) => {
                self.account(
                    sample.header().publisher_id().value(),
                    sample.user_header().seq,
                );
                Ok(Some(Received { sample }))
            }
            Ok(None) => Ok(None),
            Err(iceoryx2::port::ReceiveError::ExceedsMaxBorrows) => {
                Err(ReceiveError::TooManyHeld {
                    channel: self.channel.clone(),
                    max_held: self.max_held,
                })
            }
            Err(e) => Err(ReceiveError::Connection {
                channel: self.channel.clone(),
                reason: e.to_string(),
            }),
        }
    }

    /// Takes the newest unread sample and releases the older ones (skipped on purpose,
    /// not counted as lost).
    pub fn latest(&mut self) -> Result<Option<Received>, ReceiveError> {
        // Holds two samples for a moment (the newest so far and the next one): hence
        // `max_held` of at least 2.
        let mut newest = None;
        while let Some(sample) = self.receive()? {
            newest = Some(sample);
        }
        Ok(newest)
    }

    /// The unread samples, oldest first; each is released when dropped (holding more than
    /// `max_held` at once gives [`ReceiveError::TooManyHeld`]).
    pub fn drain(&mut self) -> Drain<'_> {
        Drain { subscriber: self }
    }

    /// Whether unread samples are waiting (no system call).
    pub fn has_data(&self) -> bool {
        // A connection failure reports true so that the caller's next receive returns it.
        self.port.has_samples().unwrap_or(true)
    }

    /// Samples this subscriber never received: gaps in the publishers' sequence numbers,
    /// from overflow or failed deliveries. Samples skipped by [`Subscriber::latest`] do not
    /// count.
    pub fn lost(&self) -> u64 {
        self.lost
    }

    /// The channel name.
    pub fn channel(&self) -> &str {
        &self.channel
    }

    /// The samples that `ended`, a publisher of this channel whose process has died, sent
    /// to this subscriber after the last one it received: unread when the publisher's
    /// memory went, they never arrive and no later sample shows the gap. Take what can
    /// still be received first. A publisher made before this subscriber and never heard
    /// from owed it nothing; one made after it owed it everything it sent. The publisher
    /// is forgotten, so that it is counted once.
    pub fn publisher_ended(&mut self, ended: &EndedPublisher) -> u64 {
        if ended.channel != self.channel {
            return 0;
        }
        match self
            .last_seq
            .iter()
            .position(|(p, _)| *p == ended.publisher_id)
        {
            Some(pos) => {
                let (_, last) = self.last_seq.remove(pos);
                ended.sent.saturating_sub(last + 1)
            }
            None if ended.created_ns >= self.created_ns => ended.sent,
            None => 0,
        }
    }

    fn account(&mut self, publisher: u128, seq: u64) {
        if let Some(pos) = self.last_seq.iter().position(|(p, _)| *p == publisher) {
            let (_, last) = self.last_seq.remove(pos);
            // A sequence number at or below the last one is a history replay, not a loss.
            if seq > last {
                self.lost += seq - last - 1;
            }
            self.last_seq.push((publisher, seq.max(last)));
        } else {
            if self.last_seq.len() >= self.tracked_publishers {
                self.last_seq.remove(0);
            }
            // The first sample seen from a publisher is the baseline: what it sent before
            // this subscriber joined was never owed to it.
            self.last_seq.push((publisher, seq));
        }
    }
}

/// The unread samples of a [`Subscriber`], oldest first (see [`Subscriber::drain`]).
#[derive(Debug)]
pub struct Drain<'a> {
    subscriber: &'a mut Subscriber,
}

impl Iterator for Drain<'_> {
    type Item = Result<Received, ReceiveError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.subscriber.receive().transpose()
    }
}

impl wait::sealed::Source for Subscriber {
    fn is_ready(&self) -> bool {
        self.has_data()
    }

    fn wake_fd(&self) -> Option<BorrowedFd<'_>> {
        Some(wait::listener_fd(&self.listener))
    }

    fn drain_wake(&self) {
        wait::drain_listener(&self.listener);
    }
}

impl Waitable for Subscriber {}

/// A received sample, borrowed from shared memory until dropped.
pub struct Received {
    sample: Sample<ipc::Service, [u8], FrameHeader>,
}

impl Received {
    /// The message bytes.
    pub fn bytes(&self) -> &[u8] {
        self.sample.payload()
    }

    /// The sequence number its publisher gave it.
    pub fn seq(&self) -> u64 {
        self.sample.user_header().seq
    }

    /// The id of the publisher that sent it (unique on this machine).
    pub fn publisher_id(&self) -> u128 {
        self.sample.header().publisher_id().value()
    }
}

impl Deref for Received {
    type Target = [u8];

    fn deref(&self) -> &[u8] {
        self.bytes()
    }
}

impl AsRef<[u8]> for Received {
    fn as_ref(&self) -> &[u8] {
        self.bytes()
    }
}

impl fmt::Debug for Received {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Received")
            .field("seq", &self.seq())
            .field("len_bytes", &self.bytes().len())
            .finish()
    }
}

impl Ipc {
    fn open_channel(
        &self,
        channel: &str,
        config: &ChannelConfig,
    ) -> Result<(PubSubFactory, event::PortFactory<ipc::Service>), IpcError> {
        let name = service_name("channel", FAMILY, channel)?;
        let data = self
            .node()
            .service_builder(&name)
            .publish_subscribe::<[u8]>()
            .user_header::<FrameHeader>()
            .enable_safe_overflow(config.overflow == OverflowPolicy::DropOldest)
            .subscriber_max_buffer_size(config.service_buffer())
            .subscriber_max_borrowed_samples(config.max_held.max(2))
            .history_size(config.history)
            .max_subscribers(config.max_subscribers.max(1))
            .max_publishers(config.max_publishers.max(1))
            .max_nodes(config.max_nodes())
            .open_or_create()
            .map_err(|e| self.service_error("channel", channel, e))?;
        let events = self
            .node()
            .service_builder(&name)
            .event()
            .max_listeners(config.max_subscribers.max(1))
            .max_notifiers(config.max_publishers.max(1))
            .max_nodes(config.max_nodes())
            .open_or_create()
            .map_err(|e| self.service_error("channel event", channel, e))?;
        Ok((data, events))
    }

    /// Opens (or creates) the data channel `channel` and publishes on it.
    pub fn publisher(&self, channel: &str, config: &ChannelConfig) -> Result<Publisher, IpcError> {
        let (data, events) = self.open_channel(channel, config)?;
        let discarded = Arc::new(AtomicU64::new(0));
        let builder = data
            .publisher_builder()
            .initial_max_slice_len(config.initial_max_len_bytes.max(1))
            .allocation_strategy(AllocationStrategy::PowerOfTwo);
        let builder = match config.overflow {
            // With safe overflow a subscriber buffer is never full: nothing to decide here.
            OverflowPolicy::DropOldest => builder,
            OverflowPolicy::DropNewest => {
                let discarded = Arc::clone(&discarded);
                builder
                    .backpressure_strategy(BackpressureStrategy::DiscardData)
                    .set_backpressure_handler(move |_: &BackpressureInfo| {
                        discarded.fetch_add(1, Ordering::Relaxed);
                        BackpressureAction::DiscardData
                    })
            }
            OverflowPolicy::Block { max_wait } => {
                let discarded = Arc::clone(&discarded);
                builder
                    .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
                    .set_backpressure_handler(move |info: &BackpressureInfo| {
                        if info.elapsed_time < max_wait {
                            BackpressureAction::Retry
                        } else {
                            discarded.fetch_add(1, Ordering::Relaxed);
                            BackpressureAction::DiscardData
                        }
                    })
            }
        };
        let port = builder
            .create()
            .map_err(|e| port_error("publisher", channel, e))?;
        let notifier = events
            .notifier_builder()
            .create()
            .map_err(|e| port_error("notifier", channel, e))?;
        let ledger = self
            .ledger
            .get_or_init(|| LedgerFile::create(&self.namespace))
            .as_ref()
            .and_then(|file| file.slot(channel, port.id().value()));
        Ok(Publisher {
            channel: channel.to_owned(),
            service: data,
            port,
            notifier,
            next_seq: 0,
            max_len_bytes: config.max_len_bytes,
            discarded,
            last_len: 0,
            spare: None,
            ledger,
        })
    }

    /// Opens (or creates) the data channel `channel` and subscribes to it. Samples published
    /// before this call are not received, except the channel's history.
    pub fn subscriber(
        &self,
        channel: &str,
        config: &ChannelConfig,
    ) -> Result<Subscriber, IpcError> {
        let (data, events) = self.open_channel(channel, config)?;
        // The listener first: a sample published between the two creations then still
        // wakes us.
        let listener = events
            .listener_builder()
            .create()
            .map_err(|e| port_error("listener", channel, e))?;
        let port = data
            .subscriber_builder()
            .buffer_size(config.buffer.max(1))
            .create()
            .map_err(|e| port_error("subscriber", channel, e))?;
        Ok(Subscriber {
            channel: channel.to_owned(),
            port,
            listener,
            max_held: config.max_held.max(2),
            last_seq: Vec::new(),
            tracked_publishers: 4 * config.max_publishers.max(1),
            lost: 0,
            created_ns: crate::clock::wall_ns(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ipc::Namespace;

    fn ipc(tag: &str) -> Ipc {
        Ipc::open(&Namespace::unique(tag), "test").unwrap()
    }

    #[test]
    fn loss_accounting_counts_gaps_per_publisher_and_ignores_replays() {
        fn check(seen: &[(u128, u64)], expected_lost: u64) {
            let ipc = ipc("loss");
            let mut sub = ipc.subscriber("x", &ChannelConfig::default()).unwrap();
            for (publisher, seq) in seen {
                sub.account(*publisher, *seq);
            }
            assert_eq!(sub.lost(), expected_lost, "{seen:?}");
        }
        check(&[(1, 0), (1, 1), (1, 2)], 0);
        check(&[(1, 5)], 0);
        check(&[(1, 0), (1, 3)], 2);
        check(&[(1, 0), (2, 10), (1, 1), (2, 12)], 1);
        check(&[(1, 4), (1, 2), (1, 5)], 0);
    }

    #[test]
    fn an_ended_publisher_owes_what_it_sent_after_the_last_sample_received() {
        let namespace = Namespace::unique("ended");
        let ipc = Ipc::open(&namespace, "pub").unwrap();
        let other = Ipc::open(&namespace, "sub").unwrap();
        let config = ChannelConfig::reliable(16);
        let mut sub = other.subscriber("scan", &config).unwrap();
        let mut publisher = ipc.publisher("scan", &config).unwrap();
        for i in 0..5_u8 {
            publisher.publish(&[i]).unwrap();
        }
        let first = sub.receive().unwrap().unwrap();
        let id = first.publisher_id();
        assert_eq!(first.bytes(), [0]);
        drop(first);
        assert_eq!(sub.receive().unwrap().unwrap().bytes(), [1]);
        let ended = |channel: &str, publisher_id, created_ns| EndedPublisher {
            channel: channel.to_owned(),
            publisher_id,
            sent: 5,
            created_ns,
        };
        assert_eq!(sub.publisher_ended(&ended("other", id, 0)), 0);
        // Samples 2, 3 and 4 were sent after the last one received (1).
        assert_eq!(sub.publisher_ended(&ended("scan", id, 0)), 3);
        // Counted once: forgotten, and made before the subscriber.
        assert_eq!(sub.publisher_ended(&ended("scan", id, 0)), 0);
        // Never heard from and made after the subscriber: everything it sent.
        assert_eq!(sub.publisher_ended(&ended("scan", id + 1, i64::MAX)), 5);
    }

    #[test]
    fn a_message_over_the_limit_is_refused_before_any_loan() {
        let ipc = ipc("limit");
        let config = ChannelConfig {
            max_len_bytes: 10,
            ..ChannelConfig::default()
        };
        let mut publisher = ipc.publisher("small", &config).unwrap();
        assert_eq!(
            publisher.publish(&[0; 11]),
            Err(PublishError::TooLarge {
                channel: "small".into(),
                len_bytes: 11,
                max_len_bytes: 10
            })
        );
    }
}
