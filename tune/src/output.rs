//! The MCAP file `lewis tune blobfinder -o OUT.mcap` writes, through the recorder: the
//! images as they were recorded (same topic, bytes and times) and the re-run results on
//! their own channels, each result stamped with its image's times and naming the image in
//! its provenance, so that the viewer draws the results over their images.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Context as _;
use lewis_interfaces::msg::{Blobs, Header, ImageSource, InputRef, Signs};
use lewis_interfaces::{Interface, interface_info};
use lewis_perception::tuning::TunedFrame;
use lewis_recorder::{ChannelId, ChannelSpec, Recorder, RecorderOptions, RobotDescription, Sample};

use crate::frames::{FILES_TOPIC, Frame, Input};

/// The provider name of the results.
pub const PROVIDER: &str = "tune";
/// The topic of the re-run blobs.
pub const BLOBS_TOPIC: &str = "/tune/blobfinder/Blobs";
/// The topic of the re-run signs.
pub const SIGNS_TOPIC: &str = "/tune/sign_detector/Signs";

/// The output recording being written.
pub struct TuneOutput {
    recorder: Recorder,
    /// The image topics' specs (from the input recording) and channels, once registered.
    images: BTreeMap<Arc<str>, (ChannelSpec, Option<ChannelId>)>,
    blobs: ChannelId,
    signs: Option<ChannelId>,
    seq: u64,
    bytes: Vec<u8>,
}

impl TuneOutput {
    /// Creates the file, with the input recording's robot description when it has one.
    ///
    /// # Errors
    /// When the file cannot be created.
    pub fn create(path: &Path, input: &Input, with_signs: bool) -> anyhow::Result<Self> {
        let mut options = RecorderOptions::new(path);
        // A file written in one go from a file: no timed flushes or syncs needed.
        options.sync_on_flush = false;
        options.recorder_name = PROVIDER.to_owned();
        let mut images = BTreeMap::new();
        match input {
            Input::Recording {
                recording, topics, ..
            } => {
                let (file_name, toml) = recording.robot_toml();
                options.robot_description = Some(RobotDescription {
                    file_name: file_name.to_owned(),
                    toml: toml.to_owned(),
                });
                for topic in topics {
                    let spec = ChannelSpec {
                        topic: topic.name.to_string(),
                        schema_name: topic.schema_name.clone(),
                        schema_text: topic.schema_text.clone(),
                        provider: topic.provider.clone().unwrap_or_default(),
                        interface: topic
                            .interface
                            .clone()
                            .unwrap_or_else(|| ImageSource::NAME.to_owned()),
                        interface_version: topic.interface_version.clone().unwrap_or_default(),
                        extra_metadata: BTreeMap::new(),
                    };
                    images.insert(topic.name.clone(), (spec, None));
                }
            }
            Input::Files(_) => {
                images.insert(
                    Arc::from(FILES_TOPIC),
                    (publication(ImageSource::NAME, FILES_TOPIC)?, None),
                );
            }
        }
        let mut recorder = Recorder::create(options)
            .with_context(|| format!("cannot create {}", path.display()))?;
        let blobs = recorder.add_channel(publication(Blobs::NAME, BLOBS_TOPIC)?)?;
        let signs = if with_signs {
            Some(recorder.add_channel(publication(Signs::NAME, SIGNS_TOPIC)?)?)
        } else {
            None
        };
        Ok(Self {
            recorder,
            images,
            blobs,
            signs,
            seq: 0,
            bytes: Vec::new(),
        })
    }

    /// Writes a frame's image and its results.
    ///
    /// # Errors
    /// When the recorder fails (disk full, ...).
    pub fn write(&mut self, frame: &Frame, tuned: &TunedFrame) -> anyhow::Result<()> {
        let image_channel = self.image_channel(&frame.topic)?;
        self.recorder.write(&Sample {
            channel: image_channel,
            seq: frame.image.header.seq,
            publish_time_ns: frame.publish_time_ns,
            log_time_ns: frame.log_time_ns,
            data: &frame.bytes,
        })?;
        self.seq += 1;
        let header = Header {
            provider: PROVIDER.to_owned(),
            seq: self.seq,
            publish_time_ns: frame.publish_time_ns,
            inputs: vec![InputRef {
                channel: frame.topic.to_string(),
                seq: frame.image.header.seq,
            }],
        };
        let mut blobs = tuned.blobs.clone();
        blobs.header = header.clone();
        self.put(self.blobs, frame, &blobs)?;
        if let (Some(channel), Some(signs)) = (self.signs, &tuned.signs) {
            let mut signs = signs.clone();
            signs.header = header;
            self.put(channel, frame, &signs)?;
        }
        Ok(())
    }

    fn put<T: Interface>(
        &mut self,
        channel: ChannelId,
        frame: &Frame,
        message: &T,
    ) -> anyhow::Result<()> {
        lewis_interfaces::cdr::encode_to_vec(message, &mut self.bytes);
        self.recorder.write(&Sample {
            channel,
            seq: self.seq,
            publish_time_ns: frame.publish_time_ns,
            log_time_ns: frame.log_time_ns,
            data: &self.bytes,
        })?;
        Ok(())
    }

    /// The channel of an image topic, registered when first written.
    fn image_channel(&mut self, topic: &Arc<str>) -> anyhow::Result<ChannelId> {
        let Some((spec, id)) = self.images.get_mut(topic) else {
            anyhow::bail!("image topic {topic} was not announced");
        };
        if let Some(id) = id {
            return Ok(*id);
        }
        let channel = self.recorder.add_channel(spec.clone())?;
        *id = Some(channel);
        Ok(channel)
    }

    /// Closes the file; returns its path and how many messages it holds.
    ///
    /// # Errors
    /// When the file cannot be finished.
    pub fn close(self) -> anyhow::Result<(PathBuf, u64)> {
        let path = self.recorder.current_path().to_path_buf();
        let report = self.recorder.close()?;
        Ok((path, report.messages()))
    }
}

/// The channel of the publications of `interface` on `topic`, by [`PROVIDER`].
fn publication(interface: &str, topic: &str) -> anyhow::Result<ChannelSpec> {
    let info = interface_info(interface)
        .with_context(|| format!("interface {interface} is not compiled in"))?;
    Ok(ChannelSpec::publication(info, PROVIDER, topic))
}
