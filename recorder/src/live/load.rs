//! The load generator of the recorder (`lewis stress-publish`): publishes the stress mix
//! ([`crate::stress`]) into live IPC at its real rate, from one process, with the settings
//! every provider uses, and reports what it published and how punctually.
//!
//! It keeps a fixed schedule: small message `k` of every channel is due at `k` ms after the
//! start, image `j` at `j / 30` s. A turn publishes everything due, so a publisher that was
//! not scheduled for a while catches up and the counts are exact whatever the load; how
//! late it ran is reported. Publishing never waits for a reader: the data channels drop
//! the oldest unread sample of a reader that does not keep up.

use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_runtime::clock::LiveClock;
use lewis_runtime::ipc::{Ipc, IpcError, Namespace, PublishError, Publisher};
use lewis_runtime::names;
use serde::Serialize;
use thiserror::Error;

use crate::stress::{
    IMAGE_INTERFACE, IMAGE_PERIOD_NS, IMAGE_PROVIDER, SMALL_CHANNELS, SMALL_INTERFACE,
    SMALL_PERIOD_NS, image_message, image_pixels, small_message, small_provider,
};

/// Why the load could not be published.
#[derive(Debug, Error)]
pub enum LoadError {
    /// A channel could not be opened.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// A publication failed.
    #[error(transparent)]
    Publish(#[from] PublishError),
}

/// What was published on one channel.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelLoad {
    /// The channel (and MCAP topic).
    pub topic: String,
    /// Messages published, numbered 1 to `published`.
    pub published: u64,
    /// The rate the schedule asks for, in Hz.
    pub nominal_hz: f64,
    /// The rate achieved: messages after the first over the time from the first to the
    /// last, in Hz.
    pub achieved_hz: f64,
}

/// What the load generator did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoadReport {
    /// Per channel, small channels first, then the camera.
    pub channels: Vec<ChannelLoad>,
    /// Seconds from the first publication to the last.
    pub elapsed_secs: f64,
    /// How late a message was published at worst, behind its due time, in ms.
    pub max_late_ms: f64,
    /// The longest a single publication took, in µs (the publisher never waits for a
    /// reader: this is the cost of one publication, and of being descheduled in it).
    pub max_publish_us: f64,
}

