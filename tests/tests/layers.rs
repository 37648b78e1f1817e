//! The crate layers of ARCHITECTURE.md, enforced from `cargo metadata`: a crate that
//! depends on one it must not fails this test, which names the path. The rules:
//!
//! - **Every crate has an entry** in [`ALLOWED`], the crates of ours it may use (normal and
//!   build dependencies): a new crate cannot slip through without saying where it sits.
//! - **Some outside crates live in one place** ([`ONLY_IN`]): Rerun in the viewer, axum in
//!   the pages, iceoryx2 in the runtime, MCAP in the MCAP layer and the recorder, and
//!   **Zenoh** in the bridge (and the coming ROS 2 gateway), dev-dependencies included.
//! - **No IPC below the runtime** ([`NO_IPC`]): the components, the apps, the service model,
//!   the robot file, the registry of kinds, the ROS 2 mappings and the test kit do not
//!   reach `lewis-runtime` or iceoryx2 through their normal dependencies, directly or not:
//!   what `cargo tree -e normal -i iceoryx2` shows, as a test.
//! - **No dev-dependency cycle**: no crate (dev-)depends on a crate that depends on it,
//!   which would build its tests against a second copy of it and everything between.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::process::Command;

/// Which of our crates each crate of the workspace may use (normal and build dependencies;
/// a crate's own tests may use any crate that does not depend on it). Every crate of the
/// workspace has an entry.
const ALLOWED: &[(&str, &[&str])] = &[
    // What people type (positions, did-you-mean, durations): below everything.
    ("lewis-stdx", &[]),
    ("lewis-interfaces", &["lewis-stdx"]),
    // The robot file's model: read by the CLI, the bridge and the tools, without IPC.
    ("lewis-robot", &["lewis-stdx"]),
    // The service model (Service, Context, Backend, Health, the registry): without IPC, so
    // the components, the apps and the test kit do not link iceoryx2.
    (
        "lewis-service",
        &["lewis-stdx", "lewis-interfaces", "lewis-robot"],
    ),
    // IPC (iceoryx2), clients, the live harness, the broker, supervision.
    (
        "lewis-runtime",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-service",
        ],
    ),
    // The one MCAP reading layer: below everything that reads a recording.
    ("lewis-mcap", &["lewis-stdx"]),
    // The ROS 2 mappings both ways (pure functions over messages): below the recorder's
    // companions, the importers and the coming live ROS 2 gateway, which share them.
    (
        "lewis-ros2-map",
        &["lewis-stdx", "lewis-interfaces", "lewis-images"],
    ),
    // The one HTTP server of the pages served on localhost.
    ("lewis-pages", &[]),
    (
        "lewis-recorder",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-service",
            "lewis-mcap",
            "lewis-runtime",
            "lewis-ros2-map",
        ],
    ),
    // Recordings read back (the parts of a run in order, `lewis info`, `lewis play`): above
    // the recorder, whose channel description and parts index it reads, below everything
    // that reads a run.
    (
        "lewis-recording",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-mcap",
            "lewis-runtime",
            "lewis-recorder",
        ],
    ),
    (
        "lewis-sequencer",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-runtime",
            "lewis-pages",
        ],
    ),
    // The components: on the service model, not the runtime; shared vocabulary below all
    // of them, nothing borrowed sideways.
    (
        "lewis-geometry",
        &["lewis-stdx", "lewis-interfaces", "lewis-service"],
    ),
    ("lewis-images", &["lewis-stdx", "lewis-interfaces"]),
    (
        "lewis-sim",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-service",
            "lewis-geometry",
        ],
    ),
    (
        "lewis-drivers",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-service",
            "lewis-geometry",
            "lewis-images",
        ],
    ),
    (
        "lewis-motion",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-service",
            "lewis-geometry",
        ],
    ),
    (
        "lewis-perception",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-service",
            "lewis-geometry",
            "lewis-images",
        ],
    ),
    (
        "lewis-emulators",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-service",
            "lewis-geometry",
            "lewis-drivers",
            "lewis-sim",
        ],
    ),
    // The live ROS 2 gateway: a component (the service model, no runtime) that also uses
    // the ROS 2 mappings, the one place that knows DDS.
    (
        "lewis-ros2",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-service",
            "lewis-ros2-map",
        ],
    ),
    // The registry of every kind, above all the components that have kinds.
    (
        "lewis-kinds",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-service",
            "lewis-sim",
            "lewis-drivers",
            "lewis-motion",
            "lewis-perception",
            "lewis-emulators",
            "lewis-ros2",
        ],
    ),
    (
        "lewis-replay",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-service",
            "lewis-mcap",
            "lewis-runtime",
            "lewis-recorder",
            "lewis-recording",
            "lewis-sequencer",
            // The sub-task programs a mission lived again runs (`lockstep::AppPrograms`).
            "lewis-apps",
            // The sweep plot's font and PNG encoding (`lewis_images::plot`).
            "lewis-images",
        ],
    ),
    // The regression suite (`lewis test`): replay as a library, other software's logs
    // imported through the formats; no viewer (the binary passes a picture drawer).
    (
        "lewis-suite",
        &[
            "lewis-stdx",
            "lewis-service",
            "lewis-recorder",
            "lewis-recording",
            "lewis-replay",
            "lewis-formats",
        ],
    ),
    // Other robot software's logs in and out: above the recorder (it writes through it) and
    // the recording reader (it reads through it), with the ROS 2 mappings and the components
    // an import runs; not replay.
    (
        "lewis-formats",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-mcap",
            "lewis-runtime",
            "lewis-recorder",
            "lewis-recording",
            "lewis-ros2-map",
            "lewis-motion",
            "lewis-perception",
        ],
    ),
    // A simulator world rebuilt from a real run's scans (`lewis world`): runs read through
    // the recording reader and the importers, worlds loaded and ray cast by the simulator.
    (
        "lewis-rebuild",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-mcap",
            "lewis-runtime",
            "lewis-recorder",
            "lewis-recording",
            "lewis-ros2-map",
            "lewis-motion",
            "lewis-perception",
            "lewis-formats",
            "lewis-service",
            "lewis-geometry",
            "lewis-sim",
            // The check's plots: their font and PNG encoding (`lewis_images::plot`).
            "lewis-images",
        ],
    ),
    // The tuning workbench behind `lewis tune`.
    (
        "lewis-tune",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-geometry",
            "lewis-images",
            "lewis-perception",
            "lewis-sim",
            "lewis-recording",
            "lewis-recorder",
            "lewis-pages",
        ],
    ),
    (
        "lewis-viewer",
        &["lewis-stdx", "lewis-interfaces", "lewis-mcap"],
    ),
    // The sub-task programs: clients of interfaces through the service model, never of a
    // component's code but the shared geometry, and without IPC.
    (
        "lewis-apps",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-service",
            "lewis-geometry",
        ],
    ),
    // A robot run whole: it puts the broker, the recorder, a goal, the apps and a mission
    // together and owns none of their decisions; only the binary is above it.
    (
        "lewis-launch",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-service",
            "lewis-runtime",
            "lewis-recorder",
            "lewis-sequencer",
            "lewis-motion",
            "lewis-apps",
        ],
    ),
    // The robot's hosts as one system over Zenoh: the robot file and the runtime's names
    // and IPC, not the recorder.
    (
        "lewis-bridge",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-runtime",
        ],
    ),
    // The README's main job: a launch, a verdict and a replay put together.
    (
        "lewis-demo",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-service",
            "lewis-runtime",
            "lewis-recorder",
            "lewis-recording",
            "lewis-replay",
            "lewis-sequencer",
            "lewis-launch",
            // The chaos picture's font and PNG encoding (`lewis_images::plot`).
            "lewis-images",
            // The mission bench draws start poses and walking people in the simulated
            // world.
            "lewis-sim",
            "lewis-geometry",
        ],
    ),
    // The test kit: below the runtime, so a component's own tests, and the tests of the
    // crates the end-to-end tests use, can use it.
    (
        "lewis-testkit",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-service",
        ],
    ),
    // The end-to-end tests' helpers (their tests may use anything).
    (
        "lewis-tests",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-runtime",
            "lewis-testkit",
        ],
    ),
    // The binary: on top. The components it names directly: the emulators (with geometry's
    // poses) for `lewis fake-device`, motion's goal for `lewis up --goal`.
    (
        "lewis",
        &[
            "lewis-stdx",
            "lewis-interfaces",
            "lewis-robot",
            "lewis-service",
            "lewis-runtime",
            "lewis-recorder",
            "lewis-recording",
            "lewis-replay",
            "lewis-formats",
            "lewis-suite",
            "lewis-tune",
            "lewis-sequencer",
            "lewis-pages",
            "lewis-geometry",
            "lewis-motion",
            "lewis-emulators",
            "lewis-kinds",
            "lewis-launch",
            "lewis-apps",
            "lewis-bridge",
            "lewis-demo",
            "lewis-viewer",
            "lewis-rebuild",
            "lewis-sim",
        ],
    ),
    // A team's own kind and binary (the guide's how-to): what such a crate uses, no more.
    (
        "lewis-example-front-clearance",
        &["lewis-interfaces", "lewis-service", "lewis-kinds", "lewis"],
    ),
];

