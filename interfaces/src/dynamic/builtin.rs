//! Standard ROS 2 definitions used when a schema refers to them without including them.
//!
//! Recorders normally append every dependency after the main text, but some omit the
//! `builtin_interfaces` types, and ROS 2 service event schemas (`pkg/srv/Name_Event`) are
//! stored as the bare service text, whose wire layout wraps the request and response in a
//! `service_msgs/ServiceEventInfo`. These texts are the published ROS 2 definitions; a
//! definition present in the schema text always wins over them.

use super::types::TypeName;

/// The .msg text of a standard type, if it is one of those known here.
pub(crate) fn definition_text(name: &TypeName) -> Option<&'static str> {
    Some(match (name.package.as_str(), name.name.as_str()) {
        ("builtin_interfaces", "Time" | "Duration") => "int32 sec\nuint32 nanosec\n",
        ("std_msgs", "Header") => "builtin_interfaces/Time stamp\nstring frame_id\n",
        // Since ROS 2 Jazzy `client_gid` is `uint8[16]`; Iron had `char[16]`: same bytes.
        ("service_msgs", "ServiceEventInfo") => {
            "uint8 REQUEST_SENT=0\nuint8 REQUEST_RECEIVED=1\nuint8 RESPONSE_SENT=2\n\
             uint8 RESPONSE_RECEIVED=3\nuint8 event_type\nbuiltin_interfaces/Time stamp\n\
             uint8[16] client_gid\nint64 sequence_number\n"
        }
        _ => return None,
    })
}
