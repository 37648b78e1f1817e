//! The [`Context`]: everything a service may do, over a [`Backend`] that each harness
//! (live, lockstep replay) implements.

use std::collections::BTreeMap;
use std::fmt;
use std::time::Duration;

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Header, InputRef, LogLineLevel};
use lewis_interfaces::{Command, Interface, Message, SizeMismatch};

use super::events::{CallFailure, CallId, Reply};
use super::rng::Rng;
use crate::Health;
use crate::wire;

/// How much a log line matters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Something is wrong.
    Error,
    /// Something may be wrong.
    Warn,
    /// What happens, for people.
    Info,
    /// Details for whoever debugs.
    Debug,
}

impl fmt::Display for Level {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(LogLineLevel::from(*self).as_str())
    }
}

/// Its word in a `LogLine`.
impl From<Level> for LogLineLevel {
    fn from(level: Level) -> Self {
        match level {
            Level::Error => Self::Error,
            Level::Warn => Self::Warn,
            Level::Info => Self::Info,
            Level::Debug => Self::Debug,
        }
    }
}

/// What a harness provides to the [`Context`]: the clock, the channels, the calls, health
/// and logs. The live harness does real IPC; the replay harness records and feeds.
pub trait Backend {
    /// The service's clock, in nanoseconds.
    fn now_ns(&self) -> i64;

    /// Whether what the service publishes goes out now: `false` while the harness
    /// silences the service (an injected stall or out-of-service). A silenced message is
    /// not numbered either: a silent service publishes nothing, and a gap in a channel's
    /// numbers is a loss to the recorder.
    fn publishing(&self) -> bool {
        true
    }

    /// Publishes a message of `len_bytes` on the service's channel of `interface`;
    /// `encode` writes it in place (call it exactly once).
    ///
    /// # Errors
    /// When the service does not provide `interface` or the channel refuses the message.
    fn publish(
        &mut self,
        interface: &str,
        len_bytes: usize,
        encode: &mut dyn FnMut(&mut [u8]),
    ) -> Result<(), ContextError>;

    /// Sends a command frame ([`wire`]) to the current provider of `interface`; the reply,
    /// or its failure, is later handed to the service as `on_reply` with `call`.
    ///
    /// # Errors
    /// When the call cannot even be sent (no provider, not required, IPC failure).
    fn call(
        &mut self,
        call: CallId,
        interface: &str,
        command: &'static str,
        frame: &[u8],
        timeout_ns: i64,
    ) -> Result<(), CallFailure>;

    /// The service declared a new health.
    fn health_changed(&mut self, health: &Health);

    /// A log line of the service.
    fn log(&mut self, service: &str, level: Level, text: &str);
}

/// Why a publication failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ContextError {
    /// The service publishes an interface it does not provide in the robot file.
    #[error("{service} publishes {interface} but does not provide it: add it to `provides`")]
    NotProvided {
        /// The service.
        service: String,
        /// The interface.
        interface: String,
    },
    /// An array's length disagrees with its size field.
    #[error(transparent)]
    Size(#[from] SizeMismatch),
    /// The channel refused the message.
    #[error("cannot publish {interface}: {reason}")]
    Publish {
        /// The interface.
        interface: String,
        /// Why.
        reason: String,
    },
}

/// What a service's context remembers between events: its name, the sequence numbers of its
/// channels, its random source, its health and the provenance of the event being handled.
/// The harness owns it and lends it to each [`Context`].
#[derive(Debug, Clone)]
pub struct ContextState {
    service: String,
    seqs: BTreeMap<String, u64>,
    rng: Rng,
    health: Health,
    inputs: Vec<InputRef>,
    next_call: u64,
}

impl ContextState {
    /// The state of service `service` before its first event, with its random source seeded
    /// from `seed`.
    #[must_use]
    pub fn new(service: &str, seed: u64) -> Self {
        Self {
            service: service.to_owned(),
            seqs: BTreeMap::new(),
            rng: Rng::new(seed),
            health: Health::Ok,
            inputs: Vec::new(),
            next_call: 0,
        }
    }

    /// The service's name.
    #[must_use]
    pub fn service(&self) -> &str {
        &self.service
    }

    /// The health the service declared last.
    #[must_use]
    pub fn health(&self) -> &Health {
        &self.health
    }

    /// Sets the provenance of the event about to be handled (the input sample it came from);
    /// cleared with an empty vector.
    pub fn set_inputs(&mut self, inputs: Vec<InputRef>) {
        self.inputs = inputs;
    }

    /// The context for one event.
    pub fn context<'a>(&'a mut self, backend: &'a mut dyn Backend) -> Context<'a> {
        Context {
            state: self,
            backend,
        }
    }
}

