//! An interop test that does not trust our own decoder: one message of every generated
//! type goes into an MCAP file (written with the mcap crate), Python's
//! `mcap-ros2-support` decodes each with its own CDR parser and ros2msg reader and
//! compares it field by field with what was written, and `pymcap-cli doctor` checks the
//! file.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;

use lewis_interfaces::idl::{FieldType, Idl, Primitive, StructType};
use lewis_interfaces::msg::*;
use lewis_interfaces::{Struct, cdr};
use lewis_tests::{python_tool, repo_root, run_ok};
use serde_json::{Value, json};

/// Values that exercise the encoding: signs, extremes, unicode; finite floats only, as
/// JSON has no NaN (NaN and infinities are covered by the roundtrip property tests).
struct Filler {
    counter: u64,
}

impl Filler {
    fn next(&mut self) -> u64 {
        self.counter += 1;
        self.counter
    }

    fn primitive(&mut self, p: Primitive) -> Value {
        let n = self.next();
        match p {
            Primitive::Bool => json!(n % 2 == 1),
            Primitive::Byte | Primitive::Char | Primitive::UInt8 => json!((n * 37) % 256),
            Primitive::Int8 => json!(-((n % 128) as i64)),
            Primitive::Int16 => json!(-1000 - n as i64),
            Primitive::UInt16 => json!(60_000 - n),
            Primitive::Int32 => json!(if n.is_multiple_of(3) {
                i64::from(i32::MIN) + n as i64
            } else {
                n as i64 * 7
            }),
            Primitive::UInt32 => json!(u64::from(u32::MAX) - n),
            Primitive::Int64 => json!(-(1_i64 << 62) + n as i64),
            Primitive::UInt64 => json!(u64::MAX - n),
            Primitive::Float32 => json!(f64::from(1.5_f32 * n as f32)),
            Primitive::Float64 => json!(match n % 4 {
                0 => -1.0e300,
                1 => 2.5e-310,
                2 => std::f64::consts::PI * n as f64,
                _ => -0.125,
            }),
            Primitive::String => json!(format!("provider-{n} é 日本 🤖")),
            Primitive::Bytes => json!(
                (0..(n % 5 + 3))
                    .map(|i| (i * 41 + n) % 256)
                    .collect::<Vec<_>>()
            ),
        }
    }

    fn value(&mut self, idl: &Idl, ty: &FieldType) -> Value {
        match ty {
            FieldType::Primitive { primitive, .. } => self.primitive(*primitive),
            FieldType::Struct(name) => self.structure(idl, idl.compound(name).expect("known type")),
        }
    }

    fn structure(&mut self, idl: &Idl, ty: &StructType) -> Value {
        let mut object = serde_json::Map::new();
        // Several arrays may share one count field: one length per count field.
        let mut lengths: BTreeMap<&str, usize> = BTreeMap::new();
        if ty.has_header() {
            object.insert(
                "header".into(),
                self.structure(idl, idl.compound("Header").expect("header")),
            );
        }
        for field in &ty.fields {
            let value = if field.is_array {
                let fresh = (self.next() % 4) as usize;
                let len = match &field.array_size {
                    Some(size) => *lengths.entry(size.as_str()).or_insert(fresh),
                    None => fresh,
                };
                Value::Array((0..len).map(|_| self.value(idl, &field.ty)).collect())
            } else {
                self.value(idl, &field.ty)
            };
            object.insert(field.name.clone(), value);
        }
        // Count fields agree with their arrays, as a well-formed message has them.
        for field in &ty.fields {
            if let Some(size) = &field.array_size {
                let len = object[&field.name].as_array().map_or(0, Vec::len);
                object.insert(size.clone(), json!(len));
            }
        }
        Value::Object(object)
    }
}

struct Case {
    topic: String,
    schema_name: &'static str,
    schema_text: &'static str,
    bytes: Vec<u8>,
    expected: Value,
}