/// Publishes the stress mix in `namespace` for `duration`.
///
/// # Errors
/// When a channel cannot be opened or a publication fails.
pub fn publish_stress(namespace: &Namespace, duration: Duration) -> Result<LoadReport, LoadError> {
    let ipc = Ipc::open(namespace, "lewis-stress-publish")?;
    let mut small: Vec<Publisher> = (0..SMALL_CHANNELS)
        .map(|channel| {
            ipc.publisher(
                &names::data_channel(&small_provider(channel), SMALL_INTERFACE),
                &names::data_config(SMALL_INTERFACE),
            )
        })
        .collect::<Result<_, _>>()?;
    let mut camera = ipc.publisher(
        &names::data_channel(IMAGE_PROVIDER, IMAGE_INTERFACE),
        &names::data_config(IMAGE_INTERFACE),
    )?;
    // The readers already there are connected before the schedule starts: the first
    // publications are then as quick as the others.
    for publisher in small.iter().chain(std::iter::once(&camera)) {
        publisher.update_connections()?;
    }
    let clock = LiveClock::new();
    // One frame's pixels, made once; each frame is told apart by its header.
    let mut frame = image_message(0, 0, image_pixels(0));
    let duration_ns = i64::try_from(duration.as_nanos()).unwrap_or(i64::MAX);
    let small_total = u64::try_from(duration_ns / SMALL_PERIOD_NS).unwrap_or(0);
    let image_total = u64::try_from(duration_ns / IMAGE_PERIOD_NS).unwrap_or(0);
    let mut punctuality = Punctuality::default();
    let start = Instant::now();
    let (mut small_next, mut image_next) = (0_u64, 0_u64);
    let mut first_ns = None;
    let mut last_small_ns = 0;
    let mut last_image_ns = 0;
    while small_next < small_total || image_next < image_total {
        let small_due = due(start, small_next, SMALL_PERIOD_NS);
        let image_due = due(start, image_next, IMAGE_PERIOD_NS);
        let now = Instant::now();
        if small_next < small_total && now >= small_due {
            let seq = small_next + 1;
            for (channel, publisher) in small.iter_mut().enumerate() {
                let publish_time_ns = clock.now_ns();
                first_ns.get_or_insert(publish_time_ns);
                let message = small_message(channel, seq, publish_time_ns);
                punctuality.publish(publisher, &message, small_due)?;
            }
            last_small_ns = clock.now_ns();
            small_next += 1;
            continue;
        }
        if image_next < image_total && now >= image_due {
            image_next += 1;
            frame.header.seq = image_next;
            frame.header.publish_time_ns = clock.now_ns();
            first_ns.get_or_insert(frame.header.publish_time_ns);
            punctuality.publish(&mut camera, &frame, image_due)?;
            last_image_ns = clock.now_ns();
            continue;
        }
        let next = [
            (small_next < small_total).then_some(small_due),
            (image_next < image_total).then_some(image_due),
        ]
        .into_iter()
        .flatten()
        .min();
        if let Some(next) = next {
            std::thread::sleep(next.saturating_duration_since(Instant::now()));
        }
    }
    let first_ns = first_ns.unwrap_or_default();
    let mut channels: Vec<ChannelLoad> = (0..SMALL_CHANNELS)
        .map(|channel| {
            load(
                names::data_channel(&small_provider(channel), SMALL_INTERFACE),
                small_total,
                SMALL_PERIOD_NS,
                last_small_ns - first_ns,
            )
        })
        .collect();
    channels.push(load(
        names::data_channel(IMAGE_PROVIDER, IMAGE_INTERFACE),
        image_total,
        IMAGE_PERIOD_NS,
        last_image_ns - first_ns,
    ));
    Ok(LoadReport {
        channels,
        elapsed_secs: secs(last_small_ns.max(last_image_ns) - first_ns),
        max_late_ms: punctuality.max_late.as_secs_f64() * 1e3,
        max_publish_us: punctuality.max_publish.as_secs_f64() * 1e6,
    })
}

/// When message `index` (from 0) of a stream of period `period_ns` is due.
fn due(start: Instant, index: u64, period_ns: i64) -> Instant {
    let offset = u64::try_from(period_ns).unwrap_or(0).saturating_mul(index);
    start + Duration::from_nanos(offset)
}

fn secs(ns: i64) -> f64 {
    ns as f64 / 1e9
}

fn load(topic: String, published: u64, period_ns: i64, span_ns: i64) -> ChannelLoad {
    let span = secs(span_ns);
    ChannelLoad {
        topic,
        published,
        nominal_hz: 1e9 / period_ns as f64,
        achieved_hz: if span > 0.0 {
            published.saturating_sub(1) as f64 / span
        } else {
            0.0
        },
    }
}

/// How late and how long the publications were, at worst.
#[derive(Debug, Default)]
struct Punctuality {
    max_late: Duration,
    max_publish: Duration,
}

impl Punctuality {
    fn publish<T: cdr::Encode>(
        &mut self,
        publisher: &mut Publisher,
        message: &T,
        due: Instant,
    ) -> Result<(), PublishError> {
        let before = Instant::now();
        self.max_late = self.max_late.max(before.saturating_duration_since(due));
        let len = cdr::encoded_len(message);
        publisher.publish_with(len, |buf| {
            // The length was computed from the same message: it fits.
            let _ = cdr::encode_into(message, buf);
        })?;
        self.max_publish = self.max_publish.max(before.elapsed());
        Ok(())
    }
}
