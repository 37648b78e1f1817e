//! The IDL compiler on the shipped definitions and on deliberately broken ones.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

use expect_test::{Expect, expect};
use lewis_interfaces::idl::{self, FieldType};

fn shipped() -> idl::Idl {
    idl::load_dir(&Path::new(env!("CARGO_MANIFEST_DIR")).join("idl")).expect("shipped IDL is valid")
}

/// Loads a folder and renders its diagnostics with paths relative to the crate.
fn diagnostics_of(dir: &Path) -> String {
    let err = idl::load_dir(dir).expect_err("the folder holds broken definitions");
    let root = format!("{}/", env!("CARGO_MANIFEST_DIR"));
    err.to_string().replace(&root, "")
}

fn check_file(name: &str, xml: &str, expected: &Expect) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("idl/types.xml"),
        dir.path().join("types.xml"),
    )
    .unwrap();
    std::fs::write(dir.path().join(name), xml).unwrap();
    let err = idl::load_dir(dir.path()).expect_err("broken definition");
    let prefix = format!("{}/", dir.path().display());
    expected.assert_eq(&err.to_string().replace(&prefix, ""));
}

#[test]
fn every_interface_of_the_paper_is_defined() {
    let idl = shipped();
    let names: Vec<&str> = idl.interfaces.iter().map(|i| i.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "Blobs",
            "Blobs3D",
            "Broker",
            "CameraControl",
            "Clock",
            "CommandLog",
            "Distance",
            "Egomotion",
            "GroundTruth",
            "Health",
            "HostLink",
            "ImageSource",
            "LogLine",
            "Mover",
            "Power",
            "ProcessCpu",
            "RangeFinder",
            "RecorderStats",
            "Sequencer",
            "Signs",
            "Speech",
            "Synchrodrive",
            "UnansweredCall",
            "WorldState"
        ]
    );
    // The system interfaces and the simulator's truth are records; the paper's all take
    // commands.
    let system = [
        "Clock",
        "CommandLog",
        "GroundTruth",
        "Health",
        "HostLink",
        "LogLine",
        "ProcessCpu",
        "RecorderStats",
        "Sequencer",
        "UnansweredCall",
        "WorldState",
    ];
    for interface in idl
        .interfaces
        .iter()
        .filter(|i| !system.contains(&i.name.as_str()))
    {
        assert!(
            !interface.commands.is_empty(),
            "{} has no command",
            interface.name
        );
    }
    let mover = idl.interface("Mover").unwrap();
    let commands: Vec<&str> = mover.commands.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(commands, ["goto", "rotate", "translate", "stop"]);
}

