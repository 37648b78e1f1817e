//! Encode then decode is the identity for every generated type.
//!
//! Random messages are made as CDR bytes by a generator that walks the IDL model (not
//! the generated code), with NaNs, infinities, subnormals, non-ASCII strings, empty and
//! large arrays. Each generated type must decode those bytes and encode them back to
//! exactly the same bytes.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

use lewis_interfaces::cdr::{self, DecodeError, EncodeError, ViewToOwned};
use lewis_interfaces::idl::{self, FieldType, Idl, Primitive, StructType};
use lewis_interfaces::msg::*;
use lewis_interfaces::{InPlace, Interface, Message, Struct};
use proptest::prelude::*;

/// A small deterministic generator: splitmix64.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
}

/// Writes CDR the simple way, with alignment relative to the payload start.
struct Writer {
    out: Vec<u8>,
}

impl Writer {
    fn align(&mut self, n: usize) {
        while !(self.out.len() - 4).is_multiple_of(n) {
            self.out.push(0);
        }
    }
    fn number(&mut self, bytes: &[u8]) {
        self.align(bytes.len());
        self.out.extend_from_slice(bytes);
    }
}

fn float64(rng: &mut Rng) -> f64 {
    match rng.below(10) {
        0 => f64::NAN,
        1 => f64::from_bits(0x7FF4_0000_0000_0001), // a NaN with a payload
        2 => f64::INFINITY,
        3 => f64::NEG_INFINITY,
        4 => -0.0,
        5 => f64::MIN_POSITIVE / 2.0,
        _ => f64::from_bits(rng.next()),
    }
}

fn string(rng: &mut Rng) -> String {
    const PIECES: &[&str] = &[
        "a", "Z", " ", "laser", "é", "日本", "🤖", "\u{7f}", "ß", "\t",
    ];
    let n = if rng.below(8) == 0 { 200 } else { rng.below(6) };
    (0..n)
        .map(|_| PIECES[rng.below(PIECES.len() as u64) as usize])
        .collect()
}

fn array_len(rng: &mut Rng, big: bool) -> usize {
    match rng.below(6) {
        0 => 0,
        1 if big => 2_000 + rng.below(3_000) as usize,
        _ => rng.below(5) as usize,
    }
}

fn primitive(w: &mut Writer, rng: &mut Rng, p: Primitive) {
    match p {
        Primitive::Bool => w.out.push(u8::from(rng.below(2) == 1)),
        Primitive::Byte | Primitive::Char | Primitive::UInt8 | Primitive::Int8 => {
            w.out.push(rng.next() as u8);
        }
        Primitive::Int16 | Primitive::UInt16 => w.number(&(rng.next() as u16).to_le_bytes()),
        Primitive::Int32 | Primitive::UInt32 => w.number(&(rng.next() as u32).to_le_bytes()),
        Primitive::Int64 | Primitive::UInt64 => w.number(&rng.next().to_le_bytes()),
        Primitive::Float32 => {
            let bits = if rng.below(3) == 0 {
                f32::NAN.to_bits()
            } else {
                rng.next() as u32
            };
            w.number(&bits.to_le_bytes());
        }
        Primitive::Float64 => w.number(&float64(rng).to_le_bytes()),
        Primitive::String => {
            let s = string(rng);
            w.number(&(s.len() as u32 + 1).to_le_bytes());
            w.out.extend_from_slice(s.as_bytes());
            w.out.push(0);
        }
        Primitive::Bytes => {
            let n = if rng.below(4) == 0 {
                921_600
            } else {
                rng.below(9) as usize
            };
            w.number(&(n as u32).to_le_bytes());
            w.out.extend((0..n).map(|i| (i as u8).wrapping_mul(31)));
        }
    }
}

fn value(idl: &Idl, w: &mut Writer, rng: &mut Rng, ty: &FieldType) {
    match ty {
        FieldType::Primitive { primitive: p, .. } => primitive(w, rng, *p),
        FieldType::Struct(name) => structure(idl, w, rng, idl.compound(name).unwrap()),
    }
}

fn structure(idl: &Idl, w: &mut Writer, rng: &mut Rng, ty: &StructType) {
    if ty.has_header() {
        structure(idl, w, rng, idl.compound("Header").unwrap());
    }
    for field in &ty.fields {
        if field.is_array {
            let big = matches!(field.ty, FieldType::Primitive { .. });
            let n = array_len(rng, big);
            w.number(&(n as u32).to_le_bytes());
            for _ in 0..n {
                value(idl, w, rng, &field.ty);
            }
        } else {
            value(idl, w, rng, &field.ty);
        }
    }
}

