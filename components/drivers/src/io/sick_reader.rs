//! The SICK's device reader: a thread that owns the [`SickDriver`] (opening the port, probing
//! the scanner's rate, setting it up, reading scans, reconnecting, setting a silent scanner up
//! again) and hands what it gets to the service through a descriptor that becomes readable
//! when there is news ([`SickReader::fd`]). Everything that blocks on the device happens
//! here, so the service's own thread (which answers commands and sends heartbeats) never
//! waits for the scanner; this is the part of the `sick` service that never runs in replay.
//!
//! The queues are bounded: when the service does not take them, the oldest scans are dropped
//! and counted ([`SCAN_QUEUE`]), and the oldest status changes are dropped
//! ([`STATUS_QUEUE`]; the latest, which is what counts, is always kept).

use std::collections::VecDeque;
use std::os::fd::{AsFd, BorrowedFd, OwnedFd};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use nix::fcntl::OFlag;

use super::cancel::{Cancel, CancelHandle, cancel_pair};
use super::health::DriverHealth;
use super::sick_driver::{LaserScan, SetupStep, SickDriver, SickDriverConfig, SickHooks};
use crate::sick::BaudRate;

/// Scans kept for the service; beyond this the oldest are dropped (it is not reading).
pub const SCAN_QUEUE: usize = 64;
/// Status changes kept for the service; beyond this the oldest are dropped.
pub const STATUS_QUEUE: usize = 32;
/// The longest the reader waits in one read while the scanner is in trouble, so that the
/// status follows the driver's (CRC errors clearing, set-up attempts) without delay.
const TROUBLE_SLICE: Duration = Duration::from_millis(100);

/// What the reader says about the scanner.
#[derive(Debug, Clone, PartialEq)]
pub enum SickReaderStatus {
    /// Opening the port or setting the scanner up: the step being done.
    SettingUp(SetupStep),
    /// Valid scans flow at this rate.
    Streaming(BaudRate),
    /// No data, too many bad CRCs, the port away, or a set-up that failed; the driver
    /// retries.
    Trouble(DriverHealth),
}

impl SickReaderStatus {
    /// Whether `other` says the same thing (a [`DriverHealth::NoData`] whose silence grew is
    /// not news).
    fn same_as(&self, other: &Self) -> bool {
        match (self, other) {
            (Self::Trouble(a), Self::Trouble(b)) => match (a, b) {
                (DriverHealth::NoData { .. }, DriverHealth::NoData { .. })
                | (DriverHealth::ChecksumErrors { .. }, DriverHealth::ChecksumErrors { .. }) => {
                    true
                }
                _ => a == b,
            },
            _ => self == other,
        }
    }
}

/// A status with the moment the reader saw it (its own clock, for tests that judge the
/// driver's reaction time by the driver's timestamps).
#[derive(Debug, Clone, PartialEq)]
pub struct StatusReport {
    /// The status.
    pub status: SickReaderStatus,
    /// When the reader saw it.
    pub at: Instant,
}

/// What arrived since the last [`SickReader::take`].
#[derive(Debug, Default)]
pub struct SickNews {
    /// Scans, oldest first.
    pub scans: Vec<LaserScan>,
    /// The status changes, oldest first (the last is the status now).
    pub statuses: Vec<StatusReport>,
}

#[derive(Debug, Default)]
struct Inbox {
    scans: VecDeque<LaserScan>,
    dropped_scans: u64,
    statuses: VecDeque<StatusReport>,
    /// The last status reported, to tell news from repetition.
    last_status: Option<SickReaderStatus>,
}

#[derive(Debug)]
struct Shared {
    inbox: Mutex<Inbox>,
    /// The write end of the news pipe.
    news_tx: OwnedFd,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Inbox> {
        self.inbox.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn wake(&self) {
        // A full pipe is readable already: the error is harmless.
        let _ = nix::unistd::write(&self.news_tx, &[1]);
    }

    fn push_scan(&self, scan: LaserScan) {
        {
            let mut inbox = self.lock();
            if inbox.scans.len() >= SCAN_QUEUE {
                inbox.scans.pop_front();
                inbox.dropped_scans += 1;
            }
            inbox.scans.push_back(scan);
        }
        self.wake();
    }

    fn report(&self, status: SickReaderStatus) {
        {
            let mut inbox = self.lock();
            if inbox
                .last_status
                .as_ref()
                .is_some_and(|last| last.same_as(&status))
            {
                return;
            }
            inbox.last_status = Some(status.clone());
            if inbox.statuses.len() >= STATUS_QUEUE {
                inbox.statuses.pop_front();
            }
            inbox.statuses.push_back(StatusReport {
                status,
                at: Instant::now(),
            });
        }
        self.wake();
    }
}

/// Why the reader could not start.
#[derive(Debug, thiserror::Error)]
pub enum SickReaderError {
    /// A pipe could not be made.
    #[error("SICK reader: cannot make a pipe: {0}")]
    Pipe(nix::errno::Errno),
    /// The thread could not be started.
    #[error("SICK reader: cannot start its thread: {0}")]
    Thread(std::io::Error),
}

/// A running device reader; dropping it stops the thread (at once: every wait of the driver
/// ends) and tells the scanner to stop streaming.
pub struct SickReader {
    shared: Arc<Shared>,
    news_rx: OwnedFd,
    cancel: CancelHandle,
    thread: Option<JoinHandle<()>>,
}

impl SickReader {
    /// Starts a reader for the scanner of `config`: it opens the port and sets the scanner
    /// up in its thread, retrying every `reconnect_interval` until it streams.
    ///
    /// # Errors
    /// When a pipe or the thread cannot be made.
    pub fn spawn(config: SickDriverConfig) -> Result<Self, SickReaderError> {
        let (news_rx, news_tx) = nix::unistd::pipe2(OFlag::O_CLOEXEC | OFlag::O_NONBLOCK)
            .map_err(SickReaderError::Pipe)?;
        let (cancel, cancel_handle) = cancel_pair().map_err(SickReaderError::Pipe)?;
        let shared = Arc::new(Shared {
            inbox: Mutex::new(Inbox::default()),
            news_tx,
        });
        let thread_shared = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("sick-reader".to_owned())
            .spawn(move || {
                let _ended = Ended {
                    shared: &thread_shared,
                    cancel: &cancel,
                };
                run(&config, &thread_shared, &cancel);
            })
            .map_err(SickReaderError::Thread)?;
        Ok(Self {
            shared,
            news_rx,
            cancel: cancel_handle,
            thread: Some(thread),
        })
    }

