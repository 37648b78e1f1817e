//! A child's stdout and stderr, cut into lines and forwarded to `tracing` and to the caller.
//!
//! One thread per stream reads the pipe until end of file, so a child never blocks on a full
//! pipe because its supervisor is busy. Lines go to the caller through a bounded channel with
//! `try_send`: when it is full the line is dropped and counted, never waited for, so a slow
//! consumer costs log lines, not the robot.

use std::io::{self, Read};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError};
use std::thread;

use super::event::{LogLine, Stream};

/// The longest piece of a line forwarded as one [`LogLine`], in bytes; a longer line is split
/// (at a UTF-8 character boundary when there is one) and the pieces say so.
pub const MAX_LINE_BYTES: usize = 16 * 1024;

/// How many bytes one `read` takes from a pipe.
const READ_CHUNK_BYTES: usize = 8 * 1024;

/// One piece of output: a whole line, or part of a line too long to forward in one piece.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Piece {
    pub(crate) text: String,
    pub(crate) continues: bool,
}

/// Cuts a byte stream into lines; holds at most `max_line_bytes` plus one read of pending
/// bytes.
#[derive(Debug)]
pub(crate) struct LineSplitter {
    pending: Vec<u8>,
    max_line_bytes: usize,
}

impl LineSplitter {
    /// A splitter cutting lines longer than `max_line_bytes` (at least 4, the longest UTF-8
    /// character).
    pub(crate) fn new(max_line_bytes: usize) -> Self {
        Self {
            pending: Vec::new(),
            max_line_bytes: max_line_bytes.max(4),
        }
    }

    /// Takes more bytes and hands out every piece they complete.
    pub(crate) fn push(&mut self, mut bytes: &[u8], out: &mut impl FnMut(Piece)) {
        while let Some(newline) = bytes.iter().position(|&b| b == b'\n') {
            self.append(&bytes[..newline], out);
            let line = self.pending.strip_suffix(b"\r").unwrap_or(&self.pending);
            out(Piece {
                text: String::from_utf8_lossy(line).into_owned(),
                continues: false,
            });
            self.pending.clear();
            bytes = &bytes[newline + 1..];
        }
        self.append(bytes, out);
    }

    /// Hands out what is left after the stream ended: a last line without a newline.
    pub(crate) fn finish(&mut self, out: &mut impl FnMut(Piece)) {
        if !self.pending.is_empty() {
            out(Piece {
                text: String::from_utf8_lossy(&self.pending).into_owned(),
                continues: false,
            });
            self.pending.clear();
        }
    }

    fn append(&mut self, bytes: &[u8], out: &mut impl FnMut(Piece)) {
        self.pending.extend_from_slice(bytes);
        while self.pending.len() > self.max_line_bytes {
            let cut = char_boundary_at_or_before(&self.pending, self.max_line_bytes);
            out(Piece {
                text: String::from_utf8_lossy(&self.pending[..cut]).into_owned(),
                continues: true,
            });
            self.pending.drain(..cut);
        }
    }
}

/// The largest index `<= at` (and > 0) where a UTF-8 character starts, looking back at most
/// three bytes; `at` itself when the bytes there are not UTF-8 anyway.
fn char_boundary_at_or_before(bytes: &[u8], at: usize) -> usize {
    let is_continuation = |b: u8| b & 0b1100_0000 == 0b1000_0000;
    (0..4)
        .map(|back| at.saturating_sub(back))
        .find(|&i| i > 0 && bytes.get(i).is_some_and(|&b| !is_continuation(b)))
        .unwrap_or(at)
}

/// Where one stream's lines go.
pub(crate) struct Forward {
    pub(crate) name: Arc<str>,
    pub(crate) pid: u32,
    pub(crate) stream: Stream,
    pub(crate) sink: Option<SyncSender<LogLine>>,
    pub(crate) dropped: Arc<AtomicU64>,
}

impl Forward {
    /// Reads `reader` on a thread of its own until end of file.
    pub(crate) fn spawn(self, reader: impl Read + Send + 'static) -> io::Result<()> {
        thread::Builder::new()
            // A NUL in a thread name would panic; names come from robot files.
            .name(format!("lewis-{}-{}", self.stream, self.name).replace('\0', ""))
            .spawn(move || self.run(reader))
            .map(drop)
    }

