//! The bridge's forwarding thread: one host's side of every channel and command that
//! crosses ([`Routes`]), between its shared memory and Zenoh.
//!
//! A publication crosses as its CDR bytes, unchanged: header and provenance travel as
//! they are, and the importing host publishes the same bytes into its own shared memory
//! from Zenoh's callback ([`Imported`]), where its clients and its recorder read them as if
//! the publisher were local. A command
//! call crosses as a Zenoh query to the host that serves it, whose bridge calls the provider
//! there and answers with the reply's bytes.
//!
//! Nothing crosses that nobody reads. A channel of another host is subscribed to on Zenoh
//! only while a process of this host reads it (its shared-memory channel has a
//! subscriber), so a camera whose client failed over to another host's provider stops
//! crossing the link; the robot host's recorder and broker read every channel of the
//! others, so everything they publish reaches it. And a channel of this host is read only
//! while a subscriber on Zenoh wants it (its publisher's matching status), so the robot
//! host's bridge does not wake for every heartbeat of a channel no tool listens to.

use std::collections::{BTreeMap, VecDeque};
use std::io::{Read as _, Write as _};
use std::os::fd::AsFd as _;
use std::os::unix::net::UnixStream;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use lewis_robot::Robot;
use lewis_runtime::ipc::{
    CallId, CommandClient, CommandServer, FdSource, Ipc, Namespace, Request, Subscriber, WaitSet,
    Waitable, WakeMode,
};
use lewis_runtime::names;
use zenoh::Session;
use zenoh::Wait as _;
use zenoh::bytes::Encoding;
use zenoh::pubsub::{Publisher as ZPublisher, Subscriber as ZSubscriber};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::query::{Query, QueryTarget};

use crate::imported::Imported;
use crate::keys;
use crate::routes::Routes;
use crate::schemas::Schemas;
use crate::{BridgeError, Heard};

/// The longest a call across hosts waits for its reply.
const CALL_TIMEOUT: Duration = Duration::from_secs(2);

/// How often a host's bridge says it is there: often enough that a host that missed a few
/// beats when one of its services misses its heartbeat deadline was cut off, not slow.
pub const BEAT_PERIOD: Duration = Duration::from_millis(10);

/// How often the bridge looks whether each channel of another host is read here.
const INTEREST_PERIOD: Duration = Duration::from_millis(50);

/// The iceoryx2 node of a host's bridge.
pub const BRIDGE_NODE: &str = "lewis-bridge";

/// A wake-up a Zenoh callback gives the forwarding thread: a byte on a socket it waits on.
#[derive(Debug, Clone)]
pub(crate) struct Wake(Arc<UnixStream>);

impl Wake {
    pub(crate) fn pair() -> std::io::Result<(Self, UnixStream)> {
        let (tx, rx) = UnixStream::pair()?;
        tx.set_nonblocking(true)?;
        rx.set_nonblocking(true)?;
        Ok((Self(Arc::new(tx)), rx))
    }

    pub(crate) fn wake(&self) {
        // A full socket already holds a wake-up.
        let _ = (&*self.0).write(&[1]);
    }
}

/// Empties a wake-up socket.
pub(crate) fn drain(rx: &UnixStream) {
    let mut buf = [0u8; 64];
    while matches!((&*rx).read(&mut buf), Ok(n) if n > 0) {}
}

/// What Zenoh's callbacks hand the thread.
enum Inbound {
    /// A call a client of another host made to a command served here (answer `index`).
    Call(usize, Query),
    /// The reply to a proxied call (`None`: none came).
    Reply(u64, Option<Vec<u8>>),
}

type Queue = Arc<Mutex<VecDeque<Inbound>>>;

fn push(queue: &Queue, wake: &Wake, item: Inbound) {
    queue
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .push_back(item);
    wake.wake();
}

/// The running forwarding thread of one host; stopped when dropped.
#[derive(Debug)]
pub struct Forwarder {
    stop: Arc<AtomicBool>,
    wake: Wake,
    thread: Option<JoinHandle<()>>,
}

