//! A schema-driven decoder: any ros2msg schema text plus CDR bytes to a value tree.
//!
//! For tools (`lewis info`, replay reports) that meet messages whose types were not
//! compiled in, such as foreign ROS 2 recordings. [`MessageSchema::parse`] reads the
//! schema text as MCAP's `ros2msg` encoding stores it (main text, then `MSG:` sections);
//! [`Decoder`] compiles it once and turns each CDR message into a [`Value`].
//!
//! ```
//! use lewis_interfaces::dynamic::{Decoder, Value};
//!
//! let decoder = Decoder::new("std_msgs/msg/String", "string data\n")?;
//! let message = [0, 1, 0, 0, 3, 0, 0, 0, b'h', b'i', 0];
//! let value = decoder.decode(&message)?;
//! assert_eq!(value.get("data"), Some(&Value::String("hi".into())));
//! assert_eq!(value.to_string(), r#"{data: "hi"}"#);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Unqualified type names resolve in the package of the text that uses them; a bare
//! `Header` is `std_msgs/Header`. Service event schemas (`pkg/srv/Name_Event`, stored by
//! rosbag2 as the service text with its `---`) decode with the ROS 2 event layout.
//! Standard types a schema uses without defining (`builtin_interfaces/Time`,
//! `builtin_interfaces/Duration`, `std_msgs/Header`, `service_msgs/ServiceEventInfo`)
//! take their published ROS 2 definitions.

mod builtin;
mod cdr;
mod diff;
mod error;
mod literal;
mod plan;
mod schema;
mod type_hash;
mod types;
mod value;

#[cfg(test)]
mod tests;

pub use diff::{CompareOptions, LargestDifference};
pub use error::{DecodeError, DecodeErrorKind, SchemaError, SchemaErrorKind};
pub use plan::{Decoder, MAX_NESTING_DEPTH};
pub use schema::MessageSchema;
pub use type_hash::type_hash;
pub use types::{
    ArrayKind, BaseType, ConstantDef, FieldDef, FieldType, MessageDefinition, Primitive, TypeName,
};
pub use value::{Value, ValueDisplay};
