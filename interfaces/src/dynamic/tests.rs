//! Schema parsing and CDR decoding checked on hand-built schemas and bytes. The ROS 2
//! recordings of `../shared/data/mcap/` are decoded in `replay/tests/`, which reads MCAP.

use super::*;

/// A CDR writer for tests, independent of the decoder: it pads by hand.
struct Cdr {
    bytes: Vec<u8>,
    big_endian: bool,
}

impl Cdr {
    fn little() -> Self {
        Self {
            bytes: vec![0, 1, 0, 0],
            big_endian: false,
        }
    }

    fn big() -> Self {
        Self {
            bytes: vec![0, 0, 0, 0],
            big_endian: true,
        }
    }

    fn align(mut self, size: usize) -> Self {
        while !(self.bytes.len() - 4).is_multiple_of(size) {
            self.bytes.push(0);
        }
        self
    }

    fn raw(mut self, bytes: &[u8]) -> Self {
        self.bytes.extend_from_slice(bytes);
        self
    }

    fn number<const N: usize>(self, little: [u8; N], big: [u8; N]) -> Self {
        let bytes = if self.big_endian { big } else { little };
        self.align(N).raw(&bytes)
    }

    fn u8(self, value: u8) -> Self {
        self.raw(&[value])
    }

    fn u16(self, value: u16) -> Self {
        self.number(value.to_le_bytes(), value.to_be_bytes())
    }

    fn u32(self, value: u32) -> Self {
        self.number(value.to_le_bytes(), value.to_be_bytes())
    }

    fn i32(self, value: i32) -> Self {
        self.number(value.to_le_bytes(), value.to_be_bytes())
    }

    fn i64(self, value: i64) -> Self {
        self.number(value.to_le_bytes(), value.to_be_bytes())
    }

    fn f32(self, value: f32) -> Self {
        self.number(value.to_le_bytes(), value.to_be_bytes())
    }

    fn f64(self, value: f64) -> Self {
        self.number(value.to_le_bytes(), value.to_be_bytes())
    }

    fn string(self, text: &str) -> Self {
        let len = u32::try_from(text.len() + 1).unwrap();
        self.u32(len).raw(text.as_bytes()).u8(0)
    }

    fn done(self) -> Vec<u8> {
        self.bytes
    }
}

fn decode(schema_name: &str, text: &str, bytes: &[u8]) -> Result<Value, DecodeError> {
    Decoder::new(schema_name, text)
        .unwrap_or_else(|error| panic!("{error}"))
        .decode(bytes)
}

fn check_decodes(schema_name: &str, text: &str, bytes: &[u8], expected: &str) {
    match decode(schema_name, text, bytes) {
        Ok(value) => assert_eq!(value.to_string(), expected),
        Err(error) => panic!("{error}"),
    }
}

fn check_decode_error(schema_name: &str, text: &str, bytes: &[u8], expected: &str) {
    match decode(schema_name, text, bytes) {
        Ok(value) => panic!("decoded {value}, expected the error {expected}"),
        Err(error) => assert_eq!(error.to_string(), expected),
    }
}

fn check_schema_error(schema_name: &str, text: &str, expected: &str) {
    match Decoder::new(schema_name, text) {
        Ok(decoder) => panic!("compiled {decoder:?}, expected the error {expected}"),
        Err(error) => assert_eq!(error.to_string(), expected),
    }
}

const BASIC_TYPES: &str = "\
bool bool_value
byte byte_value
char char_value
float32 float32_value
float64 float64_value
int8 int8_value
uint8 uint8_value
int16 int16_value
uint16 uint16_value
int32 int32_value
uint32 uint32_value
int64 int64_value
uint64 uint64_value
";

fn basic_types(cdr: Cdr) -> Vec<u8> {
    cdr.u8(1)
        .u8(0xff)
        .u8(b'A')
        .f32(-1.5)
        .f64(2.25)
        .u8(0x80)
        .u8(200)
        .u16(0x8000)
        .u16(65535)
        .i32(-7)
        .u32(4_000_000_000)
        .i64(i64::MIN)
        .i64(-1)
        .done()
}

const BASIC_TYPES_VALUE: &str = "{bool_value: true, byte_value: 255, char_value: 65, \
    float32_value: -1.5, float64_value: 2.25, int8_value: -128, uint8_value: 200, \
    int16_value: -32768, uint16_value: 65535, int32_value: -7, uint32_value: 4000000000, \
    int64_value: -9223372036854775808, uint64_value: 18446744073709551615}";

