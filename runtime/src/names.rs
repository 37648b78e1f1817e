//! The IPC names and channel settings of a running robot, in one place: every process that
//! opens a channel must use the same name and the same [`ChannelConfig`], or iceoryx2 refuses
//! the second opener.
//!
//! | what | channel | message |
//! |---|---|---|
//! | a provider's data | `/<service>/<Interface>` | the interface's publication |
//! | a provider's commands | `/<service>/<Interface>/cmd` | [`wire`](lewis_service::wire) frames |
//! | heartbeats and declared health | `/lewis/health/<service>` | `Health` |
//! | commands a service answered | `/lewis/commands/<service>` | `CommandLog` |
//! | calls a client sent that got no answer | `/lewis/calls` | `UnansweredCall` |
//! | broker decisions | `/lewis/broker` | `Broker` |
//! | the CPU each service's process used, measured by the broker | `/lewis/broker/cpu` | `ProcessCpu` |
//! | the other hosts of a robot on more than one, as the broker hears them | `/lewis/hosts` | `HostLink` |
//! | requests to the broker | `/lewis/broker/cmd` | `Broker` commands |
//! | services' output lines | `/lewis/log` | `LogLine` |
//! | the sequencer's records | `/lewis/sequencer` | `Sequencer` |
//! | the time of a recording played live | `/lewis/clock` | `Clock` |
//!
//! [`robot_channels`] lists every channel of a robot with its schema and settings, for the
//! recorder and the bridge.
//!
//! [`channel_config`] gives the settings of any of them from its name alone, for tools that
//! open channels they only know by name (`lewis play` publishing a recording's topics).
//!
//! All of them live under the namespace (`LEWIS_NAMESPACE`), see [`crate::ipc::Namespace`].

use std::time::Duration;

use lewis_interfaces::{Interface, InterfaceInfo, msg};
use lewis_robot::Robot;

use crate::ipc::{ChannelConfig, CommandConfig, OverflowPolicy};

/// The channel of broker decisions.
pub const BROKER_CHANNEL: &str = "/lewis/broker";

/// The channel of the CPU the broker measured of each service's process.
pub const CPU_CHANNEL: &str = "/lewis/broker/cpu";

/// The channel on which the robot host's broker says what it hears of the other hosts.
pub const HOSTS_CHANNEL: &str = "/lewis/hosts";

/// The command channel of the broker (`request`, `release`, `status`).
pub const BROKER_COMMAND: &str = "/lewis/broker/cmd";

/// The channel of forwarded output lines.
pub const LOG_CHANNEL: &str = "/lewis/log";

/// The channel of the sequencer's records (events, decisions, program starts).
pub const SEQUENCER_CHANNEL: &str = "/lewis/sequencer";

/// The channel on which every client records a call that got no answer (timed out, no
/// provider, provider gone): the answering side logged nothing.
pub const CALLS_CHANNEL: &str = "/lewis/calls";

/// The channel of the time of a recording played into live IPC (`lewis play`).
pub const CLOCK_CHANNEL: &str = "/lewis/clock";

/// The iceoryx2 node name of the broker (`lewis up`).
pub const BROKER_NODE: &str = "lewis-broker";
/// The node of the broker's cleaner thread ([`crate::ipc::NodeCleaner`]).
pub const BROKER_CLEANER_NODE: &str = "lewis-broker-cleaner";

/// The provider name in the header of the sequencer's records (`lewis seq run`, `lewis up
/// --script`).
pub const SEQUENCER_NODE: &str = "lewis-sequencer";

/// The data channel on which `service` publishes `interface`.
#[must_use]
pub fn data_channel(service: &str, interface: &str) -> String {
    format!("/{service}/{interface}")
}

/// The command channel on which `service` serves the commands of `interface`.
#[must_use]
pub fn command_channel(service: &str, interface: &str) -> String {
    format!("/{service}/{interface}/cmd")
}

/// The channel on which `service` publishes its heartbeats and health.
#[must_use]
pub fn health_channel(service: &str) -> String {
    format!("/lewis/health/{service}")
}

/// The channel on which the harness of `service` publishes every command it answered, with
/// the reply, so that commands are recorded and replay can feed them again.
#[must_use]
pub fn command_log_channel(service: &str) -> String {
    format!("/lewis/commands/{service}")
}

