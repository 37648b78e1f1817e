//! The supervisor's page: the mission as a diagram with the current state, the history of
//! decisions, and big buttons to choose where to resume when the sequencer asks. Served on
//! localhost by a small HTTP server (`tiny_http`), the page compiled in (no network), live
//! through Server-Sent Events.
//!
//! Routes: `GET /` the page; `GET /view` the [`View`] as JSON; `GET /events` the view again
//! on every change (`text/event-stream`), and the robot (`event: robot`); `POST /choose`
//! with `{"state":"NAME"}` (or `"stop"`) the supervisor's choice; `POST /stop` stops the
//! mission. Beside the mission, the robot ([`RobotWatch`]): `GET /robot` the [`RobotView`]
//! as JSON, `GET /camera.bmp` its latest frame, `GET /map.png` the world's map, `POST
//! /answer` with `{"answer":"yes","text":"registered"}` an answer for its Speech provider. A POST must carry the
//! header `X-Lewis-Supervisor: 1`, which a page from another origin cannot send without
//! the browser asking this server first (and it never agrees).

mod open;
mod robot;
mod view;

use std::io::{Read, Write};
use std::net::SocketAddr;
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

use serde::Deserialize;
use tiny_http::{Header, Method, Request, Response, Server};

pub use open::open_in_browser;
pub use robot::{
    Answer, AnswerRefused, BindingView, CAMERA_MAX_WIDTH_PX, CameraView, Frame, MapView,
    PersonView, PoseInterface, PoseView, ROBOT_PERIOD, RobotFeed, RobotView, RobotWatch,
    RobotWatchOptions, ServiceView, VIEWED_FOR, png_size,
};
pub use view::{
    Current, Diagram, DiagramAction, DiagramState, HISTORY_LINES, HistoryLine, Phase, Question,
    View,
};

use crate::live::Controller;
use crate::mission::Mission;
use crate::record::{Record, RecordSink};

/// The page, compiled in.
const PAGE: &str = include_str!("page.html");

/// How often an idle event stream gets a comment, so a vanished browser is noticed.
const KEEPALIVE: Duration = Duration::from_secs(15);

/// The largest request body read, in bytes.
const MAX_BODY_BYTES: u64 = 4096;

/// The server could not start.
#[derive(Debug, thiserror::Error)]
pub enum GuiError {
    /// The address could not be bound.
    #[error("cannot serve the supervisor's page on {addr}: {message}; choose another --gui-port")]
    Bind {
        /// The address asked for.
        addr: SocketAddr,
        /// What the system said.
        message: String,
    },
    /// The server's thread could not start.
    #[error("cannot start the supervisor's page: {0}")]
    Thread(#[source] std::io::Error),
}

/// The page's server; stops when dropped (or with [`GuiServer::shutdown`]).
pub struct GuiServer {
    server: Arc<Server>,
    hub: Arc<Hub>,
    addr: SocketAddr,
    thread: Option<JoinHandle<()>>,
}

impl GuiServer {
    /// Serves the page of `mission` on `bind` (port 0 picks a free port), sending the
    /// supervisor's choices to `controller`. Feed it the mission's records through
    /// [`GuiServer::sink`].
    ///
    /// # Errors
    /// When the address cannot be bound or the thread cannot start.
    pub fn start(
        bind: SocketAddr,
        mission: &Mission,
        controller: Controller,
    ) -> Result<Self, GuiError> {
        let server = Server::http(bind).map_err(|e| GuiError::Bind {
            addr: bind,
            message: e.to_string(),
        })?;
        let addr = server.server_addr().to_ip().unwrap_or(bind);
        let server = Arc::new(server);
        let hub = Arc::new(Hub::new(View::new(mission)));
        let thread = {
            let server = Arc::clone(&server);
            let hub = Arc::clone(&hub);
            std::thread::Builder::new()
                .name("lewis-seq-gui".into())
                .spawn(move || {
                    for request in server.incoming_requests() {
                        handle(request, &hub, &controller);
                    }
                })
                .map_err(GuiError::Thread)?
        };
        Ok(Self {
            server,
            hub,
            addr,
            thread: Some(thread),
        })
    }

