//! Fuzzes the dynamic decoder: ros2msg schema parsing and CDR decoding.
//!
//! The first byte chooses the mode. Even: one of the schemas of the ROS 2 recordings in
//! `../shared/data/mcap/` decodes the rest as a message (seed the corpus with their
//! messages). Odd: the rest up to the first NUL is schema text, the bytes after it a
//! message, and the first byte also picks the schema name.

#![no_main]

use std::sync::OnceLock;

use lewis_interfaces::dynamic::Decoder;
use libfuzzer_sys::fuzz_target;

static DECODERS: OnceLock<Vec<Decoder>> = OnceLock::new();

const SCHEMAS: &[(&str, &str)] = &[
    ("std_msgs/msg/String", "string data\n"),
    (
        "rcl_interfaces/msg/Log",
        "byte DEBUG=10\nbyte INFO=20\nbuiltin_interfaces/Time stamp\nuint8 level\nstring name\n\
         string msg\nstring file\nstring function\nuint32 line\n\
         ================================================================================\n\
         MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n",
    ),
    (
        "rcl_interfaces/msg/ParameterEvent",
        "builtin_interfaces/Time stamp\nstring node\nParameter[] new_parameters\n\
         Parameter[] changed_parameters\nParameter[] deleted_parameters\n\
         ================================================================================\n\
         MSG: rcl_interfaces/Parameter\nstring name\nParameterValue value\n\
         ================================================================================\n\
         MSG: rcl_interfaces/ParameterValue\nuint8 type\nbool bool_value\nint64 integer_value\n\
         float64 double_value\nstring string_value\nbyte[] byte_array_value\n\
         bool[] bool_array_value\nint64[] integer_array_value\nfloat64[] double_array_value\n\
         string[] string_array_value\n",
    ),
    (
        "test_msgs/msg/Arrays",
        "bool[3] bool_values\nchar[3] char_values\nfloat32[3] float32_values\n\
         uint64[3] uint64_values\nstring[3] string_values\nBasicTypes[3] basic_types_values\n\
         Constants[3] constants_values\nint32 alignment_check\n\
         ================================================================================\n\
         MSG: test_msgs/BasicTypes\nbool bool_value\nbyte byte_value\nfloat32 float32_value\n\
         float64 float64_value\nint16 int16_value\nuint64 uint64_value\n\
         ================================================================================\n\
         MSG: test_msgs/Constants\nint32 X=1\n",
    ),
    (
        "test_msgs/msg/Strings",
        "string string_value\nstring<=22 bounded_string_value\nwstring wide\n\
         wstring<=3 bounded_wide\nstring<=5[<=2] few\n",
    ),
    (
        "example_interfaces/srv/AddTwoInts_Event",
        "int64 a\nint64 b\n---\nint64 sum\n",
    ),
];

const NAMES: &[&str] = &[
    "fuzz/msg/T",
    "fuzz/T",
    "T",
    "fuzz/srv/T_Event",
    "fuzz/srv/T_Request",
    "fuzz/action/T_Feedback",
];

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let choice = usize::from(mode / 2);
    if mode % 2 == 0 {
        let decoders = DECODERS.get_or_init(|| {
            SCHEMAS
                .iter()
                .filter_map(|(name, text)| Decoder::new(name, text).ok())
                .collect()
        });
        assert_eq!(decoders.len(), SCHEMAS.len(), "every fixed schema compiles");
        let _ = decoders[choice % decoders.len()].decode(rest);
        return;
    }
    let split = rest.iter().position(|&b| b == 0).unwrap_or(rest.len());
    let (text, message) = rest.split_at(split);
    let Ok(text) = std::str::from_utf8(text) else {
        return;
    };
    if let Ok(decoder) = Decoder::new(NAMES[choice % NAMES.len()], text) {
        let value = decoder.decode(message.get(1..).unwrap_or_default());
        if let Ok(value) = value {
            // Display walks the whole tree: it must not panic either.
            let _ = value.to_string();
            let _ = format!("{value:#}");
        }
    }
});