/// Bytes of shared memory the recorder's unread samples of one data channel may hold: its
/// buffer on a channel holds this many bytes of typical messages, between
/// [`RECORDER_MIN_SAMPLES`] and [`RECORDER_MAX_SAMPLES`] samples.
pub const RECORDER_BUFFER_BYTES: usize = 16 << 20;

/// The shallowest buffer of the recorder on a data channel (a camera at 30 Hz: 0.5 s).
pub const RECORDER_MIN_SAMPLES: usize = 16;

/// The deepest buffer of the recorder on a data channel (a 1 kHz channel: 256 ms).
pub const RECORDER_MAX_SAMPLES: usize = 256;

/// The size a publication of `interface` typically has, at most: camera frames are large (a
/// 640x480 RGB frame is 900 KiB), every other interface's messages fit in 64 KiB (a
/// 361-beam scan is 20 KiB). Larger messages still go through (the segment grows).
#[must_use]
pub fn typical_len_bytes(interface: &str) -> usize {
    match interface {
        "ImageSource" => 1 << 20,
        _ => 64 << 10,
    }
}

/// The settings of every provider's data channel of `interface`: a sensor stream (fresh
/// data matters, the oldest unread sample is dropped, the publisher never waits), the last
/// sample kept for a client that is bound late or rebound, 8 samples of buffer for clients,
/// the interface's [`typical_len_bytes`] preallocated per sample.
///
/// The recorder takes the deepest buffer ([`ChannelConfig::deepest`]), sized by the
/// payload: [`RECORDER_BUFFER_BYTES`] of typical messages, so 256 samples of small ones
/// (256 ms of a 1 kHz channel: a tap thread descheduled that long on a loaded machine
/// loses nothing) and 16 camera frames.
#[must_use]
pub fn data_config(interface: &str) -> ChannelConfig {
    let typical = typical_len_bytes(interface);
    ChannelConfig {
        buffer: 8,
        max_buffer: (RECORDER_BUFFER_BYTES / typical)
            .clamp(RECORDER_MIN_SAMPLES, RECORDER_MAX_SAMPLES),
        max_held: 8,
        max_subscribers: 32,
        ..ChannelConfig::sensor(typical)
    }
}

/// The settings of health channels: the broker drains them before every event it takes;
/// the last heartbeat is kept for a broker that joins late. Both the broker and the recorder
/// take a buffer of 64 (640 ms of heartbeats every 10 ms): the broker's loop can be held up
/// for a while (a spawn on a loaded machine, a restart waiting for an IPC cleanup), and a
/// heartbeat dropped from a full buffer would leave a gap that the broker takes for a stall.
#[must_use]
pub fn health_config() -> ChannelConfig {
    ChannelConfig {
        buffer: 64,
        max_buffer: 64,
        max_held: 4,
        ..ChannelConfig::sensor(256)
    }
}

/// The settings of `/lewis/broker`. Decisions must reach the clients, but a client that is
/// not reading must never slow the broker down (failover latency depends on it): a deep
/// buffer, the oldest dropped on overflow; a client that sees a gap asks the broker again
/// (a repeated request answers with its current binding).
#[must_use]
pub fn broker_config() -> ChannelConfig {
    ChannelConfig {
        buffer: 256,
        overflow: OverflowPolicy::DropOldest,
        history: 0,
        max_held: 4,
        max_subscribers: 64,
        max_publishers: 2,
        ..ChannelConfig::sensor(1024)
    }
}

/// The settings of `/lewis/broker/cpu`: a measurement a second per service, every one
/// owed to the recorder (replay decides with them), none worth slowing the broker for: a
/// deep buffer, the oldest dropped.
#[must_use]
pub fn cpu_config() -> ChannelConfig {
    ChannelConfig {
        buffer: 256,
        overflow: OverflowPolicy::DropOldest,
        history: 0,
        max_held: 4,
        max_subscribers: 16,
        max_publishers: 2,
        ..ChannelConfig::sensor(256)
    }
}

/// The settings of `/lewis/hosts`: a few records a second per host, every one owed to the
/// recorder (replay loses and joins the hosts with them), none worth slowing the broker
/// for.
#[must_use]
pub fn hosts_config() -> ChannelConfig {
    cpu_config()
}

