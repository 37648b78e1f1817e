//! The interface definition language: XML files in the language of the paper (Figure 2),
//! parsed with quick-xml, validated with `file:line:column` diagnostics, and turned into
//! ros2msg schema text and Rust source.
//!
//! This module is compiled twice: into the library (for `lewis idl check` and `lewis idl
//! show` on any folder) and into `build.rs` (to generate the types of `idl/`). So it uses
//! nothing but `std` and `quick_xml`, and refers to its own items with `super::` paths only.

mod diagnostic;
mod load;
mod model;
mod parse;
mod ros2msg;
mod rust;
#[cfg(test)]
mod tests;
mod validate;

pub use diagnostic::{Diagnostic, Diagnostics, Position};
pub use load::{load_dir, load_files, load_sources};
pub use model::{
    AllowedValue, Command, Field, FieldType, HEADER_TYPE, INPUT_REF_TYPE, Idl, Interface, PACKAGE,
    Primitive, StructKind, StructType,
};
pub use ros2msg::schema_text;
pub use rust::generate_rust;
