//! The crate layers of DESIGN.md, enforced from `cargo metadata`: a crate that depends on
//! one it must not fails this test, which names the path.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::process::Command;

/// Which of our crates each crate may use (normal and build dependencies).
const ALLOWED: &[(&str, &[&str])] = &[
    // What people type (positions, did-you-mean, durations): below everything.
    ("lewis-stdx", &[]),
    ("lewis-interfaces", &["lewis-stdx"]),
    // The one MCAP reading layer: below everything that reads a recording.
    ("lewis-mcap", &["lewis-stdx"]),
    ("lewis-runtime", &["lewis-stdx", "lewis-interfaces"]),
    // The one HTTP server of the pages served on localhost.
    ("lewis-pages", &[]),
    (
        "lewis-recorder",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-mcap",
            "lewis-runtime",
        ],
    ),
    (
        "lewis-sequencer",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-runtime",
            "lewis-pages",
        ],
    ),
    // The components: shared vocabulary below all of them, nothing borrowed sideways.
    ("lewis-geometry", &["lewis-stdx", "lewis-interfaces"]),
    ("lewis-images", &["lewis-stdx", "lewis-interfaces"]),
    (
        "lewis-sim",
        &[
            "lewis-stdx",
            "lewis-geometry",
            "lewis-interfaces",
            "lewis-runtime",
        ],
    ),
    (
        "lewis-drivers",
        &[
            "lewis-stdx",
            "lewis-geometry",
            "lewis-images",
            "lewis-interfaces",
            "lewis-runtime",
        ],
    ),
    (
        "lewis-motion",
        &[
            "lewis-stdx",
            "lewis-geometry",
            "lewis-interfaces",
            "lewis-runtime",
        ],
    ),
    (
        "lewis-perception",
        &[
            "lewis-stdx",
            "lewis-geometry",
            "lewis-images",
            "lewis-interfaces",
            "lewis-runtime",
        ],
    ),
    (
        "lewis-emulators",
        &[
            "lewis-stdx",
            "lewis-drivers",
            "lewis-sim",
            "lewis-geometry",
            "lewis-interfaces",
            "lewis-runtime",
        ],
    ),
    // The registry of every kind, above all the components.
    (
        "lewis-kinds",
        &[
            "lewis-stdx",
            "lewis-sim",
            "lewis-drivers",
            "lewis-motion",
            "lewis-perception",
            "lewis-emulators",
            "lewis-geometry",
            "lewis-images",
            "lewis-interfaces",
            "lewis-runtime",
        ],
    ),
    (
        "lewis-replay",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-mcap",
            "lewis-runtime",
            "lewis-recorder",
            "lewis-sequencer",
            "lewis-motion",
            "lewis-perception",
            "lewis-images",
            "lewis-drivers",
        ],
    ),
    (
        "lewis-viewer",
        &["lewis-stdx", "lewis-interfaces", "lewis-mcap"],
    ),
    // A robot run whole: it puts the broker, the recorder, a goal and a mission together
    // and owns none of their decisions; only the binary is above it.
    (
        "lewis-launch",
        &[
            "lewis-runtime",
            "lewis-recorder",
            "lewis-sequencer",
            "lewis-motion",
        ],
    ),
    // The sub-task programs: clients of interfaces only, never of a component's code.
    (
        "lewis-apps",
        &[
            "lewis-stdx",
            "lewis-geometry",
            "lewis-interfaces",
            "lewis-runtime",
        ],
    ),
    // The README's main job: a launch, a verdict and a replay put together.
    (
        "lewis-demo",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-runtime",
            "lewis-mcap",
            "lewis-recorder",
            "lewis-replay",
            "lewis-sequencer",
            "lewis-launch",
            "lewis-viewer",
        ],
    ),
    // The service test kit: on the runtime only, so a component's own tests can use it.
    ("lewis-testkit", &["lewis-interfaces", "lewis-runtime"]),
];

/// Outside crates that only some of ours may use: the mechanism lives in one place.
const ONLY_IN: &[(&str, &[&str], &str)] = &[
    ("rerun", &["lewis-viewer"], "only the viewer knows Rerun"),
    (
        "axum",
        &["lewis-pages"],
        "only lewis-pages serves HTTP: the pages use the axum it re-exports",
    ),
    (
        "iceoryx2",
        &["lewis-runtime"],
        "only the runtime knows iceoryx2",
    ),
    (
        "lewis-emulators",
        &["lewis-kinds", "lewis"],
        "the emulators and test services are for the lewis binary and tests, not for components",
    ),
    (
        "lewis-testkit",
        &["lewis-tests"],
        "lewis-testkit is a test-support crate: for dev-dependencies and the tests' helpers only",
    ),
    (
        "mcap",
        &["lewis-mcap", "lewis-recorder"],
        "only lewis-mcap reads MCAP files and only the recorder writes them",
    ),
];

