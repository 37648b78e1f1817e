//! The `<value>`s of a String field: parsed, validated with exact diagnostics, turned into
//! ros2msg constants and a Rust enum. (The shipped definitions and the broken files of
//! `tests/idl-broken/` are checked in `tests/idl.rs`.)

use std::path::PathBuf;

use super::*;

const TYPES: &str = r#"<types version="1.0">
  <primitive name="Integer" ros2="int32"/>
  <primitive name="String" ros2="string"/>
  <struct name="Taken">
    <field name="n" type="Integer"/>
  </struct>
</types>
"#;

/// Loads `types.xml` and one interface file `Robot.xml` holding `publish`.
fn load(publish: &str) -> Result<Idl, Diagnostics> {
    load_sources(&[
        (PathBuf::from("types.xml"), TYPES.to_owned()),
        (
            PathBuf::from("Robot.xml"),
            format!(
                "<interface name=\"Robot\" version=\"1.0\">\n<types filename=\"types.xml\"/>\n{publish}\n</interface>\n"
            ),
        ),
    ])
}

fn errors(publish: &str) -> String {
    load(publish).expect_err("refused").to_string()
}

const GOOD: &str = r#"<publish>
  <data name="status" type="String" description="where it is">
    <value name="idle"/>
    <comment>On its way.</comment>
    <value name="out-of-service" description="not able to serve"/>
    <value name="timed_out"/>
  </data>
  <data name="count" type="Integer"/>
</publish>
<command name="go">
  <reply>
    <data name="answer" type="String"><value name="yes"/><value name="no"/></data>
  </reply>
</command>"#;

#[test]
fn values_are_read_in_order_with_their_descriptions() {
    let idl = load(GOOD).unwrap();
    let robot = idl.interface("Robot").unwrap();
    let status = &robot.publication.fields[0];
    let values: Vec<(&str, Option<&str>, String, String)> = status
        .values
        .iter()
        .map(|v| {
            (
                v.name.as_str(),
                v.description.as_deref(),
                v.variant(),
                v.constant(&status.name),
            )
        })
        .collect();
    assert_eq!(
        values,
        [
            ("idle", None, "Idle".to_owned(), "STATUS_IDLE".to_owned()),
            (
                "out-of-service",
                Some("not able to serve"),
                "OutOfService".to_owned(),
                "STATUS_OUT_OF_SERVICE".to_owned()
            ),
            (
                "timed_out",
                None,
                "TimedOut".to_owned(),
                "STATUS_TIMED_OUT".to_owned()
            ),
        ]
    );
    assert_eq!(status.vocabulary_name("Robot"), "RobotStatus");
    assert!(robot.publication.fields[1].values.is_empty());
    assert_eq!(robot.commands[0].reply.fields[0].values.len(), 2);
}

#[test]
fn values_are_ros2msg_string_constants_above_their_field() {
    let idl = load(GOOD).unwrap();
    let robot = idl.interface("Robot").unwrap();
    let text = schema_text(&idl, &robot.publication);
    let own = text.split("=====").next().unwrap();
    assert_eq!(
        own,
        "lewis_interfaces/Header header\n\
         string STATUS_IDLE=\"idle\"\n\
         string STATUS_OUT_OF_SERVICE=\"out-of-service\"\n\
         string STATUS_TIMED_OUT=\"timed_out\"\n\
         string status\n\
         int32 count\n"
    );
    // A reader of ros2msg schemas (ours; the ROS 2 tools in tests/interop_ros2) reads them
    // as constants, not fields.
    let schema = crate::dynamic::MessageSchema::parse("lewis_interfaces/msg/Robot", &text).unwrap();
    let root = schema.definition(schema.root()).unwrap();
    assert_eq!(root.constants.len(), 3);
    assert_eq!(root.fields.len(), 3);
}

#[test]
fn values_make_one_enum_per_field() {
    let idl = load(GOOD).unwrap();
    let rust = generate_rust(&idl, Some("Robot"));
    for expected in [
        "pub enum RobotStatus {",
        "    /// `out-of-service`: not able to serve.\n    OutOfService,",
        "pub const ALL: [Self; 3] = [Self::Idle, Self::OutOfService, Self::TimedOut];",
        "pub const WORDS: [&'static str; 3] = [\"idle\", \"out-of-service\", \"timed_out\"];",
        "pub const FIELD: &'static str = \"Robot.status\";",
        "Self::OutOfService => \"out-of-service\",",
        "\"timed_out\" => Some(Self::TimedOut),",
        "impl std::str::FromStr for RobotStatus {",
        "impl PartialEq<RobotStatus> for String {",
        "/// Its words are [`RobotStatus`].\n    pub status: String,",
        "pub enum RobotGoReplyAnswer {",
    ] {
        assert!(rust.contains(expected), "no `{expected}` in:\n{rust}");
    }
    assert!(!rust.contains("RobotCount"));
}

#[test]
fn a_value_twice_is_refused() {
    assert_eq!(
        errors(
            r#"<publish><data name="s" type="String"><value name="a"/><value name="a"/></data></publish>"#
        ),
        "Robot.xml:3:63: error: duplicate value `a` of `s`"
    );
}