/// Where and what one host forwards.
pub struct ForwardOptions {
    /// The robot's name (the keys' second chunk).
    pub robot: String,
    /// This host.
    pub host: String,
    /// What crosses.
    pub routes: Routes,
    /// The IPC namespace of this host's run.
    pub namespace: Namespace,
    /// How often this host says it is there (its beat).
    pub beat_period: Duration,
    /// The schemas of the robot's channels, for the tools that ask.
    pub schemas: Schemas,
}

impl ForwardOptions {
    /// What `host` of `robot` forwards, in `namespace`: its routes, its beat, the robot's
    /// schemas.
    #[must_use]
    pub fn of_host(robot: &Robot, host: &str, namespace: &Namespace) -> Self {
        Self {
            robot: robot.name.clone(),
            host: host.to_owned(),
            routes: crate::routes::routes(robot, host),
            namespace: namespace.clone(),
            beat_period: BEAT_PERIOD,
            schemas: Schemas::of(robot),
        }
    }
}

impl Forwarder {
    /// Opens every channel and key of `options.routes` and starts the thread.
    ///
    /// # Errors
    /// When a channel, a key or the thread cannot be made.
    pub fn start(
        session: &Session,
        options: ForwardOptions,
        heard: Heard,
    ) -> Result<Self, BridgeError> {
        let (wake, rx) = Wake::pair().map_err(BridgeError::Thread)?;
        let stop = Arc::new(AtomicBool::new(false));
        let queue: Queue = Arc::new(Mutex::new(VecDeque::new()));
        let stop_flag = Arc::clone(&stop);
        let (session, thread_wake) = (session.clone(), wake.clone());
        // iceoryx2's ports stay on the thread that made them: opened there, the outcome
        // sent back.
        let (opened_tx, opened_rx) = std::sync::mpsc::sync_channel(1);
        let handle = std::thread::Builder::new()
            .name("lewis-bridge".to_owned())
            .spawn(
                move || match Thread::open(&session, &options, &queue, &thread_wake, &heard) {
                    Ok(mut thread) => {
                        let _ = opened_tx.send(Ok(()));
                        thread.run(&rx, &queue, &stop_flag);
                    }
                    Err(e) => {
                        let _ = opened_tx.send(Err(e));
                    }
                },
            )
            .map_err(BridgeError::Thread)?;
        let opened = opened_rx.recv().unwrap_or_else(|_| {
            Err(BridgeError::Thread(std::io::Error::other(
                "the bridge's thread ended before it opened its channels",
            )))
        });
        if let Err(e) = opened {
            let _ = handle.join();
            return Err(e);
        }
        Ok(Self {
            stop,
            wake,
            thread: Some(handle),
        })
    }
}

