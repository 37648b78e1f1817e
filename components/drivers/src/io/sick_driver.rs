//! The host's side of the SICK LMS2xx / PLS laser over a serial port: find the scanner's rate
//! by probing, switch to the configured rate, set angle, resolution and unit, start streaming,
//! then hand out decoded scans, with counters of what was skipped, health, and reconnection
//! when the port comes back.
//!
//! Reads block for at most a caller's timeout ([`SickDriver::read_scan`]); a caller can also
//! wait on [`SickDriver::fd`] itself. Setting the scanner up (at open, after a reconnection,
//! and again when a scanner on an open port has been silent past its deadline: a scanner
//! power-cycled behind a fixed serial port comes back at 9600 baud, not streaming) blocks for
//! up to a few reply timeouts per candidate rate: a live service never calls this on its own
//! thread but runs it in its device reader ([`super::sick_reader`]), which reports each
//! set-up step ([`SetupStep`]) as it goes.

use std::collections::VecDeque;
use std::os::fd::BorrowedFd;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use super::cancel::Cancel;
use super::health::DriverHealth;
use super::link::{LinkDown, SerialLink};
use super::port::{LineParity, PortError};
use super::receiver::{SickReceived, SickReceiver};
use super::retry::Retry;
use crate::framing::DeframerStats;
use crate::sick::{
    BaudRate, DEFAULT_PASSWORD, RangeUnit, ReplyBody, Scan, ScanLayout, ScanValue, SickCommand,
    SickError, SickReply,
};

/// The NACK reply code.
const NACK_REPLY: u8 = 0x92;
const MODE_CHANGE_OK: u8 = 0;

/// How the driver talks to the scanner.
#[derive(Debug, Clone, PartialEq)]
pub struct SickDriverConfig {
    /// The serial port.
    pub path: PathBuf,
    /// The rate to run at (9600, 19200, 38400 or 500000; 500000 needs RS-422).
    pub baud: BaudRate,
    /// The rates to probe for the scanner, in order (power-up rate 9600 first).
    pub probe_rates: Vec<BaudRate>,
    /// Angle and resolution.
    pub layout: ScanLayout,
    /// Range unit (millimetres: at most 8.191 m; centimetres: 81.91 m).
    pub unit: RangeUnit,
    /// Line parity: none for the LMS, even for the PLS.
    pub parity: LineParity,
    /// How long to wait for a reply.
    pub reply_timeout: Duration,
    /// How long to wait for the reply to a configuration change (the scanner writes its
    /// EEPROM).
    pub config_timeout: Duration,
    /// Times a command is sent before giving up on a reply.
    pub attempts: u32,
    /// No valid scan for this long is [`DriverHealth::NoData`].
    pub scan_deadline: Duration,
    /// A fraction of bad CRCs among the recent telegrams above this is
    /// [`DriverHealth::ChecksumErrors`].
    pub crc_error_threshold: f64,
    /// Telegrams in the CRC error window.
    pub crc_window: usize,
    /// Time between attempts to reopen a port that went away.
    pub reconnect_interval: Duration,
}

impl SickDriverConfig {
    /// The defaults for a scanner on `path`: 38400 baud, 180 degrees at 0.5 degree,
    /// millimetres, 8N1, 1 s reply timeout (5 s for configuration), 2 attempts, 1 s scan
    /// deadline, CRC threshold 50% over 20 telegrams, reconnection every second.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self {
            path: path.into(),
            baud: BaudRate::B38400,
            probe_rates: BaudRate::ALL.to_vec(),
            layout: ScanLayout::WIDE_HALF_DEGREE,
            unit: RangeUnit::Millimetre,
            parity: LineParity::None,
            reply_timeout: Duration::from_secs(1),
            config_timeout: Duration::from_secs(5),
            attempts: 2,
            scan_deadline: Duration::from_secs(1),
            crc_error_threshold: 0.5,
            crc_window: 20,
            reconnect_interval: Duration::from_secs(1),
        }
    }
}

