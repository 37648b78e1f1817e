//! Process supervision: spawn, watch, restart with intensity and backoff, stop in reverse order.

mod policy;

pub use policy::{RestartDecision, RestartPolicy, RestartTracker};