#[test]
fn range_finder_has_exactly_the_fields_of_the_papers_figure_2() {
    let idl = shipped();
    let rf = idl.interface("RangeFinder").unwrap();
    let fields: Vec<String> = rf
        .publication
        .fields
        .iter()
        .map(|f| {
            let ty = match &f.ty {
                FieldType::Primitive { idl_name, .. } => idl_name.clone(),
                FieldType::Struct(name) => name.clone(),
            };
            match &f.array_size {
                Some(size) => format!("{} {ty}[{size}]", f.name),
                None => format!("{} {ty}", f.name),
            }
        })
        .collect();
    expect![[r#"
        range_count Integer
        ranges Float[range_count]
        max_range Float
        uniform Boolean
        sensor_positions Pose3D[range_count]
        x_offset Float
        y_offset Float
        z_offset Float
        theta_offset Float
        phi_offset Float
        psi_offset Float
        x_separation Float
        y_separation Float
        z_separation Float
        theta_separation Float
        phi_separation Float
        psi_separation Float"#]]
    .assert_eq(&fields.join("\n"));
}

#[test]
fn ros2msg_schema_appends_dependencies_as_ros2_does() {
    let idl = shipped();
    let rf = idl.interface("Blobs3D").unwrap();
    expect![[r#"
        lewis_interfaces/Header header
        int32 blob_count
        lewis_interfaces/Blob3D[] blobs
        ================================================================================
        MSG: lewis_interfaces/Header
        string provider
        uint64 seq
        int64 publish_time_ns
        lewis_interfaces/InputRef[] inputs
        ================================================================================
        MSG: lewis_interfaces/InputRef
        string channel
        uint64 seq
        ================================================================================
        MSG: lewis_interfaces/Blob3D
        lewis_interfaces/Blob blob
        bool range_valid
        lewis_interfaces/Point3D position
        float64 width
        float64 height
        ================================================================================
        MSG: lewis_interfaces/Blob
        int32 colour_index
        string colour_name
        uint32 colour_rgb
        int32 area
        float64 centroid_x
        float64 centroid_y
        int32 left
        int32 top
        int32 right
        int32 bottom
        ================================================================================
        MSG: lewis_interfaces/Point3D
        float64 x
        float64 y
        float64 z
    "#]]
    .assert_eq(&idl::schema_text(&idl, &rf.publication));
}

#[test]
fn generated_catalogue_matches_the_xml() {
    let idl = shipped();
    assert_eq!(
        lewis_interfaces::msg::INTERFACES.len(),
        idl.interfaces.len()
    );
    for (info, interface) in lewis_interfaces::msg::INTERFACES
        .iter()
        .zip(&idl.interfaces)
    {
        assert_eq!(info.name, interface.name);
        assert_eq!(info.xml, interface.xml);
        assert_eq!(
            info.publication.text,
            idl::schema_text(&idl, &interface.publication)
        );
        assert_eq!(info.commands.len(), interface.commands.len());
    }
}

#[test]
fn a_folder_of_broken_files_gives_one_clear_error_per_file() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/idl-broken");
    expect![[r#"
        tests/idl-broken/ArraySizeLater.xml:5:38: error: array_size `range_count` of `ranges` names a later field
          hint: move `range_count` above `ranges`: a length comes before its array
        tests/idl-broken/ArraySizeMissing.xml:6:38: error: array_size `range_cnt` of `ranges` names no field
          hint: did you mean `range_count`?
        tests/idl-broken/ArraySizeNotInteger.xml:6:38: error: array_size `max_range` of `ranges` names a field of type `Float`
          hint: array_size must name a single Integer field
        tests/idl-broken/BadVersion.xml:2:30: error: bad version `one`
          hint: write MAJOR.MINOR, for example `1.0`
        tests/idl-broken/BytesArray.xml:6:38: error: `images` is an array of Bytes
          hint: Bytes is already a sequence; an array of them is not a ROS 2 type
        tests/idl-broken/DuplicateCommand.xml:5:12: error: duplicate command `stop` in interface `DuplicateCommand`
        tests/idl-broken/DuplicateField.xml:6:11: error: duplicate field name `zoom`
        tests/idl-broken/Empty.xml:2:1: error: no root element
          hint: a definition file holds one `<interface>` or one `<types>` element
        tests/idl-broken/KeywordField.xml:5:11: error: field name `type` is a Rust keyword
          hint: choose another name, for example with a unit or a qualifier
        tests/idl-broken/Malformed.xml:6:3: error: malformed XML: ill-formed document: expected `</data>`, but `</publish>` was found
        tests/idl-broken/MissingAttribute.xml:5:5: error: `<arg>` needs a `type` attribute
        tests/idl-broken/MissingTypes.xml:3:10: error: type library `typse.xml` not found
          hint: put it beside this file; found: types.xml
        tests/idl-broken/NotUtf8.xml:3:19: error: the file is not valid UTF-8
        tests/idl-broken/TwoRoots.xml:5:1: error: a second root element `<interface>`
          hint: a definition file holds exactly one root element
        tests/idl-broken/UnknownAttribute.xml:5:36: error: unknown attribute `arraysize` on `<data>`
          hint: did you mean `array_size`?
        tests/idl-broken/UnknownElement.xml:4:3: error: unknown element `<publsh>` in `<interface>`
          hint: did you mean `<publish>`?
        tests/idl-broken/UnknownType.xml:5:24: error: unknown type `Flaot`
          hint: did you mean `Float`?
        tests/idl-broken/WrongFileName.xml:2:12: error: interface `RightName` is in a file named `WrongFileName.xml`
          hint: name the file `RightName.xml`, so tools find it by name"#]]
    .assert_eq(&diagnostics_of(&dir));
}

#[test]
fn a_struct_that_contains_itself_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("types.xml"),
        r#"<types version="1.0">
  <primitive name="Float" ros2="float64"/>
  <struct name="Node">
    <field name="value" type="Float"/>
    <field name="next" type="Node"/>
  </struct>
</types>
"#,
    )
    .unwrap();
    let err = idl::load_dir(dir.path()).unwrap_err().to_string();
    let prefix = format!("{}/", dir.path().display());
    expect![[r#"
        types.xml:3:3: error: struct `Node` contains itself (through `Node`)
          hint: a message has a fixed shape: break the cycle"#]]
    .assert_eq(&err.replace(&prefix, ""));
}

#[test]
fn unknown_ros2_spelling_in_types_gets_a_suggestion() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("types.xml"),
        "<types version=\"1.0\">\n  <primitive name=\"Float\" ros2=\"flaot64\"/>\n</types>\n",
    )
    .unwrap();
    let err = idl::load_dir(dir.path()).unwrap_err().to_string();
    let prefix = format!("{}/", dir.path().display());
    expect![[r#"
        types.xml:2:27: error: unknown ROS 2 type `flaot64`
          hint: did you mean `float64`?"#]]
    .assert_eq(&err.replace(&prefix, ""));
}

#[test]
fn the_papers_doctype_line_is_accepted() {
    check_file(
        "Paper.xml",
        r#"<?xml version="1.0"?>
<!DOCTYPE interface SYSTEM "interface.dtd">
<interface name="Paper" version="1.0">
  <types filename="types.xml"/>
  <publish><data name="x" type="Floot"/></publish>
</interface>
"#,
        &expect![[r#"
            Paper.xml:5:27: error: unknown type `Floot`
              hint: did you mean `Float`?"#]],
    );
}

#[test]
fn nesting_too_deep_is_refused_without_recursion() {
    let deep = format!(
        "<interface name=\"Deep\" version=\"1.0\">{}",
        "<publish>".repeat(100_000)
    );
    check_file(
        "Deep.xml",
        &deep,
        &expect!["Deep.xml:1:173: error: elements nested more than 16 deep"],
    );
}

#[test]
fn arbitrary_text_never_panics_the_parser() {
    use proptest::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("idl/types.xml"),
        dir.path().join("types.xml"),
    )
    .unwrap();
    let pieces = prop::collection::vec(
        prop_oneof![
            Just("<interface name=\"Fuzz\" version=\"1.0\">".to_owned()),
            Just("</interface>".to_owned()),
            Just("<types filename=\"types.xml\"/>".to_owned()),
            Just("<publish>".to_owned()),
            Just("</publish>".to_owned()),
            Just("<command name=\"go\">".to_owned()),
            Just("</command>".to_owned()),
            Just("<reply>".to_owned()),
            Just("</reply>".to_owned()),
            Just("<data name=\"n\" type=\"Integer\"/>".to_owned()),
            Just("<data name=\"a\" type=\"Float\" array_size=\"n\"/>".to_owned()),
            Just("<arg name=\"x\" type=\"Float\"/>".to_owned()),
            Just("&amp;&#x41;&bogus;".to_owned()),
            "\\PC{0,12}",
        ],
        0..24,
    );
    proptest!(ProptestConfig::with_cases(512), |(pieces in pieces)| {
        let path = dir.path().join("Fuzz.xml");
        std::fs::write(&path, pieces.concat()).unwrap();
        let _ = idl::load_files(&[dir.path().join("types.xml"), path]);
    });
}
