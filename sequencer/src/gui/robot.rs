//! The robot beside the question: where it is on the world map, what its camera sees, and
//! which provider serves each interface with its health, so that the supervisor sees the
//! robot before choosing where the mission resumes.
//!
//! A [`RobotWatch`] thread reads the robot as any client could (raw subscribers on the
//! pose, camera, people and Speech channels; the broker's `status` every second) and feeds
//! the page through a [`RobotFeed`] at most twice a second. The camera's frames and the
//! broker's status are read only while a page looks (an event stream is open, or the
//! robot's view or frame was asked for within [`VIEWED_FOR`]): nobody watching costs
//! nothing. The page gets the [`RobotView`] as
//! JSON (`GET /robot`, and `event: robot` on the event stream), the latest frame as a
//! 24-bit BMP written here (`GET /camera.bmp`: no image crate in the sequencer) and the
//! world's map as it is on disk (`GET /map.png`). `POST /answer` sends the supervisor's
//! answer to the robot's Speech provider (`hear`), as the registrar at a real desk would;
//! the supervisor's terminal sends its keys' answers the same way ([`RobotFeed::answer`]),
//! and hears when the robot speaks and what became of its answers ([`RobotFeed::on_said`],
//! [`RobotFeed::on_answered`]).
//!
//! What to watch ([`RobotWatchOptions`]) comes from the robot description: the GroundTruth
//! provider when the robot has one (a simulator), else Egomotion (the odometry's frame,
//! which the map only matches at the start); the best ImageSource, WorldState and Speech
//! providers; the `world` folder a service names, whose `world.toml` gives the map.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{
    BrokerStatus, BrokerStatusReply, Egomotion, GroundTruth, ImageSource, Speech, SpeechHear,
    WorldState,
};
use lewis_robot::Robot;
use lewis_runtime::client::call_blocking;
use lewis_runtime::ipc::{CommandClient, Ipc, Namespace, Subscriber};
use lewis_runtime::names;
use lewis_stdx::world::{WorldHeader, find_world};
use serde::{Deserialize, Serialize};

/// How often the page gets the robot: at most twice a second.
pub const ROBOT_PERIOD: Duration = Duration::from_millis(500);

/// How often the broker is asked for its status.
const STATUS_PERIOD: Duration = Duration::from_secs(1);

/// A page that asked for the robot's view or frame is taken as looking for this long.
pub const VIEWED_FOR: Duration = Duration::from_secs(5);

/// How long one question to the broker or to the Speech provider may take.
const CALL_TIMEOUT: Duration = Duration::from_secs(1);

/// Frames wider than this are shrunk (by a whole factor) before they are served: the page
/// shows a thumbnail, and a full 640x480 frame twice a second is bytes for nothing.
pub const CAMERA_MAX_WIDTH_PX: u32 = 320;

/// Which interface the robot's pose comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PoseInterface {
    /// The simulator's truth, in the world frame: the map matches it.
    GroundTruth,
    /// The odometry, in its own frame.
    Egomotion,
}

impl PoseInterface {
    /// The interface's name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::GroundTruth => "GroundTruth",
            Self::Egomotion => "Egomotion",
        }
    }
}

/// What a [`RobotWatch`] reads: each part is optional (a robot without a camera shows none).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RobotWatchOptions {
    /// The service and interface the pose comes from.
    pub pose: Option<(String, PoseInterface)>,
    /// The service whose ImageSource frames are shown.
    pub camera: Option<String>,
    /// The service whose WorldState people are drawn on the map.
    pub people: Option<String>,
    /// The service the supervisor's answers go to (Speech `hear`).
    pub speech: Option<String>,
    /// The world's map.
    pub world_map: Option<WorldHeader>,
}

