//! Lewis sequencer: the mission script language of the paper, the finite state machine
//! of sub-task programs, and the supervisor's GUI.
//!
//! The pure part: the script parser (`script`), the checker that turns a parsed script into
//! a runnable [`Mission`] (`check`), and the FSM core (`fsm`) that maps events (a program
//! exited, crashed, timed out; the supervisor chose) to decisions (run, restart, recover,
//! ask the supervisor, finish). None of it starts processes or reads a clock.
//!
//! Around it: the live driver (`live`, [`run_mission`]) runs the programs through the
//! runtime's process supervision and feeds the core; every event and decision goes as a
//! [`Record`] to a [`RecordSink`] (`/lewis/sequencer` through the runtime's IPC, as the
//! `Sequencer` interface: `publish`, `message`; a JSON-lines file);
//! the supervisor answers on a page (`gui`) or the terminal (`terminal`); `session` puts
//! these together as `lewis seq run` and `lewis up --script` run a mission; and `replay`
//! feeds recorded events (JSON lines here; from an MCAP recording, `lewis_replay::mission_log`) to a script's
//! FSM to show where it decides differently; `verdict` judges from the records whether a
//! mission succeeded (reaching `stop` through recovery does not count).
//!
//! # The language
//!
//! ```text
//! # The paper's Figure 3, unchanged, plus the extensions.
//! start door
//! restart 3
//! recovery oops
//! use gui
//! env ROBOT=lewis              # for every program
//!
//! state door ./bin/door --speed 0.3 "a quoted arg\n"
//!   action 0 trans sign
//!   timeout 2m                 # 500ms, 30s, 1.5s, 2m, 1h
//!   restart 5                  # this state's own restart limit
//!   env LOG=debug              # this state's programs only
//!
//! include "common.seq"         # relative to this file
//! ```
//!
//! Lines are independent and indentation is free. `restart` and `env` after a `state` line
//! (and before the next `state` or `include` line of the same file) belong to that state;
//! before any `state` line they are global. Programs with a `/` are paths relative to the
//! folder of the file that names them; programs without one are looked up in `PATH`.
//!
//! # Choices the paper leaves open
//!
//! - Without `restart`, the limit is 0: a crash goes straight to recovery.
//! - A crash is a signal, a timeout, a failure to start the program, or an exit code the
//!   state does not list that is 101 (Rust's panic) or 128 and above (the shell's
//!   "killed by signal" convention). Any other unlisted code goes straight to recovery
//!   without restarting. A listed code is always a transition.
//! - The restart count is per visit: a transition into a state (even the same one) starts
//!   again from attempt 1.
//! - Who answers ([`Supervision`]) is decided once, when the mission starts, and recorded:
//!   the page when the script says `use gui` (unless `--no-gui`); otherwise the terminal,
//!   when the sequencer's standard input is one (without `use gui` too: the paper's "the
//!   supervisor chooses" should not depend on having a touch screen); otherwise nobody
//!   (unattended: a service manager, CI, a pipe), which the sequencer says in a log line
//!   at the start. A closed pipe is not a supervisor, so input that is not a terminal is
//!   never read.
//! - The recovery state is restarted on a crash like any other. When it fails (beyond its
//!   limit or on an unlisted code), recovery is not entered again: the supervisor is asked
//!   when someone can answer; unattended, the mission aborts.
//! - Whenever the recovery state exits with a listed code, the supervisor (when someone
//!   can answer) is asked where to resume, the listed target (often `stop`) being the
//!   suggestion (on the terminal, an empty line takes it). Unattended, the listed
//!   transition is followed, and its reason says that nobody could be asked.
//! - A missing `recovery` is a warning: failures then ask the supervisor, or abort when
//!   unattended. States unreachable from `start` are warnings even with `use gui` (where the
//!   supervisor could still choose them), and so are states with no chain of actions to
//!   `stop`.

pub mod check;
pub mod diagnostic;
pub mod fsm;
pub mod gui;
pub mod keys;
pub mod live;
pub mod location;
pub mod message;
pub mod mission;
pub mod publish;
pub mod record;
pub mod replay;
pub mod resolve;
pub mod script;
pub mod session;
pub mod source;
pub mod terminal;
pub mod verdict;

pub use check::{CheckedScript, check_file, check_script, check_with};
pub use diagnostic::{Diagnostic, Diagnostics, Problem, Severity, diagnostic};
pub use fsm::{Decision, Event, EventError, Sequencer, Supervision};
pub use gui::{GuiError, GuiServer, GuiSink};
pub use live::{
    Command, ControlReceiver, Controller, Outcome, RunError, RunOptions, SignalForwarder,
    control_channel, run_mission,
};
pub use location::{Location, Spanned};
pub use message::{MessageError, from_message, to_message};
pub use mission::{Mission, MissionState, Target};
pub use publish::{PublishReport, PublishSink, PublishStartError, Publisher};
pub use record::{ChannelSink, Entry, JsonLinesSink, Record, RecordSink, Tee};
pub use replay::{Comparison, Difference, Recording, compare, read_json_lines, split_missions};
pub use resolve::{ProgramResolver, ResolveError, SystemResolver, TrustingResolver};
pub use script::{Script, parse};
pub use source::{FileSystem, MemorySources, SourceLoader};
pub use terminal::TerminalChooser;
pub use verdict::{Verdict, Visit};
