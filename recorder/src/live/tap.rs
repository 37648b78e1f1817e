//! The loop that takes every sample of the tapped channels and offers its bytes to the
//! recorder's [`Tap`], unchanged.

use std::os::fd::AsFd;
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::Header;
use lewis_runtime::clock::LiveClock;
use lewis_runtime::ipc::{
    FdSource, Ipc, LedgerReader, MAX_WAIT_SOURCES, Subscriber, WaitSet, Waitable, WakeMode,
};
use lewis_runtime::live::StopSignals;

use super::LiveError;
use super::discover::{Discovered, Discovery};
use super::plan::{TapChannel, TopicFilter, robot_channels};
use crate::channel::{ChannelId, Sample};
use crate::queue::{Dropped, Tap, WriterThread};

/// How often the loop looks whether the writer thread has stopped (a full disk) while no
/// sample comes: the writer has no descriptor to wait on.
const WRITER_CHECK: Duration = Duration::from_millis(200);

/// How often the loop looks for publishers whose process died (their ledgers).
const LEDGER_LOOK: Duration = Duration::from_millis(500);

/// Samples of one channel that iceoryx2 may fail to map in one turn before the tap leaves
/// the channel for the next turn.
const UNMAPPED_RETRIES: u32 = 1024;

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
    /// Samples the tap never received: its IPC buffer overflowed (dropped and counted too).
    pub missed: u64,
    /// Samples whose bytes did not start with a valid header (recorded anyway, with the
    /// receive time as publish time and sequence number 0).
    pub headerless: u64,
    /// Samples a provider sent before it died that never arrived (counted lost).
    pub lost_at_exit: u64,
}

struct Tapped {
    topic: String,
    subscriber: Subscriber,
    id: ChannelId,
    /// What the subscriber had counted as missed when last looked at.
    missed: u64,
}

/// Channels added while the loop runs: those of a robot whose broker answers later.
pub struct Growth {
    /// Asks the broker which robot it runs.
    pub discovery: Discovery,
    /// The topics to keep of that robot.
    pub topics: TopicFilter,
}

