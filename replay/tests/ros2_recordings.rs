//! The dynamic decoder of `lewis-interfaces` on every message of the ROS 2 recordings in
//! `../shared/data/mcap/` (read with the `mcap` crate), with fields checked by hand against
//! the bytes and against Python's `mcap-ros2-support`.

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::PathBuf;

use lewis_interfaces::dynamic::{Decoder, Value};

fn data_file(name: &str) -> PathBuf {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/mcap")
        .join(name);
    assert!(
        path.exists(),
        "missing test data {}: these tests need the ROS 2 recordings of ../shared/data/mcap/ \
         (see ../shared/data/README.md)",
        path.display()
    );
    path
}

/// Every message of the file as (topic, value), in file order. Fails on the first
/// message that does not decode, naming it.
fn decode_all(name: &str) -> Vec<(String, Value)> {
    let bytes = std::fs::read(data_file(name)).unwrap();
    let mut decoders: BTreeMap<u16, Decoder> = BTreeMap::new();
    let mut decoded = Vec::new();
    for (index, message) in mcap::MessageStream::new(&bytes).unwrap().enumerate() {
        let message = message.unwrap();
        let schema = message.channel.schema.as_ref().unwrap();
        assert_eq!(
            (
                schema.encoding.as_str(),
                message.channel.message_encoding.as_str()
            ),
            ("ros2msg", "cdr")
        );
        let decoder = decoders.entry(schema.id).or_insert_with(|| {
            let text = std::str::from_utf8(&schema.data).unwrap();
            Decoder::new(&schema.name, text).unwrap_or_else(|error| panic!("{name}: {error}"))
        });
        let value = decoder.decode(&message.data).unwrap_or_else(|error| {
            panic!(
                "{name}: message {index} on {}: {error}",
                message.channel.topic
            )
        });
        decoded.push((message.channel.topic.clone(), value));
    }
    decoded
}

fn on<'a>(messages: &'a [(String, Value)], topic: &str) -> Vec<&'a Value> {
    messages
        .iter()
        .filter(|(t, _)| t == topic)
        .map(|(_, value)| value)
        .collect()
}

fn text(value: &Value, path: &str) -> String {
    value
        .get(path)
        .and_then(Value::as_str)
        .unwrap_or_else(|| panic!("no string at {path} in {value}"))
        .to_owned()
}

fn int(value: &Value, path: &str) -> i64 {
    value
        .get(path)
        .and_then(Value::as_i64)
        .unwrap_or_else(|| panic!("no integer at {path} in {value}"))
}

#[test]
fn talker_strings_and_log_messages_decode() {
    let messages = decode_all("talker.mcap");
    assert_eq!(messages.len(), 20);
    let strings = on(&messages, "/topic");
    let data: Vec<String> = strings.iter().map(|value| text(value, "data")).collect();
    let expected: Vec<String> = (0..10).map(|n| format!("Hello, world! {n}")).collect();
    assert_eq!(data, expected);
    let logs = on(&messages, "/rosout");
    assert_eq!(logs.len(), 10);
    for (n, log) in logs.iter().enumerate() {
        assert_eq!(text(log, "msg"), format!("Publishing: 'Hello, world! {n}'"));
        assert_eq!(text(log, "name"), "minimal_publisher");
        assert_eq!(text(log, "function"), "operator()");
        assert_eq!(int(log, "level"), 20);
        assert_eq!(int(log, "line"), 38);
    }
    assert_eq!(int(logs[0], "stamp.sec"), 1_585_866_235);
    assert_eq!(int(logs[0], "stamp.nanosec"), 112_130_688);
}

