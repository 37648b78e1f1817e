//! Lewis interfaces: the XML interface definitions in `idl/`, their parser and
//! validator, the Rust types generated from them at build time, the ROS 2 CDR codec,
//! the ros2msg schema text, and a schema-driven dynamic decoder for tools.
//!
//! This crate is the only one that knows the wire encoding. It knows nothing of
//! processes, shared memory or MCAP files.
//!
//! A service writes `ctx.publish(&RangeFinder { ranges, ..Default::default() })` with the
//! types of [`msg`] and never touches bytes; [`cdr`] turns them into the bytes that go,
//! unchanged, into shared memory and into MCAP, under the schema [`Struct::SCHEMA_TEXT`].

pub mod cdr;
pub mod dynamic;
pub mod idl;
pub(crate) mod non_finite;
pub mod ros2;
pub mod speech;
mod traits;
mod vocabulary;

pub use traits::{
    Command, CommandDecodeError, CommandInfo, CommandSet, InPlace, Interface, InterfaceInfo,
    Message, SchemaInfo, SizeMismatch, Struct, UnknownValue,
};

/// The types generated from `idl/*.xml`: one struct per compound type, publication,
/// command and reply, per String field with declared values an enum of its words
/// (`MoverStatus`, `HealthState`, ...), and per interface an enum of its commands and one
/// of their replies.
#[allow(missing_docs, clippy::all, clippy::pedantic)]
pub mod msg {
    include!(concat!(env!("OUT_DIR"), "/generated.rs"));
}

/// The definitions compiled into this crate, validated again from their XML text: for
/// tools that show them (as ros2msg, XML or Rust) without the source folder.
///
/// # Errors
/// Never in practice: the same text was validated at build time.
pub fn builtin_idl() -> Result<idl::Idl, idl::Diagnostics> {
    let sources: Vec<(std::path::PathBuf, String)> = msg::TYPES_XML
        .iter()
        .map(|(file, xml)| (std::path::PathBuf::from(file), (*xml).to_owned()))
        .chain(msg::INTERFACES.iter().map(|i| {
            (
                std::path::PathBuf::from(format!("{}.xml", i.name)),
                i.xml.to_owned(),
            )
        }))
        .collect();
    idl::load_sources(&sources)
}

/// The names of the interfaces compiled into this crate: what a robot file may provide or
/// require.
#[must_use]
pub fn interface_names() -> Vec<&'static str> {
    msg::INTERFACES.iter().map(|i| i.name).collect()
}

/// The interface compiled into this crate with this name.
#[must_use]
pub fn interface_info(name: &str) -> Option<&'static InterfaceInfo> {
    msg::INTERFACES.iter().find(|i| i.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_non_finite_number_is_found_by_its_place_in_field_order() {
        let pose = |y: f64| msg::Pose3D {
            y,
            ..msg::Pose3D::default()
        };
        let mut scan = msg::RangeFinder {
            range_count: 3,
            ranges: vec![1.0, 2.0, 3.0],
            max_range: 8.0,
            sensor_positions: vec![pose(0.0), pose(f64::INFINITY), pose(f64::NAN)],
            ..msg::RangeFinder::default()
        };
        let mut path = String::new();
        assert_eq!(scan.first_non_finite(&mut path), Some(f64::INFINITY));
        assert_eq!(path, "sensor_positions[1].y");
        // An earlier field is found first.
        scan.ranges[2] = f64::NEG_INFINITY;
        let mut path = String::new();
        assert_eq!(scan.first_non_finite(&mut path), Some(f64::NEG_INFINITY));
        assert_eq!(path, "ranges[2]");
        scan.theta_separation = f64::NAN;
        scan.ranges[2] = 3.0;
        scan.sensor_positions = vec![pose(0.0); 3];
        let mut path = String::new();
        assert!(scan.first_non_finite(&mut path).is_some_and(f64::is_nan));
        assert_eq!(path, "theta_separation");
        scan.theta_separation = 0.0;
        let mut path = String::new();
        assert_eq!(scan.first_non_finite(&mut path), None);
        assert_eq!(path, "");
        // A message without numbers has nothing to find.
        assert_eq!(msg::Health::default().first_non_finite(&mut path), None);
    }

    #[test]
    fn every_reply_has_a_default_that_its_schema_decodes() {
        for interface in msg::INTERFACES {
            for command in interface.commands {
                let bytes = interface.default_reply(command.name).unwrap();
                let decoder =
                    dynamic::Decoder::new(command.reply.name, command.reply.text).unwrap();
                decoder.decode(&bytes).unwrap();
            }
            assert_eq!(interface.default_reply("no_such_command"), None);
        }
        assert_eq!(
            msg::default_message("lewis_interfaces/msg/NoSuchType"),
            None
        );
    }
}
