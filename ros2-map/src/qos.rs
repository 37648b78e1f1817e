//! ROS 2's QoS profiles: what a robot file asks of a topic Lewis reads or writes live
//! (by ROS 2's names, `reliability = "best-effort"`), and what a channel's publisher
//! offers, as MCAP's `ros2` profile requires it on every channel (`offered_qos_profiles`, a YAML list of rosbag2's profile records), so that
//! `ros2 bag play` republishes each topic as its publisher did: `/tf_static` and
//! `/robot_description` transient local (RViz reads them once, at start), the rest
//! reliable and volatile.
//!
//! The policies are written as rosbag2 writes them for Humble, as integer codes (rmw's
//! enums): Humble reads only those, later distributions read them too. Durations are
//! rmw's "infinite" (`sec: 9223372036`, `nsec: 854775807`), as Iron and later write it.

use std::fmt::Write as _;

use serde::Deserialize;

/// The MCAP channel metadata key of the ROS 2 profile.
pub const OFFERED_QOS_PROFILES: &str = "offered_qos_profiles";

/// Whether a publisher resends what a subscriber missed (rmw's `reliability`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Reliability {
    /// Resent until received (the rmw code 1).
    Reliable,
    /// Sent once (the rmw code 2): sensor drivers' default.
    BestEffort,
}

/// Whether a late subscriber gets what was published before it joined (rmw's
/// `durability`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Durability {
    /// The last `depth` messages are kept for late subscribers (the rmw code 1).
    TransientLocal,
    /// Only what is published after a subscriber joined (the rmw code 2).
    Volatile,
}

/// One publisher's offered QoS: the policies a subscriber must be compatible with, and its
/// history depth (keep last). In a robot file, each key left out is [`QosProfile::DEFAULT`]'s.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct QosProfile {
    /// Reliable or best effort.
    pub reliability: Reliability,
    /// Volatile or transient local.
    pub durability: Durability,
    /// How many messages the publisher keeps (history keep last).
    pub depth: u32,
}

impl Default for QosProfile {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl QosProfile {
    /// Reliable, volatile, the last 10: rclcpp's default, and what a Lewis topic offers
    /// (Lewis's IPC loses nothing that a subscriber keeps up with). A reliable publisher
    /// matches reliable and best-effort subscribers alike.
    pub const DEFAULT: Self = Self {
        reliability: Reliability::Reliable,
        durability: Durability::Volatile,
        depth: 10,
    };

    /// Reliable, transient local, the last 1: `/tf_static` as tf2's static broadcaster
    /// offers it, and `/robot_description` as robot_state_publisher does.
    pub const LATCHED: Self = Self {
        reliability: Reliability::Reliable,
        durability: Durability::TransientLocal,
        depth: 1,
    };

    /// Best effort, volatile, the last 5: rclcpp's sensor-data profile, what a ROS 2
    /// driver's LaserScan or Image usually offers.
    pub const SENSOR_DATA: Self = Self {
        reliability: Reliability::BestEffort,
        durability: Durability::Volatile,
        depth: 5,
    };

    /// What a Lewis recording offers on `topic`: latched for the topics ROS 2 tools read
    /// once, the default for the rest.
    #[must_use]
    pub fn for_topic(topic: &str) -> Self {
        if is_latched_topic(topic) {
            Self::LATCHED
        } else {
            Self::DEFAULT
        }
    }

    /// This profile as the value of [`OFFERED_QOS_PROFILES`]: a YAML list of one.
    #[must_use]
    pub fn to_offered_qos_profiles(&self) -> String {
        offered_qos_profiles(std::slice::from_ref(self))
    }
}

/// Whether ROS 2 publishes `topic` latched (transient local): tf's static transforms and
/// the robot's URDF, with or without a namespace in front.
#[must_use]
pub fn is_latched_topic(topic: &str) -> bool {
    let name = topic.rsplit('/').next().unwrap_or(topic);
    name == "tf_static" || name == "robot_description"
}

/// Profiles as the value of [`OFFERED_QOS_PROFILES`]: a YAML list with one record per
/// publisher, each record's keys in rosbag2's order.
#[must_use]
pub fn offered_qos_profiles(profiles: &[QosProfile]) -> String {
    let mut text = String::new();
    for (i, profile) in profiles.iter().enumerate() {
        if i > 0 {
            text.push('\n');
        }
        let reliability = match profile.reliability {
            Reliability::Reliable => 1,
            Reliability::BestEffort => 2,
        };
        let durability = match profile.durability {
            Durability::TransientLocal => 1,
            Durability::Volatile => 2,
        };
        // history 1 is keep last; liveliness 1 is automatic.
        let _ = write!(
            text,
            "- history: 1\n  depth: {depth}\n  reliability: {reliability}\n  \
             durability: {durability}\n{deadline}{lifespan}  liveliness: 1\n\
             {lease}  avoid_ros_namespace_conventions: false",
            depth = profile.depth,
            deadline = infinite("deadline"),
            lifespan = infinite("lifespan"),
            lease = infinite("liveliness_lease_duration"),
        );
    }
    if profiles.is_empty() {
        text.push_str("[]");
    }
    text
}

/// A duration policy left unset: rmw's infinite duration (`i64::MAX` nanoseconds).
fn infinite(key: &str) -> String {
    format!("  {key}:\n    sec: 9223372036\n    nsec: 854775807\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn static_transforms_and_the_urdf_are_latched_and_the_rest_is_not() {
        for topic in ["/tf_static", "/robot_description", "/tb4/tf_static"] {
            assert_eq!(QosProfile::for_topic(topic), QosProfile::LATCHED, "{topic}");
        }
        for topic in ["/tf", "/scan", "/laser/RangeFinder", "/tf_static_extra"] {
            assert_eq!(QosProfile::for_topic(topic), QosProfile::DEFAULT, "{topic}");
        }
    }

    #[test]
    fn a_profile_is_written_as_rosbag2_writes_it() {
        expect_test::expect![[r#"
            - history: 1
              depth: 1
              reliability: 1
              durability: 1
              deadline:
                sec: 9223372036
                nsec: 854775807
              lifespan:
                sec: 9223372036
                nsec: 854775807
              liveliness: 1
              liveliness_lease_duration:
                sec: 9223372036
                nsec: 854775807
              avoid_ros_namespace_conventions: false"#]]
        .assert_eq(&QosProfile::LATCHED.to_offered_qos_profiles());
    }

    #[test]
    fn several_publishers_are_several_records_and_none_is_an_empty_list() {
        let text = offered_qos_profiles(&[QosProfile::SENSOR_DATA, QosProfile::DEFAULT]);
        assert_eq!(text.matches("- history: 1\n").count(), 2);
        assert!(text.contains("  depth: 5\n  reliability: 2\n  durability: 2\n"));
        assert!(text.contains("\n- history: 1\n  depth: 10\n  reliability: 1\n"));
        assert_eq!(offered_qos_profiles(&[]), "[]");
    }
}
