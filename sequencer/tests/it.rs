//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.
//! Own binaries (see `Cargo.toml`): `interrupt_signal`.

mod check;
mod common;
mod fsm;
mod gui_browser;
mod gui_http;
mod gui_robot;
mod live;
mod message;
mod missions;
mod parse;
mod published;
mod replay;
mod robustness;
mod supervisor_terminal;
mod terminal_keys;
mod up_script;
