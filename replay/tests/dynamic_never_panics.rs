//! Property tests of the dynamic decoder of `lewis-interfaces` (here because only this
//! crate has proptest): no schema text and no bytes make it panic, and what a plain CDR
//! writer produces decodes back.

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use lewis_interfaces::dynamic::{Decoder, MessageSchema, Value};
use proptest::prelude::*;

const SCHEMAS: &[(&str, &str)] = &[
    ("std_msgs/msg/String", "string data\n"),
    (
        "rcl_interfaces/msg/ParameterEvent",
        "builtin_interfaces/Time stamp\nstring node\nParameter[] new_parameters\n\
         ================================================================================\n\
         MSG: rcl_interfaces/Parameter\nstring name\nParameterValue value\n\
         ================================================================================\n\
         MSG: rcl_interfaces/ParameterValue\nuint8 type\nbool bool_value\nint64 integer_value\n\
         float64 double_value\nstring string_value\nbyte[] byte_array_value\nbool[] bool_array_value\n\
         int64[] integer_array_value\nfloat64[] double_array_value\nstring[] string_array_value\n",
    ),
    (
        "test_msgs/msg/Mixed",
        "bool[3] flags\nchar c\nfloat32[<=4] few\nwstring<=3 wide\nstring<=5[2] names\n\
         Inner[] inner\nuint16 tail\n===\nMSG: test_msgs/Inner\nint8 a\nfloat64 b\nuint8[] blob\n",
    ),
    ("test_msgs/msg/Empty", ""),
    (
        "example_interfaces/srv/AddTwoInts_Event",
        "int64 a\nint64 b\n---\nint64 sum\n",
    ),
];

fn message_bytes() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        proptest::collection::vec(any::<u8>(), 0..300),
        // Most mutations keep a valid header, so the walk goes past it.
        proptest::collection::vec(any::<u8>(), 0..300).prop_map(|tail| {
            let mut bytes = vec![0, 1, 0, 0];
            bytes.extend(tail);
            bytes
        }),
        proptest::collection::vec(0u8..4, 0..300).prop_map(|tail| {
            let mut bytes = vec![0, 0, 0, 0];
            bytes.extend(tail);
            bytes
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in message_bytes()) {
        for (name, text) in SCHEMAS {
            let decoder = Decoder::new(name, text).unwrap();
            // Errors are fine; a value must have used the bytes up to padding.
            if decoder.decode(&bytes).is_ok() {
                prop_assert!(bytes.len() >= 4);
            }
        }
    }

    #[test]
    fn arbitrary_schema_text_never_panics(
        text in "([a-zA-Z0-9_/<=\\[\\] #\"'=.-]{0,30}\n){0,12}",
        name in "[a-z_]{1,8}(/msg)?/[A-Z][a-z]{0,6}(_Event|_Request)?",
        bytes in message_bytes(),
    ) {
        if let Ok(schema) = MessageSchema::parse(&name, &text)
            && let Ok(decoder) = Decoder::from_schema(&schema)
        {
            let _ = decoder.decode(&bytes);
        }
    }

    #[test]
    fn any_string_round_trips(text in "\\PC{0,40}", big_endian in any::<bool>()) {
        let decoder = Decoder::new("std_msgs/msg/String", "string data\n").unwrap();
        let length = u32::try_from(text.len() + 1).unwrap();
        let mut bytes = if big_endian { vec![0, 0, 0, 0] } else { vec![0, 1, 0, 0] };
        bytes.extend(if big_endian { length.to_be_bytes() } else { length.to_le_bytes() });
        bytes.extend(text.as_bytes());
        bytes.push(0);
        let value = decoder.decode(&bytes).unwrap();
        prop_assert_eq!(value.get("data"), Some(&Value::String(text)));
    }
}
