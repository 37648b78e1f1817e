//! Which topics of a bag become which Lewis interface: by type when the bag has one topic
//! of a type, by `--map TOPIC=INTERFACE` otherwise. With several candidates and no map, the
//! import stops and lists them (counts, rates) with the `--map` to write: it runs in
//! scripts, so it never asks.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use super::bag::Topic;

/// The Lewis interfaces a bag's topics can be mapped to.
pub const MAPPABLE: &[&str] = &["RangeFinder", "Egomotion", "ImageSource"];

/// What the import makes of a topic's type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Role {
    /// `sensor_msgs/LaserScan`: a RangeFinder.
    Laser,
    /// `nav_msgs/Odometry`: Egomotion.
    Odometry,
    /// `tf2_msgs/TFMessage`: Egomotion from its odom to base transforms, when the bag has
    /// no Odometry.
    Tf,
    /// `sensor_msgs/Image`: an ImageSource.
    Image,
    /// `sensor_msgs/CompressedImage`: an ImageSource.
    CompressedImage,
}

impl Role {
    /// The role of a topic, by its type.
    #[must_use]
    pub fn of(topic: &Topic) -> Option<Self> {
        if !topic.is_ros2() {
            return None;
        }
        match topic.short_type().as_str() {
            "sensor_msgs/LaserScan" => Some(Self::Laser),
            "nav_msgs/Odometry" => Some(Self::Odometry),
            "tf2_msgs/TFMessage" => Some(Self::Tf),
            "sensor_msgs/Image" => Some(Self::Image),
            "sensor_msgs/CompressedImage" => Some(Self::CompressedImage),
            _ => None,
        }
    }

    /// The interface it becomes.
    #[must_use]
    pub fn interface(self) -> &'static str {
        match self {
            Self::Laser => "RangeFinder",
            Self::Odometry | Self::Tf => "Egomotion",
            Self::Image | Self::CompressedImage => "ImageSource",
        }
    }
}

/// A topic of the bag with its message count and times (from a first pass).
#[derive(Debug, Clone, PartialEq)]
pub struct TopicStats {
    /// The topic.
    pub topic: Topic,
    /// Its messages.
    pub count: u64,
    /// Log time of its first and last message, in ns.
    pub span_ns: Option<(u64, u64)>,
}

impl TopicStats {
    /// Messages per second, when there are two or more over a positive span.
    #[must_use]
    pub fn rate_hz(&self) -> Option<f64> {
        rate_hz(self.count, self.span_ns)
    }

    fn line(&self) -> String {
        format!(
            "{} ({}): {} messages{}",
            self.topic.name,
            self.topic.type_name,
            self.count,
            self.rate_hz()
                .map(|r| format!(" at {r:.1} Hz"))
                .unwrap_or_default()
        )
    }
}

/// Messages per second of `count` messages from the first log time of `span_ns` to the
/// last, when there are two or more over a positive span.
#[must_use]
pub fn rate_hz(count: u64, span_ns: Option<(u64, u64)>) -> Option<f64> {
    let (first, last) = span_ns?;
    // Counts and spans of real bags are far below 2^53.
    (count >= 2 && last > first).then(|| (count - 1) as f64 * 1e9 / (last - first) as f64)
}

/// The topics chosen for each interface.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Choice {
    /// The laser (RangeFinder).
    pub laser: Option<String>,
    /// A second range sensor (RangeFinder), the laser's fallback.
    pub second_laser: Option<String>,
    /// Egomotion: an Odometry topic, or a TF topic.
    pub odometry: Option<(String, Role)>,
    /// The camera (ImageSource), raw or compressed.
    pub image: Option<(String, Role)>,
}

/// Why the topics could not be chosen.
#[derive(Debug, thiserror::Error)]
pub enum ChoiceError {
    /// Several topics could be the one of an interface.
    #[error("{}: {}", path.display(), text)]
    Ambiguous {
        /// The bag.
        path: PathBuf,
        /// The candidates and the `--map` to write.
        text: String,
    },
    /// A `--map` names what the bag does not have.
    #[error("{}: --map {map}: {reason}", path.display())]
    BadMap {
        /// The bag.
        path: PathBuf,
        /// The map as given.
        map: String,
        /// What is wrong.
        reason: String,
    },
}

