//! What crosses between the hosts of a robot, from the robot file alone.
//!
//! The robot host is the hub. Another host sends it everything its services publish (their
//! data, heartbeats and command logs: the broker judges them and the recorder keeps them)
//! and receives the broker's decisions and the data of the robot host's providers of the
//! interfaces its own services require. The robot host offers everything it publishes, so
//! that a tool without Lewis can listen in. Commands cross the same way: a client calls a
//! provider of another host, or the broker, at the same channel as on one host, and the
//! bridge carries the call and its reply. Zenoh sends a publication only to a host that
//! subscribed to it, so a channel no client of another host needs stays home.
//!
//! Two other hosts talk through the hub too: every host is linked to the robot host, and
//! not necessarily to each other. A client on one whose provider is on another gets the
//! data the robot host imported anyway (for its recorder and broker), offered again under
//! the robot host's key, and its calls carried on by the robot host's bridge. So no
//! client is bound to a provider whose data has no way to it, and a host cut off from
//! the robot host is cut off from all.

use lewis_robot::Robot;
use lewis_runtime::names;

/// One channel that crosses, with the host it comes from.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Route {
    /// The channel (`/laser/RangeFinder`).
    pub channel: String,
    /// The host that publishes it, or serves it (a command).
    pub host: String,
}

/// What one host's bridge carries.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Routes {
    /// Channels published here that other hosts may subscribe to.
    pub exports: Vec<String>,
    /// Channels of other hosts published here again, as if their publishers were here.
    pub imports: Vec<Route>,
    /// Commands served on other hosts that clients here call: the bridge serves them here
    /// and carries each call there.
    pub proxies: Vec<Route>,
    /// Commands served here that clients of other hosts call.
    pub answers: Vec<String>,
}

/// The routes of `host` of `robot` (a robot with `[[hosts]]`; `host` one of them).
#[must_use]
pub fn routes(robot: &Robot, host: &str) -> Routes {
    let Some(hub) = robot.robot_host().map(|h| h.name.as_str()) else {
        return Routes::default();
    };
    // The interfaces with commands a service of `h` requires, and their providers elsewhere.
    let needed_from = |h: &str, from: &str| {
        let mut data = Vec::new();
        let mut commands = Vec::new();
        for client in robot.services_on(h) {
            for interface in &client.requires {
                for provider in robot.services_on(from) {
                    if provider.provision(interface).is_none() {
                        continue;
                    }
                    data.push(names::data_channel(&provider.name, interface));
                    if has_commands(interface) {
                        commands.push(names::command_channel(&provider.name, interface));
                    }
                }
            }
        }
        data.sort();
        data.dedup();
        commands.sort();
        commands.dedup();
        (data, commands)
    };
    let others = || robot.hosts.iter().skip(1).map(|h| h.name.as_str());
    let mut routes = Routes::default();
    if host == hub {
        for other in others() {
            for channel in published_by(robot, other) {
                routes.imports.push(Route {
                    channel,
                    host: other.to_owned(),
                });
            }
            let (_, commands) = needed_from(other, hub);
            routes.answers.extend(commands);
            let (_, calls) = needed_from(hub, other);
            routes
                .proxies
                .extend(calls.into_iter().map(|channel| Route {
                    channel,
                    host: other.to_owned(),
                }));
        }
        // Everything it publishes, for tools listening in too: Zenoh sends a sample only
        // where a subscriber is.
        routes.exports = published_by(robot, hub);
        routes.exports.push(names::BROKER_CHANNEL.to_owned());
        routes.answers.push(names::BROKER_COMMAND.to_owned());
        // Between two other hosts: their data offered again, their calls carried on.
        for client_host in others() {
            for provider_host in others().filter(|p| *p != client_host) {
                let (data, commands) = needed_from(client_host, provider_host);
                routes.exports.extend(data);
                routes.answers.extend(commands.iter().cloned());
                routes
                    .proxies
                    .extend(commands.into_iter().map(|channel| Route {
                        channel,
                        host: provider_host.to_owned(),
                    }));
            }
        }
    } else {
        routes.exports = published_by(robot, host);
        let (data, commands) = needed_from(host, hub);
        routes.imports.extend(
            std::iter::once(names::BROKER_CHANNEL.to_owned())
                .chain(data)
                .map(|channel| Route {
                    channel,
                    host: hub.to_owned(),
                }),
        );
        routes.proxies.extend(
            std::iter::once(names::BROKER_COMMAND.to_owned())
                .chain(commands)
                .map(|channel| Route {
                    channel,
                    host: hub.to_owned(),
                }),
        );
        let (_, answers) = needed_from(hub, host);
        routes.answers = answers;
        // From and to the other hosts, through the hub.
        for other in others().filter(|o| *o != host) {
            let (data, commands) = needed_from(host, other);
            let through_hub = |channel| Route {
                channel,
                host: hub.to_owned(),
            };
            routes.imports.extend(data.into_iter().map(through_hub));
            routes.proxies.extend(commands.into_iter().map(through_hub));
            let (_, answers) = needed_from(other, host);
            routes.answers.extend(answers);
        }
    }
    for list in [&mut routes.exports, &mut routes.answers] {
        list.sort();
        list.dedup();
    }
    for list in [&mut routes.imports, &mut routes.proxies] {
        list.sort();
        list.dedup();
    }
    routes
}

/// Every channel the services of `host` publish: their data, heartbeats, command logs.
fn published_by(robot: &Robot, host: &str) -> Vec<String> {
    let mut channels = Vec::new();
    for service in robot.services_on(host) {
        for provision in &service.provides {
            channels.push(names::data_channel(&service.name, &provision.interface));
        }
        channels.push(names::health_channel(&service.name));
        channels.push(names::command_log_channel(&service.name));
    }
    channels
}