#[test]
fn every_primitive_decodes_little_endian_with_natural_alignment() {
    let bytes = basic_types(Cdr::little());
    assert_eq!(bytes.len(), 52);
    check_decodes(
        "test_msgs/msg/BasicTypes",
        BASIC_TYPES,
        &bytes,
        BASIC_TYPES_VALUE,
    );
}

#[test]
fn every_primitive_decodes_big_endian_to_the_same_values() {
    let bytes = basic_types(Cdr::big());
    check_decodes(
        "test_msgs/msg/BasicTypes",
        BASIC_TYPES,
        &bytes,
        BASIC_TYPES_VALUE,
    );
}

#[test]
fn strings_count_their_nul_and_realign_the_next_field() {
    let text = "string a\nuint8 b\nstring c\nfloat64 d\nwstring e\n";
    let bytes = Cdr::little()
        .string("héllo")
        .u8(7)
        .string("")
        .f64(0.5)
        .u32(2)
        .u32(u32::from('é'))
        .u32(u32::from('😀'))
        .done();
    check_decodes(
        "p/T",
        text,
        &bytes,
        r#"{a: "héllo", b: 7, c: "", d: 0.5, e: "é😀"}"#,
    );
}

#[test]
fn arrays_fixed_bounded_and_unbounded_decode_with_bytes_kept_whole() {
    let text = "uint8[3] fixed_bytes\nint16[2] fixed\nfloat64[] empty\nuint8 after\n\
                string[<=2] names\nbyte[] blob\nint32[<=4] bounded\n";
    let bytes = Cdr::little()
        .raw(&[1, 2, 3])
        .u16(5)
        .u16(6)
        .u32(0)
        // An empty float64 sequence does not align, so `after` follows the count directly.
        .u8(9)
        .u32(2)
        .string("a")
        .string("b")
        .u32(2)
        .raw(&[0xde, 0xad])
        .u32(1)
        .i32(-1)
        .done();
    check_decodes(
        "p/T",
        text,
        &bytes,
        r#"{fixed_bytes: [1, 2, 3], fixed: [5, 6], empty: [], after: 9, names: ["a", "b"], blob: [222, 173], bounded: [-1]}"#,
    );
    let value = decode("p/T", text, &bytes).unwrap();
    assert_eq!(
        value.get("blob").and_then(Value::as_bytes),
        Some(&[0xde, 0xad][..])
    );
}

const PARAMETER_EVENT: &str = "\
# The time stamp when this parameter event occurred.
builtin_interfaces/Time stamp
string node
Parameter[] new_parameters
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: rcl_interfaces/Parameter
string name
ParameterValue value
================================================================================
MSG: rcl_interfaces/Parameter
string name
ParameterValue value
================================================================================
MSG: rcl_interfaces/msg/ParameterValue
uint8 type
int64 integer_value
string[] string_array_value
";

#[test]
fn nested_types_resolve_in_their_own_package_and_repeated_sections_are_accepted() {
    let bytes = Cdr::little()
        .i32(10)
        .u32(20)
        .string("/node")
        .u32(1)
        .string("p")
        .u8(2)
        .i64(1000)
        .u32(1)
        .string("x")
        .done();
    check_decodes(
        "rcl_interfaces/msg/ParameterEvent",
        PARAMETER_EVENT,
        &bytes,
        r#"{stamp: {sec: 10, nanosec: 20}, node: "/node", new_parameters: [{name: "p", value: {type: 2, integer_value: 1000, string_array_value: ["x"]}}]}"#,
    );
}

#[test]
fn errors_name_the_field_path_and_the_byte_offset() {
    let bytes = Cdr::little()
        .i32(10)
        .u32(20)
        .string("/node")
        .u32(1)
        .string("p")
        .u8(2)
        .i64(1000)
        .u32(3)
        .done();
    check_decode_error(
        "rcl_interfaces/msg/ParameterEvent",
        PARAMETER_EVENT,
        &bytes,
        "at byte 44 (field `new_parameters[0].value.string_array_value`): \
         length 3 cannot fit in the 0 bytes left",
    );
}

