//! Camera images, with the blobs and signs found in them drawn over them.

use std::collections::BTreeMap;

use lewis_interfaces::msg::{Blobs, Header, ImageSource, Signs};
use rerun::components::MediaType;
use rerun::datatypes::{ChannelDatatype, ColorModel};
use rerun::{Arrows2D, AsComponents, Boxes2D, Color, EncodedImage, Image, TextLog};

use super::scans::rgb;
use super::topic_entity;
use crate::rows::{ChunkSink, Rows, Stamp};
use crate::{CameraFrames, ViewError};

/// Which image topic each picture space is named after.
#[derive(Debug, Default)]
pub(super) struct CameraState {
    /// Which frames are shown, and how they are stored.
    frames: CameraFrames,
    /// Per image topic: the log time of the last frame shown.
    last_shown_ns: BTreeMap<String, u64>,
    /// Frames left out by [`CameraFrames::every_ns`].
    pub(super) skipped: u64,
    /// Image topics seen, in order of appearance (the first is where blobs without
    /// provenance are drawn).
    image_topics: Vec<String>,
    /// Encodings that could not be shown, and how often, to say it once per topic.
    unshown: BTreeMap<String, u64>,
}

impl CameraState {
    /// The camera state of a scene that keeps `frames`.
    pub(super) fn new(frames: CameraFrames) -> Self {
        Self {
            frames,
            ..Self::default()
        }
    }

    /// The image topic that `header`'s inputs name, else the first image topic seen.
    fn space_of(&self, header: &Header) -> Option<&str> {
        header
            .inputs
            .iter()
            .find_map(|input| {
                self.image_topics
                    .iter()
                    .find(|topic| **topic == input.channel)
            })
            .or_else(|| self.image_topics.first())
            .map(String::as_str)
    }

    pub(super) fn image(
        &mut self,
        rows: &mut Rows,
        sink: &mut dyn ChunkSink,
        topic: &str,
        stamp: Stamp,
        image: &ImageSource,
    ) -> Result<(), ViewError> {
        if !self.image_topics.iter().any(|t| t == topic) {
            self.image_topics.push(topic.to_owned());
        }
        if let Some(last) = self.last_shown_ns.get(topic)
            && stamp.log_time_ns < last.saturating_add(self.frames.every_ns)
        {
            self.skipped += 1;
            return Ok(());
        }
        self.last_shown_ns
            .insert(topic.to_owned(), stamp.log_time_ns);
        let path = topic_entity(&["camera"], topic, &["image"]);
        match to_rerun_image(image, self.frames.jpeg_quality) {
            Ok((picture, bytes)) => rows.log(sink, &path, stamp, picture.as_ref(), bytes),
            Err(reason) => {
                let count = self.unshown.entry(topic.to_owned()).or_default();
                *count += 1;
                if *count > 1 {
                    return Ok(());
                }
                rows.log(
                    sink,
                    &path,
                    stamp,
                    &TextLog::new(format!("image not shown: {reason}")).with_level("WARN"),
                    64,
                )
            }
        }
    }

    pub(super) fn blobs(
        &self,
        rows: &mut Rows,
        sink: &mut dyn ChunkSink,
        topic: &str,
        stamp: Stamp,
        blobs: &Blobs,
    ) -> Result<(), ViewError> {
        let space = self.space_of(&blobs.header).unwrap_or(topic);
        let boxes = Boxes2D::from_mins_and_sizes(
            blobs.blobs.iter().map(|b| [b.left as f32, b.top as f32]),
            blobs
                .blobs
                .iter()
                .map(|b| [(b.right - b.left + 1) as f32, (b.bottom - b.top + 1) as f32]),
        )
        .with_colors(blobs.blobs.iter().map(|b| rgb(b.colour_rgb)))
        .with_labels(blobs.blobs.iter().map(|b| b.colour_name.clone()));
        let bytes = blobs.blobs.len() * 48;
        rows.log(
            sink,
            &topic_entity(&["camera"], space, &["blobs"]).join(&topic_entity(&[], topic, &[])),
            stamp,
            &boxes,
            bytes,
        )
    }

    pub(super) fn signs(
        &self,
        rows: &mut Rows,
        sink: &mut dyn ChunkSink,
        topic: &str,
        stamp: Stamp,
        signs: &Signs,
    ) -> Result<(), ViewError> {
        let space = self.space_of(&signs.header).unwrap_or(topic);
        let base =
            topic_entity(&["camera"], space, &["signs"]).join(&topic_entity(&[], topic, &[]));
        let boards = &signs.signs;
        let white = Color::from_rgb(255, 255, 255);
        rows.log(
            sink,
            &base,
            stamp,
            &Boxes2D::from_mins_and_sizes(
                boards
                    .iter()
                    .map(|s| [s.board.left as f32, s.board.top as f32]),
                boards.iter().map(|s| {
                    [
                        (s.board.right - s.board.left + 1) as f32,
                        (s.board.bottom - s.board.top + 1) as f32,
                    ]
                }),
            )
            .with_colors([white])
            .with_labels(
                boards
                    .iter()
                    .map(|s| format!("{} {:.2}", s.arrow, s.confidence)),
            ),
            boards.len() * 48,
        )?;
        // The arrow's direction is in the image plane with y up; image rows go down.
        rows.log(
            sink,
            &base.join(&super::entity(["arrows"])),
            stamp,
            &Arrows2D::from_vectors(boards.iter().map(|s| {
                let half = (s.board.right - s.board.left + 1) as f32 / 3.0;
                let (sin, cos) = s.arrow_direction.sin_cos();
                [half * cos as f32, -half * sin as f32]
            }))
            .with_origins(
                boards
                    .iter()
                    .map(|s| [s.board.centroid_x as f32, s.board.centroid_y as f32]),
            )
            .with_colors([Color::from_rgb(255, 40, 40)]),
            boards.len() * 32,
        )
    }
}

