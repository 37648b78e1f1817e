//! Scans that stop coming are taken off the views: Rerun shows an entity's latest data
//! until something replaces it, so the last scan of a laser that died would stay in the
//! world for the rest of the run, hiding the failover. A scan topic silent for
//! [`STALE_AFTER_NS`] is cleared at that moment.

use std::collections::BTreeMap;

use rerun::Clear;

use super::topic_entity;
use crate::ViewError;
use crate::rows::{ChunkSink, Rows, Stamp};

/// A range finder silent this long is taken off the views: ten periods of the slowest
/// (a 10 Hz sonar ring).
pub(super) const STALE_AFTER_NS: u64 = 1_000_000_000;

/// When each scan topic was last drawn.
#[derive(Debug, Default)]
pub(super) struct Freshness {
    last: BTreeMap<String, Stamp>,
}

impl Freshness {
    /// Notes a scan of `topic` drawn at `stamp`.
    pub(super) fn drawn(&mut self, topic: &str, stamp: Stamp) {
        self.last.insert(topic.to_owned(), stamp);
    }

    /// Clears, at the moment they went stale, the scans silent since before `now` minus
    /// [`STALE_AFTER_NS`].
    pub(super) fn clear_stale(
        &mut self,
        rows: &mut Rows,
        sink: &mut dyn ChunkSink,
        now: Stamp,
    ) -> Result<(), ViewError> {
        let stale: Vec<(String, Stamp)> = self
            .last
            .iter()
            .filter(|(_, last)| now.log_time_ns > last.log_time_ns.saturating_add(STALE_AFTER_NS))
            .map(|(topic, last)| (topic.clone(), *last))
            .collect();
        for (topic, last) in stale {
            self.last.remove(&topic);
            let later = |ns: u64| {
                if ns == 0 {
                    0
                } else {
                    ns.saturating_add(STALE_AFTER_NS)
                }
            };
            let at = Stamp {
                log_time_ns: later(last.log_time_ns),
                publish_time_ns: later(last.publish_time_ns),
            };
            for frame in ["robot", "world"] {
                rows.log(
                    sink,
                    &topic_entity(&[frame, "scans"], &topic, &[]),
                    at,
                    &Clear::recursive(),
                    16,
                )?;
            }
        }
        Ok(())
    }
}
