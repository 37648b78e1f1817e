//! The robot host's side: its bridge, and the broker's hold on the other hosts
//! ([`RemoteHosts`]): orders to their supervisors as Zenoh queries, their exits, and
//! whether each host is there (its liveliness token and its beat).

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::os::fd::{AsFd as _, BorrowedFd};
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use lewis_robot::Robot;
use lewis_runtime::broker::remote::{HostEvent, RemoteHosts, RemoteStartError};
use lewis_runtime::ipc::Namespace;
use zenoh::Session;
use zenoh::Wait as _;
use zenoh::sample::SampleKind;

use crate::forward::{BEAT_PERIOD, Wake, drain};
use crate::wire::parse_exit;
use crate::{BridgeError, ForwardOptions, Forwarder, Heard, keys, session, wire};

/// How long the robot host waits for another host's answer to a start.
const ORDER_TIMEOUT: Duration = Duration::from_secs(1);

/// How long a host must be heard without a miss before it joins (again).
const JOIN_STEADY: Duration = Duration::from_millis(500);

/// A host that missed this many of its beats in a row is quiet.
const QUIET_BEATS: u32 = 3;

/// How often the watcher looks whether each host is still there.
const WATCH_PERIOD: Duration = Duration::from_millis(10);

#[derive(Debug, Default)]
struct State {
    /// Hosts whose liveliness token is there.
    tokens: BTreeSet<String>,
    /// Whether each host is taken as joined.
    joined: BTreeMap<String, bool>,
    /// Since when each host has been heard without missing its beats.
    steady_since: BTreeMap<String, Instant>,
    /// Hosts whose beat says another protocol version, with it.
    refused: BTreeMap<String, String>,
    /// Per host, the least of (this host's clock at a beat's arrival minus the sender's
    /// clock in its timestamp) over every beat heard: the offset of the clocks plus the least
    /// one-way latency, in nanoseconds.
    clock_offsets: BTreeMap<String, i64>,
    events: VecDeque<HostEvent>,
}

type Shared = Arc<Mutex<State>>;

fn lock(shared: &Shared) -> std::sync::MutexGuard<'_, State> {
    shared.lock().unwrap_or_else(PoisonError::into_inner)
}

/// The robot host's bridge and its hold on the other hosts, for the broker.
pub struct RobotHost {
    session: Session,
    robot: String,
    heard: Heard,
    shared: Shared,
    wake_rx: UnixStream,
    stop: Arc<AtomicBool>,
    watcher: Option<JoinHandle<()>>,
    _forwarder: Forwarder,
    _declarations: Vec<Box<dyn std::any::Any + Send>>,
}

impl std::fmt::Debug for RobotHost {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RobotHost")
            .field("robot", &self.robot)
            .finish_non_exhaustive()
    }
}

