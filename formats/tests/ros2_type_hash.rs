//! ROS 2's type hashes, as Lewis computes them from a bag's schemas, against the hashes
//! rosbag2 (Jazzy) wrote into the real recordings of `../shared/data/ros2/`: every type
//! of every bag (LaserScan, Imu, Odometry, NavSatFix) must agree.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::PathBuf;

use lewis_interfaces::dynamic::{MessageSchema, type_hash};

/// `type -> type_description_hash` from rosbag2's metadata (`serialized_metadata`, YAML):
/// each `type:` line is followed by its `type_description_hash:` and the hash.
fn recorded_hashes(yaml: &str) -> BTreeMap<String, String> {
    let mut hashes = BTreeMap::new();
    let mut current_type = None;
    let mut lines = yaml.lines().map(str::trim);
    while let Some(line) = lines.next() {
        if let Some(name) = line.strip_prefix("type: ") {
            current_type = Some(name.trim().to_owned());
        } else if let Some(rest) = line.strip_prefix("type_description_hash:") {
            let hash = match rest.trim() {
                "" => lines.next().unwrap_or_default().trim(),
                inline => inline,
            };
            if let Some(name) = current_type.take() {
                hashes.insert(name, hash.to_owned());
            }
        }
    }
    hashes
}

#[test]
fn every_type_of_the_real_bags_hashes_as_rosbag2_recorded_it() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/ros2");
    let mut checked = Vec::new();
    for name in [
        "hokuyo-scan-matcher-demo.mcap",
        "husky-outdoor-imu-odom-gps.mcap",
    ] {
        let path = dir.join(name);
        let bytes = std::fs::read(&path).unwrap_or_else(|e| {
            panic!(
                "missing test data {}: {e} (see ../shared/data/README.md)",
                path.display()
            )
        });
        let summary = mcap::read::Summary::read(&bytes).unwrap().unwrap();
        let mut recorded = BTreeMap::new();
        for index in &summary.metadata_indexes {
            let metadata = mcap::read::metadata(&bytes, index).unwrap();
            if let Some(yaml) = metadata.metadata.get("serialized_metadata") {
                recorded.extend(recorded_hashes(yaml));
            }
        }
        assert!(!recorded.is_empty(), "{name}: no type hash in its metadata");
        for schema in summary.schemas.values() {
            let Some(expected) = recorded.get(&schema.name) else {
                continue;
            };
            let text = std::str::from_utf8(&schema.data).unwrap();
            let parsed = MessageSchema::parse(&schema.name, text).unwrap();
            assert_eq!(
                type_hash(&parsed).as_deref(),
                Some(expected.as_str()),
                "{name}: {}",
                schema.name
            );
            checked.push(schema.name.clone());
        }
    }
    checked.sort();
    checked.dedup();
    assert_eq!(
        checked,
        [
            "nav_msgs/msg/Odometry",
            "sensor_msgs/msg/Imu",
            "sensor_msgs/msg/LaserScan",
            "sensor_msgs/msg/NavSatFix"
        ]
    );
}
