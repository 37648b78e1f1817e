//! Lewis replay: reading MCAP recordings, deterministic re-simulation in lockstep,
//! fault injection, comparison reports and live playback.
