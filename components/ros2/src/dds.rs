//! DDS as ROS 2 uses it, over `rustdds`: one participant per gateway process in the robot's
//! `ROS_DOMAIN_ID`, topics named as ROS 2 names them on the wire (`/scan` is `rt/scan`,
//! with the robot's namespace in front), types as rosidl names them for DDS
//! (`sensor_msgs::msg::dds_::LaserScan_`), and the QoS a ROS 2 driver offers.
//!
//! Samples travel as **raw CDR**: a reader hands out each sample's bytes as received (the
//! 4-byte encapsulation header first, as rosbag2 records them), and a writer sends bytes
//! Lewis encoded; decoding is the schema-driven decoder's (`lewis_interfaces::dynamic`), so
//! a sample of the wrong shape is counted by the gateway, not dropped inside DDS.
//!
//! The participant's threads are rustdds's own (its event loop and discovery). The service
//! waits on [`Readers::fd`], a mio poll over every reader of the process, which becomes
//! readable when a reader has samples; [`Readers::drain`] takes them without blocking.

use std::convert::Infallible;
use std::os::fd::{AsFd, AsRawFd as _, BorrowedFd};
use std::time::Duration;

use lewis_ros2_map::qos::{Durability as QosDurability, QosProfile, Reliability as QosReliability};
use rustdds::mio1::{Events, Interest, Poll, Token};
use rustdds::no_key::{
    DataReader, DataWriter, Decode, DefaultDecoder, DeserializerAdapter, SerializerAdapter,
};
use rustdds::policy::{Durability, History, Reliability};
use rustdds::{
    DomainParticipant, DomainParticipantBuilder, GUID, QosPolicies, QosPolicyBuilder,
    RepresentationIdentifier, TopicKind,
};

/// One sample's bytes as received: the 4-byte encapsulation header (representation
/// identifier, then two option bytes, zero here), then the serialized message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawCdr(pub Vec<u8>);

impl RawCdr {
    /// Whether the bytes are plain CDR (XCDR1), little- or big-endian: what ROS 2 sends
    /// and what the schema-driven decoder reads.
    #[must_use]
    pub fn is_plain_cdr(&self) -> bool {
        matches!(self.0.get(..2), Some([0, 0 | 1]))
    }
}

/// The rustdds adapter that neither decodes nor encodes: bytes in, bytes out.
pub struct RawAdapter;

/// Every representation a sample may arrive in: all are handed out, and the gateway counts
/// the ones it cannot read (XCDR2, parameter lists) instead of rustdds dropping them.
const EVERY_REPRESENTATION: &[RepresentationIdentifier] = &[
    RepresentationIdentifier::CDR_LE,
    RepresentationIdentifier::CDR_BE,
    RepresentationIdentifier::PL_CDR_LE,
    RepresentationIdentifier::PL_CDR_BE,
    RepresentationIdentifier::XCDR2_LE,
    RepresentationIdentifier::XCDR2_BE,
    RepresentationIdentifier::D_CDR2_LE,
    RepresentationIdentifier::D_CDR2_BE,
    RepresentationIdentifier::PL_XCDR2_LE,
    RepresentationIdentifier::PL_XCDR2_BE,
    RepresentationIdentifier::CDR2_LE,
    RepresentationIdentifier::CDR2_BE,
    RepresentationIdentifier::PL_CDR2_LE,
    RepresentationIdentifier::PL_CDR2_BE,
    RepresentationIdentifier::D_CDR_LE,
    RepresentationIdentifier::D_CDR_BE,
];

impl DeserializerAdapter<RawCdr> for RawAdapter {
    type Error = Infallible;
    type Decoded = RawCdr;

    fn supported_encodings() -> &'static [RepresentationIdentifier] {
        EVERY_REPRESENTATION
    }

    fn transform_decoded(decoded: RawCdr) -> RawCdr {
        decoded
    }
}

/// Copies a sample's bytes behind its encapsulation header.
#[derive(Debug, Clone, Copy)]
pub struct RawDecoder;

