//! Lewis formats: the logs of other robot software in and out of Lewis.
//!
//! - [`import`]: CARMEN logs and ROS 2 bags as Lewis recordings (`lewis import`), with the
//!   robot file that replays them; the ROS 2 messages mapped to Lewis interfaces.
//! - [`export`]: Lewis recordings with companion channels of ROS 2's standard types, for
//!   Foxglove and RViz (`lewis export`).
//! - [`whole_file`]: an output written whole or not at all.
//!
//! It reads recordings through `lewis_recording` and writes them through
//! `lewis-recorder`, so an imported log is a recording like any other. Replay does not
//! depend on it: nothing here is needed to replay a recording.

pub mod export;
pub mod import;
pub mod whole_file;
