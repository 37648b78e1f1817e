//! What the recorder is told about a channel before its first message, and the names it
//! writes into the MCAP channel record.

use std::collections::BTreeMap;

use lewis_interfaces::{InterfaceInfo, SchemaInfo};
use lewis_ros2_map::qos::{OFFERED_QOS_PROFILES, QosProfile};

/// Channel metadata key naming the service that publishes on the channel.
pub const META_PROVIDER: &str = "provider";
/// Channel metadata key naming the interface.
pub const META_INTERFACE: &str = "interface";
/// Channel metadata key giving the interface version (`MAJOR.MINOR`).
pub const META_INTERFACE_VERSION: &str = "interface_version";

/// The MCAP message encoding of every channel: plain little-endian ROS 2 CDR.
pub const MESSAGE_ENCODING: &str = "cdr";
/// The MCAP schema encoding of every schema: ROS 2 `.msg` text.
pub const SCHEMA_ENCODING: &str = "ros2msg";

/// Channel metadata key saying how a channel's sequence numbers run: absent, one provider
/// numbers the channel's messages 1, 2, 3, ... (a gap is a loss); [`NUMBERED_PER_PUBLISHER`],
/// many processes publish on it, each numbering its own, interleaved (`/lewis/calls`), so
/// the numbers prove no loss.
pub const META_NUMBERING: &str = "numbering";

/// [`META_NUMBERING`]'s value for a channel of many publishers.
pub const NUMBERED_PER_PUBLISHER: &str = "per-publisher";

/// One channel to record: one provider's publications (or commands, or replies) of one
/// interface, on one topic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelSpec {
    /// The topic, as the runtime names it (`/laser/RangeFinder`).
    pub topic: String,
    /// The schema name, `lewis_interfaces/msg/<Name>`.
    pub schema_name: String,
    /// The ros2msg schema text, nested types appended as ROS 2 does.
    pub schema_text: String,
    /// The service that publishes on it.
    pub provider: String,
    /// The interface it belongs to.
    pub interface: String,
    /// The interface's version.
    pub interface_version: String,
    /// More channel metadata (`kind = command`, ...); the three keys above win over
    /// entries of the same name here.
    pub extra_metadata: BTreeMap<String, String>,
}

impl ChannelSpec {
    /// The channel of `provider`'s publications of `interface` on `topic`.
    #[must_use]
    pub fn publication(interface: &InterfaceInfo, provider: &str, topic: &str) -> Self {
        Self::with_schema(interface, interface.publication, provider, topic)
    }

    /// A channel of `interface` whose messages have the schema `schema` (a command's
    /// request or reply, from [`InterfaceInfo::commands`]).
    #[must_use]
    pub fn with_schema(
        interface: &InterfaceInfo,
        schema: SchemaInfo,
        provider: &str,
        topic: &str,
    ) -> Self {
        Self {
            topic: topic.to_owned(),
            schema_name: schema.name.to_owned(),
            schema_text: schema.text.to_owned(),
            provider: provider.to_owned(),
            interface: interface.name.to_owned(),
            interface_version: interface.version.to_owned(),
            extra_metadata: BTreeMap::new(),
        }
    }

    /// Whether a gap in the sequence numbers on this channel is a loss (see
    /// [`META_NUMBERING`]).
    #[must_use]
    pub fn gaps_are_losses(&self) -> bool {
        self.extra_metadata.get(META_NUMBERING).map(String::as_str) != Some(NUMBERED_PER_PUBLISHER)
    }

    /// The MCAP channel metadata: the extra entries, then provider, interface and version,
    /// and the QoS the topic is offered with (MCAP's `ros2` profile requires it on every
    /// channel) unless the extra entries carry one (a ROS 2 input recorded as received).
    #[must_use]
    pub fn metadata(&self) -> BTreeMap<String, String> {
        let mut metadata = self.extra_metadata.clone();
        metadata
            .entry(OFFERED_QOS_PROFILES.to_owned())
            .or_insert_with(|| QosProfile::for_topic(&self.topic).to_offered_qos_profiles());
        metadata.insert(META_PROVIDER.to_owned(), self.provider.clone());
        metadata.insert(META_INTERFACE.to_owned(), self.interface.clone());
        metadata.insert(
            META_INTERFACE_VERSION.to_owned(),
            self.interface_version.clone(),
        );
        metadata
    }
}

/// A channel registered with a [`crate::Recorder`] or a [`crate::Tap`]: an index in
/// registration order, the same in every file of a rotated recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ChannelId(pub u32);

impl std::fmt::Display for ChannelId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "channel #{}", self.0)
    }
}

/// One message as it travelled: the CDR bytes, unchanged, and what the header says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sample<'a> {
    /// The channel it came on.
    pub channel: ChannelId,
    /// The header's sequence number (from 1 per channel and provider run).
    pub seq: u64,
    /// The header's publish time: MCAP `publish_time`.
    pub publish_time_ns: i64,
    /// When the recorder's tap received it: MCAP `log_time`.
    pub log_time_ns: i64,
    /// The CDR bytes, encapsulation header included, exactly as they travelled.
    pub data: &'a [u8],
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(topic: &str) -> ChannelSpec {
        let interface = lewis_interfaces::interface_info("RangeFinder").expect("a known interface");
        ChannelSpec::publication(interface, "laser", topic)
    }

    #[test]
    fn every_channel_offers_a_qos_and_the_static_transforms_are_latched() {
        let qos = |spec: &ChannelSpec| spec.metadata()[OFFERED_QOS_PROFILES].clone();
        assert_eq!(
            qos(&spec("/laser/RangeFinder")),
            QosProfile::DEFAULT.to_offered_qos_profiles()
        );
        assert_eq!(
            qos(&spec("/tf_static")),
            QosProfile::LATCHED.to_offered_qos_profiles()
        );
    }

    #[test]
    fn a_qos_recorded_as_received_is_kept() {
        let mut received = spec("/scan");
        let text = QosProfile::SENSOR_DATA.to_offered_qos_profiles();
        received
            .extra_metadata
            .insert(OFFERED_QOS_PROFILES.to_owned(), text.clone());
        assert_eq!(received.metadata()[OFFERED_QOS_PROFILES], text);
    }
}