/// Everything a service may do while it handles one event.
pub struct Context<'a> {
    state: &'a mut ContextState,
    backend: &'a mut dyn Backend,
}

impl fmt::Debug for Context<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Context")
            .field("state", &self.state)
            .finish_non_exhaustive()
    }
}

/// The timeout of [`Context::call`].
pub const DEFAULT_CALL_TIMEOUT: Duration = Duration::from_secs(1);

impl Context<'_> {
    /// The service's clock, in nanoseconds: the only clock a service may read.
    #[must_use]
    pub fn now(&self) -> i64 {
        self.backend.now_ns()
    }

    /// The service's name (its provider name in every header).
    #[must_use]
    pub fn name(&self) -> &str {
        &self.state.service
    }

    /// Publishes `message` on this service's channel of its interface. Its header is filled
    /// in place first: provider, the channel's next sequence number (from 1), the publish
    /// time, and, unless the service set them, the inputs of the event being handled.
    /// Returns the sequence number (the last one given, when the harness silences the
    /// service: nothing is published then).
    ///
    /// # Errors
    /// When the service does not provide `T`, an array disagrees with its size field, or the
    /// channel refuses the message.
    pub fn publish<T: Interface>(&mut self, message: &mut T) -> Result<u64, ContextError> {
        message.check_sizes()?;
        if !self.backend.publishing() {
            return Ok(self.last_seq(T::NAME));
        }
        let seq = self.stamp(T::NAME, message.header_mut());
        let len = cdr::encoded_len(message);
        let mut encode = |buf: &mut [u8]| {
            // The loan was sized by `encoded_len`, so this cannot run short.
            let _ = cdr::encode_into(&*message, buf);
        };
        self.backend.publish(T::NAME, len, &mut encode)?;
        Ok(seq)
    }

    /// Publishes a message whose arrays of numbers and of plain structs `fill` writes
    /// straight into the channel's shared memory ([`lewis_interfaces::InPlace`]): a camera
    /// frame or a scan is then written once, where its subscribers read it, rather than
    /// built in the service's vectors and copied. `message` gives the other fields (its
    /// header is filled as [`Context::publish`] fills it; its own arrays that are written
    /// in place are ignored, so they are best left empty) and `lens` the lengths of the
    /// arrays. The room `fill` gets is not cleared: it must write every element. Returns the
    /// sequence number.
    ///
    /// # Errors
    /// As [`Context::publish`], the lengths in `lens` checked against their size fields.
    pub fn publish_in_place<T: Interface>(
        &mut self,
        message: &mut T,
        lens: &T::Lens,
        fill: impl FnOnce(T::Bulk<'_>),
    ) -> Result<u64, ContextError> {
        message.check_shape(lens)?;
        if !self.backend.publishing() {
            return Ok(self.last_seq(T::NAME));
        }
        let seq = self.stamp(T::NAME, message.header_mut());
        let len = cdr::in_place_len(message, lens);
        let mut fill = Some(fill);
        let mut encode = |buf: &mut [u8]| {
            // The loan was sized by `in_place_len`, so this cannot run short.
            if let (Ok(bulk), Some(fill)) =
                (cdr::encode_in_place(&*message, lens, buf), fill.take())
            {
                fill(bulk);
            }
        };
        self.backend.publish(T::NAME, len, &mut encode)?;
        Ok(seq)
    }

    /// Sends command `command` to the current provider of its interface (which this service
    /// must require). Asynchronous: the reply, or a timeout after
    /// `DEFAULT_CALL_TIMEOUT`, comes back as [`Service::on_reply`](super::Service::on_reply).
    ///
    /// # Errors
    /// When the call cannot be sent (the interface has no provider now, or is not required).
    pub fn call<C: Command>(&mut self, command: &mut C) -> Result<CallId, CallFailure> {
        self.call_with_timeout(command, DEFAULT_CALL_TIMEOUT)
    }

    /// [`Context::call`] with a timeout of its own.
    ///
    /// # Errors
    /// As [`Context::call`].
    pub fn call_with_timeout<C: Command>(
        &mut self,
        command: &mut C,
        timeout: Duration,
    ) -> Result<CallId, CallFailure> {
        let interface = <C::Interface as Interface>::NAME;
        self.stamp(&format!("{interface}/calls"), command.header_mut());
        let message = cdr::to_vec(&*command);
        let frame = wire::request_to_vec(C::NAME, &message);
        let call = CallId(self.state.next_call);
        self.state.next_call += 1;
        let timeout_ns = i64::try_from(timeout.as_nanos()).unwrap_or(i64::MAX);
        self.backend
            .call(call, interface, C::NAME, &frame, timeout_ns)?;
        Ok(call)
    }

    /// The answer to the command being handled, its header filled like a publication's.
    pub fn reply<M: Message>(&mut self, mut message: M) -> Reply {
        self.stamp("replies", message.header_mut());
        Reply {
            bytes: cdr::to_vec(&message),
        }
    }

    /// Declares the service's health; the broker hears it at once (out of service moves the
    /// clients away) and with every heartbeat.
    pub fn set_health(&mut self, health: Health) {
        if health != self.state.health {
            self.backend.health_changed(&health);
            self.state.health = health;
        }
    }

    /// The health declared last.
    #[must_use]
    pub fn health(&self) -> &Health {
        &self.state.health
    }

    /// The service's random source, seeded from the robot file.
    pub fn rng(&mut self) -> &mut Rng {
        &mut self.state.rng
    }

    /// Overrides the provenance given to the next publications of this event (a service that
    /// combines several inputs names them all).
    pub fn set_inputs(&mut self, inputs: Vec<InputRef>) {
        self.state.inputs = inputs;
    }

    /// Writes a log line.
    pub fn log(&mut self, level: Level, text: &str) {
        self.backend.log(&self.state.service, level, text);
    }

    /// Writes an info log line.
    pub fn info(&mut self, text: &str) {
        self.log(Level::Info, text);
    }

    /// Writes a warning log line.
    pub fn warn(&mut self, text: &str) {
        self.log(Level::Warn, text);
    }

    /// The last sequence number given on the channel of `key` (0: none yet).
    fn last_seq(&self, key: &str) -> u64 {
        self.state.seqs.get(key).copied().unwrap_or(0)
    }

    fn stamp(&mut self, key: &str, header: &mut Header) -> u64 {
        // Looked up before inserting: the key is allocated once per channel, not per message.
        if !self.state.seqs.contains_key(key) {
            self.state.seqs.insert(key.to_owned(), 0);
        }
        let seq = self.state.seqs.get_mut(key).map_or(1, |seq| {
            *seq += 1;
            *seq
        });
        header.provider.clone_from(&self.state.service);
        header.seq = seq;
        header.publish_time_ns = self.backend.now_ns();
        if header.inputs.is_empty() {
            header.inputs.clone_from(&self.state.inputs);
        }
        seq
    }
}

