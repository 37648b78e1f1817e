//! Which channels of a running robot the tap subscribes to, with the settings each was
//! created with and the MCAP channel each becomes.

use globset::{GlobBuilder, GlobSet, GlobSetBuilder};
use lewis_robot::Robot;
use lewis_runtime::ipc::ChannelConfig;
use lewis_runtime::names;
use thiserror::Error;

use crate::channel::ChannelSpec;

/// Channel metadata key saying what a channel carries: `data`, `health`, `commands`,
/// `broker`, `cpu`, `calls`, `sequencer`, `log` or `hosts` ([`names::ChannelKind`]).
pub const META_KIND: &str = "kind";

/// One channel to tap: its IPC name and settings, and the MCAP channel it is written to.
#[derive(Debug, Clone)]
pub struct TapChannel {
    /// The IPC settings it is opened with: those of [`names`] (a mismatch would be refused)
    /// with the deepest buffer the channel allows ([`ChannelConfig::deepest`]), so that a
    /// tap not scheduled for a while loses nothing.
    pub config: ChannelConfig,
    /// The MCAP channel; its topic is the IPC channel name.
    pub spec: ChannelSpec,
}

impl TapChannel {
    /// The tap of one of the robot's channels: the settings of [`names`] with the deepest
    /// buffer, and the MCAP channel that says what it carries (and, for a robot on more than
    /// one host, which host published it).
    fn new(channel: names::RobotChannel) -> Self {
        let mut extra_metadata = std::collections::BTreeMap::new();
        extra_metadata.insert(META_KIND.to_owned(), channel.kind.word().to_owned());
        if channel.kind == names::ChannelKind::Calls {
            // Any client publishes here, each numbering its own records.
            extra_metadata.insert(
                crate::channel::META_NUMBERING.to_owned(),
                crate::channel::NUMBERED_PER_PUBLISHER.to_owned(),
            );
        }
        if let Some(host) = channel.host {
            extra_metadata.insert(META_HOST.to_owned(), host);
        }
        Self {
            config: channel.config.deepest(),
            spec: ChannelSpec {
                topic: channel.name,
                schema_name: channel.schema_name.to_owned(),
                schema_text: channel.schema_text.to_owned(),
                provider: channel.provider,
                interface: channel.interface.to_owned(),
                interface_version: channel.interface_version.to_owned(),
                extra_metadata,
            },
        }
    }

    /// The IPC channel name (and MCAP topic).
    #[must_use]
    pub fn topic(&self) -> &str {
        &self.spec.topic
    }
}

/// Every channel of `robot` worth recording, in the stable order of
/// [`names::robot_channels`]: each provider's data channel `/<service>/<Interface>` (all of
/// them, started or not, so that a provider started later by a failover is recorded from
/// its first sample), then per service its health and its command log, then
/// `/lewis/broker`, `/lewis/broker/cpu`, `/lewis/calls`, `/lewis/sequencer` and
/// `/lewis/log` (and `/lewis/hosts` for a robot on more than one host).
/// Without a robot, only the channels that do not depend on it.
#[must_use]
pub fn robot_channels(robot: Option<&Robot>) -> Vec<TapChannel> {
    names::robot_channels(robot)
        .into_iter()
        .map(TapChannel::new)
        .collect()
}

/// Channel metadata key naming the host that published a channel, for a robot on more
/// than one.
pub const META_HOST: &str = "host";

/// A `--topics` glob that does not parse.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("--topics `{glob}` is not a valid glob: {reason}")]
pub struct BadGlob {
    /// The glob given.
    pub glob: String,
    /// What is wrong with it.
    pub reason: String,
}

/// The topics to record: all (no glob given), or those matching at least one glob. In a
/// glob, `*` stays within one level of the name (`/lewis/health/*`), `**` crosses levels
/// (`/lewis/**`), `{a,b}` is either.
#[derive(Debug, Clone, Default)]
pub struct TopicFilter {
    globs: Option<GlobSet>,
}

impl TopicFilter {
    /// Every topic.
    #[must_use]
    pub fn all() -> Self {
        Self::default()
    }

    /// The topics matching at least one of `globs` (every topic when `globs` is empty).
    ///
    /// # Errors
    /// [`BadGlob`] for the first glob that does not parse.
    pub fn new<S: AsRef<str>>(globs: &[S]) -> Result<Self, BadGlob> {
        if globs.is_empty() {
            return Ok(Self::all());
        }
        let mut set = GlobSetBuilder::new();
        for glob in globs {
            let glob = glob.as_ref();
            set.add(
                GlobBuilder::new(glob)
                    .literal_separator(true)
                    .build()
                    .map_err(|e| BadGlob {
                        glob: glob.to_owned(),
                        reason: e.kind().to_string(),
                    })?,
            );
        }
        let globs = set.build().map_err(|e| BadGlob {
            glob: globs
                .iter()
                .map(AsRef::as_ref)
                .collect::<Vec<_>>()
                .join(" "),
            reason: e.to_string(),
        })?;
        Ok(Self { globs: Some(globs) })
    }

