//! The web pages Lewis serves on localhost (the supervisor's page, the tuning page): an
//! axum [`Router`] served on one address from a thread of its own, with a small tokio
//! runtime, until stopped. The pages' crates build their routers with the [`axum`] this
//! crate re-exports, so the HTTP server is one mechanism in one place.
//!
//! Why axum (hyper underneath) rather than a thread per connection: a browser keeps idle
//! connections open. tiny_http, used before, gave each connection a pool thread, and under
//! load queued a new connection behind idle ones until one of them closed: a page's first
//! frame never came. hyper serves each connection as a task, so an idle one costs nothing.

use std::convert::Infallible;
use std::net::SocketAddr;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

pub use axum;

use axum::Router;
use axum::response::sse::{Event, Sse};
use axum::response::{IntoResponse, Response};
use tokio::sync::{mpsc, watch};

/// How long a stopped server lets open responses (an event stream's last message) finish
/// before it closes their connections.
pub const STOP_GRACE: Duration = Duration::from_secs(2);

/// The server could not start.
#[derive(Debug, thiserror::Error)]
pub enum PageError {
    /// The address could not be bound.
    #[error("cannot serve on {addr}: {source}")]
    Bind {
        /// The address asked for.
        addr: SocketAddr,
        /// What the system said.
        #[source]
        source: std::io::Error,
    },
    /// The server's thread or runtime could not start.
    #[error("cannot start the page's server: {0}")]
    Start(#[source] std::io::Error),
}

/// A router served on one address; stops when dropped (or with [`PageServer::stop`]).
pub struct PageServer {
    addr: SocketAddr,
    stop: watch::Sender<bool>,
    thread: Option<JoinHandle<()>>,
}

impl PageServer {
    /// Serves `router` on `bind` (port 0 picks a free port) from a thread named `name`.
    /// The address is bound before this returns, so a browser can be pointed at
    /// [`PageServer::url`] at once.
    ///
    /// # Errors
    /// When the address cannot be bound or the thread cannot start.
    pub fn start(name: &str, bind: SocketAddr, router: Router) -> Result<Self, PageError> {
        let listener = std::net::TcpListener::bind(bind)
            .and_then(|l| l.set_nonblocking(true).map(|()| l))
            .map_err(|source| PageError::Bind { addr: bind, source })?;
        let addr = listener.local_addr().map_err(PageError::Start)?;
        // Two workers: a handler that computes (a sweep over a recording) does it on the
        // blocking pool, and the page's other requests keep being answered meanwhile.
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name(format!("{name}-io"))
            .enable_io()
            .enable_time()
            .build()
            .map_err(PageError::Start)?;
        let (stop, stopped) = watch::channel(false);
        let thread = std::thread::Builder::new()
            .name(name.to_owned())
            .spawn(move || {
                runtime.block_on(serve(listener, router, stopped));
                runtime.shutdown_timeout(STOP_GRACE);
            })
            .map_err(PageError::Start)?;
        Ok(Self {
            addr,
            stop,
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

    /// Blocks until the server ends: for a command that serves until it is interrupted.
    pub fn wait(mut self) {
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }

    /// Stops taking connections, lets open responses finish for up to [`STOP_GRACE`],
    /// and returns once the server's thread has ended.
    pub fn stop(&mut self) {
        let _ = self.stop.send(true);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Drop for PageServer {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Runs `work` (a computation, or a lock that may wait for one) on the runtime's blocking
/// pool, so the server's other requests keep being answered meanwhile. `None` when `work`
/// panicked.
pub async fn blocking<T: Send + 'static>(work: impl FnOnce() -> T + Send + 'static) -> Option<T> {
    tokio::task::spawn_blocking(work).await.ok()
}

/// An answer of a page: `status`, its content type, `body`, and `Cache-Control: no-store`
/// (a page's answers describe the robot or the recording as they are now). A status that
/// is not one (outside 100-999) answers 500.
#[must_use]
pub fn respond(status: u16, content_type: &'static str, body: Vec<u8>) -> Response {
    let status = axum::http::StatusCode::from_u16(status)
        .unwrap_or(axum::http::StatusCode::INTERNAL_SERVER_ERROR);
    (
        status,
        [
            (axum::http::header::CONTENT_TYPE, content_type),
            (axum::http::header::CACHE_CONTROL, "no-store"),
        ],
        body,
    )
        .into_response()
}

/// What a page's event source sends next (see [`event_stream`]).
pub enum Sent {
    /// An event: its kind (`None` for the default, `message`) and its data, one line.
    Event {
        /// The `event:` field, when not `message`.
        kind: Option<&'static str>,
        /// The `data:` field.
        data: Arc<str>,
    },
    /// A comment, so that a browser gone away is noticed by the write failing.
    KeepAlive,
}

/// A Server-Sent Events response: `retry` first, then what `next` gives until it gives
/// `None`. `next` blocks until it has something to send (a condition variable, a
/// timeout for keep-alives); it runs on the blocking pool, so a page's sources stay plain
/// threads' code. It is dropped when the stream ends, either way: when it gives `None`, or
/// at its next event after the browser went away.
pub fn event_stream(
    retry: Duration,
    mut next: impl FnMut() -> Option<Sent> + Send + 'static,
) -> Response {
    let (events, received) = mpsc::channel::<Event>(1);
    tokio::task::spawn_blocking(move || {
        let mut event = Some(Event::default().retry(retry));
        while let Some(sent) = event.take() {
            if events.blocking_send(sent).is_err() {
                break;
            }
            event = next().map(|n| match n {
                Sent::Event { kind: None, data } => Event::default().data(&*data),
                Sent::Event {
                    kind: Some(kind),
                    data,
                } => Event::default().event(kind).data(&*data),
                Sent::KeepAlive => Event::default().comment("keep-alive"),
            });
        }
    });
    let stream = futures_util::stream::unfold(received, |mut received| async move {
        let event = received.recv().await?;
        Some((Ok::<_, Infallible>(event), received))
    });
    Sse::new(stream).into_response()
}

/// Serves until `stopped` turns true, then gives open responses [`STOP_GRACE`].
async fn serve(listener: std::net::TcpListener, router: Router, stopped: watch::Receiver<bool>) {
    let listener = match tokio::net::TcpListener::from_std(listener) {
        Ok(listener) => listener,
        Err(e) => {
            tracing::error!("cannot serve the page: {e}");
            return;
        }
    };
    let signal = {
        let mut stopped = stopped.clone();
        async move {
            let _ = stopped.wait_for(|s| *s).await;
        }
    };
    let graceful = axum::serve(listener, router).with_graceful_shutdown(signal);
    let deadline = {
        let mut stopped = stopped;
        async move {
            let _ = stopped.wait_for(|s| *s).await;
            tokio::time::sleep(STOP_GRACE).await;
        }
    };
    tokio::select! {
        served = graceful => {
            if let Err(e) = served {
                tracing::error!("the page's server stopped: {e}");
            }
        }
        () = deadline => tracing::debug!("the page's server closed responses still open"),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]

    use std::io::{Read as _, Write as _};
    use std::net::{Ipv4Addr, TcpStream};

    use axum::routing::get;

    use super::*;

    fn hello() -> PageServer {
        let router = Router::new().route("/", get(|| async { "hello" }));
        PageServer::start("test-page", (Ipv4Addr::LOCALHOST, 0).into(), router).unwrap()
    }

    fn get_root(addr: SocketAddr) -> String {
        let mut stream = TcpStream::connect(addr).unwrap();
        stream
            .write_all(b"GET / HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
            .unwrap();
        let mut answer = String::new();
        stream.read_to_string(&mut answer).unwrap();
        answer
    }

    #[test]
    fn a_request_is_answered_beside_many_idle_connections() {
        let server = hello();
        // More idle connections than a thread-per-connection pool starts with: a browser
        // keeps several open, and none may hold up the next request.
        let idle: Vec<TcpStream> = (0..16)
            .map(|_| TcpStream::connect(server.addr()).unwrap())
            .collect();
        let answer = get_root(server.addr());
        assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
        assert!(answer.ends_with("hello"), "{answer}");
        drop(idle);
    }

    #[test]
    fn stopping_closes_idle_connections_and_frees_the_address() {
        let mut server = hello();
        let addr = server.addr();
        let mut idle = TcpStream::connect(addr).unwrap();
        assert!(get_root(addr).ends_with("hello"));
        server.stop();
        let mut rest = Vec::new();
        // The idle connection is closed by the server: the read ends, it does not hang.
        let _ = idle.read_to_end(&mut rest);
        assert!(
            TcpStream::connect(addr).is_err(),
            "still listening on {addr}"
        );
        assert_eq!(server.url(), format!("http://{addr}/"));
    }

    #[test]
    fn an_event_stream_sends_retry_its_events_and_ends_with_its_source() {
        let router = Router::new().route(
            "/",
            get(|| async {
                let mut left = vec![
                    Sent::Event {
                        kind: Some("robot"),
                        data: Arc::from("{\"b\":2}"),
                    },
                    Sent::KeepAlive,
                    Sent::Event {
                        kind: None,
                        data: Arc::from("{\"a\":1}"),
                    },
                ];
                event_stream(Duration::from_millis(1000), move || left.pop())
            }),
        );
        let server =
            PageServer::start("test-page", (Ipv4Addr::LOCALHOST, 0).into(), router).unwrap();
        let answer = get_root(server.addr());
        assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
        assert!(
            answer.contains("content-type: text/event-stream"),
            "{answer}"
        );
        let body = answer.split("\r\n\r\n").nth(1).unwrap();
        // The body is chunked: the events in order, whole, each ended by a blank line.
        let at = |needle: &str| {
            body.find(needle)
                .unwrap_or_else(|| panic!("no {needle:?} in {body:?}"))
        };
        assert!(at("retry: 1000\n\n") < at("data: {\"a\":1}\n\n"));
        assert!(at("data: {\"a\":1}\n\n") < at(": keep-alive\n\n"));
        assert!(at(": keep-alive\n\n") < at("event: robot\ndata: {\"b\":2}\n\n"));
    }

    #[test]
    fn a_taken_address_is_refused_naming_it() {
        let server = hello();
        let router = Router::new();
        let Err(e) = PageServer::start("test-page", server.addr(), router) else {
            panic!("bound twice");
        };
        assert!(
            e.to_string()
                .starts_with(&format!("cannot serve on {}", server.addr())),
            "{e}"
        );
    }
}