#[cfg(test)]
mod tests {
    use lewis_interfaces::msg::{Pose3D, RangeFinder, RangeFinderBulkLens, RangeFinderGetGeometry};

    use super::*;

    /// A backend that keeps what the context did, on a clock the test sets.
    #[derive(Default)]
    struct Recorder {
        now_ns: i64,
        published: Vec<(String, Vec<u8>)>,
        calls: Vec<(CallId, String, String, Vec<u8>)>,
        health: Vec<Health>,
        silenced: bool,
    }

    impl Backend for Recorder {
        fn now_ns(&self) -> i64 {
            self.now_ns
        }
        fn publishing(&self) -> bool {
            !self.silenced
        }
        fn publish(
            &mut self,
            interface: &str,
            len_bytes: usize,
            encode: &mut dyn FnMut(&mut [u8]),
        ) -> Result<(), ContextError> {
            let mut buf = vec![0; len_bytes];
            encode(&mut buf);
            self.published.push((interface.to_owned(), buf));
            Ok(())
        }
        fn call(
            &mut self,
            call: CallId,
            interface: &str,
            command: &'static str,
            frame: &[u8],
            _timeout_ns: i64,
        ) -> Result<(), CallFailure> {
            self.calls
                .push((call, interface.into(), command.into(), frame.to_vec()));
            Ok(())
        }
        fn health_changed(&mut self, health: &Health) {
            self.health.push(health.clone());
        }
        fn log(&mut self, _service: &str, _level: Level, _text: &str) {}
    }

    #[test]
    fn a_silenced_service_publishes_nothing_and_numbers_nothing() {
        let mut state = ContextState::new("laser", 1);
        let mut backend = Recorder::default();
        let mut scan = RangeFinder::default();
        assert_eq!(state.context(&mut backend).publish(&mut scan), Ok(1));
        backend.silenced = true;
        assert_eq!(state.context(&mut backend).publish(&mut scan), Ok(1));
        backend.silenced = false;
        // No gap for the recorder to count as a loss.
        assert_eq!(state.context(&mut backend).publish(&mut scan), Ok(2));
        assert_eq!(backend.published.len(), 2);
    }

