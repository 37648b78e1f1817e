//! Loss accounting from sequence numbers: a provider numbers its messages 1, 2, 3, ... per
//! channel, so a gap is a loss, wherever it happened (the provider's queue, shared memory,
//! the recorder's own queue).
//!
//! The rules, for the sequence number `seq` of the next message seen on a channel whose
//! last one was `last`:
//! - the first message of a channel counts no loss: what was published before the
//!   recorder subscribed was not lost by it;
//! - `seq == last + 1`: nothing lost;
//! - `seq > last + 1`: `seq - last - 1` lost;
//! - `seq <= 1`: the provider restarted (a new run numbered from 1): no loss;
//! - `1 < seq <= last`: the provider restarted and the first `seq - 1` messages of its new
//!   run were lost (a channel is delivered in order, so this is the only way back);
//! - `seq == 0`: the message has no readable header (garbage on the wire, a provider's
//!   bytes that do not decode). It was received and recorded all the same: it stands for
//!   one of the numbers missing before the next numbered message, which are that many
//!   fewer losses.
//!
//! Messages lost at the very end of a run cannot be seen from numbers alone: the live tap
//! reads what a dead provider sent from its publication ledger
//! (`lewis_runtime::ipc::LedgerReader`) and counts the rest as lost
//! ([`crate::Tap::count_lost_at_exit`]). The recorder's own drops are also counted where
//! they happen ([`crate::Tap`]).

/// What one sequence number meant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Observation {
    /// The first message seen on the channel.
    First,
    /// The next one, nothing lost.
    Next,
    /// This many messages are missing before it.
    Gap(u64),
    /// The provider started a new run; this many of its first messages are missing.
    Restart(u64),
}

impl Observation {
    /// Messages this observation proves lost.
    #[must_use]
    pub fn lost(self) -> u64 {
        match self {
            Self::First | Self::Next => 0,
            Self::Gap(n) | Self::Restart(n) => n,
        }
    }
}

/// The last sequence number seen on one channel.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SequenceTracker {
    last: Option<u64>,
    /// Messages without a number since the last numbered one.
    unnumbered: u64,
}

impl SequenceTracker {
    /// Accounts for the next sequence number seen (0: a message without a readable
    /// header).
    pub fn observe(&mut self, seq: u64) -> Observation {
        if seq == 0 {
            self.unnumbered = self.unnumbered.saturating_add(1);
            return Observation::Next;
        }
        let unnumbered = std::mem::take(&mut self.unnumbered);
        let observation = match self.last {
            None => Observation::First,
            Some(last) if seq == last.wrapping_add(1) => Observation::Next,
            Some(last) if seq > last => match (seq - last - 1).saturating_sub(unnumbered) {
                0 => Observation::Next,
                lost => Observation::Gap(lost),
            },
            Some(_) => Observation::Restart(seq.saturating_sub(1).saturating_sub(unnumbered)),
        };
        self.last = Some(seq);
        observation
    }

    /// The last sequence number seen, if any.
    #[must_use]
    pub fn last(&self) -> Option<u64> {
        self.last
    }
}

/// What was counted on one channel.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ChannelCounts {
    /// Messages written.
    pub written: u64,
    /// Messages known lost (sequence gaps).
    pub lost: u64,
    /// Messages the recorder's queue dropped.
    pub dropped: u64,
    /// New runs of the provider (sequence back to 1).
    pub restarts: u64,
}

impl ChannelCounts {
    /// Adds one observation of a written message.
    pub fn add(&mut self, observation: Observation) {
        // Saturating: the numbers come from files and other processes, and a wild one
        // must be counted, not panic the recorder.
        self.written = self.written.saturating_add(1);
        self.lost = self.lost.saturating_add(observation.lost());
        if matches!(observation, Observation::Restart(_)) {
            self.restarts = self.restarts.saturating_add(1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(sequence: &[u64], expected: &[Observation]) {
        let mut tracker = SequenceTracker::default();
        let got: Vec<Observation> = sequence.iter().map(|&s| tracker.observe(s)).collect();
        assert_eq!(got, expected, "sequence {sequence:?}");
    }

    use Observation::{First, Gap, Next, Restart};

    #[test]
    fn wild_numbers_are_counted_without_overflow() {
        let mut counts = ChannelCounts::default();
        let mut tracker = SequenceTracker::default();
        for seq in [1, u64::MAX, 1, u64::MAX] {
            counts.add(tracker.observe(seq));
        }
        assert_eq!((counts.written, counts.lost), (4, u64::MAX));
    }

    #[test]
    fn messages_without_a_number_fill_the_gap_they_leave() {
        // One garbled message between 3 and 6: one number is really missing.
        check(&[1, 2, 3, 0, 6], &[First, Next, Next, Next, Gap(1)]);
        // As many as the gap: nothing lost.
        check(&[1, 0, 0, 4], &[First, Next, Next, Next]);
        // Counted once: the next gap is a loss again.
        check(&[1, 0, 3, 5], &[First, Next, Next, Gap(1)]);
        // After a restart, they may be the new run's first messages.
        check(&[5, 6, 0, 2], &[First, Next, Next, Restart(0)]);
    }

    #[test]
    fn consecutive_numbers_lose_nothing() {
        check(&[1, 2, 3], &[First, Next, Next]);
    }

    #[test]
    fn a_recording_that_starts_late_counts_no_loss() {
        check(&[500, 501], &[First, Next]);
    }

    #[test]
    fn a_gap_counts_the_missing_numbers() {
        check(&[1, 2, 5, 6, 8], &[First, Next, Gap(2), Next, Gap(1)]);
    }

    #[test]
    fn a_provider_restarting_at_one_is_a_new_run_not_a_loss() {
        check(&[7, 8, 1, 2], &[First, Next, Restart(0), Next]);
    }

    #[test]
    fn a_restart_whose_first_messages_were_lost_counts_them() {
        check(&[7, 8, 3, 4], &[First, Next, Restart(2), Next]);
    }

    #[test]
    fn sequence_zero_is_a_message_without_a_number_not_a_new_run() {
        check(&[4, 0, 1], &[First, Next, Restart(0)]);
        check(&[4, 0, 5], &[First, Next, Next]);
    }

    #[test]
    fn the_largest_sequence_number_does_not_overflow() {
        check(&[u64::MAX - 1, u64::MAX, 1], &[First, Next, Restart(0)]);
    }

    #[test]
    fn counts_add_losses_and_restarts() {
        let mut counts = ChannelCounts::default();
        let mut tracker = SequenceTracker::default();
        for seq in [1, 2, 4, 1, 3] {
            counts.add(tracker.observe(seq));
        }
        assert_eq!(
            counts,
            ChannelCounts {
                written: 5,
                lost: 1 + 1,
                dropped: 0,
                restarts: 1
            }
        );
    }

    proptest::proptest! {
        #[test]
        fn losses_of_an_increasing_run_are_exactly_the_missing_numbers(
            kept in proptest::collection::btree_set(1_u64..2000, 1..200)
        ) {
            let kept: Vec<u64> = kept.into_iter().collect();
            let mut tracker = SequenceTracker::default();
            let lost: u64 = kept.iter().map(|&s| tracker.observe(s).lost()).sum();
            let span = kept[kept.len() - 1] - kept[0] + 1;
            proptest::prop_assert_eq!(lost, span - kept.len() as u64);
        }
    }
}