/// Chooses the topics of `bag` (`topics` in channel order) for each interface, with the
/// user's maps (topic, interface) first.
///
/// # Errors
/// A map names an unknown topic, an interface the topic's type cannot become, or a topic
/// twice; or several topics could be one interface and no map says which.
pub fn choose(
    path: &std::path::Path,
    topics: &[TopicStats],
    maps: &[(String, String)],
) -> Result<Choice, ChoiceError> {
    let mut choice = Choice::default();
    let by_name: BTreeMap<&str, &TopicStats> =
        topics.iter().map(|t| (t.topic.name.as_str(), t)).collect();
    let mut mapped: BTreeMap<&str, Vec<(&str, Role)>> = BTreeMap::new();
    for (topic, interface) in maps {
        let bad = |reason: String| ChoiceError::BadMap {
            path: path.to_owned(),
            map: format!("{topic}={interface}"),
            reason,
        };
        let Some(stats) = by_name.get(topic.as_str()) else {
            let names: Vec<&str> = by_name.keys().copied().collect();
            return Err(bad(format!(
                "the bag has no topic `{topic}`{}",
                lewis_stdx::closest(topic, names.iter().copied())
                    .map(|c| format!(" (did you mean `{c}`?)"))
                    .unwrap_or_default()
            )));
        };
        let role = Role::of(&stats.topic).filter(|r| r.interface() == interface);
        let Some(role) = role else {
            return Err(bad(format!(
                "{} messages do not become {interface} (give one of {}: LaserScan to RangeFinder, Odometry or TF to Egomotion, Image or CompressedImage to ImageSource)",
                stats.topic.type_name,
                MAPPABLE.join(", ")
            )));
        };
        if mapped.values().flatten().any(|(t, _)| t == topic) {
            return Err(bad(format!("`{topic}` is mapped twice")));
        }
        mapped
            .entry(role.interface())
            .or_default()
            .push((stats.topic.name.as_str(), role));
    }
    let candidates = |roles: &[Role]| -> Vec<&TopicStats> {
        topics
            .iter()
            .filter(|t| Role::of(&t.topic).is_some_and(|r| roles.contains(&r)) && t.count > 0)
            .collect()
    };
    let mut ambiguous = String::new();
    // RangeFinder: one or two maps (the second is the fallback), or the only LaserScan.
    match mapped.get("RangeFinder").map(Vec::as_slice) {
        Some([first, rest @ ..]) => {
            choice.laser = Some(first.0.to_owned());
            if let Some((second, _)) = rest.first() {
                choice.second_laser = Some((*second).to_owned());
            }
            if rest.len() > 1 {
                return Err(ChoiceError::BadMap {
                    path: path.to_owned(),
                    map: "TOPIC=RangeFinder".to_owned(),
                    reason: "at most two range sensors: the laser, then its fallback".to_owned(),
                });
            }
        }
        _ => match candidates(&[Role::Laser]).as_slice() {
            [] => {}
            [one] => choice.laser = Some(one.topic.name.clone()),
            many => list(&mut ambiguous, "RangeFinder", "LaserScan", many),
        },
    }
    match mapped.get("Egomotion").map(Vec::as_slice) {
        Some([(topic, role)]) => choice.odometry = Some(((*topic).to_owned(), *role)),
        Some(_) => {
            return Err(ChoiceError::BadMap {
                path: path.to_owned(),
                map: "TOPIC=Egomotion".to_owned(),
                reason: "one topic gives Egomotion".to_owned(),
            });
        }
        None => match candidates(&[Role::Odometry]).as_slice() {
            [one] => choice.odometry = Some((one.topic.name.clone(), Role::Odometry)),
            [] => {
                // TF only when there is no Odometry: `/tf` if present, else the only one.
                let tf = candidates(&[Role::Tf]);
                let pick = tf
                    .iter()
                    .find(|t| t.topic.name == "/tf")
                    .or_else(|| (tf.len() == 1).then(|| &tf[0]));
                choice.odometry = pick.map(|t| (t.topic.name.clone(), Role::Tf));
            }
            many => list(&mut ambiguous, "Egomotion", "Odometry", many),
        },
    }
    match mapped.get("ImageSource").map(Vec::as_slice) {
        Some([(topic, role)]) => choice.image = Some(((*topic).to_owned(), *role)),
        Some(_) => {
            return Err(ChoiceError::BadMap {
                path: path.to_owned(),
                map: "TOPIC=ImageSource".to_owned(),
                reason: "one topic gives ImageSource".to_owned(),
            });
        }
        None => match candidates(&[Role::Image, Role::CompressedImage]).as_slice() {
            [] => {}
            [one] => {
                let role = Role::of(&one.topic).unwrap_or(Role::Image);
                choice.image = Some((one.topic.name.clone(), role));
            }
            many => list(&mut ambiguous, "ImageSource", "Image", many),
        },
    }
    if ambiguous.is_empty() {
        Ok(choice)
    } else {
        Err(ChoiceError::Ambiguous {
            path: path.to_owned(),
            text: ambiguous.trim_end().to_owned(),
        })
    }
}

