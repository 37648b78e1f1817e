//! When each host was last heard from: its beat, or anything it sent.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

/// When each host was last heard from, shared by the Zenoh callbacks that hear them.
#[derive(Debug, Clone, Default)]
pub struct Heard(Arc<Mutex<BTreeMap<String, Instant>>>);

impl Heard {
    /// `host` was heard now.
    pub fn hear(&self, host: &str) {
        let mut map = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        match map.get_mut(host) {
            Some(at) => *at = Instant::now(),
            None => {
                map.insert(host.to_owned(), Instant::now());
            }
        }
    }

    /// How long `host` has been silent; `None` if it was never heard.
    #[must_use]
    pub fn silence(&self, host: &str) -> Option<Duration> {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .get(host)
            .map(Instant::elapsed)
    }
}