impl RobotWatchOptions {
    /// What to watch on `robot`, described by the file `robot_path`: the best provider of
    /// each interface (highest quality, then lowest cost), and the map of the first `world`
    /// folder a service names (as written, from the current folder as the simulator reads
    /// it, else from a folder above the robot file). A world that cannot be read is logged
    /// and left out.
    #[must_use]
    pub fn from_robot(robot: &Robot, robot_path: &Path) -> Self {
        let pose = best_provider(robot, "GroundTruth")
            .map(|s| (s, PoseInterface::GroundTruth))
            .or_else(|| best_provider(robot, "Egomotion").map(|s| (s, PoseInterface::Egomotion)));
        let world_map = robot.world_folder().and_then(|world| {
            find_world(world, robot_path)
                .inspect_err(|e| tracing::warn!("the supervisor's page shows no map: {e}"))
                .ok()
        });
        Self {
            pose,
            camera: best_provider(robot, "ImageSource"),
            people: best_provider(robot, "WorldState"),
            speech: best_provider(robot, "Speech"),
            world_map,
        }
    }
}

/// The service that serves `interface` best, as the broker would choose first.
fn best_provider(robot: &Robot, interface: &str) -> Option<String> {
    robot
        .services
        .iter()
        .filter_map(|s| s.provision(interface).map(|p| (s, p)))
        .max_by(|(_, a), (_, b)| a.quality.cmp(&b.quality).then(b.cost.cmp(&a.cost)))
        .map(|(s, _)| s.name.clone())
}

/// What the page shows of the robot (`GET /robot`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RobotView {
    /// The latest pose, when one arrived.
    pub pose: Option<PoseView>,
    /// The map under it, when there is one.
    pub map: Option<MapView>,
    /// The latest camera frame's description (the pixels are at `camera.bmp`).
    pub camera: Option<CameraView>,
    /// The people of the world (simulator), present ones only.
    pub people: Vec<PersonView>,
    /// Every service with its state and health, from the broker.
    pub services: Vec<ServiceView>,
    /// Which provider serves each client's interface, from the broker.
    pub bindings: Vec<BindingView>,
    /// Whether the broker answered its latest status question.
    pub broker_answers: bool,
    /// The service answers go to, when the robot has a Speech provider.
    pub speech: Option<String>,
    /// What became of the latest answer sent, for people.
    pub answer: Option<String>,
}

/// Where the robot is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseView {
    /// In metres.
    pub x: f64,
    /// In metres.
    pub y: f64,
    /// Heading, in radians.
    pub theta: f64,
    /// The interface it comes from: `GroundTruth` (world frame) or `Egomotion`.
    pub interface: PoseInterface,
    /// The service that published it.
    pub service: String,
}

/// The map image's size and place.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapView {
    /// The image's width.
    pub width_px: u32,
    /// The image's height.
    pub height_px: u32,
    /// Metres per pixel.
    pub metres_per_pixel: f64,
    /// Where the image's bottom-left corner lies, in metres.
    pub origin_m: [f64; 2],
}

/// The latest frame served at `camera.bmp`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct CameraView {
    /// Counts the frames served, so the page knows when to fetch again.
    pub frame: u64,
    /// The served image's width (the camera's, shrunk).
    pub width_px: u32,
    /// The served image's height.
    pub height_px: u32,
    /// The service that published it.
    pub service: String,
}

/// A person of the world.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PersonView {
    /// Their name in the world file.
    pub name: String,
    /// In metres, world frame.
    pub x: f64,
    /// In metres, world frame.
    pub y: f64,
}

/// A service as the broker reports it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ServiceView {
    /// Its name.
    pub name: String,
    /// `idle`, `starting`, `ready`, `restarting`, `stopping`, `stopped` or `failed`.
    pub state: String,
    /// `ok`, `degraded` or `out-of-service` (as it last declared).
    pub health: String,
    /// Why it is not ok, or why it failed.
    pub reason: String,
}

/// A binding: `client`'s `interface` is served by `service` (empty when by nobody).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct BindingView {
    /// The client.
    pub client: String,
    /// The interface.
    pub interface: String,
    /// The provider, empty when none.
    pub service: String,
}

impl RobotView {
    /// Takes the services and bindings of a broker status reply.
    pub fn set_status(&mut self, reply: &BrokerStatusReply) {
        self.broker_answers = true;
        self.services = reply
            .services
            .iter()
            .map(|s| ServiceView {
                name: s.name.clone(),
                state: s.state.clone(),
                health: s.health.clone(),
                reason: if s.health_reason.is_empty() {
                    s.last_failure.clone()
                } else {
                    s.health_reason.clone()
                },
            })
            .collect();
        self.bindings = reply
            .bindings
            .iter()
            .map(|b| BindingView {
                client: b.client.clone(),
                interface: b.interface.clone(),
                service: b.service.clone(),
            })
            .collect();
    }
}

