//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.

mod sim_camera;
mod sim_devices;
mod sim_properties;
mod sim_scene;
mod sim_services;
mod sim_speech;
mod sim_world;
