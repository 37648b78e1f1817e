//! The robot file checked against a registry of kinds at load: a misspelt kind and wrong
//! parameters are found when the file is read, not when a service first starts.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

use expect_test::{Expect, expect};
use lewis_robot::{Known, parse_checked};

/// The interfaces these robot files use.
const KNOWN: &[&str] = &["RangeFinder"];

/// Parses `text` as `robot.toml` against a registry of one kind, `sim-laser`, whose
/// parameters are `range_m` and `rate_hz`.
fn check_kinds(text: &str, expected: &Expect) {
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[expect(dead_code, reason = "only deserialized, to check the parameters")]
    struct LaserParams {
        range_m: f64,
        #[serde(default)]
        rate_hz: f64,
    }
    let mut registry = lewis_service::ServiceRegistry::new();
    registry.register_with_parameters::<LaserParams>("sim-laser", |config| {
        Err(lewis_service::BuildError::NotAKind {
            service: config.name().to_owned(),
        })
    });
    let known = Known {
        interfaces: KNOWN,
        kinds: Some(&registry),
    };
    let shown = match parse_checked(text, Path::new("robot.toml"), known) {
        Ok(robot) => robot
            .services
            .iter()
            .map(|s| {
                format!(
                    "service {} {:?}: parameters {}\n",
                    s.name, s.launch, s.parameters
                )
            })
            .collect(),
        Err(error) => format!("{error}\n"),
    };
    expected.assert_eq(&shown);
}

#[test]
fn a_misspelt_kind_is_found_at_load_with_the_kind_it_probably_meant() {
    check_kinds(
        r#"
[robot]
name = "r"

[[services]]
name = "laser"
kind = "sim-lazer"
provides = [{ interface = "RangeFinder", quality = 10, cost = 3 }]
"#,
        &expect![[r#"
            robot.toml:7:8: service `laser` has kind `sim-lazer`, which this lewis does not know: did you mean `sim-laser`?
        "#]],
    );
}

#[test]
fn parameters_are_checked_against_the_kind_at_the_key_that_is_wrong() {
    check_kinds(
        r#"
[robot]
name = "r"

[[services]]
name = "laser"
kind = "sim-laser"
provides = [{ interface = "RangeFinder", quality = 10, cost = 3 }]

[services.parameters]
rate_hz = 10.0
rnage_m = 8.0

[[services]]
name = "laser2"
kind = "sim-laser"
provides = [{ interface = "RangeFinder", quality = 5, cost = 3 }]
parameters = { range_m = "far" }
"#,
        &expect![[r#"
            robot.toml:12:1: parameters of service `laser` (kind `sim-laser`): unknown field `rnage_m`: did you mean `range_m`?
            robot.toml:18:14: parameters of service `laser2` (kind `sim-laser`): invalid type: string "far", expected f64
        "#]],
    );
}

#[test]
fn a_file_that_fits_its_kinds_loads() {
    check_kinds(
        r#"
[robot]
name = "r"

[[services]]
name = "laser"
kind = "sim-laser"
provides = [{ interface = "RangeFinder", quality = 10, cost = 3 }]
parameters = { range_m = 8.0 }
"#,
        &expect![[r#"
            service laser Kind("sim-laser"): parameters range_m = 8.0

        "#]],
    );
}
