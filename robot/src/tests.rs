use std::fmt::Write as _;
use std::path::Path;

use expect_test::{Expect, expect};
use proptest::prelude::*;

use super::*;

/// The interfaces of the paper.
const KNOWN: &[&str] = &[
    "RangeFinder",
    "Distance",
    "Synchrodrive",
    "Egomotion",
    "Power",
    "ImageSource",
    "CameraControl",
    "Mover",
    "Blobs",
    "Blobs3D",
    "Signs",
];

/// Parses `text` as `robot.toml` and shows either a summary of the robot or every problem.
fn check(text: &str, expected: &Expect) {
    let shown = match parse(text, Path::new("robot.toml"), KNOWN) {
        Ok(robot) => summary(&robot),
        Err(error) => format!("{error}\n"),
    };
    expected.assert_eq(&shown);
}

fn summary(robot: &Robot) -> String {
    let b = &robot.broker;
    let mut out = format!(
        "robot {} ({})\nbroker: heartbeat {} ms, deadline {} ms, startup {} ms, fail back {} {:?}, retry {:?}, restart {:?}\n",
        robot.name,
        robot.description,
        b.heartbeat_period_ms,
        b.heartbeat_deadline_ms,
        b.startup_deadline_ms,
        b.fail_back,
        b.fail_back_per_interface,
        b.retry,
        b.restart,
    );
    if let Some(budget) = b.cpu_budget_percent {
        let _ = writeln!(out, "cpu budget {budget}% of a core");
    }
    for s in &robot.services {
        let _ = writeln!(
            out,
            "service {} {:?} start {:?}: deadline {} ms, startup {} ms, restart {:?}",
            s.name, s.launch, s.start, s.heartbeat_deadline_ms, s.startup_deadline_ms, s.restart
        );
        for p in &s.provides {
            let _ = writeln!(
                out,
                "  provides {} quality {} cost {} rate {:?}",
                p.interface, p.quality, p.cost, p.data_rate_hz
            );
        }
        for r in &s.requires {
            match s.min_rates_hz.get(r) {
                Some(hz) => {
                    let _ = writeln!(out, "  requires {r} at least {hz} Hz");
                }
                None => {
                    let _ = writeln!(out, "  requires {r}");
                }
            }
        }
        if let Some(group) = &s.excludes {
            let _ = writeln!(out, "  excludes {group}");
        }
        if !s.parameters.is_empty() {
            let _ = writeln!(
                out,
                "  parameters {}",
                s.parameters.to_string().replace('\n', "; ")
            );
        }
        if !s.environment.is_empty() {
            let _ = writeln!(out, "  environment {:?}", s.environment);
        }
    }
    out
}

#[test]
fn the_test_robot_file_is_valid() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/test.toml");
    let robot = load(&path, KNOWN).unwrap_or_else(|e| panic!("{e}"));
    expect![[r#"
        robot test (Failover test bench: a synthetic laser and a synthetic sonar, no hardware)
        broker: heartbeat 10 ms, deadline 50 ms, startup 5000 ms, fail back false {}, retry None, restart RestartPolicy { max_restarts: 3, window_ms: 10000, backoff_initial_ms: 50, backoff_max_ms: 1000 }
        service laser Kind("test-range") start OnDemand: deadline 50 ms, startup 5000 ms, restart RestartPolicy { max_restarts: 2, window_ms: 10000, backoff_initial_ms: 20, backoff_max_ms: 200 }
          provides RangeFinder quality 10 cost 2 rate Some(10.0)
          provides Distance quality 10 cost 2 rate Some(10.0)
          parameters beams = 181; field_of_view_deg = 180.0; max_range_m = 8.0; noise_m = 0.01; rate_hz = 10.0; seed = 1; 
        service sonar Kind("test-range") start OnDemand: deadline 50 ms, startup 5000 ms, restart RestartPolicy { max_restarts: 2, window_ms: 10000, backoff_initial_ms: 20, backoff_max_ms: 200 }
          provides RangeFinder quality 5 cost 1 rate Some(5.0)
          provides Distance quality 5 cost 1 rate Some(5.0)
          parameters beams = 24; field_of_view_deg = 360.0; max_range_m = 5.0; noise_m = 0.05; rate_hz = 5.0; seed = 2; 
    "#]]
    .assert_eq(&summary(&robot));
}

#[test]
fn a_missing_file_names_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nowhere.toml");
    let error = load(&path, KNOWN).unwrap_err();
    assert!(matches!(&error, RobotError::Read { path: p, .. } if *p == path));
    assert!(error.to_string().contains("nowhere.toml"), "{error}");
}

