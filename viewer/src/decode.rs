//! Turning a message into something to draw: the Lewis interfaces the viewer draws in a
//! special way become their generated types; every other message with a ros2msg schema
//! becomes a dynamic value tree.

use lewis_interfaces::Struct;
use lewis_interfaces::cdr;
use lewis_interfaces::dynamic::{Decoder, Value};
use lewis_interfaces::msg::{
    Blobs, Blobs3D, Broker, CommandLog, Egomotion, GroundTruth, Health, ImageSource, LogLine,
    Mover, RangeFinder, Sequencer, Signs,
};

use crate::source::ChannelInfo;

/// A message of an interface the viewer draws in its own way.
#[derive(Debug)]
pub(crate) enum Drawn {
    /// A laser or sonar scan.
    RangeFinder(RangeFinder),
    /// The odometry's pose.
    Egomotion(Egomotion),
    /// The simulator's true pose.
    GroundTruth(GroundTruth),
    /// A camera image.
    Image(ImageSource),
    /// Colour blobs in an image.
    Blobs(Blobs),
    /// Blobs placed in space.
    Blobs3D(Blobs3D),
    /// Direction signs.
    Signs(Signs),
    /// The mover's goal and waypoint.
    Mover(Mover),
    /// A broker decision.
    Broker(Broker),
    /// A service's heartbeat.
    Health(Health),
    /// A service's output line.
    LogLine(LogLine),
    /// A command a service answered.
    CommandLog(CommandLog),
    /// A record of the sequencer.
    Sequencer(Sequencer),
}

/// What a message became.
#[derive(Debug)]
pub(crate) enum Decoded {
    /// An interface with its own drawing; `value` is its value tree when the interface
    /// also has numeric fields to plot.
    Drawn(Box<Drawn>, Option<Value>),
    /// Any other decodable message.
    Generic(Value),
    /// Not decodable: why.
    Failed(String),
}

/// The decoder of one channel, built from its schema once.
pub(crate) struct ChannelDecoder {
    kind: Kind,
    dynamic: Result<Decoder, String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    RangeFinder,
    Egomotion,
    GroundTruth,
    Image,
    Blobs,
    Blobs3D,
    Signs,
    Mover,
    Broker,
    Health,
    LogLine,
    CommandLog,
    Sequencer,
    Other,
}

impl Kind {
    fn of(schema_name: &str) -> Self {
        match schema_name {
            RangeFinder::SCHEMA_NAME => Self::RangeFinder,
            Egomotion::SCHEMA_NAME => Self::Egomotion,
            GroundTruth::SCHEMA_NAME => Self::GroundTruth,
            ImageSource::SCHEMA_NAME => Self::Image,
            Blobs::SCHEMA_NAME => Self::Blobs,
            Blobs3D::SCHEMA_NAME => Self::Blobs3D,
            Signs::SCHEMA_NAME => Self::Signs,
            Mover::SCHEMA_NAME => Self::Mover,
            Broker::SCHEMA_NAME => Self::Broker,
            Health::SCHEMA_NAME => Self::Health,
            LogLine::SCHEMA_NAME => Self::LogLine,
            CommandLog::SCHEMA_NAME => Self::CommandLog,
            Sequencer::SCHEMA_NAME => Self::Sequencer,
            _ => Self::Other,
        }
    }

    /// Interfaces whose numeric fields are worth plotting besides their drawing.
    fn plotted(self) -> bool {
        matches!(self, Self::Egomotion | Self::GroundTruth | Self::Mover)
    }
}

impl ChannelDecoder {
    /// The decoder for `channel`.
    pub(crate) fn new(channel: &ChannelInfo) -> Self {
        let dynamic = if channel.message_encoding != "cdr" {
            Err(format!(
                "message encoding `{}` is not cdr",
                channel.message_encoding
            ))
        } else if channel.schema_encoding != "ros2msg" {
            Err(format!(
                "schema encoding `{}` is not ros2msg",
                channel.schema_encoding
            ))
        } else {
            match std::str::from_utf8(&channel.schema_data) {
                Ok(text) => Decoder::new(&channel.schema_name, text).map_err(|e| e.to_string()),
                Err(_) => Err("the schema text is not UTF-8".to_owned()),
            }
        };
        // A schema that only shares the name of ours (another version) must not be read
        // with our layout: the typed path is taken only when the text is ours.
        let kind = match Kind::of(&channel.schema_name) {
            Kind::Other => Kind::Other,
            kind if lewis_interfaces::msg::INTERFACES.iter().any(|i| {
                i.publication.name == channel.schema_name
                    && i.publication.text.as_bytes() == channel.schema_data.as_slice()
            }) =>
            {
                kind
            }
            _ => Kind::Other,
        };
        Self { kind, dynamic }
    }

    /// Decodes one message.
    pub(crate) fn decode(&self, data: &[u8]) -> Decoded {
        let drawn = match self.kind {
            Kind::RangeFinder => typed(data, Drawn::RangeFinder),
            Kind::Egomotion => typed(data, Drawn::Egomotion),
            Kind::GroundTruth => typed(data, Drawn::GroundTruth),
            Kind::Image => typed(data, Drawn::Image),
            Kind::Blobs => typed(data, Drawn::Blobs),
            Kind::Blobs3D => typed(data, Drawn::Blobs3D),
            Kind::Signs => typed(data, Drawn::Signs),
            Kind::Mover => typed(data, Drawn::Mover),
            Kind::Broker => typed(data, Drawn::Broker),
            Kind::Health => typed(data, Drawn::Health),
            Kind::LogLine => typed(data, Drawn::LogLine),
            Kind::CommandLog => typed(data, Drawn::CommandLog),
            Kind::Sequencer => typed(data, Drawn::Sequencer),
            Kind::Other => None,
        };
        match drawn {
            Some(Ok(drawn)) => {
                let value = if self.kind.plotted() {
                    self.dynamic.as_ref().ok().and_then(|d| d.decode(data).ok())
                } else {
                    None
                };
                Decoded::Drawn(Box::new(drawn), value)
            }
            Some(Err(error)) => Decoded::Failed(error),
            None => match &self.dynamic {
                Ok(decoder) => match decoder.decode(data) {
                    Ok(value) => Decoded::Generic(value),
                    Err(error) => Decoded::Failed(error.to_string()),
                },
                Err(error) => Decoded::Failed(error.clone()),
            },
        }
    }
}

fn typed<T: cdr::Decode>(data: &[u8], wrap: fn(T) -> Drawn) -> Option<Result<Drawn, String>> {
    Some(
        cdr::from_bytes::<T>(data)
            .map(wrap)
            .map_err(|e| e.to_string()),
    )
}
