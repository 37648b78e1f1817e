//! Lewis interfaces: the XML interface definitions in `idl/`, their parser and
//! validator, the Rust types generated from them at build time, the ROS 2 CDR codec,
//! the ros2msg schema text, and a schema-driven dynamic decoder for tools.
//!
//! This crate is the only one that knows the wire encoding. It knows nothing of
//! processes, shared memory or MCAP files.

pub mod dynamic;
