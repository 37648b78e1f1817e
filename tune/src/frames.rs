//! The frames `lewis tune` works on: the ImageSource messages of a recording (read with
//! `lewis_recording`, chunk by chunk), or the PNG and JPEG files of a folder or
//! glob.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Context as _;
use lewis_images::sequence::resolve;
use lewis_interfaces::Struct as _;
use lewis_interfaces::msg::ImageSource;
use lewis_perception::tuning::Tuner;
use lewis_recording::{Recording, Topic};

/// The topic that images read from files are written on, and their spacing in time.
pub const FILES_TOPIC: &str = "/tune/images/ImageSource";
const FILES_PERIOD_NS: i64 = 100_000_000;

/// One frame to tune on.
#[derive(Debug)]
pub struct Frame {
    /// A name for files written from it (`camera_ImageSource-000012`, or the file's stem).
    pub name: String,
    /// Its topic (for files: [`FILES_TOPIC`]).
    pub topic: Arc<str>,
    /// Its recorded time (for files: 0.1 s apart).
    pub log_time_ns: i64,
    /// The header's publish time.
    pub publish_time_ns: i64,
    /// The CDR bytes as recorded (for files: as encoded here).
    pub bytes: Vec<u8>,
    /// The image.
    pub image: ImageSource,
}

/// Where the frames come from.
#[derive(Debug)]
pub enum Input {
    /// A recording and its image topics to read.
    Recording {
        /// The path given.
        path: PathBuf,
        /// The opened recording (boxed: it is large beside a list of files).
        recording: Box<Recording>,
        /// The image topics to read.
        topics: Vec<Topic>,
    },
    /// Image files, in name order.
    Files(Vec<PathBuf>),
}

impl Input {
    /// An MCAP file (by its extension) or a folder or glob of images; `channel` picks one
    /// image topic of a recording.
    ///
    /// # Errors
    /// When the recording cannot be opened, has no such image topic, or no image matches.
    pub fn open(input: &str, channel: Option<&str>) -> anyhow::Result<Self> {
        let path = Path::new(input);
        let is_mcap = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("mcap"));
        if !is_mcap {
            anyhow::ensure!(
                channel.is_none(),
                "--channel picks a topic of a recording, and {input} is not an MCAP file"
            );
            return Ok(Self::Files(resolve(input)?));
        }
        let recording = Box::new(Recording::open(&[path.to_path_buf()])?);
        let topics = image_topics(&recording, input, channel)?;
        Ok(Self::Recording {
            path: path.to_path_buf(),
            recording,
            topics,
        })
    }

    /// The frames, in recorded order (files: in name order), each read when reached.
    ///
    /// # Errors
    /// When the recording cannot be read again.
    pub fn frames(&self) -> anyhow::Result<Box<dyn Iterator<Item = anyhow::Result<Frame>> + '_>> {
        match self {
            Self::Files(files) => Ok(Box::new(
                files
                    .iter()
                    .zip(0i64..)
                    .map(|(path, index)| file_frame(path, index)),
            )),
            Self::Recording {
                path,
                recording,
                topics,
            } => {
                let names: Vec<&str> = topics.iter().map(|t| &*t.name).collect();
                let messages = recording.messages_on(&names)?;
                Ok(Box::new(messages.map(move |message| {
                    let message = message?;
                    let image: ImageSource = lewis_interfaces::cdr::from_bytes(&message.data)
                        .with_context(|| {
                            format!(
                                "{}: message {} on {} does not decode as ImageSource",
                                path.display(),
                                message.seq,
                                message.topic
                            )
                        })?;
                    Ok(Frame {
                        name: frame_name(&message.topic, message.seq),
                        topic: message.topic,
                        log_time_ns: message.log_time_ns,
                        publish_time_ns: message.publish_time_ns,
                        bytes: message.data.to_vec(),
                        image,
                    })
                })))
            }
        }
    }
}

/// The ImageSource topics of a recording (only `channel` when given).
fn image_topics(
    recording: &Recording,
    input: &str,
    channel: Option<&str>,
) -> anyhow::Result<Vec<Topic>> {
    let images: Vec<Topic> = recording
        .topics()
        .values()
        .filter(|t| t.schema_name == ImageSource::SCHEMA_NAME)
        .cloned()
        .collect();
    let names = || {
        images
            .iter()
            .map(|t| t.name.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    anyhow::ensure!(
        !images.is_empty(),
        "{input} has no ImageSource topic: check its topics with `lewis info {input}`"
    );
    let Some(channel) = channel else {
        return Ok(images);
    };
    let chosen: Vec<Topic> = images
        .iter()
        .filter(|t| &*t.name == channel)
        .cloned()
        .collect();
    anyhow::ensure!(
        !chosen.is_empty(),
        "{input} has no ImageSource topic {channel}: its image topics are {}",
        names()
    );
    Ok(chosen)
}

/// The name of the recorded frame `seq` of `topic` (`camera_ImageSource-000012`): its
/// pictures' file name, and how a labels file names it.
pub fn frame_name(topic: &str, seq: u64) -> String {
    format!("{}-{seq:06}", file_name_of(topic))
}

/// A topic as part of a file name (`/camera/ImageSource` -> `camera_ImageSource`).
fn file_name_of(topic: &str) -> String {
    topic
        .trim_matches('/')
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

fn file_frame(path: &Path, index: i64) -> anyhow::Result<Frame> {
    let mut image = Tuner::read_image(path)?;
    let time_ns = index * FILES_PERIOD_NS;
    image.header.provider = "tune".to_owned();
    image.header.seq = u64::try_from(index + 1).unwrap_or(u64::MAX);
    image.header.publish_time_ns = time_ns;
    let bytes = lewis_interfaces::cdr::to_vec(&image);
    Ok(Frame {
        name: path
            .file_stem()
            .map_or_else(|| "frame".to_owned(), |s| s.to_string_lossy().into_owned()),
        topic: Arc::from(FILES_TOPIC),
        log_time_ns: time_ns,
        publish_time_ns: time_ns,
        bytes,
        image,
    })
}