/// An outside crate (or one of ours) that only some crates may depend on: the mechanism
/// lives in one place.
struct OnlyIn {
    /// The crate depended on.
    krate: &'static str,
    /// The crates that may depend on it.
    owners: &'static [&'static str],
    /// Whether a dev-dependency counts too (else normal and build dependencies only).
    dev_too: bool,
    /// Why, said with a violation.
    why: &'static str,
}

const ONLY_IN: &[OnlyIn] = &[
    OnlyIn {
        krate: "rerun",
        owners: &["lewis-viewer"],
        dev_too: false,
        why: "only the viewer knows Rerun",
    },
    OnlyIn {
        krate: "axum",
        owners: &["lewis-pages"],
        dev_too: false,
        why: "only lewis-pages serves HTTP: the pages use the axum it re-exports",
    },
    OnlyIn {
        krate: "iceoryx2",
        owners: &["lewis-runtime"],
        dev_too: false,
        why: "only the runtime knows iceoryx2",
    },
    OnlyIn {
        krate: "zenoh",
        // `lewis-ros2`: the coming ROS 2 gateway, for `rmw_zenoh`.
        owners: &["lewis-bridge", "lewis-ros2"],
        dev_too: true,
        why: "only the bridge (and the ROS 2 gateway) knows Zenoh, in its tests and benchmarks too",
    },
    OnlyIn {
        krate: "rustdds",
        owners: &["lewis-ros2"],
        dev_too: true,
        why: "only the ROS 2 gateway knows DDS",
    },
    OnlyIn {
        krate: "lewis-emulators",
        owners: &["lewis-kinds", "lewis"],
        dev_too: false,
        why: "the emulators and test services are for the lewis binary and tests, not for components",
    },
    OnlyIn {
        krate: "lewis-testkit",
        owners: &["lewis-tests"],
        dev_too: false,
        why: "lewis-testkit is a test-support crate: for dev-dependencies and the tests' helpers only",
    },
    OnlyIn {
        krate: "mcap",
        owners: &["lewis-mcap", "lewis-recorder"],
        dev_too: false,
        why: "only lewis-mcap reads MCAP files and only the recorder writes them",
    },
];

