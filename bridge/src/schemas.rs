//! The schema of each channel of a robot, for the tools that ask a host for one: the same
//! ros2msg names and texts the recorder writes into MCAP, from the one list of a robot's
//! channels ([`lewis_runtime::names::robot_channels`]).

use std::collections::BTreeMap;
use std::sync::Arc;

use lewis_robot::Robot;

/// Channel name to schema name and ros2msg text.
#[derive(Debug, Clone, Default)]
pub struct Schemas(Arc<BTreeMap<String, (String, String)>>);

impl Schemas {
    /// The schemas of every channel of `robot` (those the recorder records).
    #[must_use]
    pub fn of(robot: &Robot) -> Self {
        Self(Arc::new(
            lewis_runtime::names::robot_channels(Some(robot))
                .into_iter()
                .map(|c| (c.name, (c.schema_name.to_owned(), c.schema_text.to_owned())))
                .collect(),
        ))
    }

    /// The schema name and text of `channel`.
    #[must_use]
    pub fn get(&self, channel: &str) -> Option<&(String, String)> {
        self.0.get(channel)
    }
}
