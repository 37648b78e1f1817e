//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.

mod motion_obstacle_avoider;
mod motion_support;
mod motion_vector_mover;
