//! What the recording says the followed services did live, read a little ahead of the
//! virtual clock: when each one handled an event that published (its recorded outputs'
//! publish times), which inputs it had by then (their provenance), and when it took up each
//! command that another re-simulated service sent it (its recorded command log).
//!
//! The harness asks it three questions:
//! - [`Script::holds`]: must a sample wait before it is handed to a followed service? Yes
//!   when the service's next recorded event names an older sample of that channel (or none
//!   of it, while a later one names it): live, the sample had not reached the service yet.
//!   It is handed over right after that event instead. A sample never waits longer than
//!   [`MAX_HOLD_NS`].
//! - [`Script::call_time`]: when did the server take up this call live? When its recorded
//!   command log holds the same request bytes from the same caller.
//! - [`Script::gone`]: had the service stopped live by now? Yes when the recording shows no
//!   sign of its life (a heartbeat, an output) from now on, while showing enough of what
//!   follows to tell (longer than its heartbeat deadline, or all of it). `lewis up` stops
//!   a client before the providers it is bound to, so a provider's last samples are recorded
//!   after its client stopped: handed to the client in the replay, they would make outputs
//!   that the run never had.
//!
//! Everything here is bounded by the look-ahead window of the reader: events and calls are
//! dropped once the virtual clock has passed them.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

use lewis_interfaces::msg::InputRef;

/// A sample is never held back longer than this, whatever the recording says (a provider
/// whose sequence numbers differ from the recorded ones, after a restart that happened in
/// one run and not the other).
pub const MAX_HOLD_NS: i64 = 1_000_000_000;

/// A recorded call timing is used for a call made up to this long before it was taken up.
const CALL_WINDOW_NS: i64 = 1_000_000_000;

/// One recorded event of a followed service: the newest sample of each channel it had.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RecordedEvent {
    /// The newest sequence number named, per input channel.
    pub inputs: BTreeMap<Arc<str>, u64>,
}

/// What the recording says about one followed service.
#[derive(Debug, Default)]
struct ServiceScript {
    /// Its recorded events ahead of the clock, by time.
    events: BTreeMap<i64, RecordedEvent>,
    /// How many of those events name each channel.
    naming: BTreeMap<Arc<str>, usize>,
    /// Recorded calls it took up from other re-simulated services: (caller, request) ->
    /// the times it took them up, oldest first.
    calls: BTreeMap<(String, Vec<u8>), VecDeque<i64>>,
    /// The time of its latest sign of life read so far: a heartbeat or an output.
    last_life_ns: Option<i64>,
    /// Silence longer than this means it was not running: its heartbeat deadline.
    deadline_ns: i64,
}

/// The recorded schedule of every followed service.
#[derive(Debug, Default)]
pub struct Script {
    services: BTreeMap<String, ServiceScript>,
    /// The latest time read ahead so far.
    read_to_ns: i64,
    /// Whether the whole recording has been read ahead.
    read_whole: bool,
    /// Whether services stop where they stopped live (not when a mission is lived again:
    /// it ends when it ends in the replay, and its services run until then).
    stops_as_recorded: bool,
}

impl Script {
    /// A script that follows `services`, each with its heartbeat deadline in ns (none
    /// recorded yet).
    pub fn new(services: impl IntoIterator<Item = (String, i64)>) -> Self {
        Self {
            services: services
                .into_iter()
                .map(|(service, deadline_ns)| {
                    let script = ServiceScript {
                        deadline_ns,
                        ..ServiceScript::default()
                    };
                    (service, script)
                })
                .collect(),
            read_to_ns: i64::MIN,
            read_whole: false,
            stops_as_recorded: true,
        }
    }

    /// Services run on past where they stopped live: the mission is lived again, and
    /// when it ends (and so when `lewis up` would stop them) is the replay's to say.
    pub fn run_past_recorded_stops(&mut self) {
        self.stops_as_recorded = false;
    }

    /// A message recorded at `time_ns` was read ahead.
    pub fn read_to(&mut self, time_ns: i64) {
        self.read_to_ns = self.read_to_ns.max(time_ns);
    }

    /// The whole recording has been read ahead: what has not been seen will not come.
    pub fn read_whole(&mut self) {
        self.read_whole = true;
    }

    /// `service` showed it was running at `time_ns` (a heartbeat).
    pub fn expect_life(&mut self, service: &str, time_ns: i64) {
        if let Some(script) = self.services.get_mut(service) {
            script.last_life_ns = Some(script.last_life_ns.map_or(time_ns, |t| t.max(time_ns)));
        }
    }

    /// Whether `service` had stopped live by `now_ns` (see the module documentation): its
    /// latest sign of life is older, and what was read after it is longer than its deadline
    /// or the rest of the recording.
    pub fn gone(&self, service: &str, now_ns: i64) -> bool {
        let Some(script) = self.services.get(service) else {
            return false;
        };
        self.stops_as_recorded
            && script.last_life_ns.is_some_and(|last| {
                last < now_ns
                    && (self.read_whole
                        || self.read_to_ns.saturating_sub(last) > script.deadline_ns)
            })
    }

