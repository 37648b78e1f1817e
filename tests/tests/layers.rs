//! The crate layers of DESIGN.md, enforced from `cargo metadata`: a crate that depends on
//! one it must not fails this test, which names the path.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::process::Command;

/// Which of our crates each crate may use (normal and build dependencies).
const ALLOWED: &[(&str, &[&str])] = &[
    ("lewis-interfaces", &[]),
    ("lewis-mcap", &[]),
    ("lewis-runtime", &["lewis-interfaces"]),
    (
        "lewis-recorder",
        &["lewis-interfaces", "lewis-mcap", "lewis-runtime"],
    ),
    ("lewis-sequencer", &["lewis-interfaces", "lewis-runtime"]),
    ("lewis-services", &["lewis-interfaces", "lewis-runtime"]),
    (
        "lewis-replay",
        &[
            "lewis-interfaces",
            "lewis-mcap",
            "lewis-runtime",
            "lewis-recorder",
            "lewis-sequencer",
            "lewis-services",
        ],
    ),
    ("lewis-viewer", &["lewis-interfaces", "lewis-mcap"]),
];

/// Outside crates that only some of ours may use: the mechanism lives in one place.
const ONLY_IN: &[(&str, &[&str], &str)] = &[
    ("rerun", &["lewis-viewer"], "only the viewer knows Rerun"),
    (
        "iceoryx2",
        &["lewis-runtime"],
        "only the runtime knows iceoryx2",
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
            if uses && !owners.contains(&krate.as_str()) && krate != "lewis" {
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
        {"name": "lewis-services", "dependencies": [
            {"name": "lewis-runtime", "kind": null},
            {"name": "lewis-recorder", "kind": null},
            {"name": "rerun", "kind": null},
            {"name": "mcap", "kind": "dev"},
        ]},
    ]});
    assert_eq!(
        violations(&metadata),
        [
            "lewis-services -> lewis-recorder: lewis-services may use only [\"lewis-interfaces\", \"lewis-runtime\"]",
            "lewis-services -> rerun: only the viewer knows Rerun",
        ]
    );
}