/// The settings of `/lewis/log`: a deep buffer, the oldest dropped (logs must not stall
/// the broker).
#[must_use]
pub fn log_config() -> ChannelConfig {
    ChannelConfig {
        buffer: 256,
        overflow: OverflowPolicy::DropOldest,
        history: 0,
        max_held: 4,
        max_subscribers: 16,
        max_publishers: 2,
        ..ChannelConfig::sensor(512)
    }
}

/// The settings of `/lewis/commands/<service>`: every answered command is owed to the
/// recorder, but the serving service must never wait for it; a deep buffer, the oldest
/// dropped (the recorder counts the gap from the header's sequence numbers). Two
/// publishers: a restarted service may meet its dead predecessor's port.
#[must_use]
pub fn command_log_config() -> ChannelConfig {
    ChannelConfig {
        buffer: 64,
        overflow: OverflowPolicy::DropOldest,
        history: 0,
        max_held: 4,
        max_subscribers: 8,
        max_publishers: 2,
        ..ChannelConfig::sensor(512)
    }
}

/// The settings of `/lewis/calls`: any client of the robot (a service, a program, a tool)
/// may publish an unanswered call, each with its own publisher, opened at its first; the
/// caller must never wait for the recorder, so a deep buffer, the oldest dropped.
#[must_use]
pub fn calls_config() -> ChannelConfig {
    ChannelConfig {
        buffer: 64,
        overflow: OverflowPolicy::DropOldest,
        history: 0,
        max_held: 4,
        max_subscribers: 8,
        max_publishers: 64,
        ..ChannelConfig::sensor(512)
    }
}

/// The settings of `/lewis/sequencer`. A mission makes a few records a second at most and
/// every one is owed to the recorder (replay needs them all): a deep buffer, the publisher
/// waits up to 100 ms for a slow reader before dropping (counted by both sides), and the
/// last 64 records are kept for a recorder that joins after the mission started.
#[must_use]
pub fn sequencer_config() -> ChannelConfig {
    ChannelConfig {
        buffer: 256,
        history: 64,
        max_held: 4,
        max_subscribers: 16,
        max_publishers: 2,
        ..ChannelConfig::reliable(1024)
    }
}

/// The settings of `/lewis/clock`: only the newest time matters (the oldest unread is
/// dropped), and the last one is kept for a follower that joins late.
#[must_use]
pub fn clock_config() -> ChannelConfig {
    ChannelConfig {
        buffer: 4,
        max_subscribers: 32,
        ..ChannelConfig::sensor(256)
    }
}

/// The settings of the data or record channel named `channel`, from its name: the broker's,
/// log, sequencer and clock channels, health (`/lewis/health/*`) and command logs
/// (`/lewis/commands/*`) have their own; every other name is a provider's data channel,
/// sized by the interface its last segment names.
#[must_use]
pub fn channel_config(channel: &str) -> ChannelConfig {
    match channel {
        BROKER_CHANNEL => broker_config(),
        LOG_CHANNEL => log_config(),
        SEQUENCER_CHANNEL => sequencer_config(),
        CLOCK_CHANNEL => clock_config(),
        CALLS_CHANNEL => calls_config(),
        CPU_CHANNEL => cpu_config(),
        HOSTS_CHANNEL => hosts_config(),
        _ if channel.starts_with("/lewis/health/") => health_config(),
        _ if channel.starts_with("/lewis/commands/") => command_log_config(),
        // A provider's data channel is `/<provider>/<Interface>`.
        _ => data_config(channel.rsplit('/').next().unwrap_or(channel)),
    }
}

/// The settings of the broker's command channel: every client and `lewis status` may call.
#[must_use]
pub fn broker_command_config() -> CommandConfig {
    CommandConfig {
        max_pending: 4,
        max_clients: 64,
        max_servers: 2,
        ..CommandConfig::default()
    }
}

/// The settings of a provider's command channel. Two servers: a restarted provider's new
/// server may meet the old one before the dead node is cleaned up.
#[must_use]
pub fn command_config() -> CommandConfig {
    CommandConfig {
        max_pending: 8,
        max_clients: 32,
        max_servers: 2,
        ..CommandConfig::default()
    }
}

/// How long a client waits for the broker to answer a request.
pub const BROKER_CALL_TIMEOUT: Duration = Duration::from_secs(2);

