//! Plain HTTP to the supervisor's page, as a browser would speak it: one request per
//! connection, and the event stream read event by event.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::Duration;

/// An answer of the page's server.
pub struct Reply {
    /// The status code.
    pub status: u16,
    /// The status line and the headers.
    pub head: String,
    /// The body's bytes.
    pub body: Vec<u8>,
}

impl Reply {
    /// The body as text.
    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }
}

/// Sends one request (`headers` end each with `\r\n`) and reads the whole answer.
pub fn request(addr: SocketAddr, method: &str, path: &str, headers: &str, body: &str) -> Reply {
    let mut stream = TcpStream::connect(addr).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    write!(
        stream,
        "{method} {path} HTTP/1.1\r\nHost: test\r\nConnection: close\r\n{headers}\
         Content-Length: {}\r\n\r\n{body}",
        body.len()
    )
    .unwrap();
    let mut bytes = Vec::new();
    stream.read_to_end(&mut bytes).unwrap();
    let split = bytes.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8(bytes[..split].to_vec()).unwrap();
    let status = head[9..12].parse().unwrap();
    Reply {
        status,
        head,
        body: bytes[split + 4..].to_vec(),
    }
}

/// A supervisor's command: a POST with the header the page sends.
pub fn command(addr: SocketAddr, path: &str, json: &str) -> Reply {
    request(
        addr,
        "POST",
        path,
        "X-Lewis-Supervisor: 1\r\nContent-Type: application/json\r\n",
        json,
    )
}

/// The page's event stream (`GET /events`), read one event at a time.
pub struct EventStream {
    lines: BufReader<TcpStream>,
}

impl EventStream {
    /// Opens the stream.
    pub fn open(addr: SocketAddr) -> Self {
        let mut stream = TcpStream::connect(addr).unwrap();
        stream
            .set_read_timeout(Some(Duration::from_secs(10)))
            .unwrap();
        write!(stream, "GET /events HTTP/1.1\r\nHost: test\r\n\r\n").unwrap();
        Self {
            lines: BufReader::new(stream),
        }
    }

    /// The next event's data of kind `event` (`message` for the view, `robot` for the
    /// robot), skipping events of other kinds.
    pub fn next(&mut self, event: &str) -> serde_json::Value {
        let mut kind = "message".to_owned();
        loop {
            let mut line = String::new();
            assert_ne!(
                self.lines.read_line(&mut line).unwrap(),
                0,
                "the stream ended"
            );
            if let Some(name) = line.strip_prefix("event: ") {
                name.trim_end().clone_into(&mut kind);
            } else if let Some(json) = line.strip_prefix("data: ") {
                if kind == event {
                    return serde_json::from_str(json).unwrap();
                }
            } else if line == "\n" {
                "message".clone_into(&mut kind);
            }
        }
    }
}