#[test]
fn defaults_fill_what_the_file_leaves_out() {
    check(
        r#"
[robot]
name = "mini"

[broker]
fail_back = true
retry_failed_after_ms = 60000
restart = { max_restarts = 5, window_ms = 1000 }

[broker.interfaces.RangeFinder]
fail_back = false

[[services]]
name = "laser"
command = ["/usr/bin/laserd", "--port", "/dev/ttyS0"]
provides = [{ interface = "RangeFinder", quality = 10, cost = 0 }]
environment = { RUST_LOG = "debug" }

[[services]]
name = "avoider"
kind = "obstacle-avoider"
start = "always"
requires = ["RangeFinder"]
parameters = { speed_m_s = 0.3 }
"#,
        &expect![[r#"
            robot mini ()
            broker: heartbeat 20 ms, deadline 100 ms, startup 5000 ms, fail back true {"RangeFinder": false}, retry Some(RetryPolicy { after_ms: 60000, max_ms: 960000, probation_ms: 5000 }), restart RestartPolicy { max_restarts: 5, window_ms: 1000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
            service laser Command(["/usr/bin/laserd", "--port", "/dev/ttyS0"]) start OnDemand: deadline 100 ms, startup 5000 ms, restart RestartPolicy { max_restarts: 5, window_ms: 1000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
              provides RangeFinder quality 10 cost 0 rate None
              environment {"RUST_LOG": "debug"}
            service avoider Kind("obstacle-avoider") start Always: deadline 100 ms, startup 5000 ms, restart RestartPolicy { max_restarts: 5, window_ms: 1000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
              requires RangeFinder
              parameters speed_m_s = 0.3; 
        "#]],
    );
}

#[test]
fn a_service_may_require_what_it_provides_when_another_service_provides_it_too() {
    check(
        r#"
[robot]
name = "movers"
[[services]]
name = "vector-mover"
kind = "vector-mover"
provides = [{ interface = "Mover", quality = 5, cost = 1 }]
[[services]]
name = "avoider"
kind = "obstacle-avoider"
provides = [{ interface = "Mover", quality = 8, cost = 2 }]
requires = ["Mover"]
"#,
        &expect![[r#"
            robot movers ()
            broker: heartbeat 20 ms, deadline 100 ms, startup 5000 ms, fail back false {}, retry None, restart RestartPolicy { max_restarts: 3, window_ms: 10000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
            service vector-mover Kind("vector-mover") start OnDemand: deadline 100 ms, startup 5000 ms, restart RestartPolicy { max_restarts: 3, window_ms: 10000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
              provides Mover quality 5 cost 1 rate None
            service avoider Kind("obstacle-avoider") start OnDemand: deadline 100 ms, startup 5000 ms, restart RestartPolicy { max_restarts: 3, window_ms: 10000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
              provides Mover quality 8 cost 2 rate None
              requires Mover
        "#]],
    );
}

#[test]
fn a_syntax_error_is_placed_at_its_line_and_column() {
    check(
        "[robot]\nname = \"x\"\n[[services]\n",
        &expect![[r#"
            robot.toml:3:12: unclosed array table, expected `]`
        "#]],
    );
}

#[test]
fn a_misspelt_key_is_an_error_not_ignored() {
    check(
        r#"
[robot]
name = "x"
[[services]]
name = "laser"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 10, cost = 1 }]
heartbeat_deadline = 50
"#,
        &expect![[r#"
            robot.toml:8:1: unknown field `heartbeat_deadline`, expected one of `name`, `description`, `kind`, `command`, `parameters`, `provides`, `requires`, `excludes`, `restart`, `heartbeat_deadline_ms`, `startup_deadline_ms`, `start`, `environment`, `host`
        "#]],
    );
}

/// A robot of one laser with `broker` as the lines of its `[broker]` table.
fn robot(broker: &str) -> String {
    format!(
        "[robot]\nname = \"x\"\n[broker]\n{broker}\n[[services]]\nname = \"laser\"\nkind = \"test-range\"\nstart = \"always\"\nprovides = []\n"
    )
}

#[test]
fn the_retry_of_failed_services_is_checked_where_it_is_written() {
    check(
        &robot("retry_failed_after_ms = 2000\nretry_failed_max_ms = 1000\nretry_probation_ms = 0"),
        &expect![[r#"
            robot.toml:5:23: retry_failed_max_ms 1000 is shorter than retry_failed_after_ms 2000: the longest cool-down cannot be shorter than the first
            robot.toml:6:22: retry_probation_ms is 0: give a positive number of milliseconds
        "#]],
    );
    check(
        &robot("retry_probation_ms = 3000"),
        &expect![[r#"
            robot.toml:4:22: retry_probation_ms means nothing without retry_failed_after_ms, the first cool-down: give it too, or remove retry_probation_ms
        "#]],
    );
    check(
        &robot("retry_failed_after_ms = 2000"),
        &expect![[r#"
            robot x ()
            broker: heartbeat 20 ms, deadline 100 ms, startup 5000 ms, fail back false {}, retry Some(RetryPolicy { after_ms: 2000, max_ms: 32000, probation_ms: 5000 }), restart RestartPolicy { max_restarts: 3, window_ms: 10000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
            service laser Kind("test-range") start Always: deadline 100 ms, startup 5000 ms, restart RestartPolicy { max_restarts: 3, window_ms: 10000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
        "#]],
    );
}

#[test]
fn a_nice_value_out_of_range_is_placed() {
    check(
        &robot("nice = -21"),
        &expect![[r#"
            robot.toml:4:8: nice -21 is out of range: nice values run from -20 (first) to 19 (last)
        "#]],
    );
    check(
        &robot("nice = 99999999999"),
        &expect![[r#"
            robot.toml:4:8: nice 99999999999 is out of range: nice values run from -20 (first) to 19 (last)
        "#]],
    );
    let robot = parse(&robot("nice = -10"), Path::new("robot.toml"), &[]).unwrap();
    assert_eq!(robot.broker.nice, Some(-10));
}

#[test]
fn keeping_the_cores_awake_is_asked_for_and_a_wrong_value_is_placed() {
    let asked = parse(
        &robot("keep_cores_awake = true"),
        Path::new("robot.toml"),
        &[],
    )
    .unwrap();
    assert!(asked.broker.keep_cores_awake);
    let default = parse(&robot(""), Path::new("robot.toml"), &[]).unwrap();
    assert!(!default.broker.keep_cores_awake);
    check(
        &robot("keep_cores_awake = 1"),
        &expect![[r#"
            robot.toml:4:20: invalid type: integer `1`, expected a boolean
        "#]],
    );
}

#[test]
fn a_heartbeat_priority_out_of_range_is_placed_and_the_default_is_the_lowest() {
    check(
        &robot("heartbeat_priority = 100"),
        &expect![[r#"
            robot.toml:4:22: heartbeat_priority 100 is out of range: real-time priorities run from 1 (lowest) to 99, and 0 leaves heartbeats to the normal scheduler
        "#]],
    );
    let parsed = |text: &str| parse(&robot(text), Path::new("robot.toml"), &[]).unwrap();
    assert_eq!(
        parsed("heartbeat_priority = 0").broker.heartbeat_priority,
        0
    );
    assert_eq!(parsed("").broker.heartbeat_priority, 1);
}

#[test]
fn a_wrong_type_and_an_unknown_start_mode_are_placed() {
    check(
        "[robot]\nname = \"x\"\n[[services]]\nname = \"a\"\nkind = \"k\"\nstart = \"sometimes\"\nprovides = []\n",
        &expect![[r#"
            robot.toml:6:9: unknown variant `sometimes`, expected one of `on-demand`, `standby`, `always`
        "#]],
    );
    check(
        "[robot]\nname = 7\n",
        &expect![[r#"
            robot.toml:2:8: invalid type: integer `7`, expected a string
        "#]],
    );
    check(
        "",
        &expect![[r#"
            robot.toml:1:1: missing field `robot`
        "#]],
    );
}

#[test]
fn every_semantic_problem_is_reported_with_its_place() {
    check(
        r#"
[robot]
name = "test robot"

[broker]
heartbeat_period_ms = 20
heartbeat_deadline_ms = 10
restart = { max_restarts = 3, window_ms = 0, backoff_initial_ms = 500, backoff_max_ms = 100 }

[broker.interfaces.Laser]
fail_back = true

[[services]]
name = "laser"
kind = "test-range"
provides = [
    { interface = "RangeFinder", quality = 101, cost = -1 },
    { interface = "RangeFinder", quality = 5, cost = 1, data_rate_hz = 0.0 },
    { interface = "LaserScan", quality = 5, cost = 1 },
]

[[services]]
name = "laser"
command = [""]
provides = [{ interface = "Distance", quality = 5, cost = 1 }]
requires = ["Power", "Power", "Mover3D"]
heartbeat_deadline_ms = -5
environment = { "A=B" = "x" }

[[services]]
name = "both"
kind = "a"
command = ["/bin/true"]
provides = [{ interface = "Distance", quality = 5, cost = 1 }]

[[services]]
name = "neither"
provides = [{ interface = "Distance", quality = 5, cost = 1 }]

[[services]]
name = "empty"
command = []
provides = [{ interface = "Distance", quality = 5, cost = 1 }]

[[services]]
name = "lonely"
kind = "app"
"#,
        &expect![[r#"
            robot.toml:3:8: robot name `test robot` is not a valid name: use a letter then letters, digits, `-` or `_`, at most 64 characters
            robot.toml:7:25: heartbeat_deadline_ms 10 is not longer than the heartbeat period 20 ms, so every service would be seen as stalled: give a deadline of a few periods
            robot.toml:8:11: restart window_ms is 0: give the window over which restarts are counted, in milliseconds
            robot.toml:8:11: restart backoff_initial_ms 500 is above backoff_max_ms 100: the first delay cannot exceed the cap
            robot.toml:10:20: broker settings for unknown interface `Laser`: known interfaces are Blobs, Blobs3D, CameraControl, Distance, Egomotion, ImageSource, Mover, Power, RangeFinder, Signs, Synchrodrive
            robot.toml:17:44: quality 101 in service `laser` is out of range: give a value from 0 to 100
            robot.toml:17:56: cost -1 in service `laser` is out of range: give a value from 0 to 100
            robot.toml:18:19: service `laser` provides `RangeFinder` twice: keep one entry
            robot.toml:18:72: data_rate_hz 0 of `RangeFinder` in service `laser` is out of range: give a rate above 0 and at most 1000000
            robot.toml:19:19: service `laser` provides unknown interface `LaserScan`: known interfaces are Blobs, Blobs3D, CameraControl, Distance, Egomotion, ImageSource, Mover, Power, RangeFinder, Signs, Synchrodrive
            robot.toml:23:8: duplicate service name `laser` (first declared on line 14): give each service its own name
            robot.toml:24:12: the command of service `laser` has an empty program: give the program's path or name first
            robot.toml:26:13: service `laser` requires `Power` but no other service provides it: add a provider or remove the requirement
            robot.toml:26:22: service `laser` requires `Power` twice: keep one entry
            robot.toml:26:31: service `laser` requires unknown interface `Mover3D`: known interfaces are Blobs, Blobs3D, CameraControl, Distance, Egomotion, ImageSource, Mover, Power, RangeFinder, Signs, Synchrodrive
            robot.toml:27:25: heartbeat_deadline_ms is -5: give a positive number of milliseconds
            robot.toml:28:17: environment variable name `A=B` of service `laser` is empty or contains `=` or a NUL byte
            robot.toml:33:11: service `both` has both `kind` and `command`: give one (a built-in kind, or a command line)
            robot.toml:37:8: service `neither` says neither `kind` (a built-in service) nor `command` (a command line): give one
            robot.toml:42:11: the command of service `empty` is empty: give the program and its arguments
            robot.toml:46:8: service `lonely` provides no interface and starts on demand, so nothing would ever start it: add `provides` or set `start = "always"`
        "#]],
    );
}

#[test]
fn kind_services_run_through_lewis_and_commands_run_as_given() {
    let robot = parse(
        r#"
[robot]
name = "r"
[[services]]
name = "laser"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 10, cost = 1 }]
[[services]]
name = "sonar"
command = ["/opt/sonar", "--rate", "5"]
provides = [{ interface = "RangeFinder", quality = 5, cost = 1 }]
"#,
        Path::new("r.toml"),
        KNOWN,
    )
    .unwrap();
    let argv = |name: &str| {
        robot
            .service(name)
            .unwrap()
            .argv(Path::new("/bin/lewis"), Path::new("robots/r.toml"))
    };
    assert_eq!(
        argv("laser"),
        ["/bin/lewis", "service", "laser", "--robot", "robots/r.toml"]
    );
    assert_eq!(argv("sonar"), ["/opt/sonar", "--rate", "5"]);
}

proptest! {
    #[test]
    fn any_text_gives_a_robot_or_placed_problems(text in ".{0,400}") {
        if let Err(RobotError::Invalid { problems, .. }) = parse(&text, Path::new("p.toml"), KNOWN) {
            prop_assert!(!problems.is_empty());
            for p in problems {
                prop_assert!(p.line() >= 1 && p.column() >= 1);
            }
        }
    }

    #[test]
    fn mangled_robot_files_never_panic(
        cut in 0usize..2000,
        insert in "[\\[\\]={}\",a-z0-9 \n-]{0,12}",
    ) {
        let base = include_str!("../../robots/test.toml");
        let mut at = cut.min(base.len());
        while !base.is_char_boundary(at) {
            at -= 1;
        }
        let text = format!("{}{}{}", &base[..at], insert, &base[at..]);
        let _ = parse(&text, Path::new("p.toml"), KNOWN);
    }
}

#[test]
fn the_example_in_the_module_documentation_is_valid() {
    let source = include_str!("lib.rs");
    let example: String = source
        .lines()
        .skip_while(|l| *l != "//! ```toml")
        .skip(1)
        .take_while(|l| *l != "//! ```")
        .map(|l| {
            format!(
                "{}\n",
                l.trim_start_matches("//!").strip_prefix(' ').unwrap_or("")
            )
        })
        .collect();
    assert!(
        example.contains("[[services]]"),
        "example not found:\n{example}"
    );
    let robot = parse(&example, Path::new("doc.toml"), KNOWN).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(robot.services[0].name, "laser");
    assert!(robot.broker.fail_back_for("RangeFinder"));
    assert!(!robot.broker.fail_back_for("Distance"));
}

#[test]
fn data_checks_take_the_interface_defaults_and_the_file_overrides() {
    let robot = parse(
        r#"
[robot]
name = "r"

[broker]
data_checks = true

[broker.interfaces.RangeFinder]
checks = { rate = 0.25, window_ms = 2000, freshness_ms = 0, frozen = 3, on_failure = "degraded" }

[broker.interfaces.Egomotion]
checks = { values = false }

[[services]]
name = "laser"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 5, cost = 1 }]
"#,
        Path::new("robot.toml"),
        KNOWN,
    )
    .unwrap();
    let b = &robot.broker;
    assert!(b.data_checks);
    assert_eq!(
        b.checks_for("RangeFinder"),
        DataChecks {
            min_rate_fraction: 0.25,
            window_ms: 2000,
            freshness_ms: None,
            values: true,
            frozen_count: Some(3),
            on_failure: OnCheckFailure::Degraded,
        }
    );
    assert_eq!(
        b.checks_for("Egomotion"),
        DataChecks {
            values: false,
            ..DataChecks::default_for("Egomotion")
        }
    );
    // Not declared: the interface's own defaults (frozen never for blob lists).
    assert_eq!(b.checks_for("Blobs"), DataChecks::default_for("Blobs"));
    assert_eq!(b.checks_for("Blobs").frozen_count, None);
    assert_eq!(DataChecks::default_for("RangeFinder").frozen_count, Some(5));

    // Off unless the robot file turns them on.
    let off = parse("[robot]\nname = \"r\"\n", Path::new("robot.toml"), KNOWN).unwrap();
    assert!(!off.broker.checks_for("RangeFinder").any());
}

#[test]
fn a_provision_has_checks_of_its_own_over_its_interfaces() {
    let text = |data_checks: bool| {
        format!(
            r#"
[robot]
name = "r"
[broker]
data_checks = {data_checks}
[broker.interfaces.RangeFinder]
checks = {{ rate = 0.25, frozen = 3 }}

[[services]]
name = "laser"
kind = "test-range"
provides = [{{ interface = "RangeFinder", quality = 10, cost = 1 }}]

[[services]]
name = "sonar"
kind = "test-range"
provides = [{{ interface = "RangeFinder", quality = 5, cost = 1, checks = {{ frozen = 0, on_failure = "degraded" }} }}]
"#
        )
    };
    let robot = parse(&text(true), Path::new("robot.toml"), KNOWN).unwrap();
    let of = |service: &str| {
        let spec = robot.service(service).unwrap();
        robot.broker.checks_of(&spec.provides[0])
    };
    // The laser has its interface's checks; the sonar those, but not frozen.
    assert_eq!(of("laser"), robot.broker.checks_for("RangeFinder"));
    assert_eq!(
        of("sonar"),
        DataChecks {
            frozen_count: None,
            on_failure: OnCheckFailure::Degraded,
            ..robot.broker.checks_for("RangeFinder")
        }
    );
    assert_eq!(of("sonar").min_rate_fraction, 0.25);
    // Off for the whole robot: off for every provision too.
    let off = parse(&text(false), Path::new("robot.toml"), KNOWN).unwrap();
    let sonar = off.service("sonar").unwrap();
    assert!(!off.broker.checks_of(&sonar.provides[0]).any());
}

#[test]
fn a_wrong_data_check_is_placed_at_its_value() {
    check(
        r#"
[robot]
name = "r"

[broker.interfaces.RangeFinder]
checks = { rate = 1.5, window_ms = 0, freshness_ms = -1, frozen = 1 }
"#,
        &expect![[r#"
            robot.toml:6:19: checks of `RangeFinder`: rate 1.5 is not a fraction of the declared data_rate_hz: give a value from 0 (off) to 1
            robot.toml:6:36: checks of `RangeFinder`: window_ms is 0: give a positive number of milliseconds
            robot.toml:6:54: checks of `RangeFinder`: freshness_ms is -1: give how old a sample may be in milliseconds, or 0 (off)
            robot.toml:6:67: checks of `RangeFinder`: frozen is 1: give how many identical payloads in a row make a frozen stream (at least 2), or 0 (off)
        "#]],
    );
    check(
        r#"
[robot]
name = "r"

[broker.interfaces.Distance]
checks = { speed = 3 }
"#,
        &expect![[r#"
            robot.toml:6:12: unknown field `speed`, expected one of `rate`, `window_ms`, `freshness_ms`, `values`, `frozen`, `on_failure`
        "#]],
    );
    check(
        r#"
[robot]
name = "r"

[broker.interfaces.Blobs]
checks = { on_failure = "ignored" }
"#,
        &expect![[r#"
            robot.toml:6:25: unknown variant `ignored`, expected `failed` or `degraded`
        "#]],
    );
}

#[test]
fn a_cpu_budget_exclusion_groups_and_least_rates_are_read() {
    check(
        r#"
[robot]
name = "stereo"
[broker]
cpu_budget_percent = 150
[[services]]
name = "camera1"
kind = "camera"
excludes = "pan-tilt"
provides = [{ interface = "ImageSource", quality = 9, cost = 20, data_rate_hz = 10.0 }]
[[services]]
name = "camera2"
kind = "camera"
excludes = "pan-tilt"
provides = [{ interface = "ImageSource", quality = 8, cost = 2, data_rate_hz = 30.0 }]
[[services]]
name = "signs"
kind = "sign-detector"
requires = [{ interface = "ImageSource", min_rate_hz = 20 }]
provides = [{ interface = "Signs", quality = 5, cost = 5 }]
[[services]]
name = "blobs"
kind = "blob-finder"
requires = ["ImageSource"]
provides = [{ interface = "Blobs", quality = 5, cost = 5 }]
"#,
        &expect![[r#"
            robot stereo ()
            broker: heartbeat 20 ms, deadline 100 ms, startup 5000 ms, fail back false {}, retry None, restart RestartPolicy { max_restarts: 3, window_ms: 10000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
            cpu budget 150% of a core
            service camera1 Kind("camera") start OnDemand: deadline 100 ms, startup 5000 ms, restart RestartPolicy { max_restarts: 3, window_ms: 10000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
              provides ImageSource quality 9 cost 20 rate Some(10.0)
              excludes pan-tilt
            service camera2 Kind("camera") start OnDemand: deadline 100 ms, startup 5000 ms, restart RestartPolicy { max_restarts: 3, window_ms: 10000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
              provides ImageSource quality 8 cost 2 rate Some(30.0)
              excludes pan-tilt
            service signs Kind("sign-detector") start OnDemand: deadline 100 ms, startup 5000 ms, restart RestartPolicy { max_restarts: 3, window_ms: 10000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
              provides Signs quality 5 cost 5 rate None
              requires ImageSource at least 20 Hz
            service blobs Kind("blob-finder") start OnDemand: deadline 100 ms, startup 5000 ms, restart RestartPolicy { max_restarts: 3, window_ms: 10000, backoff_initial_ms: 50, backoff_max_ms: 2000 }
              provides Blobs quality 5 cost 5 rate None
              requires ImageSource
        "#]],
    );
}

#[test]
fn a_bad_cpu_budget_least_rate_or_group_is_placed_at_its_value() {
    check(
        r#"
[robot]
name = "stereo"
[broker]
cpu_budget_percent = 0
[[services]]
name = "camera1"
kind = "camera"
excludes = "pan tilt"
provides = [{ interface = "ImageSource", quality = 9, cost = 20 }]
[[services]]
name = "signs"
kind = "sign-detector"
requires = [{ interface = "ImageSource", min_rate_hz = -2 }, { interface = "Mover3D" }]
provides = [{ interface = "Signs", quality = 5, cost = 5 }]
"#,
        &expect![[r#"
            robot.toml:5:22: cpu_budget_percent is 0: give the CPU the robot's services may use together, in percent of one core (1 to 6400; 150 is one and a half cores)
            robot.toml:9:12: service `camera1` excludes group `pan tilt` is not a valid name: use a letter then letters, digits, `-` or `_`, at most 64 characters
            robot.toml:14:13: min_rate_hz -2 of `ImageSource` in service `signs` is out of range: give a rate above 0 and at most 1000000
            robot.toml:14:62: service `signs` requires unknown interface `Mover3D`: known interfaces are Blobs, Blobs3D, CameraControl, Distance, Egomotion, ImageSource, Mover, Power, RangeFinder, Signs, Synchrodrive
        "#]],
    );
}

#[test]
fn a_requirement_table_with_an_unknown_key_is_an_error() {
    check(
        r#"
[robot]
name = "stereo"
[[services]]
name = "camera1"
kind = "camera"
provides = [{ interface = "ImageSource", quality = 9, cost = 20 }]
[[services]]
name = "signs"
kind = "sign-detector"
requires = [{ interface = "ImageSource", min_rate = 20 }]
provides = [{ interface = "Signs", quality = 5, cost = 5 }]
"#,
        &expect![[r#"
            robot.toml:11:42: unknown field `min_rate`, expected `interface` or `min_rate_hz`
        "#]],
    );
}

#[test]
fn hosts_are_checked_where_they_are_written() {
    check(
        r#"
[robot]
name = "x"
[[hosts]]
name = "robot"
listen = ["tpc/10.0.0.1:7447"]
[[hosts]]
name = "workstation"
connect = ["tcp/10.0.0.1"]
[[hosts]]
name = "robot"
listen = ["tcp/10.0.0.3:7447"]
[[services]]
name = "laser"
kind = "test-range"
host = "workstaton"
provides = [{ interface = "RangeFinder", quality = 10, cost = 1 }]
"#,
        &expect![[r#"
            robot.toml:6:11: endpoint `tpc/10.0.0.1:7447` names protocol `tpc`: did you mean `tcp`? Lewis speaks tcp, quic
            robot.toml:9:12: endpoint `tcp/10.0.0.1` has no port: write it as `tcp/ADDRESS:PORT`
            robot.toml:11:8: duplicate host name `robot` (first declared on line 5): give each host its own name
            robot.toml:16:8: service `laser` runs on host `workstaton`, which the robot does not have: did you mean `workstation`? its hosts are robot, workstation, robot
        "#]],
    );
}

#[test]
fn a_host_without_hosts_is_an_error() {
    check(
        r#"
[robot]
name = "x"
[network]
link_deadline_ms = 0
[[services]]
name = "laser"
kind = "test-range"
host = "workstation"
provides = [{ interface = "RangeFinder", quality = 10, cost = 1 }]
"#,
        &expect![[r#"
            robot.toml:4:1: [network] is for a robot on more than one host, and this one has no [[hosts]]
            robot.toml:5:20: [network] link_deadline_ms is 0: give a positive number of milliseconds
            robot.toml:9:8: service `laser` runs on host `workstation`, but the robot has no [[hosts]]: declare the hosts, or remove `host`
        "#]],
    );
}

#[test]
fn a_quic_endpoint_needs_the_certificates() {
    check(
        r#"
[robot]
name = "x"
[[hosts]]
name = "robot"
listen = ["quic/10.0.0.1:7447"]
[[hosts]]
name = "workstation"
[[services]]
name = "laser"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 10, cost = 1 }]
"#,
        &expect![[r#"
            robot.toml:6:11: a `quic/` endpoint needs the certificates of [network.tls]: `ca`, `certificate` and `private_key` files
        "#]],
    );
    check(
        r#"
[robot]
name = "x"
[[hosts]]
name = "robot"
listen = ["tcp/10.0.0.1:7447"]
[network.tls]
ca = "ca.pem"
certificate = "host.pem"
[[services]]
name = "laser"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 10, cost = 1 }]
"#,
        &expect![[r#"
            robot.toml:7:1: missing field `private_key`
        "#]],
    );
}

#[test]
fn zenohs_tls_and_udp_links_are_refused_with_the_reason() {
    check(
        r#"
[robot]
name = "x"
[[hosts]]
name = "robot"
listen = ["tls/10.0.0.1:7447"]
[[hosts]]
name = "workstation"
connect = ["udp/10.0.0.1:7447"]
[[services]]
name = "laser"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 10, cost = 1 }]
"#,
        &expect![[r#"
            robot.toml:6:11: endpoint `tls/10.0.0.1:7447` names protocol `tls`, which Lewis does not offer: Zenoh 1.10's TLS link reads and writes one TLS stream from two threads at once (eclipse-zenoh/zenoh#2557), and with data crossing both ways the link broke and its host was lost every few seconds; use `quic`, which encrypts with TLS 1.3 and the same [network.tls]
            robot.toml:9:12: endpoint `udp/10.0.0.1:7447` names protocol `udp`, which Lewis does not offer: Zenoh's UDP link drops what does not arrive, decisions and heartbeats included; use `tcp`, or `quic` for an encrypted link
        "#]],
    );
}