fn violations(metadata: &serde_json::Value) -> Vec<String> {
    let mut deps: BTreeMap<String, Vec<(String, String)>> = BTreeMap::new();
    for package in metadata["packages"].as_array().into_iter().flatten() {
        let name = package["name"].as_str().unwrap_or_default().to_owned();
        for dep in package["dependencies"].as_array().into_iter().flatten() {
            let kind = dep["kind"].as_str().unwrap_or("normal").to_owned();
            let dep_name = dep["name"].as_str().unwrap_or_default().to_owned();
            deps.entry(name.clone()).or_default().push((dep_name, kind));
        }
    }
    let mut violations = Vec::new();
    for (krate, allowed) in ALLOWED {
        for (dep, kind) in deps.get(*krate).into_iter().flatten() {
            if dep.starts_with("lewis") && kind != "dev" && !allowed.contains(&dep.as_str()) {
                violations.push(format!(
                    "{krate} -> {dep}: {krate} may use only {allowed:?}"
                ));
            }
        }
    }
    for (outside, owners, why) in ONLY_IN {
        for (krate, list) in &deps {
            let uses = list
                .iter()
                .any(|(dep, kind)| dep == outside && kind != "dev");
            if uses && !owners.contains(&krate.as_str()) {
                violations.push(format!("{krate} -> {outside}: {why}"));
            }
        }
    }
    violations
}

#[test]
fn crates_depend_only_on_the_layers_below_them() {
    let output = Command::new(env!("CARGO"))
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(
        output.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let metadata: serde_json::Value =
        serde_json::from_slice(&output.stdout).expect("metadata is JSON");
    let found = violations(&metadata);
    assert!(
        found.is_empty(),
        "forbidden dependencies:\n{}",
        found.join("\n")
    );
}

#[test]
fn a_service_that_uses_the_recorder_or_rerun_is_named() {
    let metadata = serde_json::json!({"packages": [
        {"name": "lewis-motion", "dependencies": [
            {"name": "lewis-runtime", "kind": null},
            {"name": "lewis-recorder", "kind": null},
            {"name": "rerun", "kind": null},
            {"name": "mcap", "kind": "dev"},
        ]},
    ]});
    assert_eq!(
        violations(&metadata),
        [
            "lewis-motion -> lewis-recorder: lewis-motion may use only [\"lewis-stdx\", \"lewis-geometry\", \"lewis-interfaces\", \"lewis-runtime\"]",
            "lewis-motion -> rerun: only the viewer knows Rerun",
        ]
    );
}

#[test]
fn a_component_that_borrows_from_the_simulator_or_the_emulators_is_named() {
    let metadata = serde_json::json!({"packages": [
        {"name": "lewis-drivers", "dependencies": [
            {"name": "lewis-geometry", "kind": null},
            {"name": "lewis-sim", "kind": null},
        ]},
        {"name": "lewis-perception", "dependencies": [
            {"name": "lewis-emulators", "kind": null},
        ]},
        {"name": "lewis-tests", "dependencies": [
            {"name": "lewis-emulators", "kind": "dev"},
        ]},
    ]});
    assert_eq!(
        violations(&metadata),
        [
            "lewis-drivers -> lewis-sim: lewis-drivers may use only [\"lewis-stdx\", \"lewis-geometry\", \"lewis-images\", \"lewis-interfaces\", \"lewis-runtime\"]",
            "lewis-perception -> lewis-emulators: lewis-perception may use only [\"lewis-stdx\", \"lewis-geometry\", \"lewis-images\", \"lewis-interfaces\", \"lewis-runtime\"]",
            "lewis-perception -> lewis-emulators: the emulators and test services are for the lewis binary and tests, not for components",
        ]
    );
}

#[test]
fn a_crate_that_uses_the_test_kit_outside_its_tests_is_named() {
    let metadata = serde_json::json!({"packages": [
        {"name": "lewis-sim", "dependencies": [
            {"name": "lewis-runtime", "kind": null},
            {"name": "lewis-testkit", "kind": "dev"},
        ]},
        {"name": "lewis", "dependencies": [
            {"name": "lewis-testkit", "kind": null},
        ]},
        {"name": "lewis-testkit", "dependencies": [
            {"name": "lewis-sim", "kind": null},
        ]},
    ]});
    assert_eq!(
        violations(&metadata),
        [
            "lewis-testkit -> lewis-sim: lewis-testkit may use only [\"lewis-interfaces\", \"lewis-runtime\"]",
            "lewis -> lewis-testkit: lewis-testkit is a test-support crate: for dev-dependencies and the tests' helpers only",
        ]
    );
}