impl Drop for Forwarder {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        self.wake.wake();
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// A channel of this host that other hosts may subscribe to.
struct Export {
    channel: String,
    /// Its subscription here, while a subscriber on Zenoh wants it.
    subscriber: Option<Subscriber>,
    publisher: ZPublisher<'static>,
    /// Whether Zenoh has a subscriber for it, as its matching listener last said.
    matched: Arc<AtomicBool>,
}

/// A channel of another host published here again (by [`Imported`]).
struct Import {
    channel: String,
    /// Its key on Zenoh.
    key: String,
    /// The host it comes from.
    host: String,
    /// Zenoh's subscription, while a process here reads the channel.
    subscriber: Option<ZSubscriber<()>>,
}

struct Answer {
    client: CommandClient,
    pending: BTreeMap<CallId, Query>,
}

struct Proxy {
    server: CommandServer,
    key: String,
}

/// What the thread owns: iceoryx2 is used from this thread only.
struct Thread {
    session: Session,
    exports: Vec<Export>,
    imports: Vec<Import>,
    imported: Imported,
    /// When the imports' readers are looked at next.
    next_interest_look: Instant,
    heard: Heard,
    answers: Vec<Answer>,
    proxies: Vec<Proxy>,
    /// Proxied calls waiting for their reply: the proxy, the request to answer, and until
    /// when.
    waiting: BTreeMap<u64, (usize, Request, Instant)>,
    next_call: u64,
    beat: ZPublisher<'static>,
    beat_period: Duration,
    next_beat: Instant,
    wake: Wake,
    queue: Queue,
    // Zenoh's declarations live as long as the thread.
    _declarations: Vec<Box<dyn std::any::Any + Send>>,
    ipc: Ipc,
}

impl Thread {
    fn open(
        session: &Session,
        options: &ForwardOptions,
        queue: &Queue,
        wake: &Wake,
        heard: &Heard,
    ) -> Result<Self, BridgeError> {
        let ipc = Ipc::open(&options.namespace, BRIDGE_NODE)?;
        let robot = &options.robot;
        let mut exports = Vec::new();
        for channel in &options.routes.exports {
            let key = keys::channel(robot, &options.host, channel);
            let encoding = options
                .schemas
                .get(channel)
                .map_or(Encoding::APPLICATION_CDR, |(name, _)| {
                    Encoding::APPLICATION_CDR.with_schema(name.clone())
                });
            // A sensor's old sample is worth less than the next one; decisions and
            // heartbeats are never dropped on the way, and go ahead of the sensors' data: a
            // heartbeat queued behind a camera frame on a slow link made its service look
            // stalled.
            let (congestion, priority) = if channel.starts_with("/lewis/") {
                (CongestionControl::Block, Priority::InteractiveHigh)
            } else {
                (CongestionControl::Drop, Priority::Data)
            };
            let publisher = session
                .declare_publisher(key)
                .encoding(encoding)
                .congestion_control(congestion)
                .priority(priority)
                .wait()
                .map_err(BridgeError::zenoh(channel))?;
            let matched = Arc::new(AtomicBool::new(false));
            let (flag, wake) = (Arc::clone(&matched), wake.clone());
            publisher
                .matching_listener()
                .callback(move |status| {
                    flag.store(status.matching(), Ordering::Release);
                    wake.wake();
                })
                .background()
                .wait()
                .map_err(BridgeError::zenoh(channel))?;
            exports.push(Export {
                channel: channel.clone(),
                subscriber: None,
                publisher,
                matched,
            });
        }
        let mut declarations: Vec<Box<dyn std::any::Any + Send>> = Vec::new();
        let mut imports = Vec::new();
        for route in &options.routes.imports {
            imports.push(Import {
                channel: route.channel.clone(),
                key: keys::channel(robot, &route.host, &route.channel),
                host: route.host.clone(),
                subscriber: None,
            });
        }
        let mut answers = Vec::new();
        for (index, channel) in options.routes.answers.iter().enumerate() {
            let config = if channel == names::BROKER_COMMAND {
                names::broker_command_config()
            } else {
                names::command_config()
            };
            answers.push(Answer {
                client: ipc.command_client(channel, &config)?,
                pending: BTreeMap::new(),
            });
            let (queue, wake) = (Arc::clone(queue), wake.clone());
            let queryable = session
                .declare_queryable(keys::command(robot, &options.host, channel))
                .callback(move |query| push(&queue, &wake, Inbound::Call(index, query)))
                .wait()
                .map_err(BridgeError::zenoh(channel))?;
            declarations.push(Box::new(queryable));
        }
        let mut proxies = Vec::new();
        for route in &options.routes.proxies {
            let config = if route.channel == names::BROKER_COMMAND {
                names::broker_command_config()
            } else {
                names::command_config()
            };
            proxies.push(Proxy {
                server: ipc.command_server(&route.channel, &config)?,
                key: keys::command(robot, &route.host, &route.channel),
            });
        }
        let schemas = options.schemas.clone();
        let (robot_name, host) = (robot.clone(), options.host.clone());
        let queryable = session
            .declare_queryable(keys::schemas(robot, &options.host))
            .callback(move |query| {
                let key = query.key_expr().as_str().to_owned();
                let Some(channel) = keys::channel_of_schema_query(&robot_name, &host, &key) else {
                    return;
                };
                if let Some((name, text)) = schemas.get(&channel) {
                    let reply =
                        serde_json::json!({"name": name, "encoding": "ros2msg", "data": text});
                    let _ = query.reply(key, reply.to_string()).wait();
                }
            })
            .wait()
            .map_err(BridgeError::zenoh("schemas"))?;
        declarations.push(Box::new(queryable));
        let beat = session
            .declare_publisher(keys::beat(robot, &options.host))
            .congestion_control(CongestionControl::Drop)
            // Ahead of everything: a beat late behind data is a host taken for lost.
            .priority(Priority::RealTime)
            .express(true)
            .wait()
            .map_err(BridgeError::zenoh("beat"))?;
        Ok(Self {
            session: session.clone(),
            imported: Imported::open(
                &options.namespace,
                imports.iter().map(|i| i.channel.as_str()),
            )?,
            exports,
            imports,
            next_interest_look: Instant::now(),
            heard: heard.clone(),
            answers,
            proxies,
            waiting: BTreeMap::new(),
            next_call: 0,
            beat,
            beat_period: options.beat_period,
            next_beat: Instant::now(),
            wake: wake.clone(),
            queue: Arc::clone(queue),
            _declarations: declarations,
            ipc,
        })
    }

