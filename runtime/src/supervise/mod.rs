//! Process supervision: spawn, watch, restart with intensity and backoff, stop in reverse order.
