//! Lewis viewer: turns a Lewis recording into a Rerun recording. The only crate that
//! depends on `rerun`.
//!
//! Not built yet: this crate holds only what it needs to compile.
