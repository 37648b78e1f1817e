//! What every gateway kind shares: the robot file's link to the ROS 2 robot (domain,
//! namespace, interfaces), the topics it reads with their decoders, the accounting of bad
//! input (counted, said once), and health from the data (waiting, flowing, silent).

use std::collections::BTreeMap;
use std::net::IpAddr;
use std::os::fd::BorrowedFd;
use std::time::{Duration, Instant};

use lewis_interfaces::dynamic::{Decoder, MessageSchema, Value, type_hash};
use lewis_ros2_map::from_ros2::stamp_ns;
use lewis_ros2_map::robot::{dds_type_name, ros_type_name, schema_texts};
use lewis_service::{Context, Health};
use serde::Deserialize;

use crate::dds::{MAX_DOMAIN_ID, Participant, RawCdr, Readers, SeenWriter, Taken, dds_topic};
use lewis_ros2_map::qos::QosProfile;
use rustdds::GUID;

/// The variable ROS 2 reads its domain from.
pub const DOMAIN_ENV: &str = "ROS_DOMAIN_ID";

/// Samples taken in one wake-up, at most: a flood waits for the next one.
const DRAIN_LIMIT: usize = 256;

/// A duration in milliseconds from 1 to 600000 (ten minutes), checked when the robot file
/// is loaded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(try_from = "u64")]
pub struct Millis(pub(crate) u64);

impl Millis {
    /// The number of milliseconds.
    #[must_use]
    pub fn get(self) -> u64 {
        self.0
    }

    /// As a duration.
    #[must_use]
    pub fn duration(self) -> Duration {
        Duration::from_millis(self.0)
    }
}

impl TryFrom<u64> for Millis {
    type Error = String;

    fn try_from(ms: u64) -> Result<Self, String> {
        if (1..=600_000).contains(&ms) {
            Ok(Self(ms))
        } else {
            Err(format!("{ms} ms is out of range: give 1 to 600000 ms"))
        }
    }
}

/// A DDS domain, 0 to [`MAX_DOMAIN_ID`], checked when the robot file is loaded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(try_from = "u16")]
pub struct DomainId(u16);

impl TryFrom<u16> for DomainId {
    type Error = String;

    fn try_from(domain: u16) -> Result<Self, String> {
        if domain <= MAX_DOMAIN_ID {
            Ok(Self(domain))
        } else {
            Err(format!(
                "domain {domain} is beyond {MAX_DOMAIN_ID}, the last one RTPS's ports allow"
            ))
        }
    }
}

/// How the gateway reaches the robot: the robot file's keys every kind shares.
#[derive(Debug, Clone, Default, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Link {
    /// The DDS domain (ROS 2's `ROS_DOMAIN_ID`); absent: the variable, else 0.
    pub domain_id: Option<DomainId>,
    /// The robot's namespace, put in front of every topic (`/robot1`); empty: none.
    #[serde(default)]
    pub namespace: String,
    /// The addresses of the interfaces DDS may use; empty: every interface.
    #[serde(default)]
    pub interfaces: Vec<IpAddr>,
}

impl Link {
    /// The domain: the robot file's, else `ROS_DOMAIN_ID`, else 0.
    ///
    /// # Errors
    /// A domain beyond [`MAX_DOMAIN_ID`] or a variable that is not a number.
    pub fn domain(&self) -> Result<u16, String> {
        let domain = match self.domain_id {
            Some(DomainId(d)) => d,
            None => match std::env::var(DOMAIN_ENV) {
                Ok(text) if !text.trim().is_empty() => text.trim().parse().map_err(|_| {
                    format!("{DOMAIN_ENV} is `{text}`: give a domain from 0 to {MAX_DOMAIN_ID}")
                })?,
                _ => 0,
            },
        };
        if domain > MAX_DOMAIN_ID {
            return Err(format!(
                "domain {domain} is beyond {MAX_DOMAIN_ID}, the last one RTPS's ports allow"
            ));
        }
        Ok(domain)
    }
}

/// One topic the gateway reads: its decoders, what was wrong with its samples.
pub struct Intake {
    /// The ROS 2 topic, as the robot file names it (`/scan`).
    pub topic: String,
    type_name: String,
    decoders: Vec<Decoder>,
    /// The type hash of each definition Lewis reads the type with (the distributions'
    /// definitions differ for some types: each has its hash).
    type_hashes: Vec<String>,
    /// Bad samples by what was wrong.
    pub bad: BTreeMap<&'static str, u64>,
    /// Good samples.
    pub good: u64,
    last_stamp_ns: Option<i64>,
}