#[test]
fn values_that_make_one_variant_are_refused() {
    assert_eq!(
        errors(
            r#"<publish><data name="s" type="String"><value name="ask-for-help"/><value name="ask_for_help"/></data></publish>"#
        ),
        "Robot.xml:3:74: error: values `ask-for-help` and `ask_for_help` of `s` both make the variant `AskForHelp`\n  \
         hint: `-` and `_` join words alike: choose another word"
    );
}

#[test]
fn a_value_on_a_field_that_is_not_a_string_is_refused() {
    assert_eq!(
        errors(r#"<publish><data name="n" type="Integer"><value name="one"/></data></publish>"#),
        "Robot.xml:3:47: error: `<value>` on `n`, a field of type `Integer`\n  \
         hint: only String fields take values"
    );
    assert_eq!(
        errors(r#"<publish><data name="t" type="Taken"><value name="one"/></data></publish>"#),
        "Robot.xml:3:45: error: `<value>` on `t`, a field of type `Taken`\n  \
         hint: only String fields take values"
    );
}

#[test]
fn a_value_that_makes_no_identifier_is_refused() {
    let hint = "hint: values are lower-case words of letters and digits, each starting with a letter, joined by `-` or `_`";
    for (word, column) in [
        ("Idle", 46),
        ("2fast", 46),
        ("a--b", 46),
        ("a_", 46),
        ("", 46),
        ("out of service", 46),
        ("é", 46),
    ] {
        assert_eq!(
            errors(&format!(
                r#"<publish><data name="s" type="String"><value name="{word}"/></data></publish>"#
            )),
            format!("Robot.xml:3:{column}: error: bad value `{word}` of `s`\n  {hint}"),
            "{word:?}"
        );
    }
    assert_eq!(
        errors(r#"<publish><data name="s" type="String"><value name="self"/></data></publish>"#),
        "Robot.xml:3:46: error: bad value `self` of `s`\n  \
         hint: `self` makes the variant `Self`, a Rust keyword: choose another word"
    );
}

#[test]
fn values_of_two_fields_that_make_one_constant_are_refused() {
    assert_eq!(
        errors(
            r#"<publish>
<data name="a_b" type="String"><value name="c"/></data>
<data name="a" type="String"><value name="b_c"/></data>
</publish>"#
        ),
        "Robot.xml:5:37: error: value `b_c` of `a` makes the constant `A_B_C`, as a value of `a_b` does\n  \
         hint: rename the field or the value"
    );
}

#[test]
fn an_enum_name_that_is_taken_is_refused() {
    // By a command's request: `Robot.request` and the command `request` both want
    // `RobotRequest`.
    assert_eq!(
        errors(
            r#"<publish><data name="request" type="String"><value name="a"/></data></publish>
<command name="request"/>"#
        ),
        "Robot.xml:3:16: error: the values of `request` need the type name `RobotRequest`, which is taken\n  \
         hint: rename the field or the type"
    );
    // By another field's values: `Robot.go_reply_x` and `RobotGoReply.x`.
    assert_eq!(
        errors(
            r#"<publish><data name="go_reply_x" type="String"><value name="a"/></data></publish>
<command name="go"><reply><data name="x" type="String"><value name="b"/></data></reply></command>"#
        ),
        "Robot.xml:4:33: error: the values of `x` need the type name `RobotGoReplyX`, which is taken\n  \
         hint: rename the field or the type"
    );
}

#[test]
fn an_enum_name_taken_by_a_type_is_refused() {
    let types = TYPES.replace(
        "<struct name=\"Taken\">",
        "<struct name=\"RobotStatus\"><field name=\"m\" type=\"Integer\"/></struct>\n  <struct name=\"Taken\">",
    );
    let err = load_sources(&[
        (PathBuf::from("types.xml"), types),
        (
            PathBuf::from("Robot.xml"),
            "<interface name=\"Robot\" version=\"1.0\">\n<types filename=\"types.xml\"/>\n<publish><data name=\"status\" type=\"String\"><value name=\"a\"/></data></publish>\n</interface>\n".to_owned(),
        ),
    ])
    .expect_err("refused");
    assert_eq!(
        err.to_string(),
        "Robot.xml:3:16: error: the values of `status` need the type name `RobotStatus`, which is taken\n  \
         hint: rename the field or the type"
    );
}

#[test]
fn a_value_element_is_checked_like_any_other() {
    assert_eq!(
        errors(r#"<publish><data name="s" type="String"><value nam="a"/></data></publish>"#),
        "Robot.xml:3:46: error: unknown attribute `nam` on `<value>`\n  hint: did you mean `name`?"
    );
    assert_eq!(
        errors(r#"<publish><data name="s" type="String"><value/></data></publish>"#),
        "Robot.xml:3:39: error: `<value>` needs a `name` attribute"
    );
    assert_eq!(
        errors(r#"<publish><data name="s" type="String"><valeu name="a"/></data></publish>"#),
        "Robot.xml:3:39: error: unknown element `<valeu>` in `<data>`\n  hint: did you mean `<value>`?"
    );
    assert_eq!(
        errors(
            r#"<publish><data name="s" type="String"><value name="a">x</value></data></publish>"#
        ),
        "Robot.xml:3:39: error: `<value>` holds text; only elements belong there\n  \
         hint: put prose in a `<description>` or `<comment>` element"
    );
}