#[test]
fn cdr_test_basic_types_and_arrays_decode() {
    let messages = decode_all("cdr_test_0.mcap");
    assert_eq!(messages.len(), 7);
    let basic = on(&messages, "/test_topic");
    assert_eq!(basic.len(), 3);
    for value in &basic {
        assert_eq!(int(value, "int32_value"), 123);
        assert_eq!(value.get("bool_value"), Some(&Value::Bool(false)));
    }
    let arrays = on(&messages, "/array_topic");
    assert_eq!(arrays.len(), 4);
    let first = arrays[0];
    let strings: Vec<String> = (0..3)
        .map(|i| text(first, &format!("string_values[{i}]")))
        .collect();
    assert_eq!(
        strings,
        ["Complex Hello1", "Complex Hello2", "Complex Hello3"]
    );
    assert_eq!(
        first.get("bool_values").unwrap().to_string(),
        "[true, false, true]"
    );
    assert_eq!(
        first.get("byte_values_default").and_then(Value::as_bytes),
        Some(&[0, 1, 255][..])
    );
    assert_eq!(
        first.get("uint64_values_default").unwrap().to_string(),
        "[0, 1, 18446744073709551615]"
    );
    assert_eq!(
        first.get("float64_values_default").unwrap().to_string(),
        "[3.1415, 0.0, -3.1415]"
    );
    assert_eq!(int(first, "defaults_values[2].int16_value"), -1000);
    assert_eq!(
        first.get("constants_values[0]"),
        Some(&Value::Struct(vec![]))
    );
    assert_eq!(text(first, "string_values_default[1]"), "max value");
    assert_eq!(int(first, "alignment_check"), 0);
}

#[test]
fn rewriter_strings_and_empty_messages_decode() {
    let messages = decode_all("rewriter_b_0.mcap");
    assert_eq!(messages.len(), 75);
    let strings = on(&messages, "c_strings");
    assert_eq!(strings.len(), 50);
    for (n, value) in strings.iter().enumerate() {
        assert_eq!(text(value, "string_value"), format!("stringval{n}"));
        assert_eq!(text(value, "string_value_default3"), "Hello\"world!");
        assert_eq!(text(value, "bounded_string_value_default4"), "Hello'world!");
    }
    let empty = on(&messages, "a_empty");
    assert_eq!(empty.len(), 25);
    assert!(empty.iter().all(|value| **value == Value::Struct(vec![])));
}

#[test]
fn seek_test_bag_counts_one_to_five() {
    let messages = decode_all("test_bag_for_seek_0.mcap");
    let counts: Vec<i64> = messages
        .iter()
        .map(|(_, value)| int(value, "int32_value"))
        .collect();
    assert_eq!(counts, [1, 2, 3, 4, 5]);
}

#[test]
fn parameter_events_and_service_events_decode() {
    let messages = decode_all("topics_and_services.mcap");
    assert_eq!(messages.len(), 13);
    let events = on(&messages, "/parameter_events");
    let names: Vec<String> = events
        .iter()
        .map(|e| text(e, "new_parameters[0].name"))
        .collect();
    assert_eq!(names[0], "use_sim_time");
    assert_eq!(names[4], "qos_overrides./parameter_events.publisher.depth");
    assert_eq!(text(events[0], "node"), "/introspection_client");
    assert_eq!(int(events[0], "new_parameters[0].value.type"), 1);
    assert_eq!(
        text(events[2], "new_parameters[0].value.string_value"),
        "volatile"
    );
    assert_eq!(
        int(events[4], "new_parameters[0].value.integer_value"),
        1000
    );

    // Each call shows up twice: the request as received, then the response as sent.
    let calls = on(&messages, "/add_two_ints/_service_event");
    assert_eq!(calls.len(), 6);
    for (index, pair) in calls.chunks(2).enumerate() {
        let (request, response) = (pair[0], pair[1]);
        let sequence = i64::try_from(index).unwrap() + 1;
        assert_eq!(int(request, "info.sequence_number"), sequence);
        assert_eq!(int(response, "info.sequence_number"), sequence);
        assert_eq!(int(request, "info.event_type"), 1);
        assert_eq!(int(response, "info.event_type"), 2);
        let (a, b) = (int(request, "request[0].a"), int(request, "request[0].b"));
        assert_eq!((a, b), (sequence, 3));
        assert_eq!(int(response, "response[0].sum"), a + b);
        assert_eq!(request.get("response").unwrap().to_string(), "[]");
    }
}