fn list(out: &mut String, interface: &str, kind: &str, many: &[&TopicStats]) {
    let _ = writeln!(
        out,
        "{} {kind} topics could be the {interface}; say which with --map:",
        many.len()
    );
    for t in many {
        let _ = writeln!(out, "  {}", t.line());
    }
    if let Some(first) = many.first() {
        let _ = writeln!(out, "  e.g. --map {}={interface}", first.topic.name);
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use std::path::Path;

    use super::*;

    fn topic(name: &str, type_name: &str, count: u64) -> TopicStats {
        TopicStats {
            topic: Topic {
                id: 0,
                name: name.to_owned(),
                type_name: type_name.to_owned(),
                schema_encoding: "ros2msg".to_owned(),
                schema_text: String::new(),
                message_encoding: "cdr".to_owned(),
                offered_qos: None,
            },
            count,
            span_ns: Some((0, (count.max(2) - 1) * 100_000_000)),
        }
    }

    fn check(topics: &[TopicStats], maps: &[(&str, &str)]) -> Result<Choice, String> {
        let maps: Vec<(String, String)> = maps
            .iter()
            .map(|(t, i)| ((*t).to_owned(), (*i).to_owned()))
            .collect();
        choose(Path::new("bag.mcap"), topics, &maps).map_err(|e| e.to_string())
    }

    #[test]
    fn one_topic_of_a_type_is_chosen_by_its_type_and_tf_only_without_odometry() {
        let bag = [
            topic("/scan", "sensor_msgs/msg/LaserScan", 10),
            topic("/odom", "nav_msgs/msg/Odometry", 10),
            topic("/tf", "tf2_msgs/msg/TFMessage", 10),
            topic("/image/compressed", "sensor_msgs/msg/CompressedImage", 3),
        ];
        let choice = check(&bag, &[]).unwrap();
        assert_eq!(choice.laser.as_deref(), Some("/scan"));
        assert_eq!(choice.odometry, Some(("/odom".to_owned(), Role::Odometry)));
        assert_eq!(
            choice.image,
            Some(("/image/compressed".to_owned(), Role::CompressedImage))
        );
        let choice = check(&bag[2..], &[]).unwrap();
        assert_eq!(choice.odometry, Some(("/tf".to_owned(), Role::Tf)));
    }

    #[test]
    fn several_candidates_stop_with_a_list_and_a_map_chooses() {
        let bag = [
            topic("/front", "sensor_msgs/msg/LaserScan", 20),
            topic("/rear", "sensor_msgs/LaserScan", 11),
        ];
        let error = check(&bag, &[]).unwrap_err();
        assert_eq!(
            error,
            "bag.mcap: 2 LaserScan topics could be the RangeFinder; say which with --map:\n  \
             /front (sensor_msgs/msg/LaserScan): 20 messages at 10.0 Hz\n  \
             /rear (sensor_msgs/LaserScan): 11 messages at 10.0 Hz\n  \
             e.g. --map /front=RangeFinder"
        );
        let choice = check(&bag, &[("/rear", "RangeFinder"), ("/front", "RangeFinder")]).unwrap();
        assert_eq!(choice.laser.as_deref(), Some("/rear"));
        assert_eq!(choice.second_laser.as_deref(), Some("/front"));
    }

    #[test]
    fn a_map_to_an_unknown_topic_or_the_wrong_interface_is_refused() {
        let bag = [topic("/scan", "sensor_msgs/msg/LaserScan", 5)];
        let error = check(&bag, &[("/scna", "RangeFinder")]).unwrap_err();
        assert!(
            error.contains("no topic `/scna` (did you mean `/scan`?)"),
            "{error}"
        );
        let error = check(&bag, &[("/scan", "Egomotion")]).unwrap_err();
        assert!(error.contains("do not become Egomotion"), "{error}");
    }
}