    /// Whether `topic` is recorded.
    #[must_use]
    pub fn matches(&self, topic: &str) -> bool {
        self.globs.as_ref().is_none_or(|g| g.is_match(topic))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn robot() -> Robot {
        robot_with("", "")
    }

    /// The test robot with `hosts` before its services, the sonar on `sonar_host`.
    fn robot_with(hosts: &str, sonar_host: &str) -> Robot {
        let text = format!(
            r#"
[robot]
name = "t"
{hosts}
[[services]]
name = "laser"
command = ["/bin/true"]
provides = [{{ interface = "RangeFinder", quality = 1, cost = 1 }}, {{ interface = "Distance", quality = 1, cost = 1 }}]

[[services]]
name = "sonar"
{sonar_host}
command = ["/bin/true"]
provides = [{{ interface = "Distance", quality = 1, cost = 1 }}]
"#
        );
        let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
            .iter()
            .map(|i| i.name)
            .collect();
        lewis_robot::parse(&text, std::path::Path::new("t.toml"), &known).unwrap()
    }

    #[test]
    fn a_robot_on_two_hosts_names_each_channel_s_host_and_keeps_what_its_broker_heard() {
        let robot = robot_with(
            "[[hosts]]\nname = \"robot\"\nlisten = [\"tcp/10.0.0.1:7447\"]\n\
             [[hosts]]\nname = \"workstation\"\n",
            "host = \"workstation\"",
        );
        let channels = robot_channels(Some(&robot));
        let host = |topic: &str| {
            let c = channels.iter().find(|c| c.topic() == topic).unwrap();
            c.spec.metadata()[META_HOST].clone()
        };
        assert_eq!(host("/sonar/Distance"), "workstation");
        assert_eq!(host("/lewis/health/sonar"), "workstation");
        assert_eq!(host("/laser/Distance"), "robot");
        assert_eq!(host("/lewis/hosts"), "robot");
        assert!(
            robot_channels(Some(&self::robot()))
                .iter()
                .all(|c| c.topic() != "/lewis/hosts")
        );
    }

    #[test]
    fn a_robot_gives_every_provider_channel_then_health_commands_broker_and_log() {
        let robot = robot();
        let topics: Vec<String> = robot_channels(Some(&robot))
            .iter()
            .map(|c| c.topic().to_owned())
            .collect();
        assert_eq!(
            topics,
            [
                "/laser/RangeFinder",
                "/laser/Distance",
                "/sonar/Distance",
                "/lewis/health/laser",
                "/lewis/commands/laser",
                "/lewis/health/sonar",
                "/lewis/commands/sonar",
                "/lewis/broker",
                "/lewis/broker/cpu",
                "/lewis/calls",
                "/lewis/sequencer",
                "/lewis/log",
            ]
        );
    }

    #[test]
    fn every_channel_names_its_provider_interface_and_kind() {
        let robot = robot();
        let channels = robot_channels(Some(&robot));
        let check = |topic: &str, expected: [&str; 3]| {
            let c = channels.iter().find(|c| c.topic() == topic).unwrap();
            let metadata = c.spec.metadata();
            assert_eq!(
                [
                    metadata["provider"].as_str(),
                    metadata["interface"].as_str(),
                    metadata["kind"].as_str()
                ],
                expected,
                "{topic}"
            );
            assert!(!c.spec.schema_text.is_empty(), "{topic}");
        };
        check("/sonar/Distance", ["sonar", "Distance", "data"]);
        check("/lewis/health/laser", ["laser", "Health", "health"]);
        check("/lewis/commands/sonar", ["sonar", "CommandLog", "commands"]);
        check("/lewis/broker", ["lewis-broker", "Broker", "broker"]);
        check("/lewis/broker/cpu", ["lewis-broker", "ProcessCpu", "cpu"]);
        check("/lewis/calls", ["*", "UnansweredCall", "calls"]);
        check(
            "/lewis/sequencer",
            ["lewis-sequencer", "Sequencer", "sequencer"],
        );
        check("/lewis/log", ["lewis-broker", "LogLine", "log"]);
    }

    #[test]
    fn only_the_calls_channel_is_numbered_per_publisher() {
        let numbered: Vec<String> = robot_channels(Some(&robot()))
            .iter()
            .filter(|c| !c.spec.gaps_are_losses())
            .map(|c| c.topic().to_owned())
            .collect();
        assert_eq!(numbered, ["/lewis/calls"]);
    }

    #[test]
    fn without_a_robot_only_the_robot_wide_channels_are_tapped() {
        let topics: Vec<String> = robot_channels(None)
            .iter()
            .map(|c| c.topic().to_owned())
            .collect();
        assert_eq!(
            topics,
            [
                "/lewis/broker",
                "/lewis/broker/cpu",
                "/lewis/calls",
                "/lewis/sequencer",
                "/lewis/log"
            ]
        );
    }

    #[test]
    fn topic_globs_match_one_level_with_a_star_and_any_with_two() {
        fn check(globs: &[&str], topic: &str, expected: bool) {
            let filter = TopicFilter::new(globs).unwrap();
            assert_eq!(filter.matches(topic), expected, "{globs:?} {topic}");
        }
        check(&[], "/laser/RangeFinder", true);
        check(&["/laser/*"], "/laser/RangeFinder", true);
        check(&["/laser/*"], "/laser/RangeFinder/cmd", false);
        check(&["/lewis/*"], "/lewis/health/laser", false);
        check(&["/lewis/**"], "/lewis/health/laser", true);
        check(&["/*/Distance", "/lewis/broker"], "/sonar/Distance", true);
        check(&["/*/Distance", "/lewis/broker"], "/lewis/broker", true);
        check(&["/*/Distance", "/lewis/broker"], "/lewis/log", false);
        check(&["/{laser,sonar}/RangeFinder"], "/sonar/RangeFinder", true);
    }

    #[test]
    fn a_bad_glob_is_named_in_the_error() {
        let error = TopicFilter::new(&["/laser/[a"]).unwrap_err();
        assert_eq!(error.glob, "/laser/[a");
        assert!(
            error.to_string().starts_with("--topics `/laser/[a`"),
            "{error}"
        );
    }
}