/// An answer for the robot's Speech provider (`POST /answer`, or a key on the terminal).
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
pub struct Answer {
    /// `yes` or `no`.
    pub answer: String,
    /// The words, for people (`registered`).
    #[serde(default)]
    pub text: String,
}

/// Why an answer was not sent ([`RobotFeed::answer`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AnswerRefused {
    /// The answer is not `yes` or `no`.
    #[error("the answer is yes or no, not `{0}`")]
    NotYesOrNo(String),
    /// The robot has no Speech provider to take it.
    #[error("the robot has no Speech provider to answer")]
    NoSpeech,
    /// Nobody watches the robot any more (the mission is over).
    #[error("the robot is no longer watched")]
    NotWatched,
}

/// A camera frame, as 8-bit RGB rows without padding.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frame {
    /// In pixels.
    pub width: u32,
    /// In pixels.
    pub height: u32,
    /// `width * height * 3` bytes, top row first.
    pub rgb: Vec<u8>,
}

impl Frame {
    /// The frame of an ImageSource message, shrunk by a whole factor to at most
    /// [`CAMERA_MAX_WIDTH_PX`] wide; `None` for an encoding other than rgb8, bgr8, rgba8,
    /// bgra8 and mono8, or a message shorter than it says.
    #[must_use]
    pub fn from_image(image: &ImageSource) -> Option<Self> {
        let (channels, red, blue) = match image.encoding.as_str() {
            "rgb8" => (3, 0, 2),
            "bgr8" => (3, 2, 0),
            "rgba8" => (4, 0, 2),
            "bgra8" => (4, 2, 0),
            "mono8" => (1, 0, 0),
            _ => return None,
        };
        let width = usize::try_from(image.width).ok().filter(|w| *w > 0)?;
        let height = usize::try_from(image.height).ok().filter(|h| *h > 0)?;
        let step = usize::try_from(image.step)
            .ok()
            .filter(|s| *s >= width * channels)
            .unwrap_or(width * channels);
        if image.data.len() < step * (height - 1) + width * channels {
            return None;
        }
        let max = usize::try_from(CAMERA_MAX_WIDTH_PX).unwrap_or(usize::MAX);
        let factor = width.div_ceil(max).max(1);
        let (out_w, out_h) = (width / factor, height / factor);
        if out_w == 0 || out_h == 0 {
            return None;
        }
        let mut rgb = Vec::with_capacity(out_w * out_h * 3);
        for row in 0..out_h {
            let line = &image.data[row * factor * step..];
            for col in 0..out_w {
                let px = &line[col * factor * channels..][..channels];
                rgb.extend_from_slice(&[px[red], px[if channels == 1 { 0 } else { 1 }], px[blue]]);
            }
        }
        Some(Self {
            width: u32::try_from(out_w).ok()?,
            height: u32::try_from(out_h).ok()?,
            rgb,
        })
    }