fn random_message(idl: &Idl, ty: &StructType, seed: u64) -> Vec<u8> {
    let mut w = Writer {
        out: cdr::ENCAPSULATION_LE.to_vec(),
    };
    structure(idl, &mut w, &mut Rng(seed), ty);
    w.out
}

fn check_roundtrip<T: Struct + InPlace>(idl: &Idl, seed: u64) {
    let ty = idl
        .all_structs()
        .find(|s| format!("lewis_interfaces/msg/{}", s.name) == T::SCHEMA_NAME)
        .unwrap_or_else(|| panic!("{} is not in the IDL", T::SCHEMA_NAME));
    let bytes = random_message(idl, ty, seed);
    let value: T = cdr::from_bytes(&bytes).unwrap_or_else(|e| panic!("{}: {e}", T::SCHEMA_NAME));
    assert_eq!(
        cdr::to_vec(&value),
        bytes,
        "{} re-encodes differently",
        T::SCHEMA_NAME
    );
    assert_eq!(cdr::encoded_len(&value), bytes.len());

    let mut exact = vec![0xAA; bytes.len()];
    assert_eq!(cdr::encode_into(&value, &mut exact), Ok(bytes.len()));
    assert_eq!(exact, bytes);
    let mut short = vec![0; bytes.len() - 1];
    assert_eq!(
        cdr::encode_into(&value, &mut short),
        Err(EncodeError::BufferTooSmall {
            needed: bytes.len(),
            available: bytes.len() - 1
        })
    );
    // The zero-copy view reads the same value in place.
    let view = T::view(&bytes).unwrap_or_else(|e| panic!("{} view: {e}", T::SCHEMA_NAME));
    assert_eq!(
        cdr::to_vec(&view.to_owned_value()),
        bytes,
        "{}'s view reads another value",
        T::SCHEMA_NAME
    );
    // Written in place over stale bytes, its arrays filled afterwards, it is the same
    // message: the generated shape and writer leave room for exactly the arrays they fill.
    let lens = value.bulk_lens();
    assert_eq!(cdr::in_place_len(&value, &lens), bytes.len());
    // Random counts rarely match their size fields: both checks must agree on that.
    assert_eq!(value.check_shape(&lens), value.check_sizes());
    let mut loan = vec![0xA5; bytes.len()];
    let bulk = cdr::encode_in_place(&value, &lens, &mut loan)
        .unwrap_or_else(|e| panic!("{} in place: {e}", T::SCHEMA_NAME));
    value.write_bulk(bulk);
    assert_eq!(loan, bytes, "{} written in place differs", T::SCHEMA_NAME);
    assert!(cdr::encode_in_place(&value, &lens, &mut loan[..bytes.len() - 1]).is_err());
    // Every truncation is an error or (within the tolerated padding) the same value, and
    // the view agrees with the decoder on which, and on the error.
    for cut in [1, 2, 3, 4, 5, 9, bytes.len() / 2, bytes.len() - 4] {
        let cut_bytes = &bytes[..bytes.len().saturating_sub(cut)];
        let decoded: Result<T, DecodeError> = cdr::from_bytes(cut_bytes);
        let viewed = T::view(cut_bytes).map(|v| v.to_owned_value());
        match (decoded, viewed) {
            (Ok(d), Ok(v)) => assert_eq!(cdr::to_vec(&d), cdr::to_vec(&v)),
            (Err(d), Err(v)) => assert_eq!(d, v, "{} cut by {cut}", T::SCHEMA_NAME),
            (d, v) => panic!(
                "{} cut by {cut}: decode {:?} but view {:?}",
                T::SCHEMA_NAME,
                d.err(),
                v.err()
            ),
        }
    }
}

macro_rules! every_type {
    ($($ty:ident),* $(,)?) => {
        const TYPE_NAMES: &[&str] = &[$(stringify!($ty)),*];
        fn roundtrip_all(idl: &Idl, seed: u64) {
            $(check_roundtrip::<$ty>(idl, seed);)*
        }
    };
}

lewis_interfaces::for_each_struct!(every_type);

fn shipped() -> Idl {
    idl::load_dir(&Path::new(env!("CARGO_MANIFEST_DIR")).join("idl")).unwrap()
}