#[test]
fn malformed_bytes_are_reported_not_trusted() {
    let text = "bool flag\nstring<=3 short\nint32[<=2] few\n";
    let check = |bytes: Vec<u8>, expected: &str| check_decode_error("p/T", text, &bytes, expected);
    check(
        vec![0, 1],
        "at byte 0: the message has 2 bytes, fewer than the 4-byte CDR encapsulation header",
    );
    check(
        vec![0, 2, 0, 0, 1],
        "at byte 0: encapsulation 00 02 is not plain CDR (00 01 little-endian or 00 00 big-endian)",
    );
    check(
        Cdr::little().u8(2).done(),
        "at byte 4 (field `flag`): bool byte 0x02 is neither 0 nor 1",
    );
    check(
        Cdr::little().u8(1).u32(u32::MAX).done(),
        "at byte 8 (field `short`): length 4294967295 cannot fit in the 0 bytes left",
    );
    check(
        Cdr::little().u8(1).string("long").u32(0).done(),
        "at byte 12 (field `short`): length 4 exceeds the bound 3 of the schema",
    );
    check(
        Cdr::little().u8(1).u32(2).raw(b"ab").done(),
        "at byte 13 (field `short`): string does not end with a NUL byte",
    );
    check(
        Cdr::little().u8(1).u32(2).raw(&[0xff, 0]).done(),
        "at byte 12 (field `short`): string is not valid UTF-8",
    );
    check(
        Cdr::little().u8(1).string("ab").u32(3).done(),
        "at byte 16 (field `few`): length 3 exceeds the bound 2 of the schema",
    );
    check(
        Cdr::little().u8(1).string("ab").u32(1).raw(&[1, 0]).done(),
        "at byte 16 (field `few`): length 1 cannot fit in the 2 bytes left",
    );
    check(
        Cdr::little().u8(1).string("ab").u32(0).raw(&[0; 4]).done(),
        "at byte 20: 4 bytes are left after the end of the message",
    );
}

#[test]
fn final_padding_to_four_bytes_is_accepted() {
    let padded = Cdr::little().u8(1).raw(&[0, 0, 0]).done();
    check_decodes("p/T", "bool flag\n", &padded, "{flag: true}");
}

#[test]
fn huge_fixed_arrays_fail_before_allocating() {
    check_decode_error(
        "p/T",
        "float64[1000000000000] many\n",
        &Cdr::little().f64(1.0).done(),
        "at byte 4 (field `many`): the message ends early: 8000000000000 more bytes needed, 8 left",
    );
}

#[test]
fn empty_messages_carry_one_placeholder_byte() {
    check_decodes("test_msgs/msg/Empty", "", &[0, 1, 0, 0, 0], "{}");
    check_decode_error(
        "test_msgs/msg/Empty",
        "",
        &[0, 1, 0, 0],
        "at byte 4 (field `structure_needs_at_least_one_member`): the message ends early: \
         1 more bytes needed, 0 left",
    );
}

