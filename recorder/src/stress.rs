//! The stress mix of the recorder's requirements, as messages: 20 channels of small
//! messages at 1 kHz (`/sensorNN/Distance`, about 150 bytes each) and one 640x480 RGB
//! stream at 30 Hz (`/camera/ImageSource`, 900 KiB each), about 30 MB/s in all.
//!
//! One definition for everything that measures the recorder with it: the zero-loss test
//! with real processes (`lewis stress-publish`, [`crate::live::load`]), the throughput
//! benchmark and the recorder's own tests, so that they all write the same kind of bytes.

use lewis_interfaces::msg::{Distance, Header, ImageSource};

/// Channels of small messages.
pub const SMALL_CHANNELS: usize = 20;
/// Their period: 1 kHz.
pub const SMALL_PERIOD_NS: i64 = 1_000_000;
/// The image period: 30 Hz.
pub const IMAGE_PERIOD_NS: i64 = 1_000_000_000 / 30;
/// Image width in pixels.
pub const IMAGE_WIDTH: usize = 640;
/// Image height in pixels.
pub const IMAGE_HEIGHT: usize = 480;
/// The provider of the image stream.
pub const IMAGE_PROVIDER: &str = "camera";
/// The interface of the small messages.
pub const SMALL_INTERFACE: &str = "Distance";
/// The interface of the image stream.
pub const IMAGE_INTERFACE: &str = "ImageSource";

/// The provider of small channel `channel` (`sensor00` to `sensor19`).
#[must_use]
pub fn small_provider(channel: usize) -> String {
    format!("sensor{channel:02}")
}

fn header(provider: String, seq: u64, publish_time_ns: i64) -> Header {
    Header {
        provider,
        seq,
        publish_time_ns,
        inputs: Vec::new(),
    }
}

/// A small message of channel `channel`: a Distance with 8 sectors.
#[must_use]
pub fn small_message(channel: usize, seq: u64, publish_time_ns: i64) -> Distance {
    let base = seq as f64 * 0.001 + channel as f64;
    Distance {
        header: header(small_provider(channel), seq, publish_time_ns),
        sector_count: 8,
        sector_distances: (0..8).map(|s| base + f64::from(s) * 0.25).collect(),
        first_sector_angle: -std::f64::consts::PI,
        sector_width: std::f64::consts::FRAC_PI_4,
        max_range: 8.0,
        min_distance: base,
        min_bearing: 0.5,
    }
}

/// The pixels of frame `seq` (rgb8): a moving gradient with a little noise, about as
/// compressible as a camera image.
#[must_use]
pub fn image_pixels(seq: u64) -> Vec<u8> {
    let mut data = vec![0_u8; IMAGE_WIDTH * IMAGE_HEIGHT * 3];
    let mut noise = lewis_service::NoiseBytes::new(seq.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1, 0);
    let shift = seq as usize;
    for (i, px) in data.iter_mut().enumerate() {
        let noise = noise.next_u64();
        let x = (i / 3) % IMAGE_WIDTH;
        let y = i / 3 / IMAGE_WIDTH;
        let value = ((x + y + shift) as u8) ^ ((noise & 0x7) as u8);
        *px = value;
    }
    data
}

/// Frame `seq` with the given pixels.
#[must_use]
pub fn image_message(seq: u64, publish_time_ns: i64, pixels: Vec<u8>) -> ImageSource {
    ImageSource {
        header: header(IMAGE_PROVIDER.to_owned(), seq, publish_time_ns),
        width: IMAGE_WIDTH as i32,
        height: IMAGE_HEIGHT as i32,
        encoding: "rgb8".to_owned(),
        step: (IMAGE_WIDTH * 3) as i32,
        data: pixels,
        focal_length_x: 525.0,
        focal_length_y: 525.0,
        principal_point_x: 319.5,
        principal_point_y: 239.5,
    }
}

/// A robot description whose services are the providers of the stress mix, so that a
/// recorder given it (`lewis record --robot`) taps every channel of the mix. Its services
/// are never started: `lewis stress-publish` publishes for all of them.
#[must_use]
pub fn robot_toml() -> String {
    let mut toml = String::from(
        "# The providers of the recorder's stress mix (`lewis stress-publish`): never started,\n\
         # the load generator publishes for them.\n\n\
         [robot]\nname = \"stress\"\n\
         description = \"20 channels of small messages at 1 kHz and a 640x480 RGB stream at 30 Hz\"\n",
    );
    let mut service = |name: &str, interface: &str, rate_hz: u32| {
        toml.push_str(&format!(
            "\n[[services]]\nname = \"{name}\"\ncommand = [\"true\"]\nstart = \"on-demand\"\n\
             provides = [{{ interface = \"{interface}\", quality = 1, cost = 1, data_rate_hz = {rate_hz}.0 }}]\n"
        ));
    };
    for channel in 0..SMALL_CHANNELS {
        service(&small_provider(channel), SMALL_INTERFACE, 1000);
    }
    service(IMAGE_PROVIDER, IMAGE_INTERFACE, 30);
    toml
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pixels_are_those_the_old_inline_xorshift_gave() {
        // Produced by this function's own xorshift before it used the one NoiseBytes.
        let check = |seq: u64, first: [u8; 12], checksum: u64| {
            let pixels = image_pixels(seq);
            let sum = pixels.iter().fold(0_u64, |h, &b| {
                (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
            });
            assert_eq!((&pixels[..12], sum), (&first[..], checksum), "frame {seq}");
        };
        check(
            0,
            [1, 1, 1, 4, 4, 0, 3, 7, 5, 5, 7, 2],
            0xc044_2228_4055_85c1,
        );
        check(
            1,
            [4, 7, 7, 6, 6, 3, 4, 1, 0, 2, 1, 7],
            0xecc4_b2b8_6cf8_060e,
        );
        check(
            7,
            [5, 0, 0, 15, 8, 15, 11, 12, 9, 12, 13, 14],
            0x84d0_67e7_dbce_7432,
        );
    }

    #[test]
    fn the_stress_robot_lists_every_provider_of_the_mix() {
        let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
            .iter()
            .map(|i| i.name)
            .collect();
        let robot =
            lewis_robot::parse(&robot_toml(), std::path::Path::new("stress.toml"), &known).unwrap();
        let provided: Vec<(String, String)> = robot
            .services
            .iter()
            .flat_map(|s| {
                s.provides
                    .iter()
                    .map(|p| (s.name.clone(), p.interface.clone()))
            })
            .collect();
        assert_eq!(provided.len(), SMALL_CHANNELS + 1);
        assert_eq!(provided[0], ("sensor00".into(), "Distance".into()));
        assert_eq!(provided[19], ("sensor19".into(), "Distance".into()));
        assert_eq!(provided[20], ("camera".into(), "ImageSource".into()));
    }

    #[test]
    fn messages_are_numbered_and_sized_as_the_mix_says() {
        let small = lewis_interfaces::cdr::to_vec(&small_message(3, 7, 11));
        assert!((100..300).contains(&small.len()), "{}", small.len());
        let image = image_message(2, 5, image_pixels(2));
        assert_eq!(image.data.len(), 640 * 480 * 3);
        assert_eq!((image.header.seq, image.header.publish_time_ns), (2, 5));
    }
}