impl Intake {
    fn new(topic: &str, type_name: &str) -> Result<Self, String> {
        let mut decoders = Vec::new();
        let mut type_hashes = Vec::new();
        for text in schema_texts(type_name) {
            let schema = MessageSchema::parse(type_name, &text).map_err(|e| e.to_string())?;
            type_hashes.extend(type_hash(&schema));
            decoders.push(Decoder::from_schema(&schema).map_err(|e| e.to_string())?);
        }
        if decoders.is_empty() {
            return Err(format!("no schema of {type_name} is known"));
        }
        Ok(Self {
            topic: topic.to_owned(),
            type_name: type_name.to_owned(),
            decoders,
            type_hashes,
            bad: BTreeMap::new(),
            good: 0,
            last_stamp_ns: None,
        })
    }

    /// Counts a bad sample; says so the first time this kind of trouble is seen.
    pub fn bad(&mut self, ctx: &mut Context<'_>, what: &'static str, detail: &str) {
        let count = self.bad.entry(what).or_insert(0);
        *count += 1;
        if *count == 1 {
            ctx.warn(&format!(
                "{}: {what}: {detail} (such samples are dropped and counted; said once)",
                self.topic
            ));
        }
    }

    /// The sample as a value tree, or `None` when it is not one (counted).
    pub fn decode(&mut self, ctx: &mut Context<'_>, raw: &RawCdr) -> Option<Value> {
        if !raw.is_plain_cdr() {
            let id = raw.0.get(..2).unwrap_or_default().to_vec();
            self.bad(
                ctx,
                "not plain CDR",
                &format!("representation {id:02x?}, not ROS 2's XCDR1"),
            );
            return None;
        }
        let mut first_error = None;
        for decoder in &self.decoders {
            match decoder.decode(&raw.0) {
                Ok(value) => {
                    if let Some(stamp) = stamp_ns(&value) {
                        if self.last_stamp_ns.is_some_and(|last| stamp < last) {
                            self.bad(
                                ctx,
                                "stamp went back",
                                "a header stamp earlier than the one before (kept: Lewis stamps with its own clock)",
                            );
                            // Kept: the reading is still a reading.
                        }
                        self.last_stamp_ns = Some(stamp);
                    }
                    return Some(value);
                }
                Err(e) => {
                    first_error.get_or_insert(e.to_string());
                }
            }
        }
        let detail = format!(
            "{} bytes that do not decode as {}: {}",
            raw.0.len(),
            self.type_name,
            first_error.unwrap_or_default()
        );
        self.bad(ctx, "undecodable", &detail);
        None
    }