/// The crates that must not reach IPC through their normal dependencies, directly or not.
const NO_IPC: &[&str] = &[
    "lewis-stdx",
    "lewis-interfaces",
    "lewis-robot",
    "lewis-service",
    "lewis-mcap",
    "lewis-ros2-map",
    "lewis-geometry",
    "lewis-images",
    "lewis-sim",
    "lewis-drivers",
    "lewis-emulators",
    "lewis-motion",
    "lewis-perception",
    "lewis-ros2",
    "lewis-kinds",
    "lewis-apps",
    "lewis-testkit",
];

/// What [`NO_IPC`]'s crates must not reach.
const IPC: &[&str] = &["lewis-runtime", "iceoryx2"];

/// The kind of a dependency, as `cargo metadata` says it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Normal,
    Dev,
    Build,
}

/// Each package of the metadata (the workspace's, with `--no-deps`) with its dependencies,
/// in the metadata's order.
struct Graph {
    packages: Vec<(String, Vec<(String, Kind)>)>,
}

impl Graph {
    fn new(metadata: &serde_json::Value) -> Self {
        let packages = metadata["packages"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|package| {
                let name = package["name"].as_str().unwrap_or_default().to_owned();
                let deps = package["dependencies"]
                    .as_array()
                    .into_iter()
                    .flatten()
                    .map(|dep| {
                        let kind = match dep["kind"].as_str() {
                            Some("dev") => Kind::Dev,
                            Some("build") => Kind::Build,
                            _ => Kind::Normal,
                        };
                        (dep["name"].as_str().unwrap_or_default().to_owned(), kind)
                    })
                    .collect();
                (name, deps)
            })
            .collect();
        Self { packages }
    }

