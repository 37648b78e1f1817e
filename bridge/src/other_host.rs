//! Another host's side (`lewis up ROBOT --host NAME`): its services under a supervisor of
//! its own, started and stopped on the robot host's broker's orders, its exits reported,
//! its bridge. A host that has lost the robot host for longer than the link deadline stops
//! its services, so that a partition never leaves two masters; when the link is back, they
//! come back only when the broker starts them again.

use std::collections::BTreeMap;
use std::collections::VecDeque;
use std::os::fd::AsFd as _;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use lewis_robot::Robot;
use lewis_runtime::broker::ExitStatus;
use lewis_runtime::broker::live::{UpOptions, service_child};
use lewis_runtime::ipc::{FdSource, NodeCleaner, WaitSet, Waitable, WakeMode};
use lewis_runtime::live::{ClockSource, StopSignals};
use lewis_runtime::supervise::{Supervisor, SupervisorEvent};
use nix::sys::signal::Signal;
use zenoh::Wait as _;
use zenoh::qos::CongestionControl;
use zenoh::query::Query;
use zenoh::sample::SampleKind;

use crate::forward::{Wake, drain};
use crate::wire::{self, Order, exit_text};
use crate::{BridgeError, ForwardOptions, Forwarder, Heard, keys, session};

/// How long a host waits for the robot host before it says it cannot reach it.
const UNREACHED_AFTER: Duration = Duration::from_secs(5);

/// How often the host looks whether the robot host is still there.
const WATCH_PERIOD: Duration = Duration::from_millis(10);

/// How another host runs.
#[derive(Debug, Clone)]
pub struct HostOptions {
    /// This host's name (one of the robot file's `[[hosts]]`, not the first).
    pub host: String,
    /// The robot file, handed to every service.
    pub robot_path: PathBuf,
    /// The IPC namespace of this host's run.
    pub namespace: lewis_runtime::ipc::Namespace,
    /// The `lewis` executable that runs built-in service kinds.
    pub lewis_exe: PathBuf,
    /// Time between SIGTERM and SIGKILL when a service is stopped.
    pub stop_grace: Duration,
    /// A folder of this run's own.
    pub scratch: PathBuf,
}

