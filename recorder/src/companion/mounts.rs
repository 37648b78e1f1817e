//! Where each sensor sits on the robot, as the robot description says: the frames under
//! `base_link` of the sensors whose messages do not carry their offsets (the cameras).

use std::collections::BTreeMap;

use super::Mount;

/// The `mount` parameter of each service of the robot description `toml`
/// (`mount = { x_m, y_m, heading_deg, height_m }`, a missing key 0). Read as plain TOML
/// rather than through `lewis_robot::parse`: the description was checked when it
/// was loaded, and a recording's stored one may be older than today's validator, which
/// must not cost it its frames. A text that does not parse gives no mounts.
#[must_use]
pub fn of_robot(toml: &str) -> BTreeMap<String, Mount> {
    let Ok(robot) = toml.parse::<toml::Table>() else {
        return BTreeMap::new();
    };
    let services = robot.get("services").and_then(toml::Value::as_array);
    services
        .into_iter()
        .flatten()
        .filter_map(|service| {
            let name = service.get("name")?.as_str()?;
            let mount = service.get("parameters")?.get("mount")?;
            let get = |key: &str| {
                mount
                    .get(key)
                    .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
            };
            Some((
                name.to_owned(),
                Mount {
                    x: get("x_m").unwrap_or(0.0),
                    y: get("y_m").unwrap_or(0.0),
                    z: get("height_m").unwrap_or(0.0),
                    yaw: get("heading_deg").unwrap_or(0.0).to_radians(),
                },
            ))
        })
        .collect()
}