    /// The frame as a 24-bit uncompressed BMP file, which every browser shows.
    #[must_use]
    pub fn bmp(&self) -> Vec<u8> {
        let width = self.width as usize;
        let height = self.height as usize;
        let row = (width * 3).div_ceil(4) * 4;
        let pixels = row * height;
        let size = 14 + 40 + pixels;
        let mut out = Vec::with_capacity(size);
        out.extend_from_slice(b"BM");
        out.extend_from_slice(&u32::try_from(size).unwrap_or(u32::MAX).to_le_bytes());
        out.extend_from_slice(&[0; 4]);
        out.extend_from_slice(&54u32.to_le_bytes());
        out.extend_from_slice(&40u32.to_le_bytes());
        out.extend_from_slice(&i32::try_from(self.width).unwrap_or(0).to_le_bytes());
        // Positive height: rows bottom-up.
        out.extend_from_slice(&i32::try_from(self.height).unwrap_or(0).to_le_bytes());
        out.extend_from_slice(&1u16.to_le_bytes());
        out.extend_from_slice(&24u16.to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(&u32::try_from(pixels).unwrap_or(u32::MAX).to_le_bytes());
        out.extend_from_slice(&2835i32.to_le_bytes());
        out.extend_from_slice(&2835i32.to_le_bytes());
        out.extend_from_slice(&[0; 8]);
        for y in (0..height).rev() {
            let start = out.len();
            for px in self.rgb[y * width * 3..][..width * 3].chunks_exact(3) {
                out.extend_from_slice(&[px[2], px[1], px[0]]);
            }
            out.resize(start + row, 0);
        }
        out
    }
}

/// The size of a PNG image from its header, `None` when the bytes are not a PNG.
#[must_use]
pub fn png_size(png: &[u8]) -> Option<(u32, u32)> {
    const SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
    if png.len() < 24 || !png.starts_with(SIGNATURE) || &png[12..16] != b"IHDR" {
        return None;
    }
    let word = |at: usize| u32::from_be_bytes([png[at], png[at + 1], png[at + 2], png[at + 3]]);
    Some((word(16), word(20)))
}

/// What the watch thread is told.
pub(crate) enum WatchCommand {
    Answer(Answer),
    Stop,
}

/// Told what the robot says, or what became of an answer ([`RobotFeed::on_said`],
/// [`RobotFeed::on_answered`]).
type NoteHook = Arc<dyn Fn(&str) + Send + Sync>;

/// What the page holds of the robot, shared with the server's threads.
#[derive(Default)]
pub(crate) struct RobotState {
    pub(crate) json: Option<Arc<str>>,
    pub(crate) camera_bmp: Option<Arc<Vec<u8>>>,
    pub(crate) map_png: Option<Arc<Vec<u8>>>,
    pub(crate) commands: Option<Sender<WatchCommand>>,
    pub(crate) speech: bool,
    /// When a page last asked for the robot's view or frame.
    requested_at: Option<Instant>,
    said: Option<NoteHook>,
    answered: Option<NoteHook>,
}

impl RobotState {
    /// Notes that a page asked for the robot now.
    pub(crate) fn requested(&mut self) -> &Self {
        self.requested_at = Some(Instant::now());
        self
    }

    /// Whether a page asked for the robot within [`VIEWED_FOR`].
    pub(crate) fn requested_lately(&self) -> bool {
        self.requested_at
            .is_some_and(|at| at.elapsed() < VIEWED_FOR)
    }
}

/// Feeds the page with the robot; from [`crate::GuiServer::robot_feed`].
#[derive(Clone)]
pub struct RobotFeed {
    pub(crate) hub: Arc<super::Hub>,
}

impl RobotFeed {
    /// A feed for a robot watched without a page: answers still go to its Speech provider
    /// ([`RobotFeed::answer`]) and what it says is still heard ([`RobotFeed::on_said`]),
    /// for the supervisor at the terminal.
    #[must_use]
    pub fn detached(mission: &crate::Mission) -> Self {
        Self {
            hub: Arc::new(super::Hub::new(super::View::new(mission))),
        }
    }

    /// Whether a page looks at the robot now (an event stream is open, or the robot was
    /// asked for within [`VIEWED_FOR`]).
    #[must_use]
    pub fn is_viewed(&self) -> bool {
        self.hub.lock().viewed()
    }

    /// Sends `answer` to the robot's Speech provider, through the watch; the one way an
    /// answer goes, from the page or the terminal. Returns what is being done, for people.
    ///
    /// # Errors
    /// When the answer is neither yes nor no, the robot has no Speech provider, or it is
    /// no longer watched.
    pub fn answer(&self, answer: Answer) -> Result<String, AnswerRefused> {
        if !matches!(answer.answer.as_str(), "yes" | "no") {
            return Err(AnswerRefused::NotYesOrNo(answer.answer));
        }
        let hub = self.hub.lock();
        let commands = hub.robot.commands.as_ref().filter(|_| hub.robot.speech);
        let Some(commands) = commands else {
            return Err(AnswerRefused::NoSpeech);
        };
        let word = answer.answer.clone();
        commands
            .send(WatchCommand::Answer(answer))
            .map_err(|_| AnswerRefused::NotWatched)?;
        Ok(format!("answering `{word}`"))
    }