fn case<T: Struct + serde::de::DeserializeOwned + serde::Serialize>(
    idl: &Idl,
    filler: &mut Filler,
) -> Case {
    let short = T::SCHEMA_NAME.rsplit('/').next().unwrap_or_default();
    let ty = idl
        .all_structs()
        .find(|s| s.name == short)
        .expect("type in the IDL");
    let json = filler.structure(idl, ty);
    let value: T = serde_json::from_value(json).unwrap_or_else(|e| panic!("{short}: {e}"));
    value.check_sizes().unwrap();
    Case {
        topic: format!("/interop/{short}"),
        schema_name: T::SCHEMA_NAME,
        schema_text: T::SCHEMA_TEXT,
        bytes: cdr::to_vec(&value),
        // What was written, as our types see it (serde), not as our decoder reads it.
        expected: serde_json::to_value(&value).unwrap(),
    }
}

macro_rules! all_cases {
    ($($ty:ident),* $(,)?) => {
        fn all_cases(idl: &Idl) -> Vec<Case> {
            let mut filler = Filler { counter: 0 };
            vec![$(case::<$ty>(idl, &mut filler)),*]
        }
    };
}

lewis_interfaces::for_each_struct!(all_cases);

fn write_mcap(path: &std::path::Path, cases: &[Case], compression: Option<mcap::Compression>) {
    let file = BufWriter::new(File::create(path).unwrap());
    let mut writer = mcap::WriteOptions::new()
        .profile("ros2")
        .compression(compression)
        .create(file)
        .unwrap();
    for (i, c) in cases.iter().enumerate() {
        let schema = writer
            .add_schema(c.schema_name, "ros2msg", c.schema_text.as_bytes())
            .unwrap();
        let channel = writer
            .add_channel(schema, &c.topic, "cdr", &BTreeMap::new())
            .unwrap();
        let time = 1_000_000_000 + i as u64;
        writer
            .write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: channel,
                    sequence: 1,
                    log_time: time,
                    publish_time: time,
                },
                &c.bytes,
            )
            .unwrap();
    }
    writer.finish().unwrap();
}

#[test]
fn mcap_ros2_support_decodes_every_type_exactly_as_written() {
    let idl = lewis_interfaces::builtin_idl().unwrap();
    let cases = all_cases(&idl);
    assert_eq!(cases.len(), idl.all_structs().count());
    let dir = tempfile::tempdir().unwrap();
    let expected: serde_json::Map<String, Value> = cases
        .iter()
        .map(|c| (c.topic.clone(), c.expected.clone()))
        .collect();
    let expected_path = dir.path().join("expected.json");
    std::fs::write(&expected_path, serde_json::to_vec(&expected).unwrap()).unwrap();
    let script = repo_root().join("tools/python/check_ros2_decode.py");

    for (name, compression) in [
        ("zstd", Some(mcap::Compression::Zstd)),
        ("lz4", Some(mcap::Compression::Lz4)),
        ("none", None),
    ] {
        let path = dir.path().join(format!("every-type-{name}.mcap"));
        write_mcap(&path, &cases, compression);
        let report = run_ok(
            python_tool("python")
                .arg(&script)
                .arg(&path)
                .arg(&expected_path),
        );
        assert!(
            report.contains(&format!("{} messages decoded, 0 mismatches", cases.len())),
            "{report}"
        );
        let doctor = run_ok(python_tool("pymcap-cli").arg("doctor").arg(&path));
        assert!(!doctor.to_lowercase().contains("error"), "{doctor}");
    }

    // The comparison can fail: one wrong value gives exactly one mismatch.
    let mut wrong = expected;
    wrong["/interop/RangeFinder"]["max_range"] = json!(1.25);
    std::fs::write(&expected_path, serde_json::to_vec(&wrong).unwrap()).unwrap();
    let output = python_tool("python")
        .arg(&script)
        .arg(dir.path().join("every-type-zstd.mcap"))
        .arg(&expected_path)
        .output()
        .unwrap();
    let report = String::from_utf8_lossy(&output.stdout);
    assert!(!output.status.success());
    assert!(
        report.contains("/interop/RangeFinder.max_range:"),
        "{report}"
    );
    assert!(
        report.contains(&format!("{} messages decoded, 1 mismatches", cases.len())),
        "{report}"
    );
}