/// The Rerun image of a camera frame and its size, or why it cannot be shown: its pixels
/// as they are, or JPEG-compressed at `jpeg_quality` (1 to 100).
fn to_rerun_image(
    image: &ImageSource,
    jpeg_quality: Option<u8>,
) -> Result<(Box<dyn AsComponents>, usize), String> {
    let channels = match image.encoding.as_str() {
        "rgb8" | "bgr8" => 3,
        "rgba8" | "bgra8" => 4,
        "mono8" | "8UC1" => 1,
        other => {
            return Err(format!(
                "encoding `{other}` is not rgb8, bgr8, rgba8, bgra8 or mono8"
            ));
        }
    };
    let (Ok(width), Ok(height), Ok(step)) = (
        usize::try_from(image.width),
        usize::try_from(image.height),
        usize::try_from(image.step),
    ) else {
        return Err(format!(
            "size {}x{} with step {} is negative",
            image.width, image.height, image.step
        ));
    };
    let row = width * channels;
    if width == 0 || height == 0 || step < row || image.data.len() < step * (height - 1) + row {
        return Err(format!(
            "{} bytes do not hold {width}x{height} {} with step {step}",
            image.data.len(),
            image.encoding
        ));
    }
    let pixels: Vec<u8> = if step == row {
        image.data[..row * height].to_vec()
    } else {
        image
            .data
            .chunks(step)
            .take(height)
            .flat_map(|line| &line[..row])
            .copied()
            .collect()
    };
    if let Some(quality) = jpeg_quality {
        let jpeg = to_jpeg(&image.encoding, pixels, width, height, quality)?;
        let bytes = jpeg.len();
        let encoded = EncodedImage::new(jpeg).with_media_type(MediaType::jpeg());
        return Ok((Box::new(encoded), bytes));
    }
    let model = match image.encoding.as_str() {
        "rgb8" => ColorModel::RGB,
        "bgr8" => ColorModel::BGR,
        "rgba8" => ColorModel::RGBA,
        "bgra8" => ColorModel::BGRA,
        _ => ColorModel::L,
    };
    let bytes = pixels.len();
    let resolution = [
        u32::try_from(width).map_err(|_| "too wide".to_owned())?,
        u32::try_from(height).map_err(|_| "too high".to_owned())?,
    ];
    Ok((
        Box::new(Image::from_color_model_and_bytes(
            pixels,
            resolution,
            model,
            ChannelDatatype::U8,
        )),
        bytes,
    ))
}

/// `pixels` (`width` x `height`, rows packed, in `encoding`) as a JPEG file; colour without
/// its alpha, BGR turned to RGB.
fn to_jpeg(
    encoding: &str,
    mut pixels: Vec<u8>,
    width: usize,
    height: usize,
    quality: u8,
) -> Result<Vec<u8>, String> {
    let channels = pixels.len() / (width * height);
    let colour_type = if channels == 1 {
        image::ExtendedColorType::L8
    } else {
        if channels == 4 {
            pixels = pixels
                .chunks_exact(4)
                .flat_map(|p| [p[0], p[1], p[2]])
                .collect();
        }
        if encoding.starts_with("bgr") {
            for p in pixels.chunks_exact_mut(3) {
                p.swap(0, 2);
            }
        }
        image::ExtendedColorType::Rgb8
    };
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err(format!("{width}x{height} is too large"));
    };
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, quality.clamp(1, 100))
        .encode(&pixels, w, h, colour_type)
        .map_err(|e| format!("cannot compress as JPEG: {e}"))?;
    Ok(jpeg)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn frame(encoding: &str, channels: i32) -> ImageSource {
        let (width, height) = (16, 8);
        ImageSource {
            width,
            height,
            step: width * channels,
            encoding: encoding.to_owned(),
            data: (0..width * height * channels)
                .map(|i| u8::try_from(i % 251).unwrap())
                .collect(),
            ..ImageSource::default()
        }
    }

    #[test]
    fn frames_are_compressed_as_jpeg_when_asked() {
        for (encoding, channels) in [("rgb8", 3), ("bgra8", 4), ("mono8", 1)] {
            let image = frame(encoding, channels);
            let (_, raw) = to_rerun_image(&image, None).unwrap();
            assert_eq!(raw, image.data.len());
            let (_, jpeg) = to_rerun_image(&image, Some(80)).unwrap();
            assert!(jpeg > 0 && jpeg != raw, "{encoding}: {jpeg} bytes");
        }
    }
}
