//! The reader on a good file, a file without a summary, a file cut short anywhere and a
//! file with a damaged chunk: it never panics, reads everything before the damage, and
//! says where the damage is and how much is lost.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::convert::Infallible;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use lewis_mcap::records::{MessageHeader, Metadata, Record};
use lewis_mcap::{At, DamageKind, Flow, McapFile, OpenError, ScanEnd, TimeOrdered, Visitor};
use proptest::prelude::*;

const MESSAGES: u32 = 60;

/// Log times go back by 25 ms at every tenth message, so that log-time order is not file
/// order.
fn log_time(n: u32) -> u64 {
    let base = 1_000_000_000 + u64::from(n) * 10_000_000;
    if n % 10 == 9 { base - 25_000_000 } else { base }
}

fn payload(n: u32) -> Vec<u8> {
    format!("message {n}").into_bytes()
}

/// `MESSAGES` messages on two channels in small zstd chunks, a metadata record, and a
/// summary unless not.
fn recording(summary: bool) -> Vec<u8> {
    let options = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .chunk_size(Some(200))
        .profile("test")
        .emit_summary_records(summary)
        .emit_summary_offsets(summary);
    let mut writer = options.create(Cursor::new(Vec::new())).unwrap();
    let schema = writer.add_schema("Text", "text", b"string").unwrap();
    let channels = [
        writer
            .add_channel(schema, "/a", "text", &BTreeMap::new())
            .unwrap(),
        writer
            .add_channel(schema, "/b", "text", &BTreeMap::new())
            .unwrap(),
    ];
    writer
        .write_metadata(&Metadata {
            name: "lewis.recording".into(),
            metadata: BTreeMap::from([("part".into(), "1".into())]),
        })
        .unwrap();
    for n in 0..MESSAGES {
        let header = MessageHeader {
            channel_id: channels[(n % 2) as usize],
            sequence: n,
            log_time: log_time(n),
            publish_time: log_time(n),
        };
        writer.write_to_known_channel(&header, &payload(n)).unwrap();
    }
    writer.finish().unwrap();
    writer.into_inner().into_inner()
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// What a scan saw: message sequence numbers in file order, chunks and where they start,
/// metadata names, whether the footer was read.
#[derive(Debug, Default)]
struct Seen {
    messages: Vec<u32>,
    /// The offset of each message's chunk.
    message_chunks: Vec<u64>,
    chunks: Vec<u64>,
    chunk_ends: Vec<u64>,
    metadata: Vec<String>,
    footer: bool,
    last_progress: u64,
    stop_after: Option<usize>,
}

impl Visitor for Seen {
    type Error = Infallible;

    fn record(&mut self, at: At, record: Record<'_>) -> Result<Flow, Infallible> {
        match record {
            Record::Message { header, data } => {
                assert!(at.in_chunk, "the writer chunks every message");
                assert_eq!(&*data, payload(header.sequence).as_slice());
                self.messages.push(header.sequence);
                self.message_chunks.push(at.offset);
                if self.stop_after == Some(self.messages.len()) {
                    return Ok(Flow::Stop);
                }
            }
            Record::Chunk { .. } => self.chunks.push(at.offset),
            Record::Metadata(metadata) => self.metadata.push(metadata.name),
            Record::Footer(_) => self.footer = true,
            _ => {}
        }
        Ok(Flow::Continue)
    }

    fn chunk_end(&mut self, offset: u64) -> Result<Flow, Infallible> {
        self.chunk_ends.push(offset);
        Ok(Flow::Continue)
    }

    fn progress(&mut self, bytes_read: u64) {
        assert!(bytes_read >= self.last_progress);
        self.last_progress = bytes_read;
    }
}

fn scan(path: &Path) -> Result<(Seen, ScanEnd), OpenError> {
    let mut file = McapFile::open(path)?;
    let mut seen = Seen::default();
    let end = file.scan(&mut seen).unwrap();
    Ok((seen, end))
}

#[test]
fn a_good_file_is_read_whole_by_summary_scan_and_log_time() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = recording(true);
    let path = write(dir.path(), "good.mcap", &bytes);
    let mut file = McapFile::open(&path).unwrap();
    assert_eq!(file.header().profile, "test");
    assert_eq!(file.size_bytes(), bytes.len() as u64);

    let summary = file.summary().unwrap().expect("a summary");
    let stats = summary.stats.as_ref().unwrap();
    assert_eq!(stats.message_count, u64::from(MESSAGES));
    assert_eq!(summary.channels.len(), 2);
    let metadata = file.metadata_named(&summary, "lewis.recording").unwrap();
    assert_eq!(metadata.len(), 1);
    assert_eq!(metadata[0].metadata["part"], "1");
    assert!(file.metadata_named(&summary, "absent").unwrap().is_empty());

    let (seen, end) = scan(&path).unwrap();
    assert_eq!(seen.messages, (0..MESSAGES).collect::<Vec<_>>());
    assert!(seen.chunks.len() > 3, "small chunks: {:?}", seen.chunks);
    assert_eq!(seen.chunks, seen.chunk_ends);
    assert_eq!(seen.metadata, ["lewis.recording"]);
    assert!(seen.footer);
    assert_eq!(seen.last_progress, bytes.len() as u64);
    assert!(end.damage.is_none());
    assert!(!end.stopped);
    // Every record: all but the end magic.
    assert_eq!(
        end.read_bytes,
        (bytes.len() - lewis_mcap::MAGIC.len()) as u64
    );

    let by_time: Vec<u64> = TimeOrdered::open(&path, &summary, None)
        .unwrap()
        .map(|m| m.unwrap().header.log_time)
        .collect();
    let mut sorted: Vec<u64> = (0..MESSAGES).map(log_time).collect();
    sorted.sort_unstable();
    assert_eq!(by_time, sorted);
    let on_b = TimeOrdered::open(&path, &summary, Some(&["/b"]))
        .unwrap()
        .map(|m| m.unwrap().header.sequence % 2)
        .collect::<Vec<_>>();
    assert_eq!(on_b, vec![1; MESSAGES as usize / 2]);
}

