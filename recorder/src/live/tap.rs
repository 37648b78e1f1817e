//! The loop that takes every sample of the tapped channels and offers its bytes to the
//! recorder's [`Tap`], unchanged.

use std::os::fd::AsFd;
use std::time::{Duration, Instant};

use lewis_interfaces::cdr::{self, Decode, Reader};
use lewis_interfaces::msg::Header;
use lewis_runtime::clock::LiveClock;
use lewis_runtime::ipc::{
    FdSource, Ipc, MAX_WAIT_SOURCES, Subscriber, WaitSet, Waitable, WakeMode,
};
use lewis_runtime::live::StopSignals;

use super::LiveError;
use super::plan::TapChannel;
use crate::channel::{ChannelId, Sample};
use crate::queue::{Dropped, Tap, WriterThread};

/// How often the loop looks whether the writer thread has stopped (a full disk) while no
/// sample comes: the writer has no descriptor to wait on.
const WRITER_CHECK: Duration = Duration::from_millis(200);

/// Why the loop ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// SIGTERM or SIGINT.
    Signal,
    /// The duration given passed.
    Duration,
    /// The writer thread stopped by itself (an error: [`WriterThread::finish`] says which).
    WriterStopped,
}

/// Counts of the loop, for the report.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TapCounts {
    /// Samples offered to the recorder.
    pub offered: u64,
    /// Samples the recorder's queue refused (dropped and counted there).
    pub refused: u64,
    /// Samples whose bytes did not start with a valid header (recorded anyway, with the
    /// receive time as publish time and sequence number 0).
    pub headerless: u64,
}

struct Tapped {
    subscriber: Subscriber,
    id: ChannelId,
}

/// The subscribers of the tapped channels, each paired with its recorder channel.
pub struct LiveTap {
    channels: Vec<Tapped>,
    clock: LiveClock,
    waits: WaitSet,
    counts: TapCounts,
}

impl LiveTap {
    /// Subscribes to every channel of `plan` and registers it with `tap`, in order;
    /// receive times are read on `clock`.
    ///
    /// # Errors
    /// [`LiveError::TooManyChannels`], or a channel that cannot be opened (another process
    /// created it with other settings).
    pub fn subscribe(
        ipc: &Ipc,
        plan: &[TapChannel],
        tap: &Tap,
        clock: LiveClock,
    ) -> Result<Self, LiveError> {
        // One source is the stop signals.
        if plan.len() >= MAX_WAIT_SOURCES {
            return Err(LiveError::TooManyChannels {
                count: plan.len(),
                max: MAX_WAIT_SOURCES - 1,
            });
        }
        let mut channels = Vec::with_capacity(plan.len());
        for channel in plan {
            let subscriber = ipc.subscriber(channel.topic(), &channel.config)?;
            channels.push(Tapped {
                subscriber,
                id: tap.register(channel.spec.clone()),
            });
        }
        Ok(Self {
            channels,
            clock,
            waits: WaitSet::new(WakeMode::Event),
            counts: TapCounts::default(),
        })
    }

    /// Offers every sample to `tap` until a stop signal, `end`, or the writer stops.
    ///
    /// # Errors
    /// When waiting fails.
    pub fn run(
        &mut self,
        tap: &Tap,
        writer: &WriterThread,
        signals: &StopSignals,
        end: Option<Instant>,
    ) -> Result<Ended, LiveError> {
        loop {
            if signals.take() {
                // What the publishers sent before the stop (the services stop first) is
                // still in the buffers.
                self.take_all(tap);
                return Ok(Ended::Signal);
            }
            if !self.take_all(tap) || writer.is_finished() {
                return Ok(Ended::WriterStopped);
            }
            let now = Instant::now();
            if end.is_some_and(|e| now >= e) {
                return Ok(Ended::Duration);
            }
            let check = now + WRITER_CHECK;
            let deadline = end.map_or(check, |e| e.min(check));
            let signal_fd = FdSource::new(signals.as_fd());
            let mut sources: Vec<&dyn Waitable> = Vec::with_capacity(self.channels.len() + 1);
            sources.push(&signal_fd);
            sources.extend(self.channels.iter().map(|c| &c.subscriber as &dyn Waitable));
            // Whatever woke it, the next turn looks at everything.
            self.waits.wait(&sources, Some(deadline))?;
        }
    }

    /// What the loop counted.
    #[must_use]
    pub fn counts(&self) -> TapCounts {
        self.counts
    }

    /// Takes every unread sample of every channel; false when the recorder has stopped.
    fn take_all(&mut self, tap: &Tap) -> bool {
        let mut running = true;
        for channel in &mut self.channels {
            // A look at shared memory, cheaper than a receive that finds nothing.
            if !channel.subscriber.has_data() {
                continue;
            }
            loop {
                let received = match channel.subscriber.receive() {
                    Ok(Some(received)) => received,
                    Ok(None) => break,
                    Err(e) => {
                        tracing::warn!("{e}");
                        break;
                    }
                };
                let log_time_ns = self.clock.now_ns();
                let bytes = received.bytes();
                let (seq, publish_time_ns) = match header_of(bytes) {
                    Some(header) => (header.seq, header.publish_time_ns),
                    None => {
                        self.counts.headerless += 1;
                        (0, log_time_ns)
                    }
                };
                self.counts.offered += 1;
                let sample = Sample {
                    channel: channel.id,
                    seq,
                    publish_time_ns,
                    log_time_ns,
                    data: bytes,
                };
                match tap.try_record(&sample) {
                    Ok(()) => {}
                    Err(Dropped::QueueFull) => self.counts.refused += 1,
                    Err(Dropped::Stopped) => {
                        self.counts.refused += 1;
                        running = false;
                    }
                }
            }
        }
        running
    }
}

/// The header at the start of a CDR message (the first field of every message), without
/// decoding the rest.
fn header_of(bytes: &[u8]) -> Option<Header> {
    let payload = bytes.strip_prefix(&cdr::ENCAPSULATION_LE[..])?;
    Header::decode(&mut Reader::new(payload)).ok()
}

#[cfg(test)]
mod tests {
    use lewis_interfaces::msg::Distance;
    use lewis_interfaces::{Message, cdr};

    use super::*;

    #[test]
    fn the_header_is_read_from_the_message_bytes() {
        let mut message = Distance::default();
        message.header_mut().seq = 42;
        message.header_mut().publish_time_ns = 1_700_000_000_123;
        message.header_mut().provider = "sonar".into();
        let header = header_of(&cdr::to_vec(&message)).unwrap();
        assert_eq!(
            (header.seq, header.publish_time_ns, header.provider.as_str()),
            (42, 1_700_000_000_123, "sonar")
        );
    }

    #[test]
    fn bytes_without_a_header_give_none() {
        fn check(bytes: &[u8]) {
            assert_eq!(header_of(bytes), None, "{bytes:?}");
        }
        check(&[]);
        check(&[0, 1, 0]);
        check(&[0, 1, 0, 0, 200, 0, 0, 0]);
        check(b"not cdr at all");
    }
}