/// The subscribers of the tapped channels, each paired with its recorder channel.
pub struct LiveTap {
    channels: Vec<Tapped>,
    clock: LiveClock,
    waits: WaitSet,
    counts: TapCounts,
    growth: Option<Growth>,
    /// The ledgers of the namespace's processes, read as they die.
    ledgers: LedgerReader,
    next_ledger_look: Instant,
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
        let mut live = Self {
            channels: Vec::with_capacity(plan.len()),
            clock,
            waits: WaitSet::new(WakeMode::Event),
            counts: TapCounts::default(),
            growth: None,
            ledgers: LedgerReader::new(ipc.namespace()),
            next_ledger_look: Instant::now() + LEDGER_LOOK,
        };
        live.check_room(plan.len())?;
        for channel in plan {
            live.add(ipc, channel, tap)?;
        }
        Ok(live)
    }

    /// Lets the loop add the channels of the robot that `growth` finds.
    pub fn grow_with(&mut self, growth: Growth) {
        self.growth = Some(growth);
    }

    /// Whether `count` more channels fit in one wait beside the stop signals and the
    /// broker's answer.
    fn check_room(&self, count: usize) -> Result<(), LiveError> {
        let max = MAX_WAIT_SOURCES - 2;
        let total = self.channels.len() + count;
        if total > max {
            return Err(LiveError::TooManyChannels { count: total, max });
        }
        Ok(())
    }

    /// Subscribes to `channel` and registers it with `tap`.
    fn add(&mut self, ipc: &Ipc, channel: &TapChannel, tap: &Tap) -> Result<(), LiveError> {
        let subscriber = ipc.subscriber(channel.topic(), &channel.config)?;
        self.channels.push(Tapped {
            topic: channel.topic().to_owned(),
            subscriber,
            id: tap.register(channel.spec.clone()),
            missed: 0,
        });
        Ok(())
    }

    /// Taps the channels of a robot found from its broker that are not tapped yet, and
    /// hands its description to the writer. A channel that cannot be opened is said and
    /// left out: the others are still recorded.
    fn adopt(&mut self, ipc: &Ipc, tap: &Tap, found: Discovered) {
        let topics = self.growth.as_ref().map(|g| &g.topics);
        let plan: Vec<TapChannel> = robot_channels(Some(&found.robot))
            .into_iter()
            .filter(|c| topics.is_none_or(|t| t.matches(c.topic())))
            .filter(|c| !self.channels.iter().any(|t| t.topic == c.topic()))
            .collect();
        // Before the channels: the writer stores it before their first message.
        tap.set_robot_description(found.description);
        if let Err(e) = self.check_room(plan.len()) {
            tracing::error!("{e}");
            return;
        }
        let mut added = 0;
        for channel in &plan {
            match self.add(ipc, channel, tap) {
                Ok(()) => added += 1,
                Err(e) => tracing::error!("{} is not recorded: {e}", channel.topic()),
            }
        }
        tracing::info!(
            "robot `{}` found from its broker: {added} more topics recorded",
            found.robot.name
        );
    }

    /// Offers every sample to `tap` until a stop signal, `end`, or the writer stops.
    ///
    /// # Errors
    /// When waiting fails.
    pub fn run(
        &mut self,
        ipc: &Ipc,
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
                self.count_lost_at_exit(tap);
                return Ok(Ended::Signal);
            }
            if !self.take_all(tap) || writer.is_finished() {
                return Ok(Ended::WriterStopped);
            }
            let now = Instant::now();
            if now >= self.next_ledger_look {
                self.count_lost_at_exit(tap);
                self.next_ledger_look = now + LEDGER_LOOK;
            }
            if end.is_some_and(|e| now >= e) {
                return Ok(Ended::Duration);
            }
            if let Some(found) = self.growth.as_mut().and_then(|g| g.discovery.poll(now)) {
                self.adopt(ipc, tap, found);
            }
            let next_ask = self.growth.as_ref().and_then(|g| g.discovery.next_ask());
            let deadline = [Some(now + WRITER_CHECK), end, next_ask]
                .into_iter()
                .flatten()
                .min()
                .unwrap_or(now + WRITER_CHECK);
            let signal_fd = FdSource::new(signals.as_fd());
            let mut sources: Vec<&dyn Waitable> = Vec::with_capacity(self.channels.len() + 2);
            sources.push(&signal_fd);
            sources.extend(self.growth.as_ref().and_then(|g| g.discovery.waitable()));
            sources.extend(self.channels.iter().map(|c| &c.subscriber as &dyn Waitable));
            // Whatever woke it, the next turn looks at everything.
            self.waits.wait(&sources, Some(deadline))?;
        }
    }

    /// Counts, for each publisher whose process died since the last look, the samples it
    /// sent that never arrived.
    fn count_lost_at_exit(&mut self, tap: &Tap) {
        let ended = self.ledgers.ended();
        if ended.is_empty() {
            return;
        }
        // The processes are dead: what they sent is all in the buffers now. What can
        // still be received is taken first, so that only the rest counts.
        self.take(tap, |topic| ended.iter().any(|e| e.channel == topic));
        for ended in ended {
            for channel in self
                .channels
                .iter_mut()
                .filter(|c| c.topic == ended.channel)
            {
                let lost = channel.subscriber.publisher_ended(&ended);
                if lost > 0 {
                    tracing::warn!(
                        "{lost} messages on {} that its provider sent before it died never arrived",
                        channel.topic
                    );
                    tap.count_lost_at_exit(channel.id, lost);
                    self.counts.lost_at_exit += lost;
                }
            }
        }
    }

    /// What the loop counted.
    #[must_use]
    pub fn counts(&self) -> TapCounts {
        self.counts
    }

    /// Takes every unread sample of every channel; false when the recorder has stopped.
    fn take_all(&mut self, tap: &Tap) -> bool {
        self.take(tap, |_| true)
    }

    /// Takes every unread sample of the channels whose topic is `wanted`; false when the
    /// recorder has stopped.
    fn take(&mut self, tap: &Tap, wanted: impl Fn(&str) -> bool) -> bool {
        let mut running = true;
        // One hand-over to the writer for everything taken in this turn.
        let mut batch = tap.batch();
        for channel in &mut self.channels {
            // A look at shared memory, cheaper than a receive that finds nothing.
            if !wanted(&channel.topic) || !channel.subscriber.has_data() {
                continue;
            }
            // Each unmappable sample is released as it is met, so looking again ends; the
            // bound is a guard against a subscriber that says it has data and gives none.
            let mut unmapped = 0;
            loop {
                let received = match channel.subscriber.receive() {
                    Ok(Some(received)) => received,
                    // Nothing, or a sample iceoryx2 could not map (its publisher is gone
                    // with its memory; a later sample shows the gap): look again.
                    Ok(None) if unmapped < UNMAPPED_RETRIES && channel.subscriber.has_data() => {
                        unmapped += 1;
                        continue;
                    }
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
                if batch.record(&sample) == Err(Dropped::Stopped) {
                    running = false;
                }
            }
            // Gaps in the IPC publisher's numbering: samples overwritten in the buffer
            // before the tap took them.
            let missed = channel.subscriber.lost();
            if missed > channel.missed {
                tap.count_missed(channel.id, missed - channel.missed);
                self.counts.missed += missed - channel.missed;
                channel.missed = missed;
            }
        }
        if batch.flush() == Err(Dropped::Stopped) {
            running = false;
        }
        self.counts.refused += batch.dropped();
        running
    }
}

/// The header at the start of a CDR message (the first field of every message), without
/// decoding the rest.
fn header_of(bytes: &[u8]) -> Option<Header> {
    cdr::peek_header(bytes).ok()
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
