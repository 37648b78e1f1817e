//! Property tests of the ROS 2 importer: a damaged bag (cut anywhere, bytes changed
//! anywhere) is imported as far as it reads or refused with an error, never a panic; and
//! whatever it streams never goes back in time on a topic.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::OnceLock;

use lewis_formats::import::ros2::{ImportError, ImportOptions, Out, Ros2Import};
use proptest::prelude::*;

/// The real Hokuyo bag (1 MB: its scans in one uncompressed chunk, so a changed byte
/// reaches the decoder rather than a checksum).
fn hokuyo() -> &'static [u8] {
    static BYTES: OnceLock<Vec<u8>> = OnceLock::new();
    BYTES.get_or_init(|| {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../shared/data/ros2/hokuyo-scan-matcher-demo.mcap");
        std::fs::read(&path).unwrap_or_else(|e| {
            panic!(
                "missing test data {}: {e} (see ../shared/data/README.md)",
                path.display()
            )
        })
    })
}

fn import(bytes: &[u8]) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("damaged.mcap");
    std::fs::write(&path, bytes).unwrap();
    let Ok(import) = Ros2Import::open(&path, &ImportOptions::default()) else {
        return;
    };
    let mut last: BTreeMap<String, i64> = BTreeMap::new();
    let _ = import.stream::<ImportError, _>(|out| {
        if let Out::Lewis(m) = out {
            let before = last.insert(m.channel.clone(), m.time_ns);
            assert!(before.is_none_or(|b| b <= m.time_ns), "{}", m.channel);
        }
        Ok(())
    });
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn a_bag_with_bytes_changed_anywhere_never_panics_the_importer(
        changes in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
    ) {
        let mut bytes = hokuyo().to_vec();
        for (at, value) in changes {
            let i = at.index(bytes.len());
            bytes[i] = value;
        }
        import(&bytes);
    }

    #[test]
    fn a_bag_cut_anywhere_never_panics_the_importer(cut in any::<prop::sample::Index>()) {
        let bytes = hokuyo();
        import(&bytes[..cut.index(bytes.len() + 1)]);
    }

    #[test]
    fn arbitrary_bytes_after_the_magic_never_panic_the_importer(
        bytes in prop::collection::vec(any::<u8>(), 0..400),
    ) {
        let mut file = lewis_mcap::MAGIC.to_vec();
        file.extend(bytes);
        import(&file);
    }
}
