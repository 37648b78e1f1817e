//! Rows of Rerun data, gathered per entity into chunks with ids that depend only on the
//! input, so that the same recording always gives the same bytes.
//!
//! Rerun ids (`RowId`, `ChunkId`) are time-ordered UIDs: 64 bits of nanoseconds, then 64
//! bits that make them unique. The SDK fills them from the wall clock and a random seed;
//! here the nanoseconds are the message's log time and the rest a counter.

use std::collections::BTreeMap;

use rerun::log::{Chunk, ChunkId, RowId};
use rerun::{
    AsComponents, EntityPath, SerializedComponentBatch, StateChange, TimeCell, TimePoint,
    TimelineName,
};

use crate::ViewError;

/// The timeline of the recorder's receive time (MCAP `log_time`).
pub const LOG_TIME: &str = "log_time";
/// The timeline of the publisher's send time (MCAP `publish_time`).
pub const PUBLISH_TIME: &str = "publish_time";

/// Rows of a chunk are gathered until one of these limits is reached: chunks of this size
/// load fast in the viewer and keep memory bounded on large files.
const MAX_ROWS_PER_CHUNK: usize = 512;
const MAX_BYTES_PER_CHUNK: usize = 4 << 20;

/// When a row happened, on both timelines.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Stamp {
    /// The recorder's receive time, ns since the epoch.
    pub log_time_ns: u64,
    /// The publisher's send time, ns since the epoch.
    pub publish_time_ns: u64,
}

impl Stamp {
    /// The row's times; a publish time of 0 (a sender that does not say when it sent, as
    /// for some foreign messages) is left off its timeline rather than put in 1970.
    fn time_point(self) -> TimePoint {
        let cell = |ns: u64| TimeCell::from_timestamp_nanos_since_epoch(clamp_ns(ns));
        let log = TimePoint::from([(TimelineName::from(LOG_TIME), cell(self.log_time_ns))]);
        if self.publish_time_ns == 0 {
            return log;
        }
        log.with_index(TimelineName::from(PUBLISH_TIME), cell(self.publish_time_ns))
    }
}

fn clamp_ns(ns: u64) -> i64 {
    i64::try_from(ns).unwrap_or(i64::MAX)
}

/// Where finished chunks go.
pub(crate) trait ChunkSink {
    /// Takes one chunk.
    ///
    /// # Errors
    /// When it cannot be written or sent.
    fn chunk(&mut self, chunk: Chunk) -> Result<(), ViewError>;
}

struct Pending {
    path: EntityPath,
    first_ns: u64,
    rows: Vec<(RowId, TimePoint, Vec<SerializedComponentBatch>)>,
    bytes: usize,
}

/// Rows per entity, turned into chunks.
pub(crate) struct Rows {
    pending: BTreeMap<String, Pending>,
    counter: u64,
    row_counts: BTreeMap<String, u64>,
    /// Per state lane: its values, in the order they first appeared.
    lanes: BTreeMap<String, (EntityPath, Vec<String>)>,
}

impl Rows {
    pub(crate) fn new() -> Self {
        Self {
            pending: BTreeMap::new(),
            counter: 0,
            row_counts: BTreeMap::new(),
            lanes: BTreeMap::new(),
        }
    }

    /// Sets the state lane at `path` to `value` from `stamp` on (a [`StateChange`]),
    /// remembering the values each lane took, for their colours.
    pub(crate) fn lane(
        &mut self,
        sink: &mut dyn ChunkSink,
        path: &EntityPath,
        stamp: Stamp,
        value: &str,
    ) -> Result<(), ViewError> {
        let (_, values) = self
            .lanes
            .entry(path.to_string())
            .or_insert_with(|| (path.clone(), Vec::new()));
        if !values.iter().any(|v| v == value) {
            values.push(value.to_owned());
        }
        self.log(
            sink,
            path,
            stamp,
            &StateChange::single(value.to_owned()),
            64,
        )
    }