#[test]
fn service_event_schemas_decode_with_the_ros2_event_layout() {
    // A real /add_two_ints/_service_event message of topics_and_services.mcap (rosbag2).
    let hex = "000100000100000057222e657efd7a25010feb7d3836ae8a00000000000013040000000001000000\
               0000000001000000000000000100000000000000030000000000000000000000";
    let bytes: Vec<u8> = (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
        .collect();
    let value = decode(
        "example_interfaces/srv/AddTwoInts_Event",
        "int64 a\nint64 b\n---\nint64 sum\n",
        &bytes,
    )
    .unwrap();
    assert_eq!(
        value.to_string(),
        "{info: {event_type: 1, stamp: {sec: 1697522263, nanosec: 628817278}, \
         client_gid: [1, 15, 235, 125, 56, 54, 174, 138, 0, 0, 0, 0, 0, 0, 19, 4], \
         sequence_number: 1}, request: [{a: 1, b: 3}], response: []}"
    );
}

#[test]
fn service_halves_decode_by_their_suffix() {
    let text = "int64 a\nint64 b\n---\nint64 sum\n";
    let bytes = Cdr::little().i64(5).done();
    check_decodes(
        "example_interfaces/srv/AddTwoInts_Response",
        text,
        &bytes,
        "{sum: 5}",
    );
    check_schema_error(
        "example_interfaces/srv/AddTwoInts",
        text,
        "ros2msg schema `example_interfaces/srv/AddTwoInts`, line 1: `example_interfaces/AddTwoInts` \
         is a service or action definition (it has `---` lines); only its _Request, _Response, \
         _Event, _Goal, _Result or _Feedback message can be decoded",
    );
}

#[test]
fn header_and_builtin_types_resolve_without_being_defined() {
    let text = "Header header\nbuiltin_interfaces/Duration timeout\n";
    let bytes = Cdr::little()
        .i32(1)
        .u32(2)
        .string("map")
        .i32(3)
        .u32(4)
        .done();
    check_decodes(
        "nav/msg/Goal",
        text,
        &bytes,
        r#"{header: {stamp: {sec: 1, nanosec: 2}, frame_id: "map"}, timeout: {sec: 3, nanosec: 4}}"#,
    );
}

#[test]
fn constants_and_defaults_are_parsed_with_their_types() {
    let text = "\
# comment line
int32 FOO=3 # trailing comment
string NAME=\"x # not a comment\"
uint8 REQUEST_SENT = 0
string<=22 greeting \"Hello'world!\"
int8[3] values [0, 127, -128]
float64 ratio 0.5
";
    let schema = MessageSchema::parse("p/msg/T", text).unwrap();
    let definition = schema.definition(schema.root()).unwrap();
    let constants: Vec<String> = definition
        .constants
        .iter()
        .map(|c| format!("{} {}={}", c.ty, c.name, c.value))
        .collect();
    assert_eq!(
        constants,
        [
            "int32 FOO=3",
            "string NAME=\"x # not a comment\"",
            "uint8 REQUEST_SENT=0"
        ]
    );
    let fields: Vec<String> = definition
        .fields
        .iter()
        .map(|f| {
            let default = f
                .default
                .as_ref()
                .map(ToString::to_string)
                .unwrap_or_default();
            format!("{} {} {default}", f.ty, f.name)
        })
        .collect();
    assert_eq!(
        fields,
        [
            "string<=22 greeting \"Hello'world!\"",
            "int8[3] values [0, 127, -128]",
            "float64 ratio 0.5",
        ]
    );
}

#[test]
fn schema_errors_point_at_the_line() {
    let check = |text: &str, expected: &str| check_schema_error("p/msg/T", text, expected);
    check(
        "int32 a\nFoo b\n",
        "ros2msg schema `p/msg/T`, line 2: field `b` has type `p/Foo`, which is not defined in \
         the schema (add a `MSG: p/Foo` section)",
    );
    check(
        "int32\n",
        "ros2msg schema `p/msg/T`, line 1: cannot read `int32`: expected `TYPE NAME`, \
         `TYPE NAME DEFAULT` or `TYPE NAME=VALUE`",
    );
    check(
        "int32 a\nint32 a\n",
        "ros2msg schema `p/msg/T`, line 2: `a` is defined twice in the same message",
    );
    check(
        "int32[x] a\n",
        "ros2msg schema `p/msg/T`, line 1: `int32[x]` is not a valid type",
    );
    check(
        "int8 a 300\n",
        "ros2msg schema `p/msg/T`, line 1: `300` is not a valid int8 value: out of range -128..=127",
    );
    check(
        "int32 a\n=====\nint32 b\n",
        "ros2msg schema `p/msg/T`, line 3: expected `MSG: package/Type` after the separator \
         line, found `int32 b`",
    );
    check(
        "B b\n===\nMSG: p/B\nint32 x\n===\nMSG: p/B\nint64 x\n",
        "ros2msg schema `p/msg/T`, line 6: `p/B` is defined twice with different contents",
    );
    check(
        "B b\n===\nMSG: p/B\nB[] children\n",
        "ros2msg schema `p/msg/T`: type `p/B` contains itself, so it has no finite encoding",
    );
    check(
        "int32[] A=1\n",
        "ros2msg schema `p/msg/T`, line 1: constant `A` must have a primitive or string type",
    );
    check_schema_error(
        "not a name",
        "",
        "ros2msg schema `not a name`: `not a name` is not a message type name of the form \
         package/msg/Type",
    );
}

#[test]
fn deep_nesting_is_refused_at_compile_time() {
    let mut text = String::from("T0 next\n");
    for depth in 0..100 {
        text.push_str(&format!("===\nMSG: p/T{depth}\nT{} next\n", depth + 1));
    }
    text.push_str("===\nMSG: p/T100\nint32 leaf\n");
    check_schema_error(
        "p/msg/Root",
        &text,
        "ros2msg schema `p/msg/Root`: types are nested more than 64 levels deep",
    );
}

#[test]
fn a_decoder_is_reused_across_messages() {
    let decoder = Decoder::new("std_msgs/msg/String", "string data\n").unwrap();
    assert_eq!(decoder.type_name().to_string(), "std_msgs/String");
    for n in 0..3 {
        let text = format!("Hello, world! {n}");
        let bytes = Cdr::little().string(&text).done();
        let value = decoder.decode(&bytes).unwrap();
        assert_eq!(
            value.get("data").and_then(Value::as_str),
            Some(text.as_str())
        );
    }
}
