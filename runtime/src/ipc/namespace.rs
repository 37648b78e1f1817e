//! The namespace every IPC name lives under (`LEWIS_NAMESPACE`, default `default`).
//!
//! Isolation comes from iceoryx2's `config.global.prefix`: every file and shared-memory
//! segment iceoryx2 creates (nodes, services, data segments, event sockets) starts with it,
//! so two namespaces share no service, no node list and no memory.

use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

use iceoryx2::config::Config;
use iceoryx2::prelude::{FileName, SemanticString};

/// The environment variable that selects the namespace of a process.
pub const NAMESPACE_ENV: &str = "LEWIS_NAMESPACE";

/// The namespace used when `LEWIS_NAMESPACE` is not set.
pub const DEFAULT_NAMESPACE: &str = "default";

/// The longest namespace accepted, so that the iceoryx2 file names built from it stay
/// well under the file-name limit.
pub const MAX_NAMESPACE_LEN: usize = 48;

/// What every file name of every namespace starts with, before the namespace's name.
const FILE_PREFIX_START: &str = "lewis.";

/// The longest tag [`Namespace::unique`] keeps.
const UNIQUE_TAG_LEN: usize = 20;

/// Why a namespace name was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NamespaceError {
    /// The name is empty.
    #[error("namespace is empty: set {NAMESPACE_ENV} to a name such as `default` or `test-1`")]
    Empty,
    /// The name is longer than [`MAX_NAMESPACE_LEN`].
    #[error("namespace `{name}` is {len} bytes long: use at most {MAX_NAMESPACE_LEN}")]
    TooLong {
        /// The refused name.
        name: String,
        /// Its length in bytes.
        len: usize,
    },
    /// The name contains a character outside `A-Z a-z 0-9 - _`.
    #[error("namespace `{name}` contains {character:?}: use only letters, digits, `-` and `_`")]
    InvalidCharacter {
        /// The refused name.
        name: String,
        /// The first character that is not allowed.
        character: char,
    },
    /// `LEWIS_NAMESPACE` is set but is not valid Unicode.
    #[error("{NAMESPACE_ENV} is not valid Unicode: use only letters, digits, `-` and `_`")]
    NotUnicode,
}

/// A validated namespace name: letters, digits, `-` and `_`, 1 to [`MAX_NAMESPACE_LEN`] bytes.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Namespace(String);

impl Namespace {
    /// Checks and wraps an explicit namespace name.
    pub fn new(name: &str) -> Result<Self, NamespaceError> {
        if name.is_empty() {
            return Err(NamespaceError::Empty);
        }
        if name.len() > MAX_NAMESPACE_LEN {
            return Err(NamespaceError::TooLong {
                name: name.to_owned(),
                len: name.len(),
            });
        }
        if let Some(character) = name
            .chars()
            .find(|c| !(c.is_ascii_alphanumeric() || *c == '-' || *c == '_'))
        {
            return Err(NamespaceError::InvalidCharacter {
                name: name.to_owned(),
                character,
            });
        }
        Ok(Self(name.to_owned()))
    }

    /// The namespace of this process: `LEWIS_NAMESPACE`, or `default` when it is unset.
    pub fn from_env() -> Result<Self, NamespaceError> {
        match std::env::var(NAMESPACE_ENV) {
            Ok(name) => Self::new(&name),
            Err(std::env::VarError::NotPresent) => Self::new(DEFAULT_NAMESPACE),
            Err(std::env::VarError::NotUnicode(_)) => Err(NamespaceError::NotUnicode),
        }
    }

    /// The namespace given on a command line (`--namespace`), else [`Namespace::from_env`].
    pub fn from_arg(given: Option<&str>) -> Result<Self, NamespaceError> {
        given.map_or_else(Self::from_env, Self::new)
    }

