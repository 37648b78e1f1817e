//! Log output for people, the same in every Lewis process: one line per event with its
//! subject first (`laser: RangeFinder bound to base`), `warning:` and `error:` where they
//! apply, colour only when standard error is a terminal, and quiet by default (`-v` shows
//! the broker's every decision and each process's routine lines, as cargo's `-v` does).
//!
//! A supervised child writes to a pipe, so it never colours its lines; the parent forwards
//! each line under the child's name ([`forwarded_line`]) after stripping any escape codes a
//! program that is not ours may still write. Nothing is ever shown escaped.

use std::fmt;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicU8, Ordering};

use anstyle::{AnsiColor, Style};
use tracing::field::{Field, Visit};
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::EnvFilter;
use tracing_subscriber::fmt::format::Writer;
use tracing_subscriber::fmt::{FmtContext, FormatEvent, FormatFields};
use tracing_subscriber::registry::LookupSpan;

/// The target of a line forwarded from a supervised child; its `service` field names the
/// child.
pub const FORWARDED_TARGET: &str = "lewis::service";

/// The environment variable that passes the parent's verbosity to its children, so that
/// `lewis up -v` makes every service as talkative as the broker.
pub const VERBOSITY_ENV: &str = "LEWIS_VERBOSITY";

/// How much a process says on standard error.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default)]
pub enum Verbosity {
    /// Warnings and errors only (`-q`).
    Quiet,
    /// What a person running the robot wants to see: failures, failovers, restarts,
    /// summaries.
    #[default]
    Normal,
    /// Also the broker's every decision and each process's routine lines (`-v`).
    Verbose,
    /// Also what only a developer needs (`-vv`).
    Trace,
}

impl Verbosity {
    /// Every verbosity, from the quietest.
    pub const ALL: [Self; 4] = [Self::Quiet, Self::Normal, Self::Verbose, Self::Trace];

    /// The verbosity of `-v` given `verbose` times, or of `-q`.
    #[must_use]
    pub fn from_flags(verbose: u8, quiet: bool) -> Self {
        match (quiet, verbose) {
            (true, _) => Self::Quiet,
            (false, 0) => Self::Normal,
            (false, 1) => Self::Verbose,
            (false, _) => Self::Trace,
        }
    }

    /// The verbosity a parent passed down in [`VERBOSITY_ENV`], when it did.
    #[must_use]
    pub fn inherited() -> Option<Self> {
        let value = std::env::var(VERBOSITY_ENV).ok()?;
        Self::ALL.into_iter().find(|v| v.as_env() == value)
    }

    /// This verbosity as the value of [`VERBOSITY_ENV`].
    #[must_use]
    pub fn as_env(self) -> &'static str {
        match self {
            Self::Quiet => "quiet",
            Self::Normal => "normal",
            Self::Verbose => "verbose",
            Self::Trace => "trace",
        }
    }

    fn filter(self) -> &'static str {
        // Targets match by prefix: `lewis` covers every crate of ours.
        match self {
            Self::Quiet => "warn",
            Self::Normal => "warn,lewis=info",
            Self::Verbose => "warn,lewis=debug",
            Self::Trace => "info,lewis=trace",
        }
    }
}

/// The verbosity this process's logs were set up with (what its children inherit).
static CURRENT: AtomicU8 = AtomicU8::new(1);

/// The verbosity [`init`] was given, for a supervisor to pass on to its children.
#[must_use]
pub fn current() -> Verbosity {
    let index = usize::from(CURRENT.load(Ordering::Relaxed));
    Verbosity::ALL[index.min(Verbosity::ALL.len() - 1)]
}

/// Sends this process's `tracing` events to standard error for people. `RUST_LOG`, when
/// set, overrides the filter of `verbosity`. A second call does nothing.
pub fn init(verbosity: Verbosity) {
    CURRENT.store(verbosity as u8, Ordering::Relaxed);
    let filter =
        EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(verbosity.filter()));
    let ansi = colour_wanted(std::io::stderr().is_terminal());
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(ansi)
        .event_format(PeopleFormat { ansi })
        .try_init();
}

/// Whether to colour output going to a terminal or not: never off a terminal, and never
/// when `NO_COLOR` is set (<https://no-color.org>).
fn colour_wanted(terminal: bool) -> bool {
    terminal && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty())
}

