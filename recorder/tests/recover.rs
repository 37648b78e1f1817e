//! `recover`: a complete file loses nothing; a file cut anywhere keeps exactly the
//! messages of its complete chunks, in order.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use common::traffic;
use common::{Digests, options, python_read, write_all};
use lewis_recorder::{Compression, Recorder, RecoverError, SECOND_NS, recover};
use lewis_testkit::doctor;

fn record(path: &std::path::Path) -> std::collections::BTreeMap<String, common::TopicDigest> {
    let mut options = options(path);
    options.compression = Compression::Zstd;
    options.chunk_size_bytes = 128 * 1024;
    let mut recorder = Recorder::create(options).unwrap();
    let written = write_all(
        &mut recorder,
        &traffic::stress_channels(),
        traffic::stress_mix(SECOND_NS / 2),
    );
    recorder.close().unwrap();
    written
}

#[test]
fn recovering_a_complete_file_loses_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let fixed = dir.path().join("fixed.mcap");
    let written = record(&path);
    let report = recover(&path, &fixed).unwrap();
    assert!(report.input_complete);
    assert_eq!(report.discarded_bytes, 0);
    assert_eq!(report.damage, None);
    assert_eq!(report.metadata, 4, "interfaces, robot, recording, loss");
    doctor(&fixed);
    let view = python_read(&[fixed]);
    assert_eq!(view.digests(), written);
    assert_eq!(view.file(0)["profile"], "ros2");
    assert_eq!(view.file(0)["compressions"], serde_json::json!(["zstd"]));
}

#[test]
fn a_file_cut_anywhere_keeps_a_prefix_of_its_messages() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    record(&path);
    let bytes = std::fs::read(&path).unwrap();
    let channels = traffic::stress_channels();
    let all: Vec<_> = traffic::stress_mix(SECOND_NS / 2).collect();
    let mut previous = 0;
    for (i, fraction) in [0.1, 0.35, 0.6, 0.85, 0.99].into_iter().enumerate() {
        let cut = (bytes.len() as f64 * fraction) as usize;
        let broken = dir.path().join(format!("cut{i}.mcap"));
        let fixed = dir.path().join(format!("fixed{i}.mcap"));
        std::fs::write(&broken, &bytes[..cut]).unwrap();
        let report = recover(&broken, &fixed).unwrap();
        assert!(!report.input_complete);
        assert!(
            report.damage.as_ref().unwrap().contains("at byte"),
            "{report:?}"
        );
        assert_eq!(report.valid_bytes + report.discarded_bytes, cut as u64);
        doctor(&fixed);
        let got = python_read(&[fixed]).digests();
        let count: u64 = got.values().map(|d| d.count).sum();
        let mut expected = Digests::default();
        for m in all.iter().take(count as usize) {
            expected.add(&channels[m.channel].topic, m.seq, &m.data);
        }
        assert_eq!(got, expected.finish(), "cut at {cut} of {}", bytes.len());
        assert!(
            count >= previous,
            "a longer file never recovers fewer messages"
        );
        previous = count;
    }
    assert!(previous > 0);
}

#[test]
fn recover_refuses_to_write_over_its_input_and_names_a_file_that_is_not_mcap() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("notes.txt");
    std::fs::write(&path, "not a recording").unwrap();
    let same = recover(&path, &path).unwrap_err();
    assert!(matches!(same, RecoverError::SamePath { .. }), "{same:?}");
    let error = recover(&path, &dir.path().join("out.mcap")).unwrap_err();
    assert!(
        matches!(&error, RecoverError::NotMcap { path: p, .. } if *p == path),
        "{error:?}"
    );
    assert!(error.to_string().contains("notes.txt"), "{error}");
    assert!(!dir.path().join("out.mcap").exists());
}