    /// A namespace no other process on this machine uses: `tag`, the process id, a counter
    /// and the start time. For tests and throw-away runs that must not see each other.
    ///
    /// `tag` is cut and cleaned so that the result is always valid.
    pub fn unique(tag: &str) -> Self {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let count = COUNTER.fetch_add(1, Ordering::Relaxed);
        let nanos = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let clean: String = tag
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' {
                    c
                } else {
                    '-'
                }
            })
            .take(UNIQUE_TAG_LEN)
            .collect();
        let tag = if clean.is_empty() { "ns" } else { &clean };
        Self(format!(
            "{tag}-{pid}-{count}-{nanos:x}",
            pid = std::process::id()
        ))
    }

    /// The id of the process that made this namespace with [`Namespace::unique`], read
    /// back from its name (`TAG-PID-COUNT-HEX`), so that the namespaces of ended test runs
    /// can be told apart; `None` for a name of any other shape. A name chosen by hand may
    /// have that shape too: the id is a hint, not a proof of who uses the namespace.
    pub fn unique_maker(&self) -> Option<u32> {
        // From the right: the tag may hold `-` itself.
        let mut parts = self.0.rsplitn(4, '-');
        let (nanos, count, pid, tag) = (parts.next()?, parts.next()?, parts.next()?, parts.next()?);
        // `nanos` is below 10^9: at most 8 hex digits, in lower case as `{:x}` writes them.
        let hex = |s: &str| {
            (1..=8).contains(&s.len())
                && s.bytes()
                    .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
        };
        let tag_ok = (1..=UNIQUE_TAG_LEN).contains(&tag.len())
            && tag.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-');
        // Digits checked before `parse`: it takes a leading `+`, which `unique` never writes.
        if !(tag_ok && hex(nanos) && decimal(count) && decimal(pid)) {
            return None;
        }
        pid.parse::<u32>().ok().filter(|&pid| pid != 0)
    }

    /// The namespace a file of some namespace (`lewis.NAME.rest`, in `/dev/shm` or
    /// `/tmp/iceoryx2`) belongs to, for finding the namespaces that left files behind;
    /// `None` for a name that is no namespace's.
    pub fn of_file_name(file_name: &str) -> Option<Self> {
        let (name, _rest) = file_name.strip_prefix(FILE_PREFIX_START)?.split_once('.')?;
        Self::new(name).ok()
    }

    /// The name itself.
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// The iceoryx2 file prefix for this namespace. The `.` separators cannot appear in a
    /// namespace, so two namespaces never produce overlapping prefixes.
    pub fn iceoryx2_prefix(&self) -> String {
        format!("{FILE_PREFIX_START}{}.", self.0)
    }

    /// The iceoryx2 configuration that confines everything to this namespace.
    pub(crate) fn iceoryx2_config(&self) -> Result<Config, NamespaceError> {
        let prefix = self.iceoryx2_prefix();
        // Validated characters and length make this conversion infallible in practice; the
        // error arm keeps it that way if iceoryx2 ever tightens its rules.
        let prefix =
            FileName::new(prefix.as_bytes()).map_err(|_| NamespaceError::InvalidCharacter {
                name: self.0.clone(),
                character: '.',
            })?;
        let mut config = Config::default();
        config.global.prefix = prefix;
        // Each subscriber keeps slots for the connections of publishers that left while it
        // still held their samples. iceoryx2's default, 128 slots, costs about 470 KiB per
        // subscriber (the recorder has one per channel of the robot: 30 MiB for 66
        // channels); a subscriber holds at most `max_held` samples (8 on data channels).
        config
            .defaults
            .publish_subscribe
            .subscriber_expired_connection_buffer = EXPIRED_CONNECTION_SLOTS;
        Ok(config)
    }
}

/// Whether `s` is a plain decimal number: digits only, no sign.
fn decimal(s: &str) -> bool {
    !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit())
}

/// Slots a subscriber keeps for the connections of publishers that left (see
/// [`Namespace::iceoryx2_config`]): at least the samples a subscriber may hold.
const EXPIRED_CONNECTION_SLOTS: usize = 16;