fn has_commands(interface: &str) -> bool {
    lewis_interfaces::interface_info(interface).is_some_and(|i| !i.commands.is_empty())
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    const ROBOT: &str = r#"
[robot]
name = "two"
[[hosts]]
name = "robot"
listen = ["tcp/10.0.0.1:7447"]
[[hosts]]
name = "workstation"
[[services]]
name = "camera"
kind = "sim-camera"
provides = [{ interface = "ImageSource", quality = 10, cost = 1 }]
[[services]]
name = "blobfinder"
kind = "blobfinder"
host = "workstation"
requires = ["ImageSource"]
provides = [{ interface = "Blobs", quality = 10, cost = 1 }]
[[services]]
name = "blobfinder3d"
kind = "blobfinder3d"
requires = ["Blobs"]
provides = [{ interface = "Blobs3D", quality = 10, cost = 1 }]
"#;

    fn robot() -> Robot {
        let known = lewis_interfaces::interface_names();
        lewis_robot::parse(ROBOT, Path::new("two.toml"), &known).unwrap_or_else(|e| panic!("{e}"))
    }

    fn route(channel: &str, host: &str) -> Route {
        Route {
            channel: channel.to_owned(),
            host: host.to_owned(),
        }
    }

    #[test]
    fn the_workstation_sends_what_it_publishes_and_gets_what_it_needs() {
        let routes = routes(&robot(), "workstation");
        assert_eq!(
            routes.exports,
            [
                "/blobfinder/Blobs",
                "/lewis/commands/blobfinder",
                "/lewis/health/blobfinder"
            ]
        );
        assert_eq!(
            routes.imports,
            [
                route("/camera/ImageSource", "robot"),
                route("/lewis/broker", "robot")
            ]
        );
        assert_eq!(
            routes.proxies,
            [
                route("/camera/ImageSource/cmd", "robot"),
                route("/lewis/broker/cmd", "robot")
            ]
        );
        assert_eq!(routes.answers, ["/blobfinder/Blobs/cmd"]);
    }

    #[test]
    fn the_robot_host_gets_everything_the_others_publish() {
        let routes = routes(&robot(), "robot");
        assert_eq!(
            routes.exports,
            [
                "/blobfinder3d/Blobs3D",
                "/camera/ImageSource",
                "/lewis/broker",
                "/lewis/commands/blobfinder3d",
                "/lewis/commands/camera",
                "/lewis/health/blobfinder3d",
                "/lewis/health/camera",
            ]
        );
        assert_eq!(
            routes.imports,
            [
                route("/blobfinder/Blobs", "workstation"),
                route("/lewis/commands/blobfinder", "workstation"),
                route("/lewis/health/blobfinder", "workstation"),
            ]
        );
        assert_eq!(
            routes.answers,
            ["/camera/ImageSource/cmd", "/lewis/broker/cmd"]
        );
        assert_eq!(
            routes.proxies,
            [route("/blobfinder/Blobs/cmd", "workstation")]
        );
    }

    /// The blob finder on a third host: its blobs reach the workstation's blobfinder3d
    /// through the robot host, and so do the calls to it.
    const THREE: &str = r#"
[robot]
name = "three"
[[hosts]]
name = "robot"
listen = ["tcp/10.0.0.1:7447"]
[[hosts]]
name = "workstation"
[[hosts]]
name = "gpu"
[[services]]
name = "camera"
kind = "sim-camera"
provides = [{ interface = "ImageSource", quality = 10, cost = 1 }]
[[services]]
name = "blobfinder"
kind = "blobfinder"
host = "gpu"
requires = ["ImageSource"]
provides = [{ interface = "Blobs", quality = 10, cost = 1 }]
[[services]]
name = "blobfinder3d"
kind = "blobfinder3d"
host = "workstation"
requires = ["Blobs"]
provides = [{ interface = "Blobs3D", quality = 10, cost = 1 }]
"#;

    #[test]
    fn two_other_hosts_talk_through_the_robot_host() {
        let known = lewis_interfaces::interface_names();
        let robot = lewis_robot::parse(THREE, Path::new("three.toml"), &known)
            .unwrap_or_else(|e| panic!("{e}"));
        let hub = routes(&robot, "robot");
        assert!(hub.imports.contains(&route("/blobfinder/Blobs", "gpu")));
        assert!(hub.exports.contains(&"/blobfinder/Blobs".to_owned()));
        assert!(hub.proxies.contains(&route("/blobfinder/Blobs/cmd", "gpu")));
        assert!(hub.answers.contains(&"/blobfinder/Blobs/cmd".to_owned()));
        let workstation = routes(&robot, "workstation");
        assert!(
            workstation
                .imports
                .contains(&route("/blobfinder/Blobs", "robot"))
        );
        assert!(
            workstation
                .proxies
                .contains(&route("/blobfinder/Blobs/cmd", "robot"))
        );
        let gpu = routes(&robot, "gpu");
        assert!(gpu.exports.contains(&"/blobfinder/Blobs".to_owned()));
        assert_eq!(gpu.answers, ["/blobfinder/Blobs/cmd"]);
        // Nothing goes straight from one other host to the other.
        for (from, to) in [(&workstation, "gpu"), (&gpu, "workstation")] {
            assert!(from.imports.iter().all(|r| r.host != to));
            assert!(from.proxies.iter().all(|r| r.host != to));
        }
    }
}
