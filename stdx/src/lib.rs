//! Small things that every Lewis crate needs and `std` lacks, each written once: where a
//! byte offset is in a file people wrote ([`line_column`]), the one `file:line:column`
//! finding about such a file and its list printer ([`Diagnostic`], [`Diagnostics`]), what
//! a misspelt word probably meant ([`closest`]), and durations as people type them
//! (`500ms`, `8s`, `1.5s`, `2m`: [`parse_duration_ns`]), a process's peak memory
//! ([`peak_resident_kib`]), and the header of a world folder's `world.toml` that every
//! display of the map reads ([`world`]).
//!
//! It depends on nothing of Lewis, so the interface compiler's build script can use it too.

pub mod diagnostic;
mod duration;
mod memory;
mod position;
mod suggest;
pub mod world;

pub use diagnostic::{Diagnostic, Diagnostics, Position, Severity};
pub use duration::{DurationError, format_duration_ns, parse_duration, parse_duration_ns};
pub use memory::peak_resident_kib;
pub use position::line_column;
pub use suggest::{closest, is_close};
