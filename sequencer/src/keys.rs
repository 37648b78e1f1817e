//! The supervisor's keys on the terminal: `y` and `n` answer the robot's Speech provider
//! for the registrar ([`answer_of_key`]), as the page's button does, while the terminal is
//! read key by key; while the sequencer asks where to resume, the terminal reads lines
//! again (the supervisor types a state's name, with echo and line editing).
//!
//! Key by key means the terminal's canonical mode and echo are off, nothing else: Ctrl-C
//! still interrupts (the mission's signal handler stops it cleanly) and output is written
//! as before. The terminal's settings are restored when the [`KeyTerminal`] is dropped,
//! whichever way the mission ends.

use std::io::{self, Read};
use std::os::fd::{AsFd, OwnedFd};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use nix::sys::termios::{self, LocalFlags, SetArg, SpecialCharacterIndices, Termios};

use crate::gui::Answer;

/// The line printed when the robot speaks and the terminal's keys can answer.
pub const KEYS_HINT: &str =
    "press y (registered) or n (not registered) to answer for the registrar";

/// How often a terminal waiting for a key checks whether it should stop or change mode.
const POLL: Duration = Duration::from_millis(100);

/// The answer a key gives: `y` yes (registered), `n` no; `None` for any other key.
#[must_use]
pub fn answer_of_key(key: u8) -> Option<Answer> {
    let (answer, text) = match key {
        b'y' | b'Y' => ("yes", "registered"),
        b'n' | b'N' => ("no", "not registered"),
        _ => return None,
    };
    Some(Answer {
        answer: answer.to_owned(),
        text: text.to_owned(),
    })
}

/// Where the supervisor's bytes come from.
pub trait TerminalInput: Send + 'static {
    /// The next byte typed, `Ok(None)` when the input is over. While `lines()` is true the
    /// terminal reads whole lines (echo and line editing: the supervisor types a state),
    /// else single keys; it is asked again while waiting.
    ///
    /// # Errors
    /// When the input cannot be read.
    fn next_byte(&mut self, lines: &dyn Fn() -> bool) -> io::Result<Option<u8>>;
}

/// A reader's bytes as they come, with no modes (a pipe, a file, a test).
pub struct Plain<R>(pub R);

impl<R: Read + Send + 'static> TerminalInput for Plain<R> {
    fn next_byte(&mut self, _lines: &dyn Fn() -> bool) -> io::Result<Option<u8>> {
        let mut byte = [0u8];
        loop {
            match self.0.read(&mut byte) {
                Ok(0) => return Ok(None),
                Ok(_) => return Ok(Some(byte[0])),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
}

/// A terminal read key by key (see the module's documentation); its settings come back
/// when this is dropped.
pub struct KeyTerminal {
    fd: OwnedFd,
    saved: Termios,
    /// Whether the input is stopped; held while the input changes the terminal's mode, so
    /// that a mode set after the settings came back cannot be.
    stopped: Arc<Mutex<bool>>,
}

impl KeyTerminal {
    /// The standard input, when it is a terminal this process may set (it runs in the
    /// foreground).
    ///
    /// # Errors
    /// When the standard input is no terminal, or this process runs in the background.
    pub fn stdin() -> io::Result<(Self, KeyInput)> {
        let fd = io::stdin().as_fd().try_clone_to_owned()?;
        // A background process that sets the terminal is stopped by SIGTTOU.
        if let Ok(foreground) = nix::unistd::tcgetpgrp(&fd)
            && foreground != nix::unistd::getpgrp()
        {
            return Err(io::Error::other("this process runs in the background"));
        }
        Self::open(fd)
    }

    /// The terminal `fd` (a pseudo-terminal's in tests), read key by key through the
    /// returned input until this is dropped.
    ///
    /// # Errors
    /// When `fd` is no terminal.
    pub fn open(fd: OwnedFd) -> io::Result<(Self, KeyInput)> {
        let saved = termios::tcgetattr(&fd)?;
        let keys = single_key_mode(&saved, true);
        let stopped = Arc::new(Mutex::new(false));
        let input = KeyInput {
            fd: fd.try_clone()?,
            keys,
            lines: saved.clone(),
            in_lines: None,
            stopped: Arc::clone(&stopped),
        };
        Ok((Self { fd, saved, stopped }, input))
    }
}

/// The terminal settings `saved` with line editing and echo off, so that each key comes as
/// it is pressed, unseen; signals (Ctrl-C) still work. With `wait`, a read waits for a key;
/// without, it returns at once with what is there.
#[must_use]
pub fn single_key_mode(saved: &Termios, wait: bool) -> Termios {
    let mut keys = saved.clone();
    keys.local_flags
        .remove(LocalFlags::ICANON | LocalFlags::ECHO);
    keys.control_chars[SpecialCharacterIndices::VMIN as usize] = u8::from(wait);
    keys.control_chars[SpecialCharacterIndices::VTIME as usize] = 0;
    keys
}

/// Stops the input (it returns the end within its 100 ms poll) and restores the settings.
impl Drop for KeyTerminal {
    fn drop(&mut self) {
        let mut stopped = self.stopped.lock().unwrap_or_else(PoisonError::into_inner);
        *stopped = true;
        if let Err(e) = termios::tcsetattr(&self.fd, SetArg::TCSANOW, &self.saved) {
            tracing::warn!("cannot restore the terminal's settings: {e}");
        }
    }
}

/// The bytes of a [`KeyTerminal`], switching its mode as asked.
pub struct KeyInput {
    fd: OwnedFd,
    keys: Termios,
    lines: Termios,
    in_lines: Option<bool>,
    stopped: Arc<Mutex<bool>>,
}

impl TerminalInput for KeyInput {
    fn next_byte(&mut self, lines: &dyn Fn() -> bool) -> io::Result<Option<u8>> {
        loop {
            let lines = lines();
            {
                // Once stopped, the terminal is left as the KeyTerminal restored it.
                let stopped = self.stopped.lock().unwrap_or_else(PoisonError::into_inner);
                if *stopped {
                    return Ok(None);
                }
                if self.in_lines != Some(lines) {
                    let mode = if lines { &self.lines } else { &self.keys };
                    termios::tcsetattr(&self.fd, SetArg::TCSANOW, mode)?;
                    self.in_lines = Some(lines);
                }
            }
            let mut fds = [rustix::event::PollFd::new(
                &self.fd,
                rustix::event::PollFlags::IN,
            )];
            let timeout = rustix::time::Timespec::try_from(POLL).ok();
            match rustix::event::poll(&mut fds, timeout.as_ref()) {
                Ok(0) | Err(rustix::io::Errno::INTR) => continue,
                Ok(_) => {}
                Err(e) => return Err(e.into()),
            }
            let mut byte = [0u8];
            match rustix::io::read(&self.fd, &mut byte) {
                Ok(0) => return Ok(None),
                Ok(_) => return Ok(Some(byte[0])),
                Err(rustix::io::Errno::INTR | rustix::io::Errno::AGAIN) => {}
                Err(e) => return Err(e.into()),
            }
        }
    }
}