#[test]
fn a_file_without_a_summary_has_none_and_is_scanned_whole() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = recording(false);
    let path = write(dir.path(), "no-summary.mcap", &bytes);
    let mut file = McapFile::open(&path).unwrap();
    assert!(file.summary().unwrap().is_none());
    let (seen, end) = scan(&path).unwrap();
    assert_eq!(seen.messages, (0..MESSAGES).collect::<Vec<_>>());
    assert!(seen.footer);
    assert!(end.damage.is_none());
}

#[test]
fn a_visitor_that_stops_ends_the_scan_after_the_record() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "good.mcap", &recording(true));
    let mut file = McapFile::open(&path).unwrap();
    let mut seen = Seen {
        stop_after: Some(5),
        ..Seen::default()
    };
    let end = file.scan(&mut seen).unwrap();
    assert_eq!(seen.messages, [0, 1, 2, 3, 4]);
    assert!(end.stopped);
    assert!(end.damage.is_none());
}

#[test]
fn a_file_that_is_not_mcap_is_refused_with_its_first_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "notes.txt", b"not a recording");
    match McapFile::open(&path) {
        Err(OpenError::NotMcap { start, .. }) => assert_eq!(start, b"not a re"),
        other => panic!("{other:?}"),
    }
    let empty = write(dir.path(), "empty.mcap", b"");
    assert!(matches!(
        McapFile::open(&empty),
        Err(OpenError::NotMcap { .. })
    ));
    assert!(!lewis_mcap::starts_like_mcap(&path).unwrap());
    let good = write(dir.path(), "good.mcap", &recording(true));
    assert!(lewis_mcap::starts_like_mcap(&good).unwrap());
    assert!(matches!(
        McapFile::open(&dir.path().join("absent.mcap")),
        Err(OpenError::Io(_))
    ));
}

/// The file cut to `len` bytes: never a panic; when it opens, what is read is a prefix of
/// the messages of whole chunks, and the damage says where reading stopped and how much
/// was left unread.
fn check_cut(bytes: &[u8], len: usize) {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "cut.mcap", &bytes[..len]);
    let Ok((seen, end)) = scan(&path) else {
        // Only a file cut inside its magic or Header record is not MCAP.
        assert!(len < 64, "cut at {len}");
        return;
    };
    let count = seen.messages.len();
    assert_eq!(seen.messages, (0..count as u32).collect::<Vec<_>>());
    assert_eq!(seen.chunks, seen.chunk_ends, "a chunk is handed out whole");
    if len == bytes.len() {
        assert!(end.damage.is_none());
        return;
    }
    let damage = end.damage.expect("a file cut short is damaged");
    assert!(
        matches!(damage.kind, DamageKind::CutShort | DamageKind::Unfinished),
        "cut at {len}: {damage}"
    );
    assert_eq!(damage.offset, end.read_bytes);
    assert!(damage.offset <= len as u64);
    assert_eq!(damage.offset + damage.lost_bytes, len as u64);
    assert!(
        damage
            .to_string()
            .contains(&format!("at byte {}", damage.offset))
    );
    // The summary of a cut file is absent or unreadable, never wrong.
    let mut file = McapFile::open(&path).unwrap();
    if let Ok(Some(summary)) = file.summary() {
        panic!("cut at {len}: a summary was read: {summary:?}");
    }
}