/// A line of the child `name` as it is forwarded: without escape codes or the child's own
/// `name: ` subject (the parent puts it first), and with its level read back from the
/// `warning:`/`error:` word that this module's format puts first.
#[must_use]
pub fn forwarded_line(name: &str, text: &str) -> (Level, String) {
    let mut plain = anstream::adapter::strip_str(text).to_string();
    if let Some(rest) = plain.strip_prefix(name).and_then(|r| r.strip_prefix(": ")) {
        plain = rest.to_owned();
    }
    let level = if plain.starts_with("error: ") {
        Level::ERROR
    } else if plain.starts_with("warning: ") {
        Level::WARN
    } else {
        Level::INFO
    };
    (level, plain)
}

/// One line per event: `SUBJECT: [warning: |error: ]message [field=value ...]`.
struct PeopleFormat {
    ansi: bool,
}

impl<S, N> FormatEvent<S, N> for PeopleFormat
where
    S: Subscriber + for<'a> LookupSpan<'a>,
    N: for<'a> FormatFields<'a> + 'static,
{
    fn format_event(
        &self,
        _ctx: &FmtContext<'_, S, N>,
        mut writer: Writer<'_>,
        event: &Event<'_>,
    ) -> fmt::Result {
        let mut fields = Fields::default();
        event.record(&mut fields);
        let forwarded = event.metadata().target() == FORWARDED_TARGET;
        let paint = |style: Style| if self.ansi { style } else { Style::new() };
        if let Some(subject) = &fields.service {
            let bold = paint(Style::new().bold());
            write!(writer, "{bold}{subject}{bold:#}: ")?;
        }
        // A forwarded line already carries its child's level word.
        if !forwarded {
            let word = match *event.metadata().level() {
                Level::ERROR => Some(("error", AnsiColor::Red)),
                Level::WARN => Some(("warning", AnsiColor::Yellow)),
                // `-v` lines need no label: asking for them says what they are.
                Level::INFO | Level::DEBUG | Level::TRACE => None,
            };
            if let Some((word, colour)) = word {
                let style = paint(Style::new().fg_color(Some(colour.into())).bold());
                write!(writer, "{style}{word}{style:#}: ")?;
            }
        }
        write!(writer, "{}", fields.message)?;
        if !forwarded {
            let dim = paint(Style::new().dimmed());
            for (name, value) in &fields.rest {
                // A value the message already says (`started base (pid 7)`) is not repeated.
                if !fields.message.contains(value.as_str()) {
                    write!(writer, " {dim}{name}={value}{dim:#}")?;
                }
            }
        }
        writeln!(writer)
    }
}

/// An event's fields: the message, the subject (a `service` or `subject` field), and the
/// rest in order.
#[derive(Default)]
struct Fields {
    message: String,
    service: Option<String>,
    rest: Vec<(&'static str, String)>,
}

impl Visit for Fields {
    fn record_str(&mut self, field: &Field, value: &str) {
        self.record(field, value.to_owned());
    }

    fn record_debug(&mut self, field: &Field, value: &dyn fmt::Debug) {
        self.record(field, format!("{value:?}"));
    }
}

impl Fields {
    fn record(&mut self, field: &Field, value: String) {
        match field.name() {
            "message" => self.message = value,
            "service" | "subject" => self.service = Some(value),
            // Which pipe a forwarded line came from is noise for a person.
            "stream" => {}
            name => self.rest.push((name, value)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verbosity_flags_map_to_levels_and_survive_the_environment() {
        assert_eq!(Verbosity::from_flags(0, false), Verbosity::Normal);
        assert_eq!(Verbosity::from_flags(1, false), Verbosity::Verbose);
        assert_eq!(Verbosity::from_flags(3, false), Verbosity::Trace);
        assert_eq!(Verbosity::from_flags(2, true), Verbosity::Quiet);
        for v in Verbosity::ALL {
            let found = Verbosity::ALL
                .into_iter()
                .find(|w| w.as_env() == v.as_env());
            assert_eq!(found, Some(v));
        }
    }

    #[test]
    fn forwarded_lines_lose_escape_codes_and_keep_their_level() {
        let (level, text) = forwarded_line(
            "laser",
            "\x1b[1mlaser\x1b[0m: \x1b[33mwarning\x1b[0m: heartbeat late \x1b[2mby=3ms\x1b[0m",
        );
        assert_eq!(level, Level::WARN);
        assert_eq!(text, "warning: heartbeat late by=3ms");
        let (level, text) = forwarded_line("laser", "error: cannot open /dev/ttyS0");
        assert_eq!(level, Level::ERROR);
        assert_eq!(text, "error: cannot open /dev/ttyS0");
        assert_eq!(
            forwarded_line("app", "RangeFinder bound to laser").0,
            Level::INFO
        );
    }

    #[test]
    fn no_colour_off_a_terminal() {
        assert!(!colour_wanted(false));
    }
}