#[test]
fn the_roundtrip_covers_every_generated_type() {
    let idl = shipped();
    let mut all: Vec<&str> = idl.all_structs().map(|s| s.name.as_str()).collect();
    let mut listed = TYPE_NAMES.to_vec();
    all.sort_unstable();
    listed.sort_unstable();
    assert_eq!(listed, all, "add the new types to every_type!");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn decode_then_encode_gives_the_same_bytes_for_every_type(seed in any::<u64>()) {
        roundtrip_all(&shipped(), seed);
    }

    #[test]
    fn range_finder_survives_encode_then_decode(
        ranges in prop::collection::vec(prop_oneof![any::<f64>(), Just(f64::NAN), Just(f64::INFINITY)], 0..800),
        provider in "\\PC{0,20}",
        seq in any::<u64>(),
    ) {
        let scan = RangeFinder {
            header: Header { provider, seq, publish_time_ns: -5, inputs: vec![InputRef { channel: "égo".into(), seq: 3 }] },
            range_count: ranges.len() as i32,
            sensor_positions: vec![Pose3D::default(); ranges.len()],
            ranges,
            max_range: 8.191,
            uniform: true,
            ..Default::default()
        };
        scan.check_sizes().unwrap();
        let bytes = cdr::to_vec(&scan);
        let back: RangeFinder = cdr::from_bytes(&bytes).unwrap();
        // NaN != NaN, so compare the bits through the encoding.
        prop_assert_eq!(cdr::to_vec(&back), bytes);
        prop_assert_eq!(back.header(), scan.header());
    }

    #[test]
    fn arbitrary_bytes_never_panic_the_typed_decoder(bytes in prop::collection::vec(any::<u8>(), 0..256)) {
        let mut framed = cdr::ENCAPSULATION_LE.to_vec();
        framed.extend_from_slice(&bytes);
        let _ = cdr::from_bytes::<RangeFinder>(&framed);
        let _ = cdr::from_bytes::<Blobs3D>(&framed);
        let _ = cdr::from_bytes::<ImageSource>(&framed);
        let _ = cdr::from_bytes::<Signs>(&bytes);
        // The views agree with the decoder on what is valid.
        prop_assert_eq!(RangeFinder::view(&framed).err(), cdr::from_bytes::<RangeFinder>(&framed).err());
        prop_assert_eq!(Blobs3D::view(&framed).err(), cdr::from_bytes::<Blobs3D>(&framed).err());
        prop_assert_eq!(Signs::view(&bytes).err(), cdr::from_bytes::<Signs>(&bytes).err());
    }

    #[test]
    fn a_scan_written_in_place_from_a_template_without_arrays_is_the_scan(
        ranges in prop::collection::vec(any::<f64>(), 0..500),
        provider in "\\PC{0,20}",
    ) {
        let scan = RangeFinder {
            header: Header { provider, seq: 4, publish_time_ns: 77, inputs: vec![] },
            range_count: ranges.len() as i32,
            sensor_positions: (0..ranges.len()).map(|i| Pose3D { y: i as f64, ..Pose3D::default() }).collect(),
            ranges: ranges.clone(),
            uniform: true,
            ..Default::default()
        };
        // What a publisher holds: the small fields, no arrays; their lengths apart.
        let template = RangeFinder { ranges: vec![], sensor_positions: vec![], ..scan.clone() };
        let lens = RangeFinderBulkLens { ranges: ranges.len(), sensor_positions: ranges.len() };
        prop_assert!(template.check_sizes().is_err() || ranges.is_empty());
        template.check_shape(&lens).unwrap();
        let mut loan = vec![0xFF; cdr::in_place_len(&template, &lens)];
        let mut bulk = cdr::encode_in_place(&template, &lens, &mut loan).unwrap();
        prop_assert_eq!(bulk.ranges.fill_from(ranges.iter().copied()), ranges.len());
        for i in 0..ranges.len() {
            let pose = Pose3D { y: i as f64, ..Pose3D::default() };
            prop_assert!(bulk.sensor_positions.set(i, &pose));
        }
        prop_assert_eq!(loan, cdr::to_vec(&scan));
        // Lengths that disagree with range_count are refused, as check_sizes refuses them.
        let wrong = RangeFinderBulkLens { ranges: ranges.len() + 1, ..lens };
        prop_assert!(template.check_shape(&wrong).is_err());
    }

    #[test]
    fn a_scan_read_in_place_has_the_fields_it_was_given(
        ranges in prop::collection::vec(any::<f64>(), 0..500),
        provider in "\\PC{0,20}",
    ) {
        let scan = RangeFinder {
            header: Header { provider: provider.clone(), seq: 4, publish_time_ns: 77, inputs: vec![InputRef { channel: "/x".into(), seq: 9 }] },
            range_count: ranges.len() as i32,
            sensor_positions: (0..ranges.len()).map(|i| Pose3D { x: i as f64, psi: -(i as f64), ..Pose3D::default() }).collect(),
            ranges: ranges.clone(),
            max_range: 8.191,
            ..Default::default()
        };
        let bytes = cdr::to_vec(&scan);
        let view = RangeFinder::view(&bytes).unwrap();
        prop_assert_eq!(view.header.provider, provider.as_str());
        prop_assert_eq!(view.header.inputs.iter().map(|i| (i.channel, i.seq)).collect::<Vec<_>>(), vec![("/x", 9)]);
        prop_assert_eq!(view.ranges.len(), ranges.len());
        for (i, r) in ranges.iter().enumerate() {
            prop_assert_eq!(view.ranges.get(i).unwrap().to_bits(), r.to_bits());
            prop_assert_eq!(view.sensor_positions.get(i).unwrap(), scan.sensor_positions[i].clone());
        }
        prop_assert!(view.ranges.get(ranges.len()).is_none());
        prop_assert_eq!(view.max_range, 8.191);
    }
}

