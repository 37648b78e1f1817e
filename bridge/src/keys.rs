//! The Zenoh key expressions of a robot: one place for every name that crosses a network.
//!
//! | what | key |
//! |---|---|
//! | channel `/C` published on host H | `lewis/ROBOT/H/C` |
//! | its schema (a query) | `lewis/ROBOT/H/@schema/C` |
//! | a command `/C` served on host H (a query) | `lewis/ROBOT/H/@cmd/C` |
//! | host H's beat | `lewis/ROBOT/H/@beat` |
//! | orders to host H's supervisor (a query) | `lewis/ROBOT/H/@control` |
//! | exits on host H | `lewis/ROBOT/H/@exits` |
//! | host H is connected (a liveliness token) | `lewis/ROBOT/@hosts/H` |
//!
//! Chunks that start with `@` are verbatim in Zenoh: no wildcard matches them, so a tool
//! subscribed to `lewis/ROBOT/**` sees the publications and none of the bridge's own keys.

/// The key of channel `channel` (`/laser/RangeFinder`) published on `host`.
#[must_use]
pub fn channel(robot: &str, host: &str, channel: &str) -> String {
    format!("lewis/{robot}/{host}/{}", channel.trim_start_matches('/'))
}

/// The key a tool asks for the schema of `channel` published on `host`.
#[must_use]
pub fn schema(robot: &str, host: &str, channel: &str) -> String {
    format!(
        "lewis/{robot}/{host}/@schema/{}",
        channel.trim_start_matches('/')
    )
}

/// The key of every schema of `host`'s channels, for the queryable that answers them.
#[must_use]
pub fn schemas(robot: &str, host: &str) -> String {
    format!("lewis/{robot}/{host}/@schema/**")
}

/// The key a command served on `host` is called at.
#[must_use]
pub fn command(robot: &str, host: &str, channel: &str) -> String {
    format!(
        "lewis/{robot}/{host}/@cmd/{}",
        channel.trim_start_matches('/')
    )
}

/// The key of `host`'s beat.
#[must_use]
pub fn beat(robot: &str, host: &str) -> String {
    format!("lewis/{robot}/{host}/@beat")
}

/// The key of the orders to `host`'s supervisor.
#[must_use]
pub fn control(robot: &str, host: &str) -> String {
    format!("lewis/{robot}/{host}/@control")
}

/// The key of the exits `host`'s supervisor reports.
#[must_use]
pub fn exits(robot: &str, host: &str) -> String {
    format!("lewis/{robot}/{host}/@exits")
}

/// The liveliness token of `host`.
#[must_use]
pub fn host_token(robot: &str, host: &str) -> String {
    format!("lewis/{robot}/@hosts/{host}")
}

/// The host a liveliness token names.
#[must_use]
pub fn host_of_token<'k>(robot: &str, key: &'k str) -> Option<&'k str> {
    key.strip_prefix("lewis/")?
        .strip_prefix(robot)?
        .strip_prefix("/@hosts/")
}

/// The channel (`/laser/RangeFinder`) a schema query asks for.
#[must_use]
pub fn channel_of_schema_query(robot: &str, host: &str, key: &str) -> Option<String> {
    let prefix = format!("lewis/{robot}/{host}/@schema/");
    key.strip_prefix(&prefix).map(|c| format!("/{c}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_follow_the_channel_names() {
        assert_eq!(
            channel("sim", "robot", "/laser/RangeFinder"),
            "lewis/sim/robot/laser/RangeFinder"
        );
        assert_eq!(
            schema("sim", "robot", "/lewis/broker"),
            "lewis/sim/robot/@schema/lewis/broker"
        );
        assert_eq!(
            channel_of_schema_query("sim", "robot", "lewis/sim/robot/@schema/lewis/broker"),
            Some("/lewis/broker".to_owned())
        );
        assert_eq!(
            host_of_token("sim", &host_token("sim", "workstation")),
            Some("workstation")
        );
        assert_eq!(host_of_token("sim", "lewis/other/@hosts/workstation"), None);
    }
}