/// What a channel of a running robot carries: the word the recorder writes as the channel's
/// `kind` in a recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChannelKind {
    /// A provider's data, `/<service>/<Interface>`.
    Data,
    /// A service's heartbeats and declared health.
    Health,
    /// The commands a service answered.
    Commands,
    /// The broker's decisions.
    Broker,
    /// The CPU each service's process used.
    Cpu,
    /// The calls clients sent that got no answer.
    Calls,
    /// The sequencer's records.
    Sequencer,
    /// The services' output lines.
    Log,
    /// What the robot host's broker hears of the other hosts.
    Hosts,
}

impl ChannelKind {
    /// Its word: `data`, `health`, `commands`, `broker`, `cpu`, `calls`, `sequencer`,
    /// `log` or `hosts`.
    #[must_use]
    pub fn word(self) -> &'static str {
        match self {
            Self::Data => "data",
            Self::Health => "health",
            Self::Commands => "commands",
            Self::Broker => "broker",
            Self::Cpu => "cpu",
            Self::Calls => "calls",
            Self::Sequencer => "sequencer",
            Self::Log => "log",
            Self::Hosts => "hosts",
        }
    }
}

/// One channel of a running robot: its name, who publishes it, the interface and schema of
/// its messages, what it carries, its settings and, for a robot on more than one host, the
/// host that publishes it. The recorder taps these; the bridge tells other hosts their
/// schemas.
#[derive(Debug, Clone)]
pub struct RobotChannel {
    /// The IPC channel name (a recording's topic).
    pub name: String,
    /// The provider in its messages' headers (`*` for any client, on [`CALLS_CHANNEL`]).
    pub provider: String,
    /// The interface's name.
    pub interface: &'static str,
    /// The interface's version.
    pub interface_version: &'static str,
    /// The ros2msg name of its messages' schema.
    pub schema_name: &'static str,
    /// The ros2msg text of its messages' schema.
    pub schema_text: &'static str,
    /// What it carries.
    pub kind: ChannelKind,
    /// Its settings (the publishers', see the functions of this module).
    pub config: ChannelConfig,
    /// The host that publishes it, for a robot on more than one host (the robot host for
    /// the broker's, the sequencer's and the log); `None` for a robot on one.
    pub host: Option<String>,
}

impl RobotChannel {
    /// A channel of the publications of `interface`.
    fn publication(
        interface: &'static InterfaceInfo,
        provider: &str,
        name: String,
        kind: ChannelKind,
        config: ChannelConfig,
    ) -> Self {
        Self {
            name,
            provider: provider.to_owned(),
            interface: interface.name,
            interface_version: interface.version,
            schema_name: interface.publication.name,
            schema_text: interface.publication.text,
            kind,
            config,
            host: None,
        }
    }

    /// A robot-wide channel of interface `T`.
    fn of<T: Interface>(
        provider: &str,
        name: &str,
        kind: ChannelKind,
        config: ChannelConfig,
    ) -> Self {
        Self {
            name: name.to_owned(),
            provider: provider.to_owned(),
            interface: T::NAME,
            interface_version: T::VERSION,
            schema_name: T::SCHEMA_NAME,
            schema_text: T::SCHEMA_TEXT,
            kind,
            config,
            host: None,
        }
    }
}