impl Decode<'_, RawCdr> for RawDecoder {
    type Error = Infallible;

    fn decode_bytes(
        self,
        input_bytes: &[u8],
        encoding: RepresentationIdentifier,
    ) -> Result<RawCdr, Infallible> {
        let mut bytes = Vec::with_capacity(input_bytes.len() + 4);
        bytes.extend_from_slice(&encoding.to_bytes());
        bytes.extend_from_slice(&[0, 0]);
        bytes.extend_from_slice(input_bytes);
        Ok(RawCdr(bytes))
    }
}

impl DefaultDecoder<RawCdr> for RawAdapter {
    type Decoder = RawDecoder;
    const DECODER: RawDecoder = RawDecoder;
}

impl SerializerAdapter<RawCdr> for RawAdapter {
    type Error = Infallible;

    fn output_encoding() -> RepresentationIdentifier {
        RepresentationIdentifier::CDR_LE
    }

    /// The bytes after Lewis's little-endian encapsulation header.
    fn to_bytes(value: &RawCdr) -> Result<rustdds::bytes::Bytes, Infallible> {
        Ok(rustdds::bytes::Bytes::copy_from_slice(
            value.0.get(4..).unwrap_or_default(),
        ))
    }
}

/// How a reader of `/tf_static` keeps what the robot's static broadcasters sent: latched,
/// as they offer it, and deep enough for one transform per frame of a robot.
pub const TF_STATIC_READER: QosProfile = QosProfile {
    depth: 100,
    ..QosProfile::LATCHED
};

/// A profile as rustdds's policies.
fn policies(qos: QosProfile) -> QosPolicies {
    let reliability = match qos.reliability {
        QosReliability::BestEffort => Reliability::BestEffort,
        QosReliability::Reliable => Reliability::Reliable {
            max_blocking_time: rustdds::Duration::from_millis(100),
        },
    };
    let durability = match qos.durability {
        QosDurability::Volatile => Durability::Volatile,
        QosDurability::TransientLocal => Durability::TransientLocal,
    };
    QosPolicyBuilder::new()
        .reliability(reliability)
        .durability(durability)
        .history(History::KeepLast {
            depth: i32::try_from(qos.depth.max(1)).unwrap_or(i32::MAX),
        })
        .build()
}

/// The DDS topic name of a ROS 2 topic: `rt` and the namespace before it (`/scan` in
/// namespace `/robot1` is `rt/robot1/scan`).
#[must_use]
pub fn dds_topic(namespace: &str, topic: &str) -> String {
    let namespace = namespace.trim_matches('/');
    let topic = topic.trim_start_matches('/');
    if namespace.is_empty() {
        format!("rt/{topic}")
    } else {
        format!("rt/{namespace}/{topic}")
    }
}

/// The highest `ROS_DOMAIN_ID` whose ports fit in RTPS's port formula.
pub const MAX_DOMAIN_ID: u16 = 232;

/// The process's DDS participant.
pub struct Participant {
    // Fields drop in order: the participant last.
    subscriber: rustdds::Subscriber,
    publisher: rustdds::Publisher,
    participant: DomainParticipant,
}

impl Participant {
    /// Joins `domain_id`, on the given interfaces' addresses only when some are given.
    ///
    /// # Errors
    /// When the sockets cannot be opened.
    pub fn join(domain_id: u16, interfaces: &[std::net::IpAddr]) -> Result<Self, String> {
        let mut builder = DomainParticipantBuilder::new(domain_id);
        if !interfaces.is_empty() {
            builder = builder.with_only_networks(interfaces.iter().copied());
        }
        let participant = builder
            .build()
            .map_err(|e| format!("cannot join DDS domain {domain_id}: {e}"))?;
        let default = QosPolicyBuilder::new().build();
        let subscriber = participant
            .create_subscriber(&default)
            .map_err(|e| format!("cannot make a DDS subscriber: {e}"))?;
        let publisher = participant
            .create_publisher(&default)
            .map_err(|e| format!("cannot make a DDS publisher: {e}"))?;
        Ok(Self {
            participant,
            subscriber,
            publisher,
        })
    }

