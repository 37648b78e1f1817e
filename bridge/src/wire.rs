//! What one host's bridge reads from the bytes another host sends it, besides the channels'
//! CDR samples (those cross unread, and their readers decode them): its beat, the orders of
//! the robot host's broker and their answers, and the exits its supervisor reports.
//!
//! All of it comes off the network, so each reader takes any bytes: a peer of another
//! version, or no Lewis bridge at all, gets an error or `None`, never a panic
//! (`bridge/fuzz`, target `bridge_frames`, throws arbitrary bytes at every one).

use lewis_runtime::broker::ExitStatus;
use lewis_runtime::broker::remote::{HostEvent, RemoteStartError};

use crate::session::PROTOCOL;

/// The text of a payload as the bridge reads it: empty when it is not UTF-8, which every
/// reader below refuses as it refuses any other text it does not know.
#[must_use]
pub fn text(payload: &[u8]) -> &str {
    std::str::from_utf8(payload).unwrap_or_default()
}

/// What a host's beat says: `Ok` when it speaks this [`PROTOCOL`], else the version it
/// says (or its text, from a peer that is no Lewis bridge).
///
/// # Errors
/// The beat is of another protocol: what it said, at most 32 characters.
pub fn beat_protocol(said: &str) -> Result<(), String> {
    // Read, not formatted: it runs for every beat heard.
    if said.parse::<u32>() == Ok(PROTOCOL) {
        Ok(())
    } else {
        let said: String = said.chars().take(32).collect();
        Err(if said.is_empty() {
            "unknown".to_owned()
        } else {
            said
        })
    }
}

/// One order of the robot host's broker to another host's supervisor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order<'t> {
    /// `start NAME`.
    Start(&'t str),
    /// `stop NAME`.
    Stop(&'t str),
}

/// The order in `text` (`start NAME`, `stop NAME`).
///
/// # Errors
/// Anything else: why, to answer with.
pub fn parse_order(text: &str) -> Result<Order<'_>, String> {
    match text.split_once(' ') {
        Some(("start", service)) => Ok(Order::Start(service.trim())),
        Some(("stop", service)) => Ok(Order::Stop(service.trim())),
        _ => Err(format!("unknown order `{}`", text.escape_debug())),
    }
}

/// The process id in another host's answer to a start (`ok PID`, `error WHY`).
///
/// # Errors
/// The host refused, or said something else.
pub fn parse_answer(host: &str, text: &str) -> Result<u32, RemoteStartError> {
    match text.split_once(' ') {
        Some(("ok", pid)) => pid
            .trim()
            .parse()
            .map_err(|_| RemoteStartError::Refused(format!("host {host} said `{text}`"))),
        Some(("error", why)) => Err(RemoteStartError::Refused(format!("on {host}: {why}"))),
        _ => Err(RemoteStartError::Refused(format!(
            "host {host} said `{text}`"
        ))),
    }
}

/// `SERVICE code N` or `SERVICE signal N`, as another host's supervisor reports an exit.
#[must_use]
pub fn parse_exit(text: &str) -> Option<HostEvent> {
    let mut words = text.split_whitespace();
    let service = words.next()?.to_owned();
    let how = words.next()?;
    let number: i32 = words.next()?.parse().ok()?;
    let status = match how {
        "code" => ExitStatus::Code(number),
        "signal" => ExitStatus::Signal(number),
        _ => return None,
    };
    Some(HostEvent::Exited { service, status })
}

/// How another host's supervisor reports an exit ([`parse_exit`] reads it).
#[must_use]
pub fn exit_text(service: &str, status: ExitStatus) -> String {
    match status {
        ExitStatus::Code(code) => format!("{service} code {code}"),
        ExitStatus::Signal(signal) => format!("{service} signal {signal}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exits_are_read_as_they_are_written() {
        for status in [ExitStatus::Code(3), ExitStatus::Signal(9)] {
            assert_eq!(
                parse_exit(&exit_text("blobfinder", status)),
                Some(HostEvent::Exited {
                    service: "blobfinder".to_owned(),
                    status
                })
            );
        }
        assert_eq!(parse_exit("blobfinder died"), None);
    }

    #[test]
    fn a_beat_of_another_version_or_of_no_lewis_says_what_it_said() {
        assert_eq!(beat_protocol(&PROTOCOL.to_string()), Ok(()));
        assert_eq!(beat_protocol("99"), Err("99".to_owned()));
        assert_eq!(beat_protocol(""), Err("unknown".to_owned()));
        assert_eq!(beat_protocol(&"x".repeat(1000)).unwrap_err().len(), 32);
        assert_eq!(
            beat_protocol(text(&[0xff, 0xfe])),
            Err("unknown".to_owned())
        );
    }

    #[test]
    fn orders_and_answers_are_read_or_refused() {
        assert_eq!(parse_order("start laser "), Ok(Order::Start("laser")));
        assert_eq!(parse_order("stop laser"), Ok(Order::Stop("laser")));
        assert!(parse_order("reboot now").is_err());
        assert_eq!(parse_answer("nuc", "ok 42"), Ok(42));
        assert!(matches!(
            parse_answer("nuc", "error no such service"),
            Err(RemoteStartError::Refused(why)) if why == "on nuc: no such service"
        ));
        assert!(parse_answer("nuc", "ok -1").is_err());
    }
}
