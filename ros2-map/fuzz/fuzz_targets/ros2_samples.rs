//! Arbitrary bytes as a sample from a ROS 2 robot, as the live gateway (`lewis-ros2`) reads
//! it: decoded by each schema the gateway knows for the type (`robot::schema_texts`), then
//! converted to what the gateway publishes. The first byte picks the type; the rest is
//! the sample with its encapsulation header, as DDS hands it over. Errors are fine; panics,
//! huge allocations and numbers that are not numbers in a Lewis message are not.
#![no_main]

use std::sync::OnceLock;

use lewis_interfaces::dynamic::{Decoder, Value};
use lewis_interfaces::ros2::{COMPRESSED_IMAGE, LASER_SCAN, ODOMETRY, TF_MESSAGE};
use lewis_ros2_map::from_ros2::{self, RangeCounts};
use lewis_ros2_map::robot::{
    self, BATTERY_STATE, HAZARD_DETECTION_VECTOR, IMAGE, IR_INTENSITY_VECTOR, RANGE,
};
use libfuzzer_sys::fuzz_target;

/// Every type the gateway reads (`components/ros2/src/sensors.rs` and `base.rs`).
const TYPES: &[&str] = &[
    LASER_SCAN,
    TF_MESSAGE,
    RANGE,
    ODOMETRY,
    BATTERY_STATE,
    IMAGE,
    COMPRESSED_IMAGE,
    IR_INTENSITY_VECTOR,
    HAZARD_DETECTION_VECTOR,
];

/// The decoders of each type, built once as the gateway builds them when it starts.
fn decoders() -> &'static [Vec<Decoder>] {
    static DECODERS: OnceLock<Vec<Vec<Decoder>>> = OnceLock::new();
    DECODERS.get_or_init(|| {
        TYPES
            .iter()
            .map(|name| {
                robot::schema_texts(name)
                    .iter()
                    .map(|text| Decoder::new(name, text).expect("the gateway's schemas parse"))
                    .collect()
            })
            .collect()
    })
}

/// What the gateway makes of a decoded sample of `type_name`.
fn convert(type_name: &str, value: &Value) {
    let _ = from_ros2::stamp_ns(value);
    match type_name {
        LASER_SCAN => {
            if let Ok(scan) = from_ros2::laser_scan(value) {
                let reading = from_ros2::range_finder(&scan, &mut RangeCounts::default());
                assert_eq!(reading.ranges.len(), scan.ranges_m.len());
            }
        }
        TF_MESSAGE => {
            if let Ok(transforms) = robot::transforms(value) {
                for t in &transforms {
                    let _ = robot::frame_in(&transforms, "base_link", &t.child);
                }
            }
            let _ = from_ros2::tf_odometry(value);
        }
        RANGE => {
            if let Ok(range) = robot::range(value) {
                let _ = range.distance_m();
            }
        }
        ODOMETRY => {
            let _ = from_ros2::odometry(value);
        }
        BATTERY_STATE => {
            let _ = robot::battery(value);
        }
        IMAGE | COMPRESSED_IMAGE => {
            let image = if type_name == IMAGE {
                from_ros2::image(value)
            } else {
                from_ros2::compressed_image(value)
            };
            if let Ok((width, height, rgb)) = image {
                assert_eq!(rgb.len(), width as usize * height as usize * 3);
                let _ = from_ros2::image_source(width, height, rgb);
            }
        }
        IR_INTENSITY_VECTOR => {
            let _ = robot::ir_intensities(value);
        }
        HAZARD_DETECTION_VECTOR => {
            let _ = robot::bumps(value);
        }
        _ => unreachable!("every type of TYPES is converted"),
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&pick, sample)) = data.split_first() else {
        return;
    };
    let index = usize::from(pick) % TYPES.len();
    // As the gateway's intake: the first schema that decodes the sample is taken.
    if let Some(value) = decoders()[index].iter().find_map(|d| d.decode(sample).ok()) {
        convert(TYPES[index], &value);
    }
});