    /// Calls `hook` with the words of every utterance the robot's Speech provider says from
    /// now on (one hook at a time: a later call replaces it).
    pub fn on_said(&self, hook: impl Fn(&str) + Send + Sync + 'static) {
        self.hub.lock().robot.said = Some(Arc::new(hook));
    }

    fn said(&self, text: &str) {
        let hook = self.hub.lock().robot.said.clone();
        if let Some(hook) = hook {
            hook(text);
        }
    }

    /// Calls `hook` with what became of every answer sent from now on, for people (`speech
    /// heard `yes``, or why not), as the page shows it (one hook at a time).
    pub fn on_answered(&self, hook: impl Fn(&str) + Send + Sync + 'static) {
        self.hub.lock().robot.answered = Some(Arc::new(hook));
    }

    fn answered(&self, what: &str) {
        let hook = self.hub.lock().robot.answered.clone();
        if let Some(hook) = hook {
            hook(what);
        }
    }

    /// Shows `view` on the page (and sends it to every open page).
    pub fn show(&self, view: &RobotView) {
        let json = match serde_json::to_string(view) {
            Ok(json) => Arc::from(json),
            Err(e) => {
                tracing::error!("cannot serialise the robot's view: {e}");
                return;
            }
        };
        let mut state = self.hub.lock();
        state.robot.json = Some(Arc::clone(&json));
        state.robot.speech = view.speech.is_some();
        state.publish_robot(&json);
    }

    /// Serves `frame` at `camera.bmp` from now on.
    pub fn frame(&self, frame: &Frame) {
        let bmp = Arc::new(frame.bmp());
        self.hub.lock().robot.camera_bmp = Some(bmp);
    }

    /// Serves `png` at `map.png`.
    pub fn map(&self, png: Vec<u8>) {
        self.hub.lock().robot.map_png = Some(Arc::new(png));
    }

    /// From now on the answers of `POST /answer` come out of the returned receiver (one
    /// receiver at a time: a later call replaces it).
    #[must_use]
    pub fn answers(&self) -> Receiver<Answer> {
        let (tx, rx) = mpsc::channel();
        let (commands, incoming) = mpsc::channel();
        self.hub.lock().robot.commands = Some(commands);
        std::thread::spawn(move || {
            for command in incoming {
                match command {
                    WatchCommand::Answer(answer) => {
                        if tx.send(answer).is_err() {
                            return;
                        }
                    }
                    WatchCommand::Stop => return,
                }
            }
        });
        rx
    }