#[test]
fn a_count_larger_than_the_message_is_an_error_not_an_allocation() {
    let mut bytes = cdr::to_vec(&RangeFinder::default());
    // The header's provider string length is at offset 4: claim 4 GiB.
    bytes[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    let err = cdr::from_bytes::<RangeFinder>(&bytes).unwrap_err();
    assert_eq!(
        err.to_string(),
        "message truncated: 4294967295 bytes needed, 148 left at byte 8 in field `header.provider`"
    );
    let mut bytes = cdr::to_vec(&Blobs::default());
    let at = bytes.len() - 4;
    bytes[at..].copy_from_slice(&(u32::MAX / 2).to_le_bytes());
    let err = cdr::from_bytes::<Blobs>(&bytes).unwrap_err();
    assert_eq!(
        err.to_string(),
        "sequence of 2147483647 elements cannot fit in the 0 bytes left at byte 48 in field `blobs`"
    );
}

#[test]
fn a_wrong_size_field_is_reported_by_check_sizes() {
    let scan = RangeFinder {
        range_count: 3,
        ranges: vec![1.0, 2.0],
        ..Default::default()
    };
    assert_eq!(
        scan.check_sizes().unwrap_err().to_string(),
        "`RangeFinder.ranges` has 2 elements but `RangeFinder.range_count` says 3"
    );
}

#[test]
fn commands_decode_by_name_and_unknown_names_list_the_valid_ones() {
    use lewis_interfaces::CommandSet;
    let goto = MoverGoto {
        x: 1.5,
        y: -2.0,
        ..Default::default()
    };
    let bytes = cdr::to_vec(&goto);
    let decoded = <Mover as Interface>::Command::decode("goto", &bytes).unwrap();
    assert_eq!(decoded, MoverCommand::Goto(goto));
    assert_eq!(decoded.name(), "goto");
    let err = <Mover as Interface>::Command::decode("fly", &bytes).unwrap_err();
    assert_eq!(
        err.to_string(),
        "interface `Mover` has no command `fly`; it has: goto, rotate, translate, stop"
    );
}

#[test]
fn a_known_message_has_the_bytes_ros2_would_write() {
    // Hand-computed: header (empty provider, seq 7, time 9, no inputs), then x, y.
    let goto = MoverGoto {
        header: Header {
            provider: String::new(),
            seq: 7,
            publish_time_ns: 9,
            inputs: vec![],
        },
        x: 1.0,
        y: 2.0,
    };
    let expected: Vec<u8> = [
        &[0, 1, 0, 0][..],
        &[1, 0, 0, 0, 0], // provider: length 1, NUL
        &[0, 0, 0],       // pad to 8
        &7u64.to_le_bytes(),
        &9i64.to_le_bytes(),
        &[0, 0, 0, 0], // inputs: empty
        &[0, 0, 0, 0], // pad to 8
        &1.0f64.to_le_bytes(),
        &2.0f64.to_le_bytes(),
    ]
    .concat();
    assert_eq!(cdr::to_vec(&goto), expected);
}