/// Why the scanner could not be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SickDriverError {
    /// The port could not be opened.
    #[error(transparent)]
    Port(#[from] PortError),
    /// No rate got an answer.
    #[error(
        "no SICK scanner answered on {path} at {rates} baud: check the scanner's power, the cable (RS-232 or RS-422), the port and the parity"
    )]
    NoAnswer {
        /// The port.
        path: PathBuf,
        /// The rates tried.
        rates: String,
    },
    /// A command got no reply.
    #[error(
        "the SICK scanner on {path} did not answer {command} at {baud} baud: check the cable and the scanner"
    )]
    NoReply {
        /// The port.
        path: PathBuf,
        /// The command.
        command: &'static str,
        /// The rate.
        baud: u32,
    },
    /// A command was refused.
    #[error("the SICK scanner on {path} refused {command}: {detail}")]
    Refused {
        /// The port.
        path: PathBuf,
        /// What was asked.
        command: &'static str,
        /// What it answered.
        detail: String,
    },
    /// The port went away during the setup.
    #[error("lost the SICK scanner during setup: {reason}")]
    Lost {
        /// What happened.
        reason: String,
    },
    /// A command could not be encoded (a configuration the codec refuses).
    #[error("SICK command for {path}: {source}")]
    Codec {
        /// The port.
        path: PathBuf,
        /// The codec's error.
        source: SickError,
    },
}

/// A step of setting the scanner up, as a device reader reports it while it waits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SetupStep {
    /// Opening the port.
    Opening,
    /// Asking for an answer at this rate.
    Probing(BaudRate),
    /// Moving the scanner and the port to this rate.
    Switching(BaudRate),
    /// Setting angle and resolution.
    SettingLayout,
    /// Reading the configuration, and changing the range unit if needed (an EEPROM write).
    SettingUnit,
    /// Asking for continuous streaming.
    StartingStream,
}

impl std::fmt::Display for SetupStep {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Opening => write!(f, "opening the port"),
            Self::Probing(rate) => write!(f, "probing at {} baud", rate.bits_per_second()),
            Self::Switching(rate) => write!(f, "switching to {} baud", rate.bits_per_second()),
            Self::SettingLayout => write!(f, "setting angle and resolution"),
            Self::SettingUnit => write!(f, "setting the range unit"),
            Self::StartingStream => write!(f, "starting the stream"),
        }
    }
}

/// What a device reader hands the driver: a report of each set-up step, and a stop request
/// that ends every wait of the driver at once.
#[derive(Default)]
pub(crate) struct SickHooks {
    pub(crate) progress: Option<Box<dyn FnMut(SetupStep) + Send>>,
    pub(crate) cancel: Option<Cancel>,
}

impl std::fmt::Debug for SickHooks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SickHooks")
            .field("progress", &self.progress.is_some())
            .field("cancel", &self.cancel)
            .finish()
    }
}

/// A decoded scan with its angles.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserScan {
    /// Angle and resolution of the values.
    pub layout: ScanLayout,
    /// The values as sent: ranges in the scan's unit and flags.
    pub scan: Scan,
    /// When the driver decoded it.
    pub received_at: Instant,
}

impl LaserScan {
    /// The ranges in metres, in angular order.
    pub fn ranges_m(&self) -> Vec<f64> {
        self.scan.ranges_m()
    }

    /// The angle of value `index` in the scanner's frame (0 ahead, counter-clockwise).
    pub fn angle_rad(&self, index: usize) -> f64 {
        self.layout.angle_rad(index)
    }

    /// The largest range the unit can carry: a value there means nothing seen.
    pub fn max_range_m(&self) -> f64 {
        f64::from(ScanValue::MAX_RANGE) * self.scan.unit.metres()
    }
}

/// What the driver counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SickStats {
    /// Scans decoded.
    pub scans: u64,
    /// Valid telegrams that were not scans (replies).
    pub other_telegrams: u64,
    /// Telegrams with a good CRC whose content could not be decoded, or scans of a layout
    /// other than the configured one.
    pub undecodable_telegrams: u64,
    /// The deframer's counters: bytes skipped (garbage), CRC and length errors.
    pub frames: DeframerStats,
    /// Times the port came back and the scanner was set up again.
    pub reconnects: u64,
    /// Times a scanner silent past its deadline on an open port was set up again.
    pub resetups: u64,
}

