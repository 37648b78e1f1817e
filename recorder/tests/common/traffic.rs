//! Recorded-like traffic for tests and benchmarks: the stress mix of the issue (20
//! channels at 1 kHz of small messages and a 640x480 RGB stream at 30 Hz) and a stream of
//! 1 KiB messages, generated in receive-time order, deterministically.

#![allow(dead_code)]

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Header, LogLine};
use lewis_recorder::ChannelSpec;

pub use lewis_recorder::stress::{
    IMAGE_PERIOD_NS, SMALL_CHANNELS, SMALL_PERIOD_NS, image_pixels, small_provider,
};

/// Time between publishing and receiving.
pub const LATENCY_NS: i64 = 50_000;

/// One generated message.
#[derive(Debug, Clone)]
pub struct Msg {
    pub channel: usize,
    pub seq: u64,
    pub publish_time_ns: i64,
    pub log_time_ns: i64,
    pub data: Vec<u8>,
}

/// The stress mix's channels: 20 Distance channels, then the camera.
pub fn stress_channels() -> Vec<ChannelSpec> {
    let distance = lewis_interfaces::interface_info("Distance").unwrap();
    let image = lewis_interfaces::interface_info("ImageSource").unwrap();
    let mut channels: Vec<ChannelSpec> = (0..SMALL_CHANNELS)
        .map(|i| {
            let provider = small_provider(i);
            ChannelSpec::publication(distance, &provider, &format!("/{provider}/Distance"))
        })
        .collect();
    channels.push(ChannelSpec::publication(
        image,
        "camera",
        "/camera/ImageSource",
    ));
    channels
}

fn header(provider: String, seq: u64, publish_time_ns: i64) -> Header {
    Header {
        provider,
        seq,
        publish_time_ns,
        inputs: Vec::new(),
    }
}

/// A small Distance message (8 sectors: about 150 bytes), as CDR.
pub fn small_message(channel: usize, seq: u64, publish_time_ns: i64) -> Vec<u8> {
    cdr::to_vec(&lewis_recorder::stress::small_message(
        channel,
        seq,
        publish_time_ns,
    ))
}

/// A 640x480 rgb8 image, as CDR.
pub fn image_message(seq: u64, publish_time_ns: i64) -> Vec<u8> {
    cdr::to_vec(&lewis_recorder::stress::image_message(
        seq,
        publish_time_ns,
        image_pixels(seq),
    ))
}

/// The stress mix over `[start_ns, start_ns + duration_ns)`, in receive-time order.
/// Sequence numbers start at 1 at `start_ns == 0`.
pub fn stress_mix(duration_ns: i64) -> impl Iterator<Item = Msg> {
    let mut small_tick = 0_i64;
    let mut image_tick = 0_i64;
    std::iter::from_fn(move || {
        let small_time = small_tick / SMALL_CHANNELS as i64 * SMALL_PERIOD_NS
            + (small_tick % SMALL_CHANNELS as i64) * 10_000;
        let image_time = image_tick * IMAGE_PERIOD_NS + 5_000;
        if small_time >= duration_ns && image_time >= duration_ns {
            return None;
        }
        if image_time < small_time {
            image_tick += 1;
            let seq = image_tick as u64;
            Some(Msg {
                channel: SMALL_CHANNELS,
                seq,
                publish_time_ns: image_time,
                log_time_ns: image_time + LATENCY_NS,
                data: image_message(seq, image_time),
            })
        } else {
            let channel = (small_tick % SMALL_CHANNELS as i64) as usize;
            let seq = (small_tick / SMALL_CHANNELS as i64 + 1) as u64;
            small_tick += 1;
            Some(Msg {
                channel,
                seq,
                publish_time_ns: small_time,
                log_time_ns: small_time + LATENCY_NS,
                data: small_message(channel, seq, small_time),
            })
        }
    })
}

/// One LogLine channel.
pub fn kib_channels() -> Vec<ChannelSpec> {
    let log = lewis_interfaces::interface_info("LogLine").unwrap();
    vec![ChannelSpec::publication(log, "chatty", "/lewis/log")]
}

/// `count` LogLine messages of 1 KiB each, 10 µs apart.
pub fn kib_messages(count: u64) -> impl Iterator<Item = Msg> {
    (1..=count).map(|seq| {
        let time = seq as i64 * 10_000;
        let mut text = String::with_capacity(1024);
        let mut n = seq;
        while text.len() < 930 {
            text.push_str(&format!("sample {n} range {:.3} ", n as f64 * 0.37));
            n = n
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407)
                >> 40;
        }
        let data = cdr::to_vec(&LogLine {
            header: header("chatty".to_owned(), seq, time),
            service: "chatty".to_owned(),
            stream: "stdout".to_owned(),
            level: "info".to_owned(),
            text,
        });
        Msg {
            channel: 0,
            seq,
            publish_time_ns: time,
            log_time_ns: time + LATENCY_NS,
            data,
        }
    })
}
