//! What a Lewis recording holds besides messages, as the recorder writes it and the tools
//! read it: the names of its metadata records, and which version of the format, of Lewis
//! and of the interfaces wrote it.

use std::collections::BTreeMap;

/// File metadata: the robot description, keyed by its file name.
pub const ROBOT_METADATA: &str = "lewis.robot";
/// File metadata: lost messages per topic, at close (keys: topics, values: decimal
/// counts).
pub const LOSS_METADATA: &str = "lewis.loss";
/// File metadata: the interface XML, keyed by file name (`types.xml`, `RangeFinder.xml`).
pub const INTERFACES_METADATA: &str = "lewis.interfaces";
/// File metadata: about the recording (recorder, part number, parts index) and who wrote
/// it ([`WrittenBy`]). Every file the recorder writes has one, from before versioning on.
pub const RECORDING_METADATA: &str = "lewis.recording";

/// The version of the recording format this code writes. Version 1 is the first that
/// says so; recordings made before have no version and are read as they always were.
/// Raise it when a recording changes in a way that an older reader would misread.
pub const FORMAT_VERSION: u32 = 1;

/// [`RECORDING_METADATA`] key: the recording format's version ([`FORMAT_VERSION`]).
pub const FORMAT_VERSION_KEY: &str = "format_version";
/// [`RECORDING_METADATA`] key: the version of Lewis that wrote the recording.
pub const LEWIS_VERSION_KEY: &str = "lewis_version";
/// [`RECORDING_METADATA`] key: the digest of the interfaces the messages were encoded
/// with ([`interfaces_digest`] of the [`INTERFACES_METADATA`] record).
pub const INTERFACES_KEY: &str = "interfaces";

/// Who wrote a Lewis recording, as its [`RECORDING_METADATA`] record says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum WrittenBy {
    /// A recording that says which versions wrote it.
    Versioned {
        /// The recording format's version.
        format_version: u32,
        /// The version of Lewis.
        lewis_version: String,
        /// The digest of its interfaces ([`interfaces_digest`]).
        interfaces: String,
    },
    /// A recording made before recordings said which versions wrote them.
    BeforeVersioning,
}

impl WrittenBy {
    /// What this code writes: [`FORMAT_VERSION`], `lewis_version`, and the digest of
    /// `interfaces` (the [`INTERFACES_METADATA`] entries).
    #[must_use]
    pub fn current(lewis_version: &str, interfaces: &BTreeMap<String, String>) -> Self {
        Self::Versioned {
            format_version: FORMAT_VERSION,
            lewis_version: lewis_version.to_owned(),
            interfaces: interfaces_digest(interfaces),
        }
    }

    /// The entries it adds to a [`RECORDING_METADATA`] record (none before versioning).
    #[must_use]
    pub fn entries(&self) -> BTreeMap<String, String> {
        match self {
            Self::Versioned {
                format_version,
                lewis_version,
                interfaces,
            } => BTreeMap::from([
                (FORMAT_VERSION_KEY.to_owned(), format_version.to_string()),
                (LEWIS_VERSION_KEY.to_owned(), lewis_version.clone()),
                (INTERFACES_KEY.to_owned(), interfaces.clone()),
            ]),
            Self::BeforeVersioning => BTreeMap::new(),
        }
    }

    /// Reads it from the entries of a [`RECORDING_METADATA`] record: no format version is a
    /// recording made before versioning.
    ///
    /// # Errors
    /// When the format version is not a number, for a person.
    pub fn from_entries(entries: &BTreeMap<String, String>) -> Result<Self, String> {
        let Some(version) = entries.get(FORMAT_VERSION_KEY) else {
            return Ok(Self::BeforeVersioning);
        };
        let format_version = version.trim().parse().map_err(|_| {
            format!("the `{RECORDING_METADATA}` format version is `{version}`, not a number")
        })?;
        let get = |key: &str| entries.get(key).cloned().unwrap_or_default();
        Ok(Self::Versioned {
            format_version,
            lewis_version: get(LEWIS_VERSION_KEY),
            interfaces: get(INTERFACES_KEY),
        })
    }

    /// The format version: 0 before versioning.
    #[must_use]
    pub fn format_version(&self) -> u32 {
        match self {
            Self::Versioned { format_version, .. } => *format_version,
            Self::BeforeVersioning => 0,
        }
    }
}

/// The digest of a set of interface definitions (file name to XML text, as the
/// [`INTERFACES_METADATA`] record stores them): `crc32:` and eight hex digits, the CRC-32
/// of every name and text in name order, each followed by a NUL. Two recordings with the
/// same digest were encoded with the same definitions.
#[must_use]
pub fn interfaces_digest(interfaces: &BTreeMap<String, String>) -> String {
    let mut hasher = crc32fast::Hasher::new();
    for (name, text) in interfaces {
        hasher.update(name.as_bytes());
        hasher.update(&[0]);
        hasher.update(text.as_bytes());
        hasher.update(&[0]);
    }
    format!("crc32:{:08x}", hasher.finalize())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn interfaces() -> BTreeMap<String, String> {
        BTreeMap::from([
            ("types.xml".to_owned(), "<types/>".to_owned()),
            ("Laser.xml".to_owned(), "<interface/>".to_owned()),
        ])
    }

    #[test]
    fn what_is_written_is_read_back() {
        let written = WrittenBy::current("0.1.0", &interfaces());
        let mut entries = written.entries();
        entries.insert("part".to_owned(), "1".to_owned());
        assert_eq!(WrittenBy::from_entries(&entries), Ok(written.clone()));
        assert_eq!(written.format_version(), FORMAT_VERSION);
    }

    #[test]
    fn a_record_without_a_version_was_written_before_versioning() {
        let entries = BTreeMap::from([("part".to_owned(), "1".to_owned())]);
        assert_eq!(
            WrittenBy::from_entries(&entries),
            Ok(WrittenBy::BeforeVersioning)
        );
        assert_eq!(WrittenBy::BeforeVersioning.format_version(), 0);
        assert!(WrittenBy::BeforeVersioning.entries().is_empty());
        let bad = BTreeMap::from([(FORMAT_VERSION_KEY.to_owned(), "one".to_owned())]);
        assert!(WrittenBy::from_entries(&bad).unwrap_err().contains("`one`"));
    }

    #[test]
    fn the_digest_changes_with_any_name_or_text() {
        let digest = interfaces_digest(&interfaces());
        assert!(
            digest.starts_with("crc32:") && digest.len() == 14,
            "{digest}"
        );
        let mut changed = interfaces();
        changed.insert("Laser.xml".to_owned(), "<interface />".to_owned());
        assert_ne!(interfaces_digest(&changed), digest);
        let mut renamed = interfaces();
        let text = renamed.remove("Laser.xml").unwrap_or_default();
        renamed.insert("Sonar.xml".to_owned(), text);
        assert_ne!(interfaces_digest(&renamed), digest);
    }
}