    /// The normal and build dependencies of `krate` (none for an outside crate).
    fn linked(&self, krate: &str) -> impl Iterator<Item = &str> {
        self.packages
            .iter()
            .filter(move |(name, _)| name == krate)
            .flat_map(|(_, deps)| deps)
            .filter(|(_, kind)| *kind != Kind::Dev)
            .map(|(dep, _)| dep.as_str())
    }

    /// The shortest path `from -> ... -> to` over normal and build dependencies, if `to` is
    /// reached at all.
    fn path(&self, from: &str, to: &str) -> Option<Vec<String>> {
        let mut parent: BTreeMap<&str, &str> = BTreeMap::new();
        let mut seen = BTreeSet::from([from]);
        let mut queue = VecDeque::from([from]);
        while let Some(krate) = queue.pop_front() {
            if krate == to {
                let mut path = vec![to.to_owned()];
                let mut at = to;
                while let Some(up) = parent.get(at) {
                    path.push((*up).to_owned());
                    at = up;
                }
                path.reverse();
                return Some(path);
            }
            for dep in self.linked(krate) {
                if seen.insert(dep) {
                    parent.insert(dep, krate);
                    queue.push_back(dep);
                }
            }
        }
        None
    }
}

fn violations(metadata: &serde_json::Value) -> Vec<String> {
    let graph = Graph::new(metadata);
    let allowed: BTreeMap<&str, &[&str]> = ALLOWED.iter().copied().collect();
    let mut violations = Vec::new();
    for (krate, deps) in &graph.packages {
        let Some(allowed) = allowed.get(krate.as_str()) else {
            violations.push(format!(
                "{krate}: no entry in ALLOWED (tests/tests/layers.rs): say which of our crates it may use"
            ));
            continue;
        };
        for (dep, kind) in deps {
            if dep.starts_with("lewis") && *kind != Kind::Dev && !allowed.contains(&dep.as_str()) {
                violations.push(format!(
                    "{krate} -> {dep}: {krate} may use only {allowed:?}"
                ));
            }
        }
    }
    for rule in ONLY_IN {
        for (krate, deps) in &graph.packages {
            for (dep, kind) in deps {
                let counts = *kind != Kind::Dev || rule.dev_too;
                if dep == rule.krate && counts && !rule.owners.contains(&krate.as_str()) {
                    let dev = if *kind == Kind::Dev { " (dev)" } else { "" };
                    violations.push(format!("{krate} ->{dev} {dep}: {}", rule.why));
                }
            }
        }
    }
    for krate in NO_IPC {
        for ipc in IPC {
            if let Some(path) = graph.path(krate, ipc).filter(|p| p.len() > 1) {
                violations.push(format!(
                    "{}: {krate} must not reach IPC (the runtime, iceoryx2), not even through another crate",
                    path.join(" -> ")
                ));
            }
        }
    }
    for (krate, deps) in &graph.packages {
        for (dep, kind) in deps {
            if let Some(back) = graph.path(dep, krate) {
                let dev = if *kind == Kind::Dev { " (dev)" } else { "" };
                violations.push(format!(
                    "{krate} ->{dev} {}: a dependency cycle, {krate}'s tests would build a second {krate}",
                    back.join(" -> ")
                ));
            }
        }
    }
    violations
}