impl RobotHost {
    /// Opens the robot host's session, starts its bridge in `namespace`, and begins to
    /// watch the other hosts. `scratch` is a folder of this run's own.
    ///
    /// # Errors
    /// When the session, a key or a channel cannot be opened.
    pub fn start(
        robot: &Robot,
        namespace: &Namespace,
        scratch: &Path,
    ) -> Result<Self, BridgeError> {
        let Some(hub) = robot.robot_host() else {
            return Err(BridgeError::UnknownHost {
                host: String::new(),
                hint: String::new(),
                hosts: "none".to_owned(),
            });
        };
        let session = session::open(robot, hub, scratch)?;
        let heard = Heard::default();
        let forwarder = Forwarder::start(
            &session,
            ForwardOptions::of_host(robot, &hub.name, namespace),
            heard.clone(),
        )?;
        let (wake, wake_rx) = Wake::pair().map_err(BridgeError::Thread)?;
        let shared: Shared = Arc::default();
        let mut declarations: Vec<Box<dyn std::any::Any + Send>> = Vec::new();
        let name = robot.name.clone();
        let token = session
            .liveliness()
            .declare_token(keys::host_token(&name, &hub.name))
            .wait()
            .map_err(BridgeError::zenoh("host token"))?;
        declarations.push(Box::new(token));
        let (tokens, robot_name) = (Arc::clone(&shared), name.clone());
        let liveliness = session
            .liveliness()
            .declare_subscriber(format!("lewis/{name}/@hosts/*"))
            .history(true)
            .callback(move |sample| {
                let Some(host) = keys::host_of_token(&robot_name, sample.key_expr().as_str())
                else {
                    return;
                };
                let mut state = lock(&tokens);
                match sample.kind() {
                    SampleKind::Put => state.tokens.insert(host.to_owned()),
                    SampleKind::Delete => state.tokens.remove(host),
                };
            })
            .wait()
            .map_err(BridgeError::zenoh("host tokens"))?;
        declarations.push(Box::new(liveliness));
        let (beats_heard, refused) = (heard.clone(), Arc::clone(&shared));
        let beats = session
            .declare_subscriber(format!("lewis/{name}/*/@beat"))
            .callback(move |sample| {
                let Some(host) = sample.key_expr().as_str().split('/').nth(2) else {
                    return;
                };
                match session::beat_protocol(sample.payload()) {
                    Ok(()) => {
                        beats_heard.hear(host);
                        if let Some(offset) = sample.timestamp().and_then(clock_offset_ns) {
                            let mut state = lock(&refused);
                            let least =
                                state.clock_offsets.entry(host.to_owned()).or_insert(offset);
                            *least = (*least).min(offset);
                        }
                    }
                    Err(said) => {
                        lock(&refused).refused.insert(host.to_owned(), said);
                    }
                }
            })
            .wait()
            .map_err(BridgeError::zenoh("beats"))?;
        declarations.push(Box::new(beats));
        let (exits, exits_wake) = (Arc::clone(&shared), wake.clone());
        let exit_subscriber = session
            .declare_subscriber(format!("lewis/{name}/*/@exits"))
            .callback(move |sample| {
                let text = sample.payload().try_to_string().unwrap_or_default();
                if let Some(event) = parse_exit(&text) {
                    lock(&exits).events.push_back(event);
                    exits_wake.wake();
                }
            })
            .wait()
            .map_err(BridgeError::zenoh("exits"))?;
        declarations.push(Box::new(exit_subscriber));
        let stop = Arc::new(AtomicBool::new(false));
        let watcher = {
            let others: Vec<String> = robot.hosts.iter().skip(1).map(|h| h.name.clone()).collect();
            let deadline = Duration::from_millis(robot.network.link_deadline_ms);
            let (shared, heard, stop) = (Arc::clone(&shared), heard.clone(), Arc::clone(&stop));
            std::thread::Builder::new()
                .name("lewis-hosts".to_owned())
                .spawn(move || {
                    while !stop.load(Ordering::Acquire) {
                        watch(&others, deadline, &shared, &heard, &wake);
                        std::thread::sleep(WATCH_PERIOD);
                    }
                })
                .map_err(BridgeError::Thread)?
        };
        Ok(Self {
            session,
            robot: name,
            heard,
            shared,
            wake_rx,
            stop,
            watcher: Some(watcher),
            _forwarder: forwarder,
            _declarations: declarations,
        })
    }
}

impl Drop for RobotHost {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(watcher) = self.watcher.take() {
            let _ = watcher.join();
        }
    }
}