    fn commands(&self) -> Receiver<WatchCommand> {
        let (tx, rx) = mpsc::channel();
        self.hub.lock().robot.commands = Some(tx);
        rx
    }
}

/// The thread that reads the robot and feeds the page; stops when dropped.
pub struct RobotWatch {
    commands: Sender<WatchCommand>,
    stopped: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl RobotWatch {
    /// Starts reading the robot of `namespace` as `options` say, feeding `feed`.
    ///
    /// # Errors
    /// When the thread cannot start.
    pub fn start(
        namespace: &Namespace,
        options: RobotWatchOptions,
        feed: RobotFeed,
    ) -> std::io::Result<Self> {
        if let Some(map) = &options.world_map {
            match std::fs::read(&map.image) {
                Ok(png) => feed.map(png),
                Err(e) => tracing::warn!(
                    "the supervisor's page shows no map: {}: {e}",
                    map.image.display()
                ),
            }
        }
        let incoming = feed.commands();
        let commands = feed
            .hub
            .lock()
            .robot
            .commands
            .clone()
            .ok_or_else(|| std::io::Error::other("no command channel"))?;
        let stopped = Arc::new(AtomicBool::new(false));
        let namespace = namespace.clone();
        let thread_stopped = Arc::clone(&stopped);
        let thread = std::thread::Builder::new()
            .name("lewis-seq-robot".into())
            .spawn(move || watch(&namespace, &options, &feed, &incoming, &thread_stopped))?;
        Ok(Self {
            commands,
            stopped,
            thread: Some(thread),
        })
    }

    /// Stops the thread and waits for it.
    pub fn stop(mut self) {
        self.halt();
    }

    fn halt(&mut self) {
        self.stopped.store(true, Ordering::SeqCst);
        let _ = self.commands.send(WatchCommand::Stop);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Drop for RobotWatch {
    fn drop(&mut self) {
        self.halt();
    }
}

/// The watch thread's IPC: every part optional, so a robot without a camera still shows
/// its bindings.
struct Watched {
    ipc: Ipc,
    pose: Option<(Subscriber, PoseInterface, String)>,
    camera: Option<(Subscriber, String)>,
    people: Option<Subscriber>,
    /// The Speech provider's publications, for what the robot says.
    said: Option<Subscriber>,
    broker: Option<CommandClient>,
    speech: Option<CommandClient>,
}

fn subscribe(ipc: &Ipc, service: &str, interface: &str) -> Option<Subscriber> {
    let channel = names::data_channel(service, interface);
    ipc.subscriber(&channel, &names::data_config(interface))
        .map_err(|e| tracing::warn!("the supervisor's page cannot read {channel}: {e}"))
        .ok()
}

fn open(namespace: &Namespace, options: &RobotWatchOptions) -> Option<Watched> {
    let ipc = Ipc::open(
        namespace,
        &format!("lewis-seq-robot-{}", std::process::id()),
    )
    .map_err(|e| tracing::warn!("the supervisor's page cannot watch the robot: {e}"))
    .ok()?;
    let pose = options.pose.as_ref().and_then(|(service, interface)| {
        subscribe(&ipc, service, interface.name()).map(|s| (s, *interface, service.clone()))
    });
    let camera = options
        .camera
        .as_ref()
        .and_then(|service| subscribe(&ipc, service, "ImageSource").map(|s| (s, service.clone())));
    let people = options
        .people
        .as_ref()
        .and_then(|service| subscribe(&ipc, service, "WorldState"));
    let said = options
        .speech
        .as_ref()
        .and_then(|service| subscribe(&ipc, service, "Speech"));
    let broker = ipc
        .command_client(names::BROKER_COMMAND, &names::broker_command_config())
        .map_err(|e| tracing::warn!("the supervisor's page cannot ask the broker: {e}"))
        .ok();
    Some(Watched {
        ipc,
        pose,
        camera,
        people,
        said,
        broker,
        speech: None,
    })
}

fn watch(
    namespace: &Namespace,
    options: &RobotWatchOptions,
    feed: &RobotFeed,
    commands: &Receiver<WatchCommand>,
    stopped: &AtomicBool,
) {
    let Some(mut watched) = open(namespace, options) else {
        return;
    };
    let mut view = RobotView {
        map: options.world_map.as_ref().and_then(|map| {
            let png = feed.hub.lock().robot.map_png.clone()?;
            let (width_px, height_px) = png_size(&png)?;
            Some(MapView {
                width_px,
                height_px,
                metres_per_pixel: map.metres_per_pixel,
                origin_m: map.origin_m,
            })
        }),
        speech: options.speech.clone(),
        ..RobotView::default()
    };
    let mut next_status = Instant::now();
    let mut frames = 0u64;
    let mut said_count = 0;
    while !stopped.load(Ordering::SeqCst) {
        let tick = Instant::now() + ROBOT_PERIOD;
        let viewed = feed.is_viewed();
        read_robot(&mut watched, &mut view, feed, &mut frames, viewed);
        read_said(&mut watched, feed, &mut said_count);
        // Nobody looks: the broker is not asked on the page's behalf.
        if viewed && Instant::now() >= next_status {
            next_status = Instant::now() + STATUS_PERIOD;
            if let Some(broker) = watched.broker.as_mut() {
                match call_blocking(broker, &BrokerStatus::default(), CALL_TIMEOUT) {
                    Ok(reply) => view.set_status(&reply),
                    Err(e) => {
                        tracing::debug!("the supervisor's page: the broker did not answer: {e}");
                        view.broker_answers = false;
                    }
                }
            }
        }
        feed.show(&view);
        // Sleeps until the next tick, but answers at once.
        loop {
            let left = tick.saturating_duration_since(Instant::now());
            match commands.recv_timeout(left) {
                Ok(WatchCommand::Answer(answer)) => {
                    let what = send_answer(&mut watched, options, &answer);
                    feed.answered(&what);
                    view.answer = Some(what);
                    feed.show(&view);
                }
                Ok(WatchCommand::Stop) | Err(RecvTimeoutError::Disconnected) => return,
                Err(RecvTimeoutError::Timeout) => break,
            }
        }
    }
}

/// Tells the feed each new utterance of the Speech provider (`said_count`: the count last
/// seen).
fn read_said(watched: &mut Watched, feed: &RobotFeed, said_count: &mut i32) {
    let Some(subscriber) = watched.said.as_mut() else {
        return;
    };
    if let Ok(Some(sample)) = subscriber.latest()
        && let Ok(speech) = cdr::from_bytes::<Speech>(sample.bytes())
        && speech.said_count != *said_count
    {
        // A restarted provider counts from zero again: any change is a new utterance.
        *said_count = speech.said_count;
        if speech.said_count > 0 {
            feed.said(&speech.last_said);
        }
    }
}

/// Reads the latest pose and people, and (when `viewed`) the latest camera frame.
fn read_robot(
    watched: &mut Watched,
    view: &mut RobotView,
    feed: &RobotFeed,
    frames: &mut u64,
    viewed: bool,
) {
    if let Some((subscriber, interface, service)) = watched.pose.as_mut()
        && let Ok(Some(sample)) = subscriber.latest()
    {
        let pose = match interface {
            PoseInterface::GroundTruth => {
                cdr::from_bytes::<GroundTruth>(sample.bytes()).map(|m| m.pose)
            }
            PoseInterface::Egomotion => {
                cdr::from_bytes::<Egomotion>(sample.bytes()).map(|m| m.pose)
            }
        };
        match pose {
            Ok(pose) => {
                view.pose = Some(PoseView {
                    x: pose.x,
                    y: pose.y,
                    theta: pose.theta,
                    interface: *interface,
                    service: service.clone(),
                });
            }
            Err(e) => tracing::debug!("the supervisor's page: a pose does not decode: {e}"),
        }
    }
    // A frame is decoded and shrunk only for a page that looks.
    if viewed
        && let Some((subscriber, service)) = watched.camera.as_mut()
        && let Ok(Some(sample)) = subscriber.latest()
    {
        let frame = cdr::from_bytes::<ImageSource>(sample.bytes())
            .ok()
            .and_then(|image| Frame::from_image(&image));
        if let Some(frame) = frame {
            feed.frame(&frame);
            *frames += 1;
            view.camera = Some(CameraView {
                frame: *frames,
                width_px: frame.width,
                height_px: frame.height,
                service: service.clone(),
            });
        }
    }
    if let Some(subscriber) = watched.people.as_mut()
        && let Ok(Some(sample)) = subscriber.latest()
        && let Ok(world) = cdr::from_bytes::<WorldState>(sample.bytes())
    {
        view.people = world
            .people
            .iter()
            .filter(|p| p.present)
            .map(|p| PersonView {
                name: p.name.clone(),
                x: p.position.x,
                y: p.position.y,
            })
            .collect();
    }
}

/// Sends `answer` to the Speech provider; says what became of it.
fn send_answer(watched: &mut Watched, options: &RobotWatchOptions, answer: &Answer) -> String {
    let Some(service) = &options.speech else {
        return "the robot has no Speech provider".to_owned();
    };
    if watched.speech.is_none() {
        let command = names::command_channel(service, "Speech");
        match watched
            .ipc
            .command_client(&command, &names::command_config())
        {
            Ok(client) => watched.speech = Some(client),
            Err(e) => return format!("cannot reach {service}: {e}"),
        }
    }
    let Some(client) = watched.speech.as_mut() else {
        return format!("cannot reach {service}");
    };
    let hear = SpeechHear {
        answer: answer.answer.clone(),
        text: answer.text.clone(),
        ..SpeechHear::default()
    };
    match call_blocking(client, &hear, CALL_TIMEOUT) {
        Ok(_) => format!("{service} heard `{}`", answer.answer),
        Err(e) => format!("{service} did not take the answer: {e}"),
    }
}