    fn run(&mut self, rx: &UnixStream, queue: &Queue, stop: &AtomicBool) {
        let waits = WaitSet::new(WakeMode::Event);
        while !stop.load(Ordering::Acquire) {
            let now = Instant::now();
            if now >= self.next_beat {
                // Stamped with this host's clock (Zenoh's hybrid logical clock, from the
                // system clock): the robot host reads the clocks' offset from it.
                let _ = self
                    .beat
                    .put(crate::session::PROTOCOL.to_string())
                    .timestamp(self.session.new_timestamp())
                    .wait();
                self.next_beat = now + self.beat_period;
            }
            if now >= self.next_interest_look {
                self.follow_readers();
                self.next_interest_look = now + INTEREST_PERIOD;
            }
            self.follow_listeners();
            drain(rx);
            let inbound: Vec<Inbound> = queue
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .drain(..)
                .collect();
            for item in inbound {
                self.take(item);
            }
            self.forward_exports();
            self.serve_proxies();
            self.answer_calls();
            self.expire_waiting(now);
            let fd = FdSource::new(rx.as_fd());
            let mut sources: Vec<&dyn Waitable> = vec![&fd];
            sources.extend(
                self.exports
                    .iter()
                    .filter_map(|e| e.subscriber.as_ref().map(|s| s as &dyn Waitable)),
            );
            sources.extend(self.proxies.iter().map(|p| &p.server as &dyn Waitable));
            sources.extend(self.answers.iter().map(|a| &a.client as &dyn Waitable));
            sources.truncate(lewis_runtime::ipc::MAX_WAIT_SOURCES);
            let deadline = self
                .waiting
                .values()
                .map(|(_, _, until)| *until)
                .chain([self.next_beat, self.next_interest_look])
                .min();
            if let Err(e) = waits.wait(&sources, deadline) {
                tracing::warn!("the bridge cannot wait: {e}");
                std::thread::sleep(Duration::from_millis(5));
            }
        }
    }

    fn take(&mut self, item: Inbound) {
        match item {
            Inbound::Call(index, query) => {
                let Some(answer) = self.answers.get_mut(index) else {
                    return;
                };
                let bytes = query
                    .payload()
                    .map(|p| p.to_bytes().into_owned())
                    .unwrap_or_default();
                match answer.client.call(&bytes, CALL_TIMEOUT) {
                    Ok(call) => {
                        answer.pending.insert(call, query);
                    }
                    Err(e) => {
                        let _ = query.reply_err(e.to_string()).wait();
                    }
                }
            }
            Inbound::Reply(call, bytes) => {
                let Some((index, request, _)) = self.waiting.remove(&call) else {
                    return;
                };
                if let (Some(bytes), Some(proxy)) = (bytes, self.proxies.get(index))
                    && let Err(e) = proxy.server.reply(request, &bytes)
                {
                    tracing::debug!("cannot hand a reply from another host back: {e}");
                }
            }
        }
    }