/// Every channel of `robot`, in a stable order: each provider's data channel
/// `/<service>/<Interface>` (all of them, started or not, so that a provider started later
/// by a failover is recorded from its first sample), then per service its health and its
/// command log, then `/lewis/broker`, `/lewis/broker/cpu` (what each service's process used
/// of the CPU), `/lewis/calls` (the calls clients sent that got no answer),
/// `/lewis/sequencer` and `/lewis/log`, and for a robot on more than one host
/// `/lewis/hosts`, with every channel's host. Without a robot, only the channels that do
/// not depend on it.
#[must_use]
pub fn robot_channels(robot: Option<&Robot>) -> Vec<RobotChannel> {
    let mut channels = Vec::new();
    let services = robot.map_or(&[][..], |r| &r.services[..]);
    for service in services {
        for provision in &service.provides {
            // The robot file was checked against the compiled interfaces when it was loaded.
            if let Some(interface) = lewis_interfaces::interface_info(&provision.interface) {
                channels.push(RobotChannel::publication(
                    interface,
                    &service.name,
                    data_channel(&service.name, interface.name),
                    ChannelKind::Data,
                    data_config(interface.name),
                ));
            }
        }
    }
    for service in services {
        channels.push(RobotChannel::of::<msg::Health>(
            &service.name,
            &health_channel(&service.name),
            ChannelKind::Health,
            health_config(),
        ));
        channels.push(RobotChannel::of::<msg::CommandLog>(
            &service.name,
            &command_log_channel(&service.name),
            ChannelKind::Commands,
            command_log_config(),
        ));
    }
    channels.push(RobotChannel::of::<msg::Broker>(
        BROKER_NODE,
        BROKER_CHANNEL,
        ChannelKind::Broker,
        broker_config(),
    ));
    channels.push(RobotChannel::of::<msg::ProcessCpu>(
        BROKER_NODE,
        CPU_CHANNEL,
        ChannelKind::Cpu,
        cpu_config(),
    ));
    // Any client publishes here, each numbering its own records: the provider is `*`, and
    // each record's header names its caller.
    channels.push(RobotChannel::of::<msg::UnansweredCall>(
        "*",
        CALLS_CHANNEL,
        ChannelKind::Calls,
        calls_config(),
    ));
    channels.push(RobotChannel::of::<msg::Sequencer>(
        SEQUENCER_NODE,
        SEQUENCER_CHANNEL,
        ChannelKind::Sequencer,
        sequencer_config(),
    ));
    channels.push(RobotChannel::of::<msg::LogLine>(
        BROKER_NODE,
        LOG_CHANNEL,
        ChannelKind::Log,
        log_config(),
    ));
    if let Some(robot) = robot
        && let Some(hub) = robot.robot_host()
    {
        channels.push(RobotChannel::of::<msg::HostLink>(
            BROKER_NODE,
            HOSTS_CHANNEL,
            ChannelKind::Hosts,
            hosts_config(),
        ));
        for channel in &mut channels {
            let host = robot.host_of(&channel.provider).unwrap_or(&hub.name);
            channel.host = Some(host.to_owned());
        }
    }
    channels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_robot_wide_channel_has_the_schema_its_interface_lists() {
        for channel in robot_channels(None) {
            let info = lewis_interfaces::interface_info(channel.interface).unwrap();
            assert_eq!(
                (
                    channel.schema_name,
                    channel.schema_text,
                    channel.interface_version
                ),
                (info.publication.name, info.publication.text, info.version),
                "{}",
                channel.name
            );
            assert_eq!(channel.host, None);
        }
    }

    #[test]
    fn channel_names_follow_the_documented_scheme() {
        fn check(got: &str, expected: &str) {
            assert_eq!(got, expected);
        }
        check(&data_channel("laser", "RangeFinder"), "/laser/RangeFinder");
        check(
            &command_channel("laser", "RangeFinder"),
            "/laser/RangeFinder/cmd",
        );
        check(&health_channel("sonar"), "/lewis/health/sonar");
        check(&command_log_channel("mover"), "/lewis/commands/mover");
    }

    #[test]
    fn a_channel_name_gives_the_settings_its_owner_opens_it_with() {
        fn check(channel: &str, expected: &ChannelConfig) {
            assert_eq!(&channel_config(channel), expected, "{channel}");
        }
        check("/laser/RangeFinder", &data_config("RangeFinder"));
        check("/camera/ImageSource", &data_config("ImageSource"));
        check(&health_channel("laser"), &health_config());
        check(&command_log_channel("laser"), &command_log_config());
        check(BROKER_CHANNEL, &broker_config());
        check(LOG_CHANNEL, &log_config());
        check(SEQUENCER_CHANNEL, &sequencer_config());
        check(CLOCK_CHANNEL, &clock_config());
        check(CALLS_CHANNEL, &calls_config());
        check(CPU_CHANNEL, &cpu_config());
    }

    #[test]
    fn the_recorder_buffers_hold_a_budget_of_bytes_whatever_the_payload() {
        fn check(interface: &str, client_buffer: usize, recorder_buffer: usize) {
            let config = data_config(interface);
            assert_eq!(
                (config.buffer, config.deepest().buffer),
                (client_buffer, recorder_buffer),
                "{interface}"
            );
        }
        check("Distance", 8, 256);
        check("RangeFinder", 8, 256);
        check("ImageSource", 8, 16);
    }
}