    /// What was wrong with its samples so far, for a health reason (`3 undecodable`).
    #[must_use]
    pub fn bad_summary(&self) -> String {
        self.bad
            .iter()
            .map(|(what, n)| format!("{n} {what}"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// A topic to read: its name, ROS 2 type and QoS.
#[derive(Debug, Clone)]
pub struct TopicSpec {
    /// The ROS 2 topic (`/scan`).
    pub topic: String,
    /// The ROS 2 type (`sensor_msgs/msg/LaserScan`).
    pub type_name: &'static str,
    /// Its QoS.
    pub qos: QosProfile,
}

/// The DDS side of a gateway process: its participant, readers and their intakes.
pub struct Gateway {
    // Fields drop in order: the readers before the participant they belong to.
    readers: Readers,
    /// One per reader, in the order given.
    pub intakes: Vec<Intake>,
    namespace: String,
    taken: Vec<Taken>,
    /// What each writer seen on a topic of ours is, by its GUID.
    writers: BTreeMap<GUID, Writer>,
    /// When discovery was last looked through for writers of the wrong type.
    writers_checked: Option<Instant>,
    /// The participant (writers are made from it; drop them before the gateway).
    pub participant: Participant,
}

impl Gateway {
    /// Joins the robot's domain and reads `topics`.
    ///
    /// # Errors
    /// When DDS cannot be joined or a topic read.
    pub fn open(link: &Link, topics: &[TopicSpec]) -> Result<Self, String> {
        let participant = Participant::join(link.domain()?, &link.interfaces)?;
        let mut readers = Readers::new()?;
        let mut intakes = Vec::new();
        for spec in topics {
            let dds_type = dds_type_name(spec.type_name)
                .ok_or_else(|| format!("{} is not a ROS 2 type name", spec.type_name))?;
            let reader = participant.reader(
                &dds_topic(&link.namespace, &spec.topic),
                &dds_type,
                spec.qos,
            )?;
            readers.add(reader)?;
            intakes.push(Intake::new(&spec.topic, spec.type_name)?);
        }
        Ok(Self {
            participant,
            readers,
            intakes,
            namespace: link.namespace.clone(),
            taken: Vec::new(),
            writers: BTreeMap::new(),
            writers_checked: None,
        })
    }

    /// The DDS name of a topic of this robot.
    #[must_use]
    pub fn dds_topic(&self, topic: &str) -> String {
        dds_topic(&self.namespace, topic)
    }

    /// Readable when samples may be waiting.
    #[must_use]
    pub fn fd(&self) -> BorrowedFd<'_> {
        self.readers.fd()
    }

    /// Every sample waiting, decoded (bad ones counted and left out): `(reader, value)`.
    /// A sample from a writer that announced another type hash than the type Lewis reads
    /// is left out too (the same bytes would be read as other fields); writers of another
    /// type name, which DDS never matches with ours, are said from discovery.
    pub fn take(&mut self, ctx: &mut Context<'_>) -> Vec<(usize, Value)> {
        if self
            .writers_checked
            .is_none_or(|at| at.elapsed() >= WRITERS_CHECK_EVERY)
        {
            self.check_writers(ctx);
        }
        self.taken.clear();
        self.readers.drain(DRAIN_LIMIT, &mut self.taken);
        let mut values = Vec::with_capacity(self.taken.len());
        let mut taken = std::mem::take(&mut self.taken);
        for sample in taken.drain(..) {
            if !self.writers.contains_key(&sample.writer) {
                // Matched before this process looked: discovery has it by now. Once looked
                // for, a writer discovery does not show is trusted (and not looked for
                // again at every sample).
                self.check_writers(ctx);
                self.writers.entry(sample.writer).or_insert(Writer::Trusted);
            }
            let Some(intake) = self.intakes.get_mut(sample.reader) else {
                continue;
            };
            if let Some(Writer::HashDiffers(detail)) = self.writers.get(&sample.writer) {
                intake.bad(ctx, "type hash differs", detail);
                continue;
            }
            if let Some(value) = intake.decode(ctx, &sample.sample) {
                values.push((sample.reader, value));
            }
        }
        self.taken = taken;
        values
    }

    /// Judges every writer discovery shows on the topics read that was not judged yet:
    /// another type name (counted once, as `wrong type`), or the type's name with another
    /// hash (its samples are counted as they come).
    fn check_writers(&mut self, ctx: &mut Context<'_>) {
        self.writers_checked = Some(Instant::now());
        for intake in &mut self.intakes {
            let topic = dds_topic(&self.namespace, &intake.topic);
            for seen in self.participant.writers_on(&topic) {
                if self.writers.contains_key(&seen.guid) {
                    continue;
                }
                let writer = judge(intake, &seen);
                if let Writer::WrongType(detail) = &writer {
                    intake.bad(ctx, "wrong type", detail);
                }
                self.writers.insert(seen.guid, writer);
            }
        }
    }

    /// Blocks (at most `limit`) until reader `reader` has a good sample; returns every
    /// sample taken meanwhile (of any reader), that one last, or all of them with `false`
    /// when none of `reader` came in time.
    pub fn wait_first(
        &mut self,
        ctx: &mut Context<'_>,
        reader: usize,
        limit: Duration,
    ) -> (Vec<(usize, Value)>, bool) {
        let deadline = Instant::now() + limit;
        let mut taken = Vec::new();
        loop {
            taken.extend(self.take(ctx));
            if taken.iter().any(|(r, _)| *r == reader) {
                return (taken, true);
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return (taken, false);
            }
            let mut fds = [nix::poll::PollFd::new(
                self.readers.fd(),
                nix::poll::PollFlags::POLLIN,
            )];
            let wait_ms = u16::try_from(left.as_millis().min(100)).unwrap_or(100);
            let _ = nix::poll::poll(&mut fds, wait_ms);
        }
    }
}

/// How often discovery is looked through for writers of the wrong type.
const WRITERS_CHECK_EVERY: Duration = Duration::from_secs(1);

/// What a writer on a topic of ours is.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Writer {
    /// Of the type read, with its hash or none announced (Humble announces none).
    Trusted,
    /// Of the type's name but another hash: why, to say.
    HashDiffers(String),
    /// Of another type name: why, to say.
    WrongType(String),
}

/// What `seen`, a writer on `intake`'s topic, is.
fn judge(intake: &Intake, seen: &SeenWriter) -> Writer {
    let ours = dds_type_name(&intake.type_name).unwrap_or_default();
    if seen.dds_type != ours {
        let theirs = ros_type_name(&seen.dds_type).unwrap_or_else(|| seen.dds_type.clone());
        return Writer::WrongType(format!(
            "a writer publishes it as {theirs}, not {}: DDS never delivers its samples",
            intake.type_name
        ));
    }
    match &seen.type_hash {
        Some(hash) if !intake.type_hashes.iter().any(|ours| ours == hash) => {
            Writer::HashDiffers(format!(
                "a writer announces {} with type hash {hash}, which is none of the \
                 definitions Lewis reads it with ({}): its samples are not read",
                intake.type_name,
                intake.type_hashes.join(", ")
            ))
        }
        _ => Writer::Trusted,
    }
}

/// Health from one topic's data: waiting for a first sample, flowing, or silent for longer
/// than the robot file allows (a topic whose samples are all bad is silent too: only good
/// samples count).
#[derive(Debug, Clone)]
pub struct Freshness {
    silence_ns: i64,
    last_good_ns: Option<i64>,
}

impl Freshness {
    /// Silent after `silence` without a good sample.
    #[must_use]
    pub fn new(silence: Duration) -> Self {
        Self {
            silence_ns: i64::try_from(silence.as_nanos()).unwrap_or(i64::MAX),
            last_good_ns: None,
        }
    }

    /// A good sample at `now_ns`.
    pub fn good(&mut self, now_ns: i64) {
        self.last_good_ns = Some(now_ns);
    }

    /// The health at `now_ns` of `intake`'s topic.
    #[must_use]
    pub fn health(&self, now_ns: i64, intake: &Intake) -> Health {
        let bad = intake.bad_summary();
        let bad = if bad.is_empty() {
            String::new()
        } else {
            format!("; bad samples: {bad}")
        };
        match self.last_good_ns {
            None => Health::OutOfService(format!("no {} yet{bad}", intake.topic)),
            // The reason stays the same while the silence lasts: one change of health.
            Some(last) if now_ns - last > self.silence_ns => Health::OutOfService(format!(
                "no {} for more than {} ms{bad}",
                intake.topic,
                self.silence_ns / 1_000_000
            )),
            Some(_) => Health::Ok,
        }
    }
}

/// Declares `health` when it changed, saying so in the log.
pub fn declare(ctx: &mut Context<'_>, health: Health) {
    if *ctx.health() == health {
        return;
    }
    match &health {
        Health::Ok => ctx.info("data flowing: healthy"),
        Health::Degraded(why) => ctx.warn(&format!("degraded: {why}")),
        Health::OutOfService(why) => ctx.warn(&format!("out of service: {why}")),
    }
    ctx.set_health(health);
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use lewis_interfaces::cdr;
    use lewis_interfaces::ros2::{Header, LASER_SCAN, LaserScan};
    use lewis_service::{ContextState, Level};
    use lewis_testkit::RecordingBackend;

    use super::*;

    fn scan_bytes(stamp_ns: i64) -> Vec<u8> {
        cdr::to_vec(&LaserScan {
            header: Header {
                stamp_ns,
                frame_id: "laser".into(),
            },
            angle_min: -1.0,
            angle_max: 1.0,
            angle_increment: 0.5,
            time_increment: 0.0,
            scan_time: 0.1,
            range_min: 0.1,
            range_max: 5.0,
            ranges: vec![1.0, 2.0, 3.0, 4.0, 5.0],
            intensities: vec![],
        })
    }

    #[test]
    fn writers_of_another_type_or_type_hash_are_told_apart() {
        let intake = Intake::new("/scan", LASER_SCAN).unwrap();
        let writer = |dds_type: &str, type_hash: Option<&str>| SeenWriter {
            guid: GUID::GUID_UNKNOWN,
            dds_type: dds_type.to_owned(),
            type_hash: type_hash.map(str::to_owned),
        };
        let laser = "sensor_msgs::msg::dds_::LaserScan_";
        // Humble announces no hash; Jazzy announces the LaserScan's.
        assert_eq!(judge(&intake, &writer(laser, None)), Writer::Trusted);
        let jazzy = "RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828";
        assert_eq!(judge(&intake, &writer(laser, Some(jazzy))), Writer::Trusted);
        let other = "RIHS01_00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff";
        let Writer::HashDiffers(why) = judge(&intake, &writer(laser, Some(other))) else {
            panic!("another hash is not the LaserScan Lewis reads");
        };
        assert!(why.contains(other) && why.contains(jazzy), "{why}");
        let Writer::WrongType(why) = judge(&intake, &writer("std_msgs::msg::dds_::String_", None))
        else {
            panic!("a String on /scan is the wrong type");
        };
        assert!(why.contains("std_msgs/msg/String"), "{why}");
    }

    #[test]
    fn bad_samples_are_counted_and_said_once_per_kind_of_trouble() {
        let mut backend = RecordingBackend::default();
        let mut state = ContextState::new("laser", 1);
        let mut ctx = state.context(&mut backend);
        let mut intake = Intake::new("/scan", LASER_SCAN).unwrap();
        let good = scan_bytes(2_000_000_000);
        assert!(intake.decode(&mut ctx, &RawCdr(good.clone())).is_some());
        // Truncated, garbage, another representation (XCDR2), each a few times.
        for _ in 0..3 {
            assert!(
                intake
                    .decode(&mut ctx, &RawCdr(good[..good.len() - 9].to_vec()))
                    .is_none()
            );
            assert!(
                intake
                    .decode(&mut ctx, &RawCdr(vec![0, 1, 0, 0, 0xff, 0xff, 0xff, 0x7f]))
                    .is_none()
            );
            let mut xcdr2 = good.clone();
            xcdr2[1] = 0x07;
            assert!(intake.decode(&mut ctx, &RawCdr(xcdr2)).is_none());
        }
        // A stamp going back is said, and the reading kept.
        assert!(
            intake
                .decode(&mut ctx, &RawCdr(scan_bytes(1_000_000_000)))
                .is_some()
        );
        assert_eq!(intake.bad.get("undecodable"), Some(&6));
        assert_eq!(intake.bad.get("not plain CDR"), Some(&3));
        assert_eq!(intake.bad.get("stamp went back"), Some(&1));
        assert_eq!(
            intake.bad_summary(),
            "3 not plain CDR, 1 stamp went back, 6 undecodable"
        );
        let warnings: Vec<&String> = backend
            .logs
            .iter()
            .filter(|(level, _)| *level == Level::Warn)
            .map(|(_, text)| text)
            .collect();
        assert_eq!(warnings.len(), 3, "{warnings:?}");
        assert!(
            warnings.iter().all(|w| w.starts_with("/scan: ")),
            "{warnings:?}"
        );
    }

    #[test]
    fn silence_is_out_of_service_with_one_reason_while_it_lasts() {
        let intake = Intake::new("/scan", LASER_SCAN).unwrap();
        let mut freshness = Freshness::new(Duration::from_millis(500));
        assert_eq!(
            freshness.health(0, &intake),
            Health::OutOfService("no /scan yet".into())
        );
        freshness.good(1_000_000_000);
        assert_eq!(freshness.health(1_500_000_000, &intake), Health::Ok);
        let silent = freshness.health(1_600_000_000, &intake);
        assert_eq!(
            silent,
            Health::OutOfService("no /scan for more than 500 ms".into())
        );
        assert_eq!(freshness.health(9_000_000_000, &intake), silent);
    }

    #[test]
    fn the_domain_comes_from_the_robot_file_and_is_bounded() {
        let link = Link {
            domain_id: Some(DomainId(7)),
            ..Link::default()
        };
        assert_eq!(link.domain(), Ok(7));
        assert!(DomainId::try_from(233).is_err());
        assert_eq!(DomainId::try_from(232), Ok(DomainId(232)));
    }
}