    /// Readable when there is news: call [`SickReader::take`].
    pub fn fd(&self) -> BorrowedFd<'_> {
        self.news_rx.as_fd()
    }

    /// Takes what arrived, without waiting.
    pub fn take(&self) -> SickNews {
        let mut buf = [0; 64];
        while matches!(nix::unistd::read(&self.news_rx, &mut buf), Ok(count) if count > 0) {}
        let mut inbox = self.shared.lock();
        SickNews {
            scans: inbox.scans.drain(..).collect(),
            statuses: inbox.statuses.drain(..).collect(),
        }
    }

    /// Scans dropped because they were not taken in time.
    pub fn dropped_scans(&self) -> u64 {
        self.shared.lock().dropped_scans
    }
}

impl Drop for SickReader {
    fn drop(&mut self) {
        self.cancel.cancel();
        if let Some(thread) = self.thread.take() {
            // The thread ends at once (every wait watches the cancel); a panic there is a
            // bug already reported on stderr.
            let _ = thread.join();
        }
    }
}

impl std::fmt::Debug for SickReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SickReader")
            .field("status", &self.shared.lock().last_status)
            .finish_non_exhaustive()
    }
}

/// Says so when the reader thread ends without being asked to (a bug, a panic): the service
/// must not wait for news that will never come.
struct Ended<'a> {
    shared: &'a Shared,
    cancel: &'a Cancel,
}

impl Drop for Ended<'_> {
    fn drop(&mut self) {
        if !self.cancel.is_set() {
            self.shared
                .report(SickReaderStatus::Trouble(DriverHealth::NotSetUp {
                reason:
                    "the SICK device reader stopped (a bug: see the log): restart the laser service"
                        .to_owned(),
            }));
        }
    }
}

/// The reader thread: open and set up until it streams, then read scans and follow the
/// driver's health, until cancelled.
fn run(config: &SickDriverConfig, shared: &Arc<Shared>, cancel: &Cancel) {
    let mut driver: Option<SickDriver> = None;
    while !cancel.is_set() {
        let Some(open) = driver.as_mut() else {
            let progress_shared = Arc::clone(shared);
            let hooks = SickHooks {
                progress: Some(Box::new(move |step| {
                    progress_shared.report(SickReaderStatus::SettingUp(step));
                })),
                cancel: Some(cancel.clone()),
            };
            match SickDriver::open_with(config.clone(), hooks) {
                Ok(opened) => driver = Some(opened),
                Err(error) => {
                    if cancel.is_set() {
                        break;
                    }
                    shared.report(SickReaderStatus::Trouble(DriverHealth::NotSetUp {
                        reason: error.to_string(),
                    }));
                    cancel.wait(config.reconnect_interval);
                }
            }
            continue;
        };
        report_health(shared, open);
        let wait = match open.health() {
            // Wake exactly when the scanner would be late, to report it then.
            DriverHealth::Ok => {
                let (since, deadline) = open.silence();
                (since + deadline + Duration::from_millis(1))
                    .saturating_duration_since(Instant::now())
            }
            _ => TROUBLE_SLICE,
        };
        if let Some(scan) = open.read_scan(wait) {
            shared.push_scan(scan);
            while let Some(scan) = open.read_scan(Duration::ZERO) {
                shared.push_scan(scan);
            }
        }
        report_health(shared, open);
    }
}

/// Reports the driver's view: streaming when healthy, else its trouble.
fn report_health(shared: &Shared, driver: &SickDriver) {
    let status = match (driver.health(), driver.baud()) {
        (DriverHealth::Ok, Some(baud)) => SickReaderStatus::Streaming(baud),
        // Healthy but with no rate: between a loss and the end of the next set-up, which
        // reports its own steps.
        (DriverHealth::Ok, None) => return,
        (trouble, _) => SickReaderStatus::Trouble(trouble),
    };
    shared.report(status);
}