/// Runs `options.host`'s part of `robot` until a stop signal.
///
/// # Errors
/// When the host is not in the robot file, or its session, bridge or supervisor cannot be
/// set up.
pub fn run_host(
    robot: &Robot,
    options: &HostOptions,
    stop: &StopSignals,
) -> Result<(), BridgeError> {
    let Some(hub) = robot.robot_host() else {
        return Err(unknown(robot, &options.host));
    };
    let Some(me) = robot.host(&options.host).filter(|h| h.name != hub.name) else {
        return Err(unknown(robot, &options.host));
    };
    // Before the session's threads, which inherit it; undone when this host's part ends.
    let _machine = lewis_runtime::supervise::MachineSettings::apply(robot);
    let session = session::open(robot, me, &options.scratch)?;
    let heard = Heard::default();
    let _forwarder = Forwarder::start(
        &session,
        ForwardOptions::of_host(robot, &me.name, &options.namespace),
        heard.clone(),
    )?;
    let name = &robot.name;
    let _token = session
        .liveliness()
        .declare_token(keys::host_token(name, &me.name))
        .wait()
        .map_err(BridgeError::zenoh("host token"))?;
    let (wake, wake_rx) = Wake::pair().map_err(BridgeError::Thread)?;
    let orders: Arc<Mutex<VecDeque<Query>>> = Arc::default();
    let (queue, order_wake) = (Arc::clone(&orders), wake.clone());
    let _control = session
        .declare_queryable(keys::control(name, &me.name))
        .callback(move |query| {
            queue
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .push_back(query);
            order_wake.wake();
        })
        .wait()
        .map_err(BridgeError::zenoh("control"))?;
    let exits = session
        .declare_publisher(keys::exits(name, &me.name))
        .congestion_control(CongestionControl::Block)
        .wait()
        .map_err(BridgeError::zenoh("exits"))?;
    let hub_heard = heard.clone();
    let hub_name = hub.name.clone();
    // The version the robot host's beat says, when it is not this one's.
    let hub_refused: Arc<Mutex<Option<String>>> = Arc::default();
    let refused = Arc::clone(&hub_refused);
    let _hub_beat = session
        .declare_subscriber(keys::beat(name, &hub.name))
        .callback(
            move |sample| match session::beat_protocol(sample.payload()) {
                Ok(()) => hub_heard.hear(&hub_name),
                Err(said) => *refused.lock().unwrap_or_else(PoisonError::into_inner) = Some(said),
            },
        )
        .wait()
        .map_err(BridgeError::zenoh("beats"))?;
    let hub_token: Arc<Mutex<bool>> = Arc::default();
    let token_seen = Arc::clone(&hub_token);
    let _hub_liveliness = session
        .liveliness()
        .declare_subscriber(keys::host_token(name, &hub.name))
        .history(true)
        .callback(move |sample| {
            *token_seen.lock().unwrap_or_else(PoisonError::into_inner) =
                sample.kind() == SampleKind::Put;
        })
        .wait()
        .map_err(BridgeError::zenoh("host tokens"))?;
    let up = UpOptions {
        robot_path: options.robot_path.clone(),
        namespace: options.namespace.clone(),
        lewis_exe: options.lewis_exe.clone(),
        duration: None,
        stop_grace: options.stop_grace,
        clock: ClockSource::Wall,
    };
    let mut host = Host {
        robot,
        name: me.name.clone(),
        up,
        supervisor: Supervisor::new().map_err(|e| BridgeError::Thread(std::io::Error::other(e)))?,
        cleaner: NodeCleaner::start(&options.namespace, "lewis-host-cleaner")?,
        kills: BTreeMap::new(),
        hub_up: false,
        ever_up: false,
    };
    tracing::info!(
        host = me.name,
        "host {} of robot {name} up: waiting for the robot host's broker at {}",
        me.name,
        me.connect
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join(", ")
    );
    let link_deadline = Duration::from_millis(robot.network.link_deadline_ms);
    let started = Instant::now();
    let mut said_unreached = false;
    let mut said_refused = false;
    let waits = WaitSet::new(WakeMode::Event);
    loop {
        if stop.take() || stop.take_requested() {
            break;
        }
        drain(&wake_rx);
        let taken: Vec<Query> = orders
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .drain(..)
            .collect();
        for query in taken {
            host.order(&query);
        }
        while let Ok(Some(event)) = host.supervisor.try_event() {
            if let SupervisorEvent::Exited { name, status, .. } = event {
                host.kills.remove(&name);
                host.cleaner.request();
                let status = ExitStatus::from(status);
                tracing::debug!(service = name, "exited: {status}");
                let _ = exits.put(exit_text(&name, status)).wait();
            }
        }
        if !said_refused
            && let Some(said) = hub_refused
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .as_deref()
        {
            said_refused = true;
            tracing::error!(
                "the robot host {}; its orders are not taken",
                session::other_protocol(&hub.name, said)
            );
        }
        let token = *hub_token.lock().unwrap_or_else(PoisonError::into_inner);
        let hub_up = token && heard.silence(&hub.name).is_some_and(|s| s < link_deadline);
        host.robot_host_is(hub_up, &hub.name);
        if !hub_up && !host.ever_up && !said_unreached && started.elapsed() >= UNREACHED_AFTER {
            said_unreached = true;
            tracing::warn!(
                "not connected to the robot host {} after {} s: is its `lewis up` running, and do this host's connect endpoints ({}) and the robot file's key file match its own?",
                hub.name,
                UNREACHED_AFTER.as_secs(),
                me.connect
                    .iter()
                    .map(ToString::to_string)
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        host.kill_overdue();
        let signal_fd = FdSource::new(stop.as_fd());
        let supervisor_fd = FdSource::new(host.supervisor.as_fd());
        let wake_fd = FdSource::new(wake_rx.as_fd());
        let sources: [&dyn Waitable; 3] = [&signal_fd, &supervisor_fd, &wake_fd];
        if let Err(e) = waits.wait(&sources, Some(Instant::now() + WATCH_PERIOD)) {
            tracing::warn!("host {} cannot wait: {e}", me.name);
        }
    }
    for (service, result) in host.supervisor.stop_all() {
        if let Err(e) = result {
            tracing::warn!(service, "cannot stop {service}: {e}");
        }
    }
    Ok(())
}

fn unknown(robot: &Robot, host: &str) -> BridgeError {
    let others: Vec<&str> = robot
        .hosts
        .iter()
        .skip(1)
        .map(|h| h.name.as_str())
        .collect();
    let hint = lewis_stdx::closest(host, others.iter().copied())
        .map_or_else(String::new, |near| format!(" (did you mean `{near}`?)"));
    BridgeError::UnknownHost {
        host: host.to_owned(),
        hint,
        hosts: if robot.hosts.is_empty() {
            "none (the robot runs on one machine: `lewis up` without --host)".to_owned()
        } else {
            format!(
                "{} (the first, {}, is the robot host: run it without --host)",
                robot.host_names(),
                robot.hosts[0].name
            )
        },
    }
}

struct Host<'r> {
    robot: &'r Robot,
    /// This host's name.
    name: String,
    up: UpOptions,
    supervisor: Supervisor,
    cleaner: NodeCleaner,
    /// Services sent SIGTERM, and when they get SIGKILL.
    kills: BTreeMap<String, Instant>,
    /// Whether the robot host is there.
    hub_up: bool,
    /// Whether it ever was.
    ever_up: bool,
}

impl Host<'_> {
    /// Carries out one order of the broker's (`start NAME`, `stop NAME`) and answers it.
    fn order(&mut self, query: &Query) {
        let text = query
            .payload()
            .and_then(|p| p.try_to_string().ok().map(std::borrow::Cow::into_owned))
            .unwrap_or_default();
        let answer = match wire::parse_order(&text) {
            Ok(Order::Start(service)) => self.start(service),
            Ok(Order::Stop(service)) => {
                if self.supervisor.signal(service, Signal::SIGTERM).is_ok() {
                    self.kills
                        .insert(service.to_owned(), Instant::now() + self.up.stop_grace);
                }
                Ok(0)
            }
            Err(why) => Err(why),
        };
        let reply = match answer {
            Ok(pid) => format!("ok {pid}"),
            Err(why) => format!("error {why}"),
        };
        let _ = query.reply(query.key_expr().clone(), reply).wait();
    }

    fn start(&mut self, service: &str) -> Result<u32, String> {
        let Some(spec) = self.robot.service(service) else {
            return Err(format!("the robot has no service `{service}`"));
        };
        if self.robot.host_of(service) != Some(self.own_host()) {
            return Err(format!("{service} does not run on this host"));
        }
        // Ordered again while it runs (the link came back before this host stopped it):
        // it goes on, under the broker's order.
        if let Some(pid) = self.supervisor.pid(service) {
            return Ok(pid);
        }
        let child = service_child(spec, &self.up).ok_or("empty command line")?;
        let pid = self.supervisor.start(child).map_err(|e| e.to_string())?;
        tracing::info!(
            service,
            "started {service} on the broker's order (pid {pid})"
        );
        Ok(pid)
    }

    fn own_host(&self) -> &str {
        &self.name
    }

    /// Whether the robot host is there now: when it goes, this host's services stop.
    fn robot_host_is(&mut self, up: bool, hub: &str) {
        if up == self.hub_up {
            return;
        }
        self.hub_up = up;
        self.ever_up |= up;
        if up {
            tracing::info!("the robot host {hub} is there: its broker decides what runs here");
            return;
        }
        let running: Vec<String> = self
            .supervisor
            .running()
            .into_iter()
            .map(str::to_owned)
            .collect();
        if running.is_empty() {
            return;
        }
        tracing::warn!(
            "lost the robot host {hub}: stopping {} so that a partition never leaves two masters; they come back when its broker starts them",
            running.join(", ")
        );
        for service in running {
            if self.supervisor.signal(&service, Signal::SIGTERM).is_ok() {
                self.kills
                    .insert(service, Instant::now() + self.up.stop_grace);
            }
        }
    }

    fn kill_overdue(&mut self) {
        let now = Instant::now();
        let overdue: Vec<String> = self
            .kills
            .iter()
            .filter(|(_, at)| **at <= now)
            .map(|(s, _)| s.clone())
            .collect();
        for service in overdue {
            self.kills.remove(&service);
            let _ = self.supervisor.signal(&service, Signal::SIGKILL);
        }
    }
}