    /// The address served.
    #[must_use]
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's address (`http://127.0.0.1:8042/`).
    #[must_use]
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// A sink updating the page with the mission's records.
    #[must_use]
    pub fn sink(&self) -> GuiSink {
        GuiSink {
            hub: Arc::clone(&self.hub),
        }
    }

    /// A feed showing the robot beside the mission (see [`RobotWatch`]).
    #[must_use]
    pub fn robot_feed(&self) -> RobotFeed {
        RobotFeed {
            hub: Arc::clone(&self.hub),
        }
    }

    /// What the page shows now.
    #[must_use]
    pub fn view(&self) -> View {
        self.hub.lock().view.clone()
    }

    /// Sends the last view to every open page, then stops serving.
    pub fn shutdown(mut self) {
        self.stop();
    }

    fn stop(&mut self) {
        let streams = {
            let mut state = self.hub.lock();
            state.closed = true;
            for subscriber in &state.subscribers {
                subscriber.close();
            }
            std::mem::take(&mut state.streams)
        };
        self.server.unblock();
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        for stream in streams {
            let _ = stream.join();
        }
    }
}

impl Drop for GuiServer {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Updates the page with records; see [`GuiServer::sink`].
#[derive(Clone)]
pub struct GuiSink {
    hub: Arc<Hub>,
}

impl RecordSink for GuiSink {
    fn record(&mut self, record: &Record) {
        let mut state = self.hub.lock();
        state.view.apply(record);
        state.publish();
    }
}

/// The view shared between the driver's sink and the page's streams.
pub(crate) struct Hub {
    state: Mutex<HubState>,
}

pub(crate) struct HubState {
    view: View,
    subscribers: Vec<Arc<Subscriber>>,
    streams: Vec<JoinHandle<()>>,
    closed: bool,
    robot: robot::RobotState,
}

impl Hub {
    fn new(view: View) -> Self {
        Self {
            state: Mutex::new(HubState {
                view,
                subscribers: Vec::new(),
                streams: Vec::new(),
                closed: false,
                robot: robot::RobotState::default(),
            }),
        }
    }

    pub(crate) fn lock(&self) -> MutexGuard<'_, HubState> {
        // The state is a plain value, whole after any panic elsewhere.
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

impl HubState {
    fn json(&self) -> Arc<str> {
        Arc::from(serde_json::to_string(&self.view).unwrap_or_else(|e| {
            tracing::error!("cannot serialise the supervisor's view: {e}");
            "{}".to_owned()
        }))
    }

    /// Whether a page looks at the robot: an event stream is open, or the robot's view or
    /// frame was asked for lately.
    pub(crate) fn viewed(&mut self) -> bool {
        self.subscribers.retain(|s| !s.is_gone());
        !self.subscribers.is_empty() || self.robot.requested_lately()
    }

    fn publish(&mut self) {
        self.subscribers.retain(|s| !s.is_gone());
        let json = self.json();
        for subscriber in &self.subscribers {
            subscriber.offer(Arc::clone(&json));
        }
    }

    pub(crate) fn publish_robot(&mut self, json: &Arc<str>) {
        self.subscribers.retain(|s| !s.is_gone());
        for subscriber in &self.subscribers {
            subscriber.offer_robot(Arc::clone(json));
        }
    }
}

/// One open event stream: only the latest view is kept for it, so a slow browser skips
/// views instead of piling them up.
#[derive(Default)]
struct Subscriber {
    slot: Mutex<Slot>,
    ready: Condvar,
}

#[derive(Default)]
struct Slot {
    latest: Option<Arc<str>>,
    robot: Option<Arc<str>>,
    closed: bool,
    gone: bool,
}

impl Subscriber {
    fn lock(&self) -> MutexGuard<'_, Slot> {
        self.slot.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn offer(&self, json: Arc<str>) {
        self.lock().latest = Some(json);
        self.ready.notify_one();
    }

