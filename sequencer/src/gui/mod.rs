//! The supervisor's page: the mission as a diagram with the current state, the history of
//! decisions, and big buttons to choose where to resume when the sequencer asks. Served on
//! localhost by the pages' HTTP server (`lewis-pages`), the page compiled in (no network),
//! live through Server-Sent Events.
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

use std::net::SocketAddr;
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::time::Duration;

use lewis_pages::axum::Router;
use lewis_pages::axum::body::Bytes;
use lewis_pages::axum::extract::{DefaultBodyLimit, State};
use lewis_pages::axum::http::{HeaderMap, Method, Uri, header};
use lewis_pages::axum::response::{IntoResponse, Response};
use lewis_pages::{PageError, PageServer, Sent};
use serde::Deserialize;

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
const MAX_BODY_BYTES: usize = 4096;

/// How soon a browser reconnects a broken event stream.
const RETRY: Duration = Duration::from_secs(1);

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
    server: PageServer,
    hub: Arc<Hub>,
}

/// What every request's handler is given.
#[derive(Clone)]
struct Page {
    hub: Arc<Hub>,
    controller: Controller,
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
        let hub = Arc::new(Hub::new(View::new(mission)));
        let router = Router::new()
            .fallback(handle)
            .layer(DefaultBodyLimit::max(MAX_BODY_BYTES))
            .with_state(Page {
                hub: Arc::clone(&hub),
                controller,
            });
        let server = PageServer::start("lewis-seq-gui", bind, router).map_err(|e| match e {
            PageError::Bind { addr, source } => GuiError::Bind {
                addr,
                message: source.to_string(),
            },
            PageError::Start(e) => GuiError::Thread(e),
        })?;
        Ok(Self { server, hub })
    }

    /// The address served.
    #[must_use]
    pub fn addr(&self) -> SocketAddr {
        self.server.addr()
    }

    /// The page's address (`http://127.0.0.1:8042/`).
    #[must_use]
    pub fn url(&self) -> String {
        self.server.url()
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
        {
            let mut state = self.hub.lock();
            state.closed = true;
            for subscriber in &state.subscribers {
                subscriber.close();
            }
        }
        // Each stream sends what its subscriber holds, then ends; the server waits for
        // that (within its grace) before it stops.
        self.server.stop();
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
    closed: bool,
    robot: robot::RobotState,
}

impl Hub {
    fn new(view: View) -> Self {
        Self {
            state: Mutex::new(HubState {
                view,
                subscribers: Vec::new(),
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

/// Answers one request.
async fn handle(
    State(page): State<Page>,
    method: Method,
    uri: Uri,
    headers: HeaderMap,
    body: Bytes,
) -> Response {
    let hub = &page.hub;
    match (&method, uri.path()) {
        (&Method::GET, "/" | "/index.html") => {
            ([(header::CONTENT_TYPE, "text/html; charset=utf-8")], PAGE).into_response()
        }
        (&Method::GET, "/view") => {
            let json = hub.lock().json();
            json_response(200, &json)
        }
        (&Method::GET, "/events") => stream(hub),
        (&Method::GET, "/robot") => match hub.lock().robot.requested().json.clone() {
            Some(json) => json_response(200, &json),
            None => text_response(404, "the robot is not watched"),
        },
        (&Method::GET, "/camera.bmp") => match hub.lock().robot.requested().camera_bmp.clone() {
            Some(bmp) => bytes_response(&bmp, "image/bmp"),
            None => text_response(404, "no camera frame yet"),
        },
        (&Method::GET, "/map.png") => match hub.lock().robot.map_png.clone() {
            Some(png) => bytes_response(&png, "image/png"),
            None => text_response(404, "no world map"),
        },
        (&Method::POST, path @ ("/choose" | "/stop" | "/answer")) => {
            post(&headers, &body, path, hub, &page.controller)
        }
        (&Method::GET, _) => text_response(404, "no such page: try /"),
        _ => text_response(405, "method not allowed"),
    }
}

#[derive(Deserialize)]
struct Choice {
    state: String,
}

fn post(
    headers: &HeaderMap,
    body: &[u8],
    path: &str,
    hub: &Arc<Hub>,
    controller: &Controller,
) -> Response {
    let trusted = headers
        .get_all("X-Lewis-Supervisor")
        .iter()
        .any(|value| value.as_bytes() == b"1");
    if !trusted {
        return text_response(
            403,
            "send the header `X-Lewis-Supervisor: 1` with the command",
        );
    }
    let Ok(body) = std::str::from_utf8(body) else {
        return text_response(400, "the body is not UTF-8 text");
    };
    let (status, message) = if path == "/answer" {
        match serde_json::from_str::<Answer>(body) {
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
        match serde_json::from_str::<Choice>(body) {
            Err(e) => (400, format!("expected {{\"state\":\"NAME\"}}: {e}")),
            Ok(Choice { state }) => choose(hub, controller, &state),
        }
    };
    text_response(status, &message)
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

/// Answers `GET /events`: the view now, then on every change, until the mission's page
/// closes or the browser goes away.
fn stream(hub: &Arc<Hub>) -> Response {
    let subscriber = Arc::new(Subscriber::default());
    {
        let mut state = hub.lock();
        if state.closed {
            return text_response(503, "the mission is over");
        }
        subscriber.offer(state.json());
        if let Some(robot) = state.robot.json.clone() {
            subscriber.offer_robot(robot);
        }
        state.subscribers.push(Arc::clone(&subscriber));
    }
    let gone = Gone(Arc::clone(&subscriber));
    lewis_pages::event_stream(RETRY, move || {
        let _held = &gone;
        match subscriber.next() {
            Ok(Some(Next::View(json))) => Some(Sent::Event {
                kind: None,
                data: json,
            }),
            Ok(Some(Next::Robot(json))) => Some(Sent::Event {
                kind: Some("robot"),
                data: json,
            }),
            Ok(None) => Some(Sent::KeepAlive),
            Err(()) => None,
        }
    })
}

/// Marks a subscriber gone when its stream ends, however it ends: the robot's view then
/// stops being computed for it.
struct Gone(Arc<Subscriber>);

impl Drop for Gone {
    fn drop(&mut self) {
        self.0.lock().gone = true;
    }
}

fn text_response(status: u16, text: &str) -> Response {
    lewis_pages::respond(
        status,
        "text/plain; charset=utf-8",
        text.as_bytes().to_vec(),
    )
}

fn bytes_response(bytes: &[u8], content_type: &'static str) -> Response {
    lewis_pages::respond(200, content_type, bytes.to_vec())
}

fn json_response(status: u16, json: &str) -> Response {
    lewis_pages::respond(status, "application/json", json.as_bytes().to_vec())
}