/// The driver of one scanner.
#[derive(Debug)]
pub struct SickDriver {
    config: SickDriverConfig,
    link: SerialLink,
    receiver: SickReceiver,
    pending: VecDeque<LaserScan>,
    stats: SickStats,
    baud: Option<BaudRate>,
    streaming_since: Instant,
    last_scan_at: Option<Instant>,
    down_reason: Option<String>,
    /// Why the last set-up on the open port failed (cleared by one that succeeds).
    setup_error: Option<String>,
    /// When the last set-up attempt ended.
    last_setup_at: Option<Instant>,
    retry: Retry,
    hooks: SickHooks,
    buf: Vec<u8>,
}

impl SickDriver {
    /// Opens the port and sets the scanner up; it streams when this returns.
    pub fn open(config: SickDriverConfig) -> Result<Self, SickDriverError> {
        Self::open_with(config, SickHooks::default())
    }

    /// As [`SickDriver::open`], reporting each set-up step (now and at every later set-up)
    /// to `hooks.progress` and ending every wait when `hooks.cancel` is set.
    pub(crate) fn open_with(
        config: SickDriverConfig,
        mut hooks: SickHooks,
    ) -> Result<Self, SickDriverError> {
        if let Some(progress) = &mut hooks.progress {
            progress(SetupStep::Opening);
        }
        let first = config
            .probe_rates
            .first()
            .copied()
            .unwrap_or(BaudRate::B9600);
        let mut link = SerialLink::open(&config.path, first.bits_per_second(), config.parity)?;
        link.set_cancel(hooks.cancel.clone());
        let now = Instant::now();
        let mut driver = Self {
            receiver: SickReceiver::new(config.layout, config.crc_window),
            retry: Retry::new(config.reconnect_interval),
            config,
            link,
            pending: VecDeque::new(),
            stats: SickStats::default(),
            baud: None,
            streaming_since: now,
            last_scan_at: None,
            down_reason: None,
            setup_error: None,
            last_setup_at: None,
            hooks,
            buf: vec![0; 4096],
        };
        driver.setup()?;
        Ok(driver)
    }