    fn run(mut self, mut reader: impl Read) {
        let mut splitter = LineSplitter::new(MAX_LINE_BYTES);
        let mut buf = vec![0_u8; READ_CHUNK_BYTES];
        loop {
            match reader.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => splitter.push(&buf[..n], &mut |piece| self.emit(piece)),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => {
                    tracing::warn!(
                        service = %self.name, stream = %self.stream,
                        "stopped reading the service's output: {e}"
                    );
                    break;
                }
            }
        }
        splitter.finish(&mut |piece| self.emit(piece));
    }

    fn emit(&mut self, mut piece: Piece) {
        let (level, plain) = crate::logs::forwarded_line(&self.name, &piece.text);
        piece.text = plain;
        // `tracing`'s macros take the level as a constant.
        macro_rules! forward {
            ($level:expr) => {
                tracing::event!(
                    target: "lewis::service", $level,
                    service = %self.name, pid = self.pid, stream = %self.stream,
                    "{}", piece.text
                )
            };
        }
        match level {
            tracing::Level::ERROR => forward!(tracing::Level::ERROR),
            tracing::Level::WARN => forward!(tracing::Level::WARN),
            _ => forward!(tracing::Level::INFO),
        }
        let Some(sink) = &self.sink else { return };
        let line = LogLine {
            name: Arc::clone(&self.name),
            pid: self.pid,
            stream: self.stream,
            text: piece.text,
            continues: piece.continues,
        };
        match sink.try_send(line) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => {
                if self.dropped.fetch_add(1, Ordering::Relaxed) == 0 {
                    tracing::warn!(
                        service = %self.name,
                        "log line channel full: dropping lines (counted) until it drains"
                    );
                }
            }
            // The caller no longer wants lines; tracing still gets them.
            Err(TrySendError::Disconnected(_)) => self.sink = None,
        }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn split(chunks: &[&[u8]], max_line_bytes: usize) -> Vec<Piece> {
        let mut splitter = LineSplitter::new(max_line_bytes);
        let mut pieces = Vec::new();
        for chunk in chunks {
            splitter.push(chunk, &mut |p| pieces.push(p));
        }
        splitter.finish(&mut |p| pieces.push(p));
        pieces
    }

    fn check(chunks: &[&[u8]], max_line_bytes: usize, expected: &[(&str, bool)]) {
        let got = split(chunks, max_line_bytes);
        let got: Vec<(&str, bool)> = got.iter().map(|p| (p.text.as_str(), p.continues)).collect();
        assert_eq!(got, expected);
    }

    #[test]
    fn lines_are_cut_at_newlines_whatever_the_chunks() {
        check(&[b"one\ntwo\n"], 64, &[("one", false), ("two", false)]);
        check(
            &[b"o", b"ne\ntw", b"o\n"],
            64,
            &[("one", false), ("two", false)],
        );
        check(&[b"\n\n"], 64, &[("", false), ("", false)]);
    }

    #[test]
    fn a_last_line_without_newline_is_kept() {
        check(
            &[b"one\npartial"],
            64,
            &[("one", false), ("partial", false)],
        );
    }

    #[test]
    fn crlf_endings_are_stripped() {
        check(&[b"dos\r\nunix\n"], 64, &[("dos", false), ("unix", false)]);
    }

    #[test]
    fn invalid_utf8_becomes_replacement_characters() {
        check(
            &[b"ok \xff\xfe end\n"],
            64,
            &[("ok \u{fffd}\u{fffd} end", false)],
        );
    }

    #[test]
    fn a_long_line_is_split_into_marked_pieces() {
        check(
            &[b"abcdefghij\n"],
            4,
            &[("abcd", true), ("efgh", true), ("ij", false)],
        );
    }

    #[test]
    fn a_split_never_cuts_a_utf8_character() {
        // "aé" is 3 bytes; "€" is 3 bytes: a 4-byte cut would fall inside the euro sign.
        check(&["aé€b\n".as_bytes()], 4, &[("aé", true), ("€b", false)]);
    }

    proptest! {
        #[test]
        fn pieces_do_not_depend_on_how_the_input_is_chunked(
            bytes in proptest::collection::vec(any::<u8>(), 0..300),
            cuts in proptest::collection::vec(any::<usize>(), 0..8),
            max in 4_usize..40,
        ) {
            let mut cuts: Vec<usize> = cuts.iter().map(|c| c % (bytes.len() + 1)).collect();
            cuts.sort_unstable();
            let mut chunks = Vec::new();
            let mut start = 0;
            for cut in cuts {
                chunks.push(&bytes[start..cut]);
                start = cut;
            }
            chunks.push(&bytes[start..]);
            prop_assert_eq!(split(&chunks, max), split(&[&bytes], max));
        }

        #[test]
        fn valid_text_is_reassembled_exactly_and_no_piece_is_too_long(
            text in "[a-zé€\n]{0,200}",
            max in 4_usize..40,
        ) {
            let pieces = split(&[text.as_bytes()], max);
            let mut rebuilt = String::new();
            for piece in &pieces {
                prop_assert!(piece.text.len() <= max);
                rebuilt.push_str(&piece.text);
                if !piece.continues {
                    rebuilt.push('\n');
                }
            }
            let expected = if text.is_empty() || text.ends_with('\n') {
                text.clone()
            } else {
                format!("{text}\n")
            };
            prop_assert_eq!(rebuilt, expected);
        }
    }
}