#[test]
fn a_file_cut_at_chosen_places_is_read_up_to_the_cut() {
    let bytes = recording(true);
    let data_end = {
        let dir = tempfile::tempdir().unwrap();
        let (seen, _) = scan(&write(dir.path(), "good.mcap", &bytes)).unwrap();
        // Cut inside each of the first chunks, and right at their starts.
        for &offset in seen.chunks.iter().take(4) {
            let offset = usize::try_from(offset).unwrap();
            check_cut(&bytes, offset);
            check_cut(&bytes, offset + 1);
            check_cut(&bytes, offset + 20);
        }
        usize::try_from(*seen.chunks.last().unwrap()).unwrap()
    };
    for len in [
        0,
        1,
        7,
        8,
        9,
        20,
        data_end,
        bytes.len() - 9,
        bytes.len() - 1,
        bytes.len(),
    ] {
        check_cut(&bytes, len);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn a_file_cut_anywhere_never_panics_and_reports_the_cut(fraction in 0.0_f64..1.0) {
        let bytes = recording(true);
        let len = (bytes.len() as f64 * fraction) as usize;
        check_cut(&bytes, len);
    }

    #[test]
    fn a_file_with_bytes_changed_anywhere_never_panics(
        at in 0.0_f64..1.0,
        xor in 1_u8..=255,
    ) {
        let bytes = recording(true);
        let at = ((bytes.len() - 1) as f64 * at) as usize;
        let dir = tempfile::tempdir().unwrap();
        check_changed(dir.path(), &bytes, at, xor);
    }
}

/// Reads `bytes` with the byte at `at` changed by `xor` every way the crate reads a file:
/// nothing panics or aborts, every chunk begun is ended, and damage accounts for the rest.
fn check_changed(dir: &Path, bytes: &[u8], at: usize, xor: u8) {
    let mut bytes = bytes.to_vec();
    bytes[at] ^= xor;
    let path = write(dir, "changed.mcap", &bytes);
    let Ok(mut file) = McapFile::open(&path) else {
        return;
    };
    let mut seen = Seen::default();
    let end = file.scan(&mut seen).unwrap();
    assert_eq!(seen.chunks, seen.chunk_ends, "byte {at} ^ {xor:#04x}");
    if let Some(damage) = end.damage {
        assert_eq!(
            damage.offset + damage.lost_bytes,
            bytes.len() as u64,
            "byte {at} ^ {xor:#04x}"
        );
    }
    if let Ok(Some(summary)) = file.summary()
        && let Ok(messages) = TimeOrdered::open(&path, &summary, None)
    {
        messages.for_each(drop);
    }
}

/// Every byte of a small recording, changed to its complement and in its top bit: a
/// length or size field changed in its high bytes asks for exabytes, and must be refused
/// as damage, not allocated.
#[test]
fn a_file_with_any_one_byte_changed_never_panics() {
    let bytes = recording(true);
    let dir = tempfile::tempdir().unwrap();
    for at in 0..bytes.len() {
        for xor in [0xff, 0x80] {
            check_changed(dir.path(), &bytes, at, xor);
        }
    }
}

/// Changes one byte of the third chunk at `at` bytes from the chunk's start: the
/// chunk's frame stays intact, its contents do not.
fn check_damaged_third_chunk(at: usize) {
    let bytes = recording(false);
    let dir = tempfile::tempdir().unwrap();
    let (good, _) = scan(&write(dir.path(), "good.mcap", &bytes)).unwrap();
    let third = good.chunks[2];
    let start = usize::try_from(third).unwrap();
    let mut damaged = bytes.clone();
    damaged[start + at] ^= 0xff;
    let (seen, end) = scan(&write(dir.path(), "damaged.mcap", &damaged)).unwrap();
    let damage = end.damage.expect("damage");
    assert_eq!(damage.kind, DamageKind::BadChunk, "{damage}");
    assert_eq!(damage.offset, third);
    assert_eq!(damage.lost_bytes, bytes.len() as u64 - third);
    assert!(
        damage
            .to_string()
            .starts_with("a chunk that does not decode ("),
        "{damage}"
    );
    // Exactly the messages of the first two chunks, nothing of the third.
    assert_eq!(seen.chunks, &good.chunks[..2]);
    let before: Vec<u32> = good
        .messages
        .iter()
        .zip(&good.message_chunks)
        .filter(|(_, chunk)| **chunk < third)
        .map(|(n, _)| *n)
        .collect();
    assert!(!before.is_empty());
    assert_eq!(seen.messages, before);
}

/// A chunk record: opcode and length (9 bytes), then start and end times, uncompressed
/// size (24 bytes), the CRC of the uncompressed records (4), the compression (4 + 4 for
/// `zstd`), the compressed size (8), the compressed records.
const CHUNK_CRC_AT: usize = 9 + 24;
const CHUNK_DATA_AT: usize = 9 + 24 + 4 + 8 + 8;

#[test]
fn a_chunk_whose_crc_fails_is_lost_whole_and_reported_where_it_starts() {
    check_damaged_third_chunk(CHUNK_CRC_AT);
}

#[test]
fn a_chunk_whose_compressed_data_is_damaged_is_lost_whole() {
    check_damaged_third_chunk(CHUNK_DATA_AT + 10);
}