    /// The next scan, waiting at most `timeout` (zero: only what has arrived); `None` when
    /// none came. Problems do not end the stream: they show in [`SickDriver::health`], and a
    /// port that went away is reopened (and the scanner set up again) every
    /// `reconnect_interval` while this is called.
    ///
    /// A scanner silent past the scan deadline on an open port is set up again (probed from
    /// the power-up rate) one `reconnect_interval` after the deadline, and every interval
    /// after a failed attempt: this call then blocks for the set-up.
    pub fn read_scan(&mut self, timeout: Duration) -> Option<LaserScan> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(scan) = self.pending.pop_front() {
                return Some(scan);
            }
            if self.hooks.cancel.as_ref().is_some_and(Cancel::is_set) {
                return None;
            }
            if !self.link.is_open() {
                self.reconnect(deadline);
                if Instant::now() >= deadline && self.pending.is_empty() {
                    return None;
                }
                continue;
            }
            let now = Instant::now();
            let resetup_at = self.resetup_due();
            if resetup_at <= now {
                self.resetup();
                continue;
            }
            let remaining = deadline.saturating_duration_since(now);
            let wait = remaining.min(resetup_at.saturating_duration_since(now));
            match self.read_some(wait) {
                // Past the deadline: only what has arrived, even if bytes keep coming.
                Ok(_) if remaining.is_zero() => return self.pending.pop_front(),
                Ok(_) => {}
                Err(down) if down.stopped => return self.pending.pop_front(),
                Err(down) => self.lost(down),
            }
        }
    }

    /// When a silent scanner on the open port is next set up again.
    fn resetup_due(&self) -> Instant {
        let interval = self.config.reconnect_interval;
        let first = self.silent_since() + self.config.scan_deadline + interval;
        match self.last_setup_at {
            Some(at) if self.setup_error.is_some() => first.max(at + interval),
            _ => first,
        }
    }

    /// Sets a silent scanner up again on the open port.
    fn resetup(&mut self) {
        match self.setup() {
            Ok(()) => {
                self.setup_error = None;
                self.stats.resetups += 1;
            }
            Err(SickDriverError::Lost { reason }) => {
                self.lost(LinkDown {
                    reason,
                    stopped: false,
                });
            }
            Err(error) => self.setup_error = Some(error.to_string()),
        }
    }

    /// Since when no valid scan came (or since the stream started).
    fn silent_since(&self) -> Instant {
        self.last_scan_at
            .map_or(self.streaming_since, |last| last.max(self.streaming_since))
    }

    /// Since when the scanner has been silent (its last scan, or the start of the stream),
    /// and the deadline after which that is [`DriverHealth::NoData`].
    pub fn silence(&self) -> (Instant, Duration) {
        (self.silent_since(), self.config.scan_deadline)
    }

    /// What the driver thinks of the scanner now.
    pub fn health(&self) -> DriverHealth {
        let path = self.config.path.clone();
        if let Some(reason) = &self.down_reason {
            return DriverHealth::Disconnected {
                path,
                reason: reason.clone(),
            };
        }
        if let Some(reason) = &self.setup_error {
            return DriverHealth::NotSetUp {
                reason: reason.clone(),
            };
        }
        let silent_for = self.silent_since().elapsed();
        if silent_for > self.config.scan_deadline {
            return DriverHealth::NoData {
                path,
                silent_for,
                deadline: self.config.scan_deadline,
            };
        }
        let error_rate = self.receiver.error_rate();
        if error_rate > self.config.crc_error_threshold {
            return DriverHealth::ChecksumErrors {
                path,
                error_rate,
                threshold: self.config.crc_error_threshold,
            };
        }
        DriverHealth::Ok
    }

    /// The counters so far.
    pub fn stats(&self) -> SickStats {
        SickStats {
            frames: self.receiver.frames(),
            undecodable_telegrams: self.receiver.undecodable(),
            ..self.stats
        }
    }

    /// The rate the scanner and the port run at, once set up.
    pub fn baud(&self) -> Option<BaudRate> {
        self.baud
    }

    /// The configuration.
    pub fn config(&self) -> &SickDriverConfig {
        &self.config
    }

    /// The port's descriptor while it is open (readable: call [`SickDriver::read_scan`] with
    /// a zero timeout). `None` while the port is away: call `read_scan` with a timeout, which
    /// retries the port.
    pub fn fd(&self) -> Option<BorrowedFd<'_>> {
        self.link.fd()
    }

    /// Reports a set-up step to the reader, if one listens.
    fn step(&mut self, step: SetupStep) {
        if let Some(progress) = &mut self.hooks.progress {
            progress(step);
        }
    }

    fn setup(&mut self) -> Result<(), SickDriverError> {
        let result = self.setup_steps();
        self.last_setup_at = Some(Instant::now());
        result
    }

    fn setup_steps(&mut self) -> Result<(), SickDriverError> {
        self.baud = None;
        let found = self.probe()?;
        let target = self.config.baud;
        let timeout = self.config.reply_timeout;
        if found != target {
            self.step(SetupStep::Switching(target));
            let reply = self.transact(&SickCommand::SwitchBaud(target), timeout)?;
            self.expect_mode_ok(&reply, "the baud-rate switch")?;
            self.switch_port(target)?;
            // The scanner must now answer at the new rate.
            self.transact(&SickCommand::StopStreaming, timeout)?;
        }
        self.baud = Some(target);
        self.step(SetupStep::SettingLayout);
        let layout = self.config.layout;
        match self
            .transact(&SickCommand::set_layout(layout), timeout)?
            .body
        {
            ReplyBody::Layout { accepted: true, .. } => {}
            other => return Err(self.refused("the angle and resolution", &other)),
        }
        self.step(SetupStep::SettingUnit);
        let current = match self.transact(&SickCommand::GetConfig, timeout)?.body {
            ReplyBody::Config(config) => config,
            other => return Err(self.refused("the configuration request", &other)),
        };
        if current.unit().ok() != Some(self.config.unit) {
            let password = SickCommand::InstallationMode {
                password: DEFAULT_PASSWORD,
            };
            let reply = self.transact(&password, timeout)?;
            self.expect_mode_ok(&reply, "installation mode (password)")?;
            let wanted = current
                .with_unit(self.config.unit)
                .map_err(|source| self.codec(source))?;
            let config_timeout = self.config.config_timeout;
            match self
                .transact(&SickCommand::SetConfig(wanted), config_timeout)?
                .body
            {
                ReplyBody::SetConfig { accepted: true, .. } => {}
                other => return Err(self.refused("the range unit", &other)),
            }
        }
        self.pending.clear();
        self.step(SetupStep::StartingStream);
        let reply = self.transact(&SickCommand::StartStreaming, timeout)?;
        self.expect_mode_ok(&reply, "continuous streaming")?;
        self.streaming_since = Instant::now();
        self.last_scan_at = None;
        self.receiver.clear_errors();
        Ok(())
    }

    /// Finds the rate the scanner listens at: `20 25` (stop streaming) at each candidate.
    fn probe(&mut self) -> Result<BaudRate, SickDriverError> {
        let rates = self.config.probe_rates.clone();
        for rate in &rates {
            self.step(SetupStep::Probing(*rate));
            self.switch_port(*rate)?;
            match self.transact(&SickCommand::StopStreaming, self.config.reply_timeout) {
                Ok(_) => return Ok(*rate),
                Err(SickDriverError::NoReply { .. }) => {}
                Err(error) => return Err(error),
            }
        }
        let rates = rates
            .iter()
            .map(|rate| rate.bits_per_second().to_string())
            .collect::<Vec<_>>()
            .join(", ");
        Err(SickDriverError::NoAnswer {
            path: self.config.path.clone(),
            rates,
        })
    }

    /// Sets the port's speed and forgets what arrived at the old one.
    fn switch_port(&mut self, rate: BaudRate) -> Result<(), SickDriverError> {
        self.link
            .set_baud(rate.bits_per_second())
            .and_then(|()| self.link.clear_input())
            .map_err(|down| SickDriverError::Lost {
                reason: down.reason,
            })?;
        self.receiver.reset();
        Ok(())
    }

    /// Sends `command` until its reply (or a NACK) comes, `attempts` times at most.
    fn transact(
        &mut self,
        command: &SickCommand,
        timeout: Duration,
    ) -> Result<SickReply, SickDriverError> {
        let telegram = command.telegram().map_err(|source| self.codec(source))?;
        let expected = command.reply_code();
        for _ in 0..self.config.attempts.max(1) {
            self.link
                .write_all(&telegram)
                .map_err(|down| SickDriverError::Lost {
                    reason: down.reason,
                })?;
            if let Some(reply) = self.await_reply(expected, timeout)? {
                if reply.code() == NACK_REPLY {
                    return Err(self.refused(command_name(command), &reply.body));
                }
                return Ok(reply);
            }
        }
        Err(SickDriverError::NoReply {
            path: self.config.path.clone(),
            command: command_name(command),
            baud: self.link_baud(),
        })
    }

    fn await_reply(
        &mut self,
        code: u8,
        timeout: Duration,
    ) -> Result<Option<SickReply>, SickDriverError> {
        let deadline = Instant::now() + timeout;
        loop {
            let remaining = deadline.saturating_duration_since(Instant::now());
            if remaining.is_zero() {
                return Ok(None);
            }
            let count =
                self.link
                    .read(&mut self.buf, remaining)
                    .map_err(|down| SickDriverError::Lost {
                        reason: down.reason,
                    })?;
            let mut found = None;
            for reply in self.take_bytes(count) {
                if found.is_none() && (reply.code() == code || reply.code() == NACK_REPLY) {
                    found = Some(reply);
                } else {
                    self.stats.other_telegrams += 1;
                }
            }
            if found.is_some() {
                return Ok(found);
            }
        }
    }

    /// Reads what arrives within `timeout` and queues the scans; the bytes read.
    fn read_some(&mut self, timeout: Duration) -> Result<usize, LinkDown> {
        let count = self.link.read(&mut self.buf, timeout)?;
        let replies = self.take_bytes(count);
        self.stats.other_telegrams += replies.len() as u64;
        Ok(count)
    }

    /// Decodes the first `count` bytes of the buffer: scans are queued, other replies
    /// returned.
    fn take_bytes(&mut self, count: usize) -> Vec<SickReply> {
        let mut replies = Vec::new();
        for received in self.receiver.push(&self.buf[..count]) {
            match received {
                SickReceived::Scan(scan) => self.queue_scan(scan),
                SickReceived::Reply(reply) => replies.push(reply),
            }
        }
        replies
    }

    fn queue_scan(&mut self, scan: Scan) {
        let now = Instant::now();
        self.stats.scans += 1;
        self.last_scan_at = Some(now);
        self.pending.push_back(LaserScan {
            layout: self.config.layout,
            scan,
            received_at: now,
        });
    }

    fn lost(&mut self, down: LinkDown) {
        self.link.close();
        self.baud = None;
        self.down_reason = Some(down.reason);
        self.setup_error = None;
        self.retry.now();
    }

    /// Tries to reopen the port and set the scanner up when a retry is due; otherwise waits
    /// for the retry (at most until `deadline`).
    fn reconnect(&mut self, deadline: Instant) {
        if !self.retry.due_or_wait(deadline, self.hooks.cancel.as_ref()) {
            return;
        }
        self.step(SetupStep::Opening);
        let first = self
            .config
            .probe_rates
            .first()
            .copied()
            .unwrap_or(BaudRate::B9600);
        let result = self
            .link
            .reopen(first.bits_per_second())
            .map_err(SickDriverError::from)
            .and_then(|()| self.setup());
        match result {
            Ok(()) => {
                self.down_reason = None;
                self.stats.reconnects += 1;
            }
            Err(error) => {
                self.link.close();
                self.down_reason = Some(error.to_string());
            }
        }
    }

    fn expect_mode_ok(
        &self,
        reply: &SickReply,
        command: &'static str,
    ) -> Result<(), SickDriverError> {
        match reply.body {
            ReplyBody::ModeChange {
                result: MODE_CHANGE_OK,
            } => Ok(()),
            ref other => Err(self.refused(command, other)),
        }
    }

    fn refused(&self, command: &'static str, body: &ReplyBody) -> SickDriverError {
        SickDriverError::Refused {
            path: self.config.path.clone(),
            command,
            detail: format!("{body:?}"),
        }
    }

    fn codec(&self, source: SickError) -> SickDriverError {
        SickDriverError::Codec {
            path: self.config.path.clone(),
            source,
        }
    }

    fn link_baud(&self) -> u32 {
        self.link.baud_bps()
    }
}

impl Drop for SickDriver {
    /// Asks the scanner to stop streaming (best effort: the port may be gone).
    fn drop(&mut self) {
        if self.link.is_open()
            && let Ok(telegram) = SickCommand::StopStreaming.telegram()
        {
            let _ = self.link.write_all(&telegram);
        }
    }
}

fn command_name(command: &SickCommand) -> &'static str {
    match command {
        SickCommand::StopStreaming => "stop streaming (20 25)",
        SickCommand::StartStreaming => "start streaming (20 24)",
        SickCommand::SwitchBaud(_) => "the baud-rate switch (20 4x)",
        SickCommand::InstallationMode { .. } => "installation mode (20 00)",
        SickCommand::GetType => "the type request (3A)",
        SickCommand::SetLayout { .. } => "the angle and resolution (3B)",
        SickCommand::GetConfig => "the configuration request (74)",
        SickCommand::SetConfig(_) => "the configuration (77)",
        SickCommand::GetStatus => "the status request (31)",
    }
}