    /// Subscribes on Zenoh to each channel of another host that a process here reads, and
    /// no longer to one nobody reads.
    fn follow_readers(&mut self) {
        for (index, import) in self.imports.iter_mut().enumerate() {
            let read = self.imported.readers(index) > 0;
            if read == import.subscriber.is_some() {
                continue;
            }
            let channel = &import.channel;
            if !read {
                import.subscriber = None;
                tracing::debug!(
                    "{channel} of host {}: read by none here, no longer crosses",
                    import.host
                );
                continue;
            }
            let (imported, heard, host) = (
                self.imported.clone(),
                self.heard.clone(),
                import.host.clone(),
            );
            match self
                .session
                .declare_subscriber(import.key.clone())
                .callback(move |sample| {
                    heard.hear(&host);
                    imported.publish(index, sample.payload());
                })
                .wait()
            {
                Ok(subscriber) => {
                    tracing::debug!("{channel} of host {}: read here, crosses", import.host);
                    import.subscriber = Some(subscriber);
                }
                Err(e) => {
                    tracing::warn!("cannot subscribe to {channel} of host {}: {e}", import.host);
                }
            }
        }
    }

    /// Reads each channel of this host that a subscriber on Zenoh wants, and no longer one
    /// nobody there wants: a channel nobody listens to costs the bridge nothing.
    fn follow_listeners(&mut self) {
        for export in &mut self.exports {
            let wanted = export.matched.load(Ordering::Acquire);
            if wanted == export.subscriber.is_some() {
                continue;
            }
            let channel = &export.channel;
            if !wanted {
                export.subscriber = None;
                tracing::debug!("{channel}: no subscriber on another host, no longer crosses");
                continue;
            }
            match self
                .ipc
                .subscriber(channel, &names::channel_config(channel))
            {
                Ok(subscriber) => {
                    tracing::debug!("{channel}: a subscriber on another host, crosses");
                    export.subscriber = Some(subscriber);
                }
                Err(e) => tracing::warn!("cannot read {channel} for another host: {e}"),
            }
        }
    }

    fn forward_exports(&mut self) {
        for export in &mut self.exports {
            let Some(subscriber) = &mut export.subscriber else {
                continue;
            };
            while let Ok(Some(sample)) = subscriber.receive() {
                if let Err(e) = export.publisher.put(sample.bytes()).wait() {
                    tracing::debug!("cannot send {}: {e}", export.channel);
                }
            }
        }
    }

    /// Calls clients of this host made to commands served on another: carried there.
    fn serve_proxies(&mut self) {
        for (index, proxy) in self.proxies.iter().enumerate() {
            while let Ok(Some(request)) = proxy.server.receive() {
                self.next_call += 1;
                let call = self.next_call;
                let (queue, wake) = (Arc::clone(&self.queue), self.wake.clone());
                let sent = self
                    .session
                    .get(&proxy.key)
                    .payload(request.bytes().to_vec())
                    .target(QueryTarget::BestMatching)
                    .timeout(CALL_TIMEOUT)
                    .callback(move |reply| {
                        // The first reply is taken; the thread drops any other.
                        if let Ok(sample) = reply.result() {
                            let bytes = sample.payload().to_bytes().into_owned();
                            push(&queue, &wake, Inbound::Reply(call, Some(bytes)));
                        }
                    })
                    .wait();
                match sent {
                    Ok(()) => {
                        self.waiting
                            .insert(call, (index, request, Instant::now() + CALL_TIMEOUT));
                    }
                    Err(e) => tracing::debug!("cannot carry a call to {}: {e}", proxy.key),
                }
            }
        }
    }

    /// Replies to calls from other hosts, as they come.
    fn answer_calls(&mut self) {
        for answer in &mut self.answers {
            while let Some(outcome) = answer.client.take_outcome() {
                let Some(query) = answer.pending.remove(&outcome.call) else {
                    continue;
                };
                let key = query.key_expr().clone();
                let _ = match outcome.result {
                    Ok(reply) => query.reply(key, reply.bytes().to_vec()).wait(),
                    Err(e) => query.reply_err(e.to_string()).wait(),
                };
            }
        }
    }

    /// A call whose reply did not come in time: its client times out on its own.
    fn expire_waiting(&mut self, now: Instant) {
        self.waiting.retain(|_, (_, _, until)| *until > now);
    }
}