    fn offer_robot(&self, json: Arc<str>) {
        self.lock().robot = Some(json);
        self.ready.notify_one();
    }

    fn close(&self) {
        self.lock().closed = true;
        self.ready.notify_one();
    }

    fn is_gone(&self) -> bool {
        self.lock().gone
    }

    /// The next view or robot to send, `Ok(None)` for a keep-alive, `Err(())` once closed
    /// and sent.
    fn next(&self) -> Result<Option<Next>, ()> {
        let slot = self.lock();
        let (mut slot, _) = self
            .ready
            .wait_timeout_while(slot, KEEPALIVE, |s| {
                s.latest.is_none() && s.robot.is_none() && !s.closed
            })
            .unwrap_or_else(PoisonError::into_inner);
        if let Some(json) = slot.latest.take() {
            return Ok(Some(Next::View(json)));
        }
        match slot.robot.take() {
            Some(json) => Ok(Some(Next::Robot(json))),
            None if slot.closed => Err(()),
            None => Ok(None),
        }
    }
}

/// What an event stream sends next.
enum Next {
    View(Arc<str>),
    Robot(Arc<str>),
}

fn handle(request: Request, hub: &Arc<Hub>, controller: &Controller) {
    let path = request.url().split('?').next().unwrap_or("/").to_owned();
    let result = match (request.method(), path.as_str()) {
        (Method::Get, "/" | "/index.html") => request.respond(with_header(
            Response::from_string(PAGE),
            "Content-Type",
            "text/html; charset=utf-8",
        )),
        (Method::Get, "/view") => {
            let json = hub.lock().json();
            request.respond(json_response(200, &json))
        }
        (Method::Get, "/events") => {
            stream(request, hub);
            Ok(())
        }
        (Method::Get, "/robot") => match hub.lock().robot.requested().json.clone() {
            Some(json) => request.respond(json_response(200, &json)),
            None => request.respond(text_response(404, "the robot is not watched")),
        },
        (Method::Get, "/camera.bmp") => match hub.lock().robot.requested().camera_bmp.clone() {
            Some(bmp) => request.respond(bytes_response(&bmp, "image/bmp")),
            None => request.respond(text_response(404, "no camera frame yet")),
        },
        (Method::Get, "/map.png") => match hub.lock().robot.map_png.clone() {
            Some(png) => request.respond(bytes_response(&png, "image/png")),
            None => request.respond(text_response(404, "no world map")),
        },
        (Method::Post, "/choose" | "/stop" | "/answer") => post(request, &path, hub, controller),
        (Method::Get, _) => request.respond(text_response(404, "no such page: try /")),
        _ => request.respond(text_response(405, "method not allowed")),
    };
    if let Err(e) = result {
        tracing::debug!("the supervisor's page: cannot answer {path}: {e}");
    }
}

#[derive(Deserialize)]
struct Choice {
    state: String,
}

fn post(
    mut request: Request,
    path: &str,
    hub: &Arc<Hub>,
    controller: &Controller,
) -> std::io::Result<()> {
    let trusted = request
        .headers()
        .iter()
        .any(|h| h.field.equiv("X-Lewis-Supervisor") && h.value.as_str() == "1");
    if !trusted {
        return request.respond(text_response(
            403,
            "send the header `X-Lewis-Supervisor: 1` with the command",
        ));
    }
    let mut body = String::new();
    if request
        .as_reader()
        .take(MAX_BODY_BYTES)
        .read_to_string(&mut body)
        .is_err()
    {
        return request.respond(text_response(400, "the body is not UTF-8 text"));
    }
    let (status, message) = if path == "/answer" {
        match serde_json::from_str::<Answer>(&body) {
            Err(e) => (
                400,
                format!("expected {{\"answer\":\"yes\",\"text\":\"...\"}}: {e}"),
            ),
            Ok(answer) => match (RobotFeed {
                hub: Arc::clone(hub),
            })
            .answer(answer)
            {
                Ok(sent) => (202, sent),
                Err(refused @ AnswerRefused::NotYesOrNo(_)) => (400, refused.to_string()),
                Err(refused) => (409, refused.to_string()),
            },
        }
    } else if path == "/stop" {
        if controller.stop() {
            (202, "stopping the mission".to_owned())
        } else {
            (409, "the mission is over".to_owned())
        }
    } else {
        match serde_json::from_str::<Choice>(&body) {
            Err(e) => (400, format!("expected {{\"state\":\"NAME\"}}: {e}")),
            Ok(Choice { state }) => choose(hub, controller, &state),
        }
    };
    request.respond(text_response(status, &message))
}

fn choose(hub: &Hub, controller: &Controller, state: &str) -> (u16, String) {
    let asked = {
        let hub = hub.lock();
        hub.view
            .question
            .as_ref()
            .map(|q| state == "stop" || q.choices.iter().any(|c| c == state))
    };
    match asked {
        None => (409, "the sequencer is not asking for a choice now".into()),
        Some(false) => (400, format!("`{state}` is not a state of the mission")),
        Some(true) if controller.choose(state) => (202, format!("resuming at `{state}`")),
        Some(true) => (409, "the mission is over".into()),
    }
}

/// Answers `GET /events` on a thread of its own: the view now, then on every change.
fn stream(request: Request, hub: &Arc<Hub>) {
    let subscriber = Arc::new(Subscriber::default());
    let mut state = hub.lock();
    if state.closed {
        drop(state);
        let _ = request.respond(text_response(503, "the mission is over"));
        return;
    }
    subscriber.offer(state.json());
    if let Some(robot) = state.robot.json.clone() {
        subscriber.offer_robot(robot);
    }
    state.subscribers.push(Arc::clone(&subscriber));
    let spawned = std::thread::Builder::new()
        .name("lewis-seq-gui-events".into())
        .spawn(move || {
            let mut out = request.into_writer();
            let sent = write_stream(&mut *out, &subscriber);
            if let Err(e) = sent {
                tracing::debug!("an event stream of the supervisor's page ended: {e}");
            }
            subscriber.lock().gone = true;
        });
    match spawned {
        Ok(thread) => state.streams.push(thread),
        Err(e) => tracing::error!("cannot stream to the supervisor's page: {e}"),
    }
}

fn write_stream(out: &mut dyn Write, subscriber: &Subscriber) -> std::io::Result<()> {
    out.write_all(
        b"HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\n\
          Connection: close\r\n\r\nretry: 1000\n\n",
    )?;
    out.flush()?;
    while let Ok(next) = subscriber.next() {
        match next {
            Some(Next::View(json)) => write!(out, "data: {json}\n\n")?,
            Some(Next::Robot(json)) => write!(out, "event: robot\ndata: {json}\n\n")?,
            None => out.write_all(b": keep-alive\n\n")?,
        }
        out.flush()?;
    }
    Ok(())
}

type Body = std::io::Cursor<Vec<u8>>;

/// Adds a header; `from_bytes` refuses only non-ASCII, and ours are ASCII constants.
fn with_header(response: Response<Body>, field: &str, value: &str) -> Response<Body> {
    match Header::from_bytes(field.as_bytes(), value.as_bytes()) {
        Ok(header) => response.with_header(header),
        Err(()) => response,
    }
}

fn text_response(status: u16, text: &str) -> Response<Body> {
    let response = Response::from_string(text).with_status_code(status);
    with_header(response, "Content-Type", "text/plain; charset=utf-8")
}

fn bytes_response(bytes: &[u8], content_type: &str) -> Response<Body> {
    let response = Response::from_data(bytes.to_vec());
    let response = with_header(response, "Content-Type", content_type);
    with_header(response, "Cache-Control", "no-store")
}

fn json_response(status: u16, json: &str) -> Response<Body> {
    let response = Response::from_string(json).with_status_code(status);
    let response = with_header(response, "Content-Type", "application/json");
    with_header(response, "Cache-Control", "no-store")
}