/// The workspace's crates with their dependencies.
fn workspace_metadata() -> serde_json::Value {
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
    serde_json::from_slice(&output.stdout).expect("metadata is JSON")
}

#[test]
fn crates_depend_only_on_the_layers_below_them() {
    let found = violations(&workspace_metadata());
    assert!(
        found.is_empty(),
        "forbidden dependencies:\n{}",
        found.join("\n")
    );
}

#[test]
fn every_entry_of_the_rules_names_a_crate_of_the_workspace() {
    let metadata = workspace_metadata();
    let graph = Graph::new(&metadata);
    let ours: BTreeSet<&str> = graph.packages.iter().map(|(n, _)| n.as_str()).collect();
    let stale: Vec<&str> = ALLOWED
        .iter()
        .flat_map(|(krate, allowed)| std::iter::once(krate).chain(allowed.iter()))
        .chain(NO_IPC)
        .copied()
        .filter(|krate| !ours.contains(krate))
        .collect();
    assert!(
        stale.is_empty(),
        "ALLOWED or NO_IPC name crates that are not in the workspace: {stale:?}"
    );
}

#[test]
fn a_crate_without_an_entry_is_named() {
    let metadata = serde_json::json!({"packages": [
        {"name": "lewis-stdx", "dependencies": []},
        {"name": "lewis-new", "dependencies": [
            {"name": "lewis-stdx", "kind": null},
        ]},
    ]});
    assert_eq!(
        violations(&metadata),
        [
            "lewis-new: no entry in ALLOWED (tests/tests/layers.rs): say which of our crates it may use"
        ]
    );
}

#[test]
fn a_service_that_uses_the_recorder_or_rerun_is_named() {
    let metadata = serde_json::json!({"packages": [
        {"name": "lewis-motion", "dependencies": [
            {"name": "lewis-service", "kind": null},
            {"name": "lewis-recorder", "kind": null},
            {"name": "rerun", "kind": null},
            {"name": "mcap", "kind": "dev"},
        ]},
    ]});
    assert_eq!(
        violations(&metadata),
        [
            "lewis-motion -> lewis-recorder: lewis-motion may use only [\"lewis-stdx\", \"lewis-interfaces\", \"lewis-robot\", \"lewis-service\", \"lewis-geometry\"]",
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
            "lewis-drivers -> lewis-sim: lewis-drivers may use only [\"lewis-stdx\", \"lewis-interfaces\", \"lewis-robot\", \"lewis-service\", \"lewis-geometry\", \"lewis-images\"]",
            "lewis-perception -> lewis-emulators: lewis-perception may use only [\"lewis-stdx\", \"lewis-interfaces\", \"lewis-service\", \"lewis-geometry\", \"lewis-images\"]",
            "lewis-perception -> lewis-emulators: the emulators and test services are for the lewis binary and tests, not for components",
        ]
    );
}