    #[test]
    fn publish_fills_the_header_with_provider_seq_time_and_provenance() {
        let mut state = ContextState::new("laser", 1);
        let mut backend = Recorder {
            now_ns: 42,
            ..Recorder::default()
        };
        let input = InputRef {
            channel: "/odometry/Egomotion".into(),
            seq: 7,
        };
        state.set_inputs(vec![input.clone()]);
        let mut scan = RangeFinder::default();
        let mut ctx = state.context(&mut backend);
        assert_eq!(ctx.publish(&mut scan), Ok(1));
        assert_eq!(ctx.publish(&mut scan), Ok(2));
        let (interface, bytes) = &backend.published[1];
        assert_eq!(interface, "RangeFinder");
        let decoded: RangeFinder = cdr::from_bytes(bytes).unwrap();
        assert_eq!(decoded.header.provider, "laser");
        assert_eq!(decoded.header.seq, 2);
        assert_eq!(decoded.header.publish_time_ns, 42);
        assert_eq!(decoded.header.inputs, vec![input]);
    }

    #[test]
    fn a_scan_written_in_place_is_published_as_the_same_scan_encoded() {
        let mut state = ContextState::new("laser", 1);
        let mut backend = Recorder {
            now_ns: 42,
            ..Recorder::default()
        };
        let ranges: Vec<f64> = (0..361).map(|i| f64::from(i) * 0.01).collect();
        let mut template = RangeFinder {
            range_count: 361,
            max_range: 8.0,
            ..RangeFinder::default()
        };
        let lens = RangeFinderBulkLens {
            ranges: 361,
            sensor_positions: 361,
        };
        let mut ctx = state.context(&mut backend);
        let seq = ctx.publish_in_place(&mut template, &lens, |mut bulk| {
            bulk.ranges.fill_from(ranges.iter().copied());
            bulk.sensor_positions
                .fill_from((0..361).map(|_| Pose3D::default()));
        });
        assert_eq!(seq, Ok(1));
        let decoded: RangeFinder = cdr::from_bytes(&backend.published[0].1).unwrap();
        assert_eq!(decoded.ranges, ranges);
        assert_eq!(decoded.sensor_positions, vec![Pose3D::default(); 361]);
        assert_eq!(
            (decoded.header.provider.as_str(), decoded.header.seq),
            ("laser", 1)
        );
        assert_eq!(decoded.header.publish_time_ns, 42);
        // Lengths that disagree with range_count are refused before anything is sent.
        let wrong = RangeFinderBulkLens {
            ranges: 360,
            ..lens
        };
        let got = state
            .context(&mut backend)
            .publish_in_place(&mut template, &wrong, |_| {});
        assert!(matches!(got, Err(ContextError::Size(_))), "{got:?}");
        assert_eq!(backend.published.len(), 1);
    }

    #[test]
    fn an_array_that_disagrees_with_its_size_is_not_published() {
        let mut state = ContextState::new("laser", 1);
        let mut backend = Recorder::default();
        let mut scan = RangeFinder {
            range_count: 3,
            ..RangeFinder::default()
        };
        let got = state.context(&mut backend).publish(&mut scan);
        assert!(matches!(got, Err(ContextError::Size(_))), "{got:?}");
        assert!(backend.published.is_empty());
    }

    #[test]
    fn calls_are_framed_with_the_command_name_and_numbered() {
        let mut state = ContextState::new("app", 1);
        let mut backend = Recorder::default();
        let mut ctx = state.context(&mut backend);
        let first = ctx.call(&mut RangeFinderGetGeometry::default()).unwrap();
        let second = ctx.call(&mut RangeFinderGetGeometry::default()).unwrap();
        assert_eq!((first, second), (CallId(0), CallId(1)));
        let (_, interface, command, frame) = &backend.calls[0];
        assert_eq!(
            (interface.as_str(), command.as_str()),
            ("RangeFinder", "get_geometry")
        );
        let (name, message) = wire::read_request(frame).unwrap();
        assert_eq!(name, "get_geometry");
        let decoded: RangeFinderGetGeometry = cdr::from_bytes(message).unwrap();
        assert_eq!(decoded.header.provider, "app");
    }

    #[test]
    fn health_changes_reach_the_backend_once_each() {
        let mut state = ContextState::new("laser", 1);
        let mut backend = Recorder::default();
        let mut ctx = state.context(&mut backend);
        ctx.set_health(Health::Ok);
        ctx.set_health(Health::OutOfService("blinded".into()));
        ctx.set_health(Health::OutOfService("blinded".into()));
        ctx.set_health(Health::Ok);
        assert_eq!(
            backend.health,
            [Health::OutOfService("blinded".into()), Health::Ok]
        );
    }
}