/// Whether each other host is there: its token, and a beat within the link deadline.
fn watch(others: &[String], deadline: Duration, shared: &Shared, heard: &Heard, wake: &Wake) {
    let mut state = lock(shared);
    let mut woke = false;
    for host in others {
        let token = state.tokens.contains(host);
        let silence = heard.silence(host);
        let refused = state.refused.get(host).cloned();
        let was = state.joined.get(host).copied().unwrap_or(false);
        // A link that comes back may flap while the hosts' sessions are made again: a host
        // joins once it has been heard steadily for a while, and is lost past the deadline.
        if silence.is_some_and(|s| s < BEAT_PERIOD * QUIET_BEATS) {
            state
                .steady_since
                .entry(host.clone())
                .or_insert_with(Instant::now);
        } else {
            state.steady_since.remove(host);
        }
        let steady = state
            .steady_since
            .get(host)
            .is_some_and(|since| since.elapsed() >= JOIN_STEADY);
        let heard = if was {
            silence.is_some_and(|s| s < deadline)
        } else {
            steady
        };
        let up = token && refused.is_none() && heard;
        if up == was {
            if let Some(version) = refused
                && state.joined.insert(host.clone(), false).is_none()
            {
                tracing::error!(
                    "host {}; it is not joined",
                    session::other_protocol(host, &version)
                );
            }
            continue;
        }
        state.joined.insert(host.clone(), up);
        let event = if up {
            if let Some(offset) = state.clock_offsets.get(host) {
                tracing::info!(
                    "host {host}: its clock reads {:.1} ms behind this one's, one-way latency included (from its beats' Zenoh timestamps)",
                    *offset as f64 / 1e6
                );
            }
            HostEvent::Joined { host: host.clone() }
        } else if !token {
            HostEvent::Lost {
                host: host.clone(),
                why: "its Zenoh session closed".to_owned(),
            }
        } else {
            HostEvent::Lost {
                host: host.clone(),
                why: format!(
                    "nothing heard from it for {} ms (its link deadline)",
                    silence.unwrap_or_default().as_millis()
                ),
            }
        };
        state.events.push_back(event);
        woke = true;
    }
    drop(state);
    if woke {
        wake.wake();
    }
}

/// This host's clock now minus the clock in `timestamp`, in nanoseconds.
fn clock_offset_ns(timestamp: &zenoh::time::Timestamp) -> Option<i64> {
    let sent = timestamp.get_time().to_system_time();
    let now = std::time::SystemTime::now();
    match now.duration_since(sent) {
        Ok(ahead) => i64::try_from(ahead.as_nanos()).ok(),
        Err(behind) => i64::try_from(behind.duration().as_nanos()).ok().map(|n| -n),
    }
}

impl RemoteHosts for RobotHost {
    fn start(&mut self, host: &str, service: &str) -> Result<u32, RemoteStartError> {
        let unreachable = |why: String| RemoteStartError::Unreachable(why);
        let replies = self
            .session
            .get(keys::control(&self.robot, host))
            .payload(format!("start {service}"))
            .timeout(ORDER_TIMEOUT)
            .wait()
            .map_err(|e| unreachable(format!("cannot ask it to start {service}: {e}")))?;
        let reply = replies.recv().map_err(|_| {
            unreachable(format!(
                "it did not answer the order to start {service} within {} ms",
                ORDER_TIMEOUT.as_millis()
            ))
        })?;
        let sample = reply.result().map_err(|e| {
            RemoteStartError::Refused(e.payload().try_to_string().unwrap_or_default().into_owned())
        })?;
        let text = sample.payload().try_to_string().unwrap_or_default();
        wire::parse_answer(host, &text)
    }

    fn stop(&mut self, host: &str, service: &str) {
        let sent = self
            .session
            .get(keys::control(&self.robot, host))
            .payload(format!("stop {service}"))
            .timeout(ORDER_TIMEOUT)
            .callback(|_| {})
            .wait();
        if let Err(e) = sent {
            tracing::debug!("cannot ask host {host} to stop {service}: {e}");
        }
    }

    fn take_event(&mut self) -> Option<HostEvent> {
        drain(&self.wake_rx);
        lock(&self.shared).events.pop_front()
    }

    fn quiet_for(&self, host: &str) -> Option<Duration> {
        let joined = lock(&self.shared)
            .joined
            .get(host)
            .copied()
            .unwrap_or(false);
        let silence = self.heard.silence(host)?;
        (joined && silence >= BEAT_PERIOD * QUIET_BEATS).then_some(silence)
    }

    fn mark_lost(&mut self, host: &str) {
        lock(&self.shared).joined.insert(host.to_owned(), false);
    }

    fn clock_offset_ns(&self, host: &str) -> Option<i64> {
        lock(&self.shared).clock_offsets.get(host).copied()
    }

    fn wake_fd(&self) -> BorrowedFd<'_> {
        self.wake_rx.as_fd()
    }
}