#[test]
fn a_crate_that_uses_the_test_kit_outside_its_tests_is_named() {
    let metadata = serde_json::json!({"packages": [
        {"name": "lewis-sim", "dependencies": [
            {"name": "lewis-service", "kind": null},
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
            "lewis -> lewis-testkit: lewis may use only [\"lewis-stdx\", \"lewis-interfaces\", \"lewis-robot\", \"lewis-service\", \"lewis-runtime\", \"lewis-recorder\", \"lewis-recording\", \"lewis-replay\", \"lewis-formats\", \"lewis-suite\", \"lewis-tune\", \"lewis-sequencer\", \"lewis-pages\", \"lewis-geometry\", \"lewis-motion\", \"lewis-emulators\", \"lewis-kinds\", \"lewis-launch\", \"lewis-apps\", \"lewis-bridge\", \"lewis-demo\", \"lewis-viewer\", \"lewis-rebuild\", \"lewis-sim\"]",
            "lewis-testkit -> lewis-sim: lewis-testkit may use only [\"lewis-stdx\", \"lewis-interfaces\", \"lewis-robot\", \"lewis-service\"]",
            "lewis -> lewis-testkit: lewis-testkit is a test-support crate: for dev-dependencies and the tests' helpers only",
            "lewis-sim -> (dev) lewis-testkit -> lewis-sim: a dependency cycle, lewis-sim's tests would build a second lewis-sim",
        ]
    );
}

#[test]
fn a_crate_below_the_runtime_that_reaches_iceoryx2_through_another_is_named() {
    // The service model uses the runtime (forbidden in itself), and so every component
    // on it reaches iceoryx2: each is named with its path. A dev-dependency on the runtime
    // (a component's test against live IPC) reaches nothing.
    let metadata = serde_json::json!({"packages": [
        {"name": "lewis-runtime", "dependencies": [
            {"name": "iceoryx2", "kind": null},
        ]},
        {"name": "lewis-service", "dependencies": [
            {"name": "lewis-runtime", "kind": null},
        ]},
        {"name": "lewis-motion", "dependencies": [
            {"name": "lewis-service", "kind": null},
        ]},
        {"name": "lewis-sim", "dependencies": [
            {"name": "lewis-runtime", "kind": "dev"},
        ]},
    ]});
    assert_eq!(
        violations(&metadata),
        [
            "lewis-service -> lewis-runtime: lewis-service may use only [\"lewis-stdx\", \"lewis-interfaces\", \"lewis-robot\"]",
            "lewis-service -> lewis-runtime: lewis-service must not reach IPC (the runtime, iceoryx2), not even through another crate",
            "lewis-service -> lewis-runtime -> iceoryx2: lewis-service must not reach IPC (the runtime, iceoryx2), not even through another crate",
            "lewis-motion -> lewis-service -> lewis-runtime: lewis-motion must not reach IPC (the runtime, iceoryx2), not even through another crate",
            "lewis-motion -> lewis-service -> lewis-runtime -> iceoryx2: lewis-motion must not reach IPC (the runtime, iceoryx2), not even through another crate",
        ]
    );
}

#[test]
fn a_crate_other_than_the_bridge_that_uses_zenoh_even_in_its_tests_is_named() {
    let metadata = serde_json::json!({"packages": [
        {"name": "lewis-bridge", "dependencies": [
            {"name": "zenoh", "kind": null},
        ]},
        {"name": "lewis-tests", "dependencies": [
            {"name": "zenoh", "kind": "dev"},
        ]},
        {"name": "lewis-recorder", "dependencies": [
            {"name": "zenoh", "kind": null},
        ]},
    ]});
    assert_eq!(
        violations(&metadata),
        [
            "lewis-tests -> (dev) zenoh: only the bridge (and the ROS 2 gateway) knows Zenoh, in its tests and benchmarks too",
            "lewis-recorder -> zenoh: only the bridge (and the ROS 2 gateway) knows Zenoh, in its tests and benchmarks too",
        ]
    );
}

#[test]
fn a_crate_whose_tests_use_a_crate_above_it_is_named_with_the_cycle() {
    // What the recorder's tests did: they used the end-to-end tests' helpers, which used
    // the bridge, which used the recorder.
    let metadata = serde_json::json!({"packages": [
        {"name": "lewis-recorder", "dependencies": [
            {"name": "lewis-tests", "kind": "dev"},
        ]},
        {"name": "lewis-tests", "dependencies": [
            {"name": "lewis-bridge", "kind": null},
        ]},
        {"name": "lewis-bridge", "dependencies": [
            {"name": "lewis-runtime", "kind": null},
            {"name": "lewis-recorder", "kind": null},
        ]},
    ]});
    assert_eq!(
        violations(&metadata),
        [
            "lewis-tests -> lewis-bridge: lewis-tests may use only [\"lewis-stdx\", \"lewis-interfaces\", \"lewis-runtime\", \"lewis-testkit\"]",
            "lewis-bridge -> lewis-recorder: lewis-bridge may use only [\"lewis-stdx\", \"lewis-interfaces\", \"lewis-robot\", \"lewis-runtime\"]",
            "lewis-recorder -> (dev) lewis-tests -> lewis-bridge -> lewis-recorder: a dependency cycle, lewis-recorder's tests would build a second lewis-recorder",
        ]
    );
}