impl fmt::Display for Namespace {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(name: &str, expected: Result<&str, NamespaceError>) {
        let got = Namespace::new(name);
        if let Ok(ns) = &got {
            assert!(
                ns.iceoryx2_config().is_ok(),
                "{name} must give a valid prefix"
            );
        }
        assert_eq!(got.map(|ns| ns.0), expected.map(str::to_owned));
    }

    #[test]
    fn valid_names_are_accepted_and_give_a_valid_prefix() {
        check("default", Ok("default"));
        check("test-1_A", Ok("test-1_A"));
        check(
            &"x".repeat(MAX_NAMESPACE_LEN),
            Ok(&"x".repeat(MAX_NAMESPACE_LEN)),
        );
    }

    #[test]
    fn invalid_names_are_refused_with_the_reason() {
        check("", Err(NamespaceError::Empty));
        check(
            "a.b",
            Err(NamespaceError::InvalidCharacter {
                name: "a.b".into(),
                character: '.',
            }),
        );
        check(
            "a/b",
            Err(NamespaceError::InvalidCharacter {
                name: "a/b".into(),
                character: '/',
            }),
        );
        let long = "y".repeat(MAX_NAMESPACE_LEN + 1);
        check(
            &long,
            Err(NamespaceError::TooLong {
                name: long.clone(),
                len: MAX_NAMESPACE_LEN + 1,
            }),
        );
    }

    #[test]
    fn unique_namespaces_differ_and_are_valid_even_from_odd_tags() {
        let a = Namespace::unique("some test/with.odd chars and a very long tag");
        let b = Namespace::unique("some test/with.odd chars and a very long tag");
        assert_ne!(a, b);
        for ns in [a, b, Namespace::unique("")] {
            assert_eq!(Namespace::new(ns.as_str()), Ok(ns.clone()));
        }
    }

    #[test]
    fn the_maker_of_a_unique_namespace_is_read_back_and_other_shapes_give_none() {
        let own = Some(std::process::id());
        assert_eq!(
            Namespace::unique("record-discover-late").unique_maker(),
            own
        );
        assert_eq!(Namespace::unique("").unique_maker(), own);
        assert_eq!(Namespace::unique("a_b.c").unique_maker(), own);
        let maker = |name: &str| Namespace::new(name).ok().and_then(|ns| ns.unique_maker());
        assert_eq!(maker("record-discover-late-12278-31-16832040"), Some(12278));
        assert_eq!(maker("--7-0-0"), Some(7), "a tag of dashes only");
        for name in [
            "default",
            "chal1",
            "a-1-2",
            "-1-2-3",
            "a-0-1-f",
            "a-+1-2-f",
            "a-1-+2-f",
            "a-1-2-F",
            "a-1-2-123456789",
            "a-1-2-g",
            "a-1--f",
            "a-99999999999-2-f",
            "a_b-1-2-f",
            "abcdefghijklmnopqrstu-1-2-f",
        ] {
            assert_eq!(maker(name), None, "{name}");
        }
    }

    #[test]
    fn the_namespace_of_a_file_is_read_from_its_name() {
        let of = |name: &str| Namespace::of_file_name(name).map(|ns| ns.0);
        assert_eq!(of("lewis.default.ledgers").as_deref(), Some("default"));
        assert_eq!(
            of("lewis.b21r-bump-12278-0-3b24fd59.9204dd18_node.0_10_0.global_mgmt").as_deref(),
            Some("b21r-bump-12278-0-3b24fd59")
        );
        for name in [
            "lewis.default",
            "lewis..x",
            "lewis.",
            "other.ns.x",
            "lewis.a b.x",
            "",
        ] {
            assert_eq!(of(name), None, "{name}");
        }
    }

    #[test]
    fn prefix_is_set_in_the_iceoryx2_config() -> Result<(), NamespaceError> {
        let config = Namespace::new("robot-a")?.iceoryx2_config()?;
        assert_eq!(config.global.prefix.as_str(), "lewis.robot-a.");
        Ok(())
    }
}