    fn topic(&self, name: &str, dds_type: &str, qos: QosProfile) -> Result<rustdds::Topic, String> {
        self.participant
            .create_topic(
                name.to_owned(),
                dds_type.to_owned(),
                &policies(qos),
                TopicKind::NoKey,
            )
            .map_err(|e| format!("cannot make DDS topic {name}: {e}"))
    }

    /// A reader of `topic` (its DDS name) of type `dds_type`.
    ///
    /// # Errors
    /// When rustdds refuses it.
    pub fn reader(
        &self,
        topic: &str,
        dds_type: &str,
        qos: QosProfile,
    ) -> Result<DataReader<RawCdr, RawAdapter>, String> {
        let t = self.topic(topic, dds_type, qos)?;
        self.subscriber
            .create_datareader_no_key::<RawCdr, RawAdapter>(&t, Some(policies(qos)))
            .map_err(|e| format!("cannot read DDS topic {topic}: {e}"))
    }

    /// Every writer discovered on `topic` (its DDS name), of any type: ours do not match a
    /// writer of another type name, so only discovery shows it.
    #[must_use]
    pub fn writers_on(&self, topic: &str) -> Vec<SeenWriter> {
        self.participant
            .discovered_writers()
            .into_iter()
            .filter(|w| w.publication_topic_data.topic_name == topic)
            .map(|w| SeenWriter {
                guid: w.publication_topic_data.key,
                dds_type: w.publication_topic_data.type_name.clone(),
                type_hash: type_hash_in(&w.user_data),
            })
            .collect()
    }

    /// A writer of `topic` (its DDS name) of type `dds_type`.
    ///
    /// # Errors
    /// When rustdds refuses it.
    pub fn writer(
        &self,
        topic: &str,
        dds_type: &str,
        qos: QosProfile,
    ) -> Result<DataWriter<RawCdr, RawAdapter>, String> {
        let t = self.topic(topic, dds_type, qos)?;
        self.publisher
            .create_datawriter_no_key::<RawCdr, RawAdapter>(&t, Some(policies(qos)))
            .map_err(|e| format!("cannot write DDS topic {topic}: {e}"))
    }
}

/// A writer another participant announced, as discovery saw it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SeenWriter {
    /// Its endpoint GUID (a sample's [`Taken::writer`]).
    pub guid: GUID,
    /// The type it writes, as DDS names it (`sensor_msgs::msg::dds_::LaserScan_`).
    pub dds_type: String,
    /// The ROS 2 type hash it announced (`RIHS01_...`): Iron and later put
    /// `typehash=RIHS01_...;` in every endpoint's USER_DATA; Humble announces none.
    pub type_hash: Option<String>,
}

/// The type hash in an endpoint's USER_DATA (`key=value;` pairs, as `rmw_dds_common` writes
/// them), if it has one. rustdds hands the parameter's value as it came, the octet
/// sequence's length and padding included, so the pair is looked for in the bytes.
#[must_use]
pub fn type_hash_in(user_data: &[u8]) -> Option<String> {
    const KEY: &[u8] = b"typehash=";
    let start = user_data
        .windows(KEY.len())
        .position(|window| window == KEY)?
        + KEY.len();
    let hash: String = user_data[start..]
        .iter()
        .take_while(|b| b.is_ascii_alphanumeric() || **b == b'_')
        .map(|&b| char::from(b))
        .collect();
    (!hash.is_empty()).then_some(hash)
}

/// A sample taken from one of the [`Readers`]: which reader, from which writer, and its
/// bytes.
#[derive(Debug)]
pub struct Taken {
    /// The reader's index, in the order they were added.
    pub reader: usize,
    /// The writer that sent it.
    pub writer: GUID,
    /// The bytes.
    pub sample: RawCdr,
}

/// The readers of a process under one poll, whose descriptor the service hands the live
/// harness.
pub struct Readers {
    poll: Poll,
    events: Events,
    readers: Vec<DataReader<RawCdr, RawAdapter>>,
}

impl Readers {
    /// No reader yet.
    ///
    /// # Errors
    /// When the poll cannot be made.
    pub fn new() -> Result<Self, String> {
        Ok(Self {
            poll: Poll::new().map_err(|e| format!("cannot make a poll: {e}"))?,
            events: Events::with_capacity(16),
            readers: Vec::new(),
        })
    }

