//! Answers to calls made to services that are not re-simulated: the recorded
//! `CommandLog`s of the serving service (what it answered live), or, when the recording
//! has none, a default reply of the right type.
//!
//! The book is filled as the reader reads ahead of the virtual clock and forgets answers
//! older than [`MATCH_WINDOW_NS`], so it holds a few seconds of the recording at most.

use std::collections::{BTreeMap, VecDeque};

use lewis_interfaces::cdr::peek_header;
use lewis_interfaces::msg::{CommandLog, CommandLogStatus};

/// A recorded answer is used for a call made up to this long before or after it was given
/// live (the default call timeout: a later answer would have timed out).
pub const MATCH_WINDOW_NS: i64 = 1_000_000_000;

/// Who served which command from whom.
type BookKey = (String, String, String, String);

/// One recorded answer.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Answer {
    log_time_ns: i64,
    result: Result<Vec<u8>, String>,
}

/// The recorded answers of services that are fed from the log, by server, interface,
/// command and caller, each in recorded order.
#[derive(Debug, Clone, Default)]
pub struct CommandBook {
    answers: BTreeMap<BookKey, VecDeque<Answer>>,
    len: usize,
}

impl CommandBook {
    /// An empty book.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the answer `server` gave, as recorded at `log_time_ns` (its replay time).
    pub fn add(&mut self, server: &str, log_time_ns: i64, log: &CommandLog) {
        let caller = header_provider(&log.request);
        let result = if log.status == CommandLogStatus::Ok {
            Ok(log.reply.clone())
        } else {
            Err(log.error.clone())
        };
        self.answers
            .entry((
                server.to_owned(),
                log.interface.clone(),
                log.command.clone(),
                caller,
            ))
            .or_default()
            .push_back(Answer {
                log_time_ns,
                result,
            });
        self.len += 1;
    }

    /// Forgets the answers given more than [`MATCH_WINDOW_NS`] before `now_ns`: answers to
    /// calls the replay did not make.
    pub fn expire(&mut self, now_ns: i64) {
        let oldest = now_ns.saturating_sub(MATCH_WINDOW_NS);
        let mut len = 0;
        self.answers.retain(|_, queue| {
            while queue.front().is_some_and(|a| a.log_time_ns < oldest) {
                queue.pop_front();
            }
            len += queue.len();
            !queue.is_empty()
        });
        self.len = len;
    }

    /// How many answers the book holds.
    #[must_use]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the book is empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The recorded answer to `caller`'s call of `interface.command` on `server` at
    /// `now_ns`: the oldest unused one within [`MATCH_WINDOW_NS`] of now (older ones were
    /// answers to calls the replay did not make).
    pub fn take(
        &mut self,
        server: &str,
        interface: &str,
        command: &str,
        caller: &str,
        now_ns: i64,
    ) -> Option<Result<Vec<u8>, String>> {
        let key = (
            server.to_owned(),
            interface.to_owned(),
            command.to_owned(),
            caller.to_owned(),
        );
        let queue = self.answers.get_mut(&key)?;
        while queue
            .front()
            .is_some_and(|a| a.log_time_ns < now_ns.saturating_sub(MATCH_WINDOW_NS))
        {
            queue.pop_front();
            self.len -= 1;
        }
        if queue
            .front()
            .is_some_and(|a| a.log_time_ns <= now_ns.saturating_add(MATCH_WINDOW_NS))
        {
            self.len -= 1;
            return queue.pop_front().map(|a| a.result);
        }
        None
    }
}

/// The provider named in the header of a CDR message (empty when it has none).
#[must_use]
pub fn header_provider(bytes: &[u8]) -> String {
    peek_header(bytes)
        .map(|header| header.provider)
        .unwrap_or_default()
}

/// The CDR bytes of the reply to `interface.command` with every field at its default
/// (zeros, empty strings, empty sequences), or `None` when the interface or command is
/// unknown.
#[must_use]
pub fn default_reply(interface: &str, command: &str) -> Option<Vec<u8>> {
    lewis_interfaces::interface_info(interface)?.default_reply(command)
}

#[cfg(test)]
mod tests {
    use lewis_interfaces::cdr;
    use lewis_interfaces::msg::{Header, RangeFinderGetGeometry, RangeFinderGetGeometryReply};

    use super::*;

    #[test]
    fn a_default_reply_decodes_as_the_typed_reply_with_default_fields() {
        let bytes = default_reply("RangeFinder", "get_geometry").unwrap();
        let reply: RangeFinderGetGeometryReply = cdr::from_bytes(&bytes).unwrap();
        assert_eq!(reply, RangeFinderGetGeometryReply::default());
        assert_eq!(default_reply("RangeFinder", "explode"), None);
        assert_eq!(default_reply("NoSuchInterface", "get_geometry"), None);
    }

    #[test]
    fn the_provider_of_a_header_is_read_without_decoding_the_rest() {
        let request = RangeFinderGetGeometry {
            header: Header {
                provider: "avoider".into(),
                seq: 3,
                ..Header::default()
            },
        };
        assert_eq!(header_provider(&cdr::to_vec(&request)), "avoider");
        assert_eq!(header_provider(b"junk"), "");
    }

    #[test]
    fn recorded_answers_are_used_in_order_within_the_window() {
        let log = |status: &str, reply: u8| CommandLog {
            interface: "RangeFinder".into(),
            command: "get_geometry".into(),
            request: cdr::to_vec(&RangeFinderGetGeometry {
                header: Header {
                    provider: "app".into(),
                    ..Header::default()
                },
            }),
            status: status.into(),
            reply: vec![reply],
            error: if status == "ok" {
                String::new()
            } else {
                "no".into()
            },
            ..CommandLog::default()
        };
        let mut book = CommandBook::new();
        book.add("laser", 1_000, &log("ok", 1));
        book.add("laser", 2_000, &log("refused", 0));
        book.add("laser", 5_000_000_000, &log("ok", 3));
        let mut take = |now| book.take("laser", "RangeFinder", "get_geometry", "app", now);
        assert_eq!(take(1_500), Some(Ok(vec![1])));
        assert_eq!(take(1_600), Some(Err("no".into())));
        // The next answer was given 5 s later: not an answer to a call made now.
        assert_eq!(take(1_700), None);
        assert_eq!(take(5_000_000_100), Some(Ok(vec![3])));
        assert_eq!(take(6_000_000_000), None);
        assert!(book.is_empty());
    }

    #[test]
    fn answers_nobody_asked_for_are_forgotten_after_the_window() {
        let log = CommandLog {
            interface: "RangeFinder".into(),
            command: "get_geometry".into(),
            status: "ok".into(),
            ..CommandLog::default()
        };
        let mut book = CommandBook::new();
        book.add("laser", 1_000, &log);
        book.add("laser", 3_000_000_000, &log);
        book.expire(2_000_000_000);
        assert_eq!(book.len(), 1);
        book.expire(5_000_000_000);
        assert!(book.is_empty());
    }
}