    /// Every state lane and its values in order of first appearance.
    pub(crate) fn take_lanes(&mut self) -> Vec<(EntityPath, Vec<String>)> {
        std::mem::take(&mut self.lanes).into_values().collect()
    }

    /// Rows logged per entity path so far (static rows included).
    pub(crate) fn row_counts(&self) -> &BTreeMap<String, u64> {
        &self.row_counts
    }

    fn next_id(&mut self, time_ns: u64) -> u128 {
        self.counter += 1;
        (u128::from(time_ns) << 64) | u128::from(self.counter)
    }

    /// Adds one row of `data` at `path` at `stamp`; `bytes` is about the size of its data.
    pub(crate) fn log(
        &mut self,
        sink: &mut dyn ChunkSink,
        path: &EntityPath,
        stamp: Stamp,
        data: &dyn AsComponents,
        bytes: usize,
    ) -> Result<(), ViewError> {
        let key = path.to_string();
        *self.row_counts.entry(key.clone()).or_default() += 1;
        let row_id = RowId::from_u128(self.next_id(stamp.log_time_ns));
        let time_point = stamp.time_point();
        // Every row of a chunk has the same timelines: a row without a publish time starts
        // a chunk of its own.
        let same_timelines = |pending: &Pending| {
            pending.rows.first().is_none_or(|(_, first, _)| {
                first
                    .iter()
                    .map(|(name, _)| name)
                    .eq(time_point.iter().map(|(name, _)| name))
            })
        };
        if self.pending.get(&key).is_some_and(|p| !same_timelines(p))
            && let Some(pending) = self.pending.remove(&key)
        {
            self.emit(sink, pending)?;
        }
        let pending = self.pending.entry(key).or_insert_with(|| Pending {
            path: path.clone(),
            first_ns: stamp.log_time_ns,
            rows: Vec::new(),
            bytes: 0,
        });
        pending
            .rows
            .push((row_id, time_point, data.as_serialized_batches()));
        pending.bytes += bytes;
        if pending.rows.len() >= MAX_ROWS_PER_CHUNK || pending.bytes >= MAX_BYTES_PER_CHUNK {
            let key = path.to_string();
            if let Some(pending) = self.pending.remove(&key) {
                self.emit(sink, pending)?;
            }
        }
        Ok(())
    }

    /// Logs `data` at `path` for all times (a map, a whole path, a robot outline).
    pub(crate) fn log_static(
        &mut self,
        sink: &mut dyn ChunkSink,
        path: &EntityPath,
        data: &dyn AsComponents,
    ) -> Result<(), ViewError> {
        *self.row_counts.entry(path.to_string()).or_default() += 1;
        let row_id = RowId::from_u128(self.next_id(0));
        let chunk_id = ChunkId::from_u128(self.next_id(0));
        let chunk = Chunk::builder_with_id(chunk_id, path.clone())
            .with_archetype(row_id, TimePoint::default(), data)
            .build()
            .map_err(|error| build_error(path, &error))?;
        sink.chunk(chunk)
    }

    /// Sends every pending row, entity by entity in path order.
    pub(crate) fn flush(&mut self, sink: &mut dyn ChunkSink) -> Result<(), ViewError> {
        for (_, pending) in std::mem::take(&mut self.pending) {
            self.emit(sink, pending)?;
        }
        Ok(())
    }

    fn emit(&mut self, sink: &mut dyn ChunkSink, pending: Pending) -> Result<(), ViewError> {
        let chunk_id = ChunkId::from_u128(self.next_id(pending.first_ns));
        let mut builder = Chunk::builder_with_id(chunk_id, pending.path.clone());
        for (row_id, time_point, batches) in pending.rows {
            builder = builder.with_serialized_batches(row_id, time_point, batches);
        }
        let chunk = builder
            .build()
            .map_err(|error| build_error(&pending.path, &error))?;
        sink.chunk(chunk)
    }
}

fn build_error(path: &EntityPath, error: &dyn std::fmt::Display) -> ViewError {
    ViewError::Build {
        entity: path.to_string(),
        detail: error.to_string(),
    }
}
