//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.

mod camera_yuv;
mod perception_photos;
mod perception_sim;
mod sim_sonar_avoidance;
mod speech_espeak;
mod support;
