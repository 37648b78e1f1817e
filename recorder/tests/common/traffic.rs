//! Recorded-like traffic for tests and benchmarks: the stress mix of the issue (20
//! channels at 1 kHz of small messages and a 640x480 RGB stream at 30 Hz) and a stream of
//! 1 KiB messages, generated in receive-time order, deterministically.

#![allow(dead_code)]

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Distance, Header, ImageSource, LogLine};
use lewis_recorder::ChannelSpec;

/// Channels of the small messages.
pub const SMALL_CHANNELS: usize = 20;
/// Their period: 1 kHz.
pub const SMALL_PERIOD_NS: i64 = 1_000_000;
/// The image period: 30 Hz.
pub const IMAGE_PERIOD_NS: i64 = 1_000_000_000 / 30;
/// Image size.
pub const IMAGE_WIDTH: usize = 640;
/// Image size.
pub const IMAGE_HEIGHT: usize = 480;
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
            let provider = format!("sensor{i:02}");
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

/// A small Distance message (8 sectors: about 150 bytes).
pub fn small_message(channel: usize, seq: u64, publish_time_ns: i64) -> Vec<u8> {
    let base = seq as f64 * 0.001 + channel as f64;
    cdr::to_vec(&Distance {
        header: header(format!("sensor{channel:02}"), seq, publish_time_ns),
        sector_count: 8,
        sector_distances: (0..8).map(|s| base + f64::from(s) * 0.25).collect(),
        first_sector_angle: -std::f64::consts::PI,
        sector_width: std::f64::consts::FRAC_PI_4,
        max_range: 8.0,
        min_distance: base,
        min_bearing: 0.5,
    })
}

/// A 640x480 rgb8 image: a moving gradient with a little noise, as compressible as a
/// camera image roughly is.
pub fn image_message(seq: u64, publish_time_ns: i64) -> Vec<u8> {
    let mut data = vec![0_u8; IMAGE_WIDTH * IMAGE_HEIGHT * 3];
    let mut noise = seq.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    for (i, px) in data.iter_mut().enumerate() {
        noise ^= noise << 13;
        noise ^= noise >> 7;
        noise ^= noise << 17;
        let x = (i / 3) % IMAGE_WIDTH;
        let y = i / 3 / IMAGE_WIDTH;
        *px = ((x + y + seq as usize) as u8) ^ ((noise & 0x7) as u8);
    }
    cdr::to_vec(&ImageSource {
        header: header("camera".to_owned(), seq, publish_time_ns),
        width: IMAGE_WIDTH as i32,
        height: IMAGE_HEIGHT as i32,
        encoding: "rgb8".to_owned(),
        step: (IMAGE_WIDTH * 3) as i32,
        data,
        focal_length_x: 525.0,
        focal_length_y: 525.0,
        principal_point_x: 319.5,
        principal_point_y: 239.5,
    })
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