    /// Stops following `service` (it lives otherwise than it did live).
    pub fn unfollow(&mut self, service: &str) {
        self.services.remove(service);
    }

    /// Follows nothing any more (the recording is over); returns who followed it.
    pub fn unfollow_all(&mut self) -> Vec<String> {
        std::mem::take(&mut self.services).into_keys().collect()
    }

    /// Whether `service` follows the recording.
    pub fn follows(&self, service: &str) -> bool {
        self.services.contains_key(service)
    }

    /// `service` published at `time_ns` live, computed from `inputs`. Publications of one
    /// handler share its time: they make one event.
    pub fn expect_event(&mut self, service: &str, time_ns: i64, inputs: &[InputRef]) {
        self.expect_life(service, time_ns);
        let Some(script) = self.services.get_mut(service) else {
            return;
        };
        let event = script.events.entry(time_ns).or_default();
        for input in inputs {
            let channel: Arc<str> = Arc::from(input.channel.as_str());
            match event.inputs.get_mut(&channel) {
                Some(seq) => *seq = (*seq).max(input.seq),
                None => {
                    *script.naming.entry(channel.clone()).or_insert(0) += 1;
                    event.inputs.insert(channel, input.seq);
                }
            }
        }
    }

    /// Takes the recorded event of `service` at `time_ns`, if one is there (the first of
    /// several publications of one handler takes it; the others find none).
    pub fn take_event(&mut self, service: &str, time_ns: i64) -> Option<RecordedEvent> {
        let script = self.services.get_mut(service)?;
        let event = script.events.remove(&time_ns)?;
        for channel in event.inputs.keys() {
            if let Some(count) = script.naming.get_mut(channel) {
                *count -= 1;
                if *count == 0 {
                    script.naming.remove(channel);
                }
            }
        }
        Some(event)
    }

    /// Drops the recorded events of `service` before `now_ns` that never came (a recorded
    /// output whose message was not replayed), so that they hold nothing back.
    pub fn drop_past(&mut self, service: &str, now_ns: i64) {
        let past: Vec<i64> = self
            .services
            .get(service)
            .map(|s| s.events.range(..now_ns).map(|(t, _)| *t).collect())
            .unwrap_or_default();
        for time in past {
            self.take_event(service, time);
        }
    }

    /// Whether sample `seq` of `channel`, published at `published_ns`, must wait before it is
    /// handed to `service` at `now_ns` (see the module documentation).
    pub fn holds(
        &self,
        service: &str,
        channel: &str,
        seq: u64,
        published_ns: i64,
        now_ns: i64,
    ) -> bool {
        let Some(script) = self.services.get(service) else {
            return false;
        };
        if !script.naming.contains_key(channel)
            || now_ns.saturating_sub(published_ns) >= MAX_HOLD_NS
        {
            return false;
        }
        let Some((_, next)) = script.events.first_key_value() else {
            return false;
        };
        next.inputs.get(channel).copied().unwrap_or(0) < seq
    }

    /// Whether the next recorded event of `service` names sample `seq` of `channel` or a
    /// newer one: live, that sample had reached it.
    pub fn next_names(&self, service: &str, channel: &str, seq: u64) -> bool {
        self.services
            .get(service)
            .and_then(|script| script.events.first_key_value())
            .and_then(|(_, event)| event.inputs.get(channel))
            .is_some_and(|named| *named >= seq)
    }

    /// `server` took up, at `taken_ns`, a call from the re-simulated `caller` whose request
    /// bytes were `request`.
    pub fn expect_call(&mut self, server: &str, caller: &str, request: &[u8], taken_ns: i64) {
        if let Some(script) = self.services.get_mut(server) {
            script
                .calls
                .entry((caller.to_owned(), request.to_vec()))
                .or_default()
                .push_back(taken_ns);
        }
    }

    /// When `server` took up this call live: the time of the oldest recorded identical call
    /// taken up at or after `now_ns` and within a second of it. Used once.
    pub fn call_time(
        &mut self,
        server: &str,
        caller: &str,
        request: &[u8],
        now_ns: i64,
    ) -> Option<i64> {
        let script = self.services.get_mut(server)?;
        let key = (caller.to_owned(), request.to_vec());
        let times = script.calls.get_mut(&key)?;
        while times.front().is_some_and(|t| *t < now_ns) {
            times.pop_front();
        }
        let found = times
            .front()
            .copied()
            .filter(|t| *t <= now_ns.saturating_add(CALL_WINDOW_NS));
        if found.is_some() {
            times.pop_front();
        }
        if times.is_empty() {
            script.calls.remove(&key);
        }
        found
    }

    /// Forgets recorded calls taken up before `now_ns` (calls the replay did not make).
    pub fn expire_calls(&mut self, now_ns: i64) {
        for script in self.services.values_mut() {
            script.calls.retain(|_, times| {
                while times.front().is_some_and(|t| *t < now_ns) {
                    times.pop_front();
                }
                !times.is_empty()
            });
        }
    }

