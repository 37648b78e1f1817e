//! The frames of commands and replies on a command channel. An interface has several
//! commands but one channel, so a request names its command:
//!
//! - request: `[name length: u8][command name, UTF-8][the command message, CDR]`
//! - reply: `[0][the reply message, CDR]` when the command was carried out,
//!   `[1][the error, UTF-8]` when it was refused.
//!
//! Only the runtime reads and writes these frames; services and clients see typed values.

/// Why a frame could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// The frame is shorter than its own header says.
    #[error("command frame of {len_bytes} bytes is truncated")]
    Truncated {
        /// Its length.
        len_bytes: usize,
    },
    /// The command name is not UTF-8.
    #[error("command name in a frame is not UTF-8")]
    BadName,
    /// The reply's status byte is neither 0 nor 1.
    #[error("reply frame has status byte {0}: expected 0 (ok) or 1 (refused)")]
    BadStatus(u8),
}

/// The length of a request frame for a command name and a message of `message_len` bytes.
/// A name longer than 255 bytes is cut (command names are short identifiers).
#[must_use]
pub fn request_len(command: &str, message_len: usize) -> usize {
    1 + command.len().min(255) + message_len
}

/// Writes the request header into `frame` and returns the part where the message goes.
pub fn write_request<'a>(command: &str, frame: &'a mut [u8]) -> &'a mut [u8] {
    let name = &command.as_bytes()[..command.len().min(255)];
    // `name.len()` is at most 255 by construction.
    frame[0] = u8::try_from(name.len()).unwrap_or(u8::MAX);
    frame[1..=name.len()].copy_from_slice(name);
    &mut frame[1 + name.len()..]
}

/// Encodes a whole request into a new vector.
#[must_use]
pub fn request_to_vec(command: &str, message: &[u8]) -> Vec<u8> {
    let mut frame = vec![0; request_len(command, message.len())];
    write_request(command, &mut frame).copy_from_slice(message);
    frame
}

/// Splits a request frame into its command name and message bytes.
///
/// # Errors
/// When the frame is truncated or the name is not UTF-8.
pub fn read_request(frame: &[u8]) -> Result<(&str, &[u8]), FrameError> {
    let truncated = FrameError::Truncated {
        len_bytes: frame.len(),
    };
    let (&len, rest) = frame.split_first().ok_or(truncated.clone())?;
    let (name, message) = rest.split_at_checked(usize::from(len)).ok_or(truncated)?;
    let name = std::str::from_utf8(name).map_err(|_| FrameError::BadName)?;
    Ok((name, message))
}

/// A reply frame: the reply's bytes, or the refusal's text.
#[must_use]
pub fn reply_to_vec(reply: &Result<Vec<u8>, String>) -> Vec<u8> {
    let (status, body) = match reply {
        Ok(bytes) => (0, bytes.as_slice()),
        Err(text) => (1, text.as_bytes()),
    };
    let mut frame = Vec::with_capacity(1 + body.len());
    frame.push(status);
    frame.extend_from_slice(body);
    frame
}

/// Reads a reply frame: `Ok(message bytes)` or `Err(refusal text)`.
///
/// # Errors
/// When the frame is empty or its status byte is unknown.
pub fn read_reply(frame: &[u8]) -> Result<Result<&[u8], String>, FrameError> {
    match frame.split_first() {
        Some((0, body)) => Ok(Ok(body)),
        Some((1, body)) => Ok(Err(String::from_utf8_lossy(body).into_owned())),
        Some((&status, _)) => Err(FrameError::BadStatus(status)),
        None => Err(FrameError::Truncated { len_bytes: 0 }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_round_trip_and_broken_frames_are_refused() {
        fn check(frame: &[u8], expected: &Result<(&str, &[u8]), FrameError>) {
            assert_eq!(&read_request(frame), expected);
        }
        let frame = request_to_vec("get_geometry", &[1, 2, 3]);
        check(&frame, &Ok(("get_geometry", &[1, 2, 3])));
        check(&request_to_vec("", &[]), &Ok(("", &[])));
        check(&[], &Err(FrameError::Truncated { len_bytes: 0 }));
        check(&[5, b'a'], &Err(FrameError::Truncated { len_bytes: 2 }));
        check(&[1, 0xff], &Err(FrameError::BadName));
    }

    #[test]
    fn replies_round_trip_and_unknown_status_is_refused() {
        let ok = reply_to_vec(&Ok(vec![9, 8]));
        assert_eq!(read_reply(&ok), Ok(Ok(&[9u8, 8][..])));
        let refused = reply_to_vec(&Err("busy".into()));
        assert_eq!(read_reply(&refused), Ok(Err("busy".to_owned())));
        assert_eq!(read_reply(&[7]), Err(FrameError::BadStatus(7)));
        assert_eq!(read_reply(&[]), Err(FrameError::Truncated { len_bytes: 0 }));
    }
}