    /// Adds `reader`; returns its index.
    ///
    /// # Errors
    /// When it cannot be registered.
    pub fn add(&mut self, mut reader: DataReader<RawCdr, RawAdapter>) -> Result<usize, String> {
        let index = self.readers.len();
        self.poll
            .registry()
            .register(&mut reader, Token(index), Interest::READABLE)
            .map_err(|e| format!("cannot watch a DDS reader: {e}"))?;
        self.readers.push(reader);
        Ok(index)
    }

    /// Readable when a reader may have samples.
    #[must_use]
    pub fn fd(&self) -> BorrowedFd<'_> {
        // SAFETY: the poll's epoll descriptor lives as long as `self.poll`, which the
        // returned borrow cannot outlive.
        unsafe { BorrowedFd::borrow_raw(self.poll.as_raw_fd()) }
    }

    /// Takes every sample waiting in every reader (at most `limit` in all), without
    /// blocking; clears the poll's readiness first so that a sample arriving meanwhile
    /// wakes it again.
    pub fn drain(&mut self, limit: usize, out: &mut Vec<Taken>) {
        // Readiness is only a hint: every reader is asked in any case.
        let _ = self.poll.poll(&mut self.events, Some(Duration::ZERO));
        for (index, reader) in self.readers.iter_mut().enumerate() {
            while out.len() < limit {
                match reader.take_next_sample() {
                    Ok(Some(sample)) => out.push(Taken {
                        reader: index,
                        writer: sample.sample_info().writer_guid(),
                        sample: sample.into_value(),
                    }),
                    Ok(None) | Err(_) => break,
                }
            }
        }
    }
}

impl AsFd for Readers {
    fn as_fd(&self) -> BorrowedFd<'_> {
        self.fd()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros2_topics_get_their_dds_names() {
        assert_eq!(dds_topic("", "/scan"), "rt/scan");
        assert_eq!(dds_topic("/", "scan"), "rt/scan");
        assert_eq!(dds_topic("/robot1", "/scan"), "rt/robot1/scan");
        assert_eq!(
            dds_topic("robot1/", "/oakd/rgb/image"),
            "rt/robot1/oakd/rgb/image"
        );
    }

    #[test]
    fn the_type_hash_is_read_from_user_data() {
        let hash = "RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828";
        assert_eq!(
            type_hash_in(format!("typehash={hash};").as_bytes()).as_deref(),
            Some(hash)
        );
        assert_eq!(
            type_hash_in(format!("enclave=/;typehash={hash};").as_bytes()).as_deref(),
            Some(hash)
        );
        // As rustdds hands it: the sequence's length first, padding after.
        let mut framed = u32::try_from(hash.len() + 10)
            .unwrap()
            .to_le_bytes()
            .to_vec();
        framed.extend_from_slice(format!("typehash={hash};").as_bytes());
        framed.extend_from_slice(&[0, 0]);
        assert_eq!(type_hash_in(&framed).as_deref(), Some(hash));
        assert_eq!(type_hash_in(b""), None);
        assert_eq!(type_hash_in(b"enclave=/;"), None);
        assert_eq!(type_hash_in(b"typehash=;"), None);
        assert_eq!(type_hash_in(&[0xff, 0xfe]), None);
    }

    #[test]
    fn raw_samples_keep_their_encapsulation() {
        let raw = RawDecoder
            .decode_bytes(&[1, 2, 3, 4], RepresentationIdentifier::CDR_LE)
            .unwrap_or_else(|e| match e {});
        assert_eq!(raw.0, [0, 1, 0, 0, 1, 2, 3, 4]);
        assert!(raw.is_plain_cdr());
        let xcdr2 = RawDecoder
            .decode_bytes(&[1, 2, 3, 4], RepresentationIdentifier::XCDR2_LE)
            .unwrap_or_else(|e| match e {});
        assert!(!xcdr2.is_plain_cdr());
        let bytes = RawAdapter::to_bytes(&raw).unwrap_or_else(|e| match e {});
        assert_eq!(&bytes[..], [1, 2, 3, 4]);
    }
}