    /// Recorded events and calls held, for tests of the bounds.
    #[cfg(test)]
    fn len(&self) -> usize {
        self.services
            .values()
            .map(|s| s.events.len() + s.calls.values().map(VecDeque::len).sum::<usize>())
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: i64 = 1_000_000;

    fn input(channel: &str, seq: u64) -> InputRef {
        InputRef {
            channel: channel.into(),
            seq,
        }
    }

    #[test]
    fn a_service_silent_for_longer_than_its_deadline_or_to_the_end_was_gone() {
        let mut script = Script::new([("front".to_owned(), 50 * MS)]);
        script.expect_life("front", 100 * MS);
        script.expect_event("front", 120 * MS, &[]);
        script.read_to(150 * MS);
        // Heard of 30 ms ago: it may be between heartbeats.
        assert!(!script.gone("front", 130 * MS));
        script.read_to(171 * MS);
        // Nothing for longer than its deadline after its last output.
        assert!(script.gone("front", 130 * MS));
        assert!(!script.gone("front", 120 * MS));
        // At the end of the recording, any silence: it was stopped before the recorder.
        script.expect_life("front", 200 * MS);
        script.read_to(210 * MS);
        assert!(!script.gone("front", 205 * MS));
        script.read_whole();
        assert!(script.gone("front", 205 * MS));
        // A service not followed is never judged.
        assert!(!script.gone("laser", 205 * MS));
        // Nor one of a mission lived again.
        script.run_past_recorded_stops();
        assert!(!script.gone("front", 205 * MS));
    }

    #[test]
    fn a_sample_waits_while_the_next_recorded_event_names_an_older_one() {
        let mut script = Script::new([("avoider".to_owned(), 50 * MS)]);
        script.expect_event("avoider", 100 * MS, &[input("/odom", 4)]);
        script.expect_event("avoider", 200 * MS, &[input("/odom", 9)]);
        // Sample 4 was there at the event of 100 ms, sample 5 was not.
        assert!(!script.holds("avoider", "/odom", 4, 90 * MS, 95 * MS));
        assert!(script.holds("avoider", "/odom", 5, 99 * MS, 99 * MS));
        assert!(script.take_event("avoider", 100 * MS).is_some());
        assert!(!script.holds("avoider", "/odom", 5, 99 * MS, 100 * MS));
        // A channel no event names, a service that does not follow: no waiting.
        assert!(!script.holds("avoider", "/scan", 1, 99 * MS, 100 * MS));
        assert!(!script.holds("mover", "/odom", 99, 99 * MS, 100 * MS));
    }

    #[test]
    fn an_event_that_names_nothing_of_a_channel_named_later_holds_its_samples() {
        let mut script = Script::new([("avoider".to_owned(), 50 * MS)]);
        script.expect_event("avoider", 100 * MS, &[input("/odom", 4)]);
        script.expect_event("avoider", 200 * MS, &[input("/odom", 9), input("/scan", 1)]);
        assert!(script.holds("avoider", "/scan", 1, 90 * MS, 95 * MS));
        // Never longer than MAX_HOLD_NS.
        assert!(!script.holds("avoider", "/scan", 1, 90 * MS, 90 * MS + MAX_HOLD_NS));
    }

    #[test]
    fn publications_of_one_handler_make_one_event_and_are_taken_once() {
        let mut script = Script::new([("laser".to_owned(), 50 * MS)]);
        script.expect_event("laser", 100 * MS, &[input("/truth", 3)]);
        script.expect_event("laser", 100 * MS, &[input("/truth", 2)]);
        let event = script.take_event("laser", 100 * MS).unwrap();
        assert_eq!(event.inputs.get("/truth"), Some(&3));
        assert_eq!(script.take_event("laser", 100 * MS), None);
        assert_eq!(script.len(), 0);
    }

    #[test]
    fn recorded_calls_are_matched_by_caller_and_bytes_once_and_expire() {
        let mut script = Script::new([("mover".to_owned(), 50 * MS)]);
        script.expect_call("mover", "avoider", b"goto 1", 101 * MS);
        script.expect_call("mover", "avoider", b"goto 2", 301 * MS);
        script.expect_call("mover", "avoider", b"goto 3", 501 * MS);
        assert_eq!(
            script.call_time("mover", "avoider", b"goto 1", 100 * MS),
            Some(101 * MS)
        );
        assert_eq!(
            script.call_time("mover", "avoider", b"goto 1", 100 * MS),
            None
        );
        assert_eq!(
            script.call_time("mover", "other", b"goto 2", 300 * MS),
            None
        );
        script.expire_calls(400 * MS);
        assert_eq!(
            script.call_time("mover", "avoider", b"goto 2", 300 * MS),
            None
        );
        assert_eq!(script.len(), 1);
    }
}
