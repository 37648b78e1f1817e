//! What a recorded topic is to the harness, from the runtime's channel names
//! ([`lewis_runtime::names`]).

use lewis_robot::Robot;
use lewis_runtime::names;

/// What a recorded topic carries.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Route {
    /// A provider's publications of an interface (`/<service>/<Interface>`).
    Data {
        /// The provider.
        service: String,
        /// The interface.
        interface: String,
    },
    /// A service's heartbeats (`/lewis/health/<service>`).
    Health {
        /// The service.
        service: String,
    },
    /// The commands a service answered (`/lewis/commands/<service>`).
    Commands {
        /// The service.
        service: String,
    },
    /// The broker's decisions (`/lewis/broker`).
    Broker,
    /// The CPU the broker measured of each service's process (`/lewis/broker/cpu`).
    Cpu,
    /// What the robot host's broker heard of the other hosts (`/lewis/hosts`).
    Hosts,
    /// Anything else (logs, the recorder's stats, topics of other programs).
    Other,
}

/// The route of `topic` in a recording of `robot`.
#[must_use]
pub fn route(topic: &str, robot: &Robot) -> Route {
    let service_of = |name: &str| robot.service(name).map(|s| s.name.clone());
    if let Some(service) = topic
        .strip_prefix(&names::health_channel(""))
        .and_then(service_of)
    {
        return Route::Health { service };
    }
    if let Some(service) = topic
        .strip_prefix(&names::command_log_channel(""))
        .and_then(service_of)
    {
        return Route::Commands { service };
    }
    if topic == names::BROKER_CHANNEL {
        return Route::Broker;
    }
    if topic == names::CPU_CHANNEL {
        return Route::Cpu;
    }
    if topic == names::HOSTS_CHANNEL {
        return Route::Hosts;
    }
    let mut parts = topic.strip_prefix('/').unwrap_or("").splitn(2, '/');
    if let (Some(service), Some(interface)) = (parts.next(), parts.next())
        && let Some(spec) = robot.service(service)
        && spec.provision(interface).is_some()
    {
        return Route::Data {
            service: service.to_owned(),
            interface: interface.to_owned(),
        };
    }
    Route::Other
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_are_routed_by_the_runtime_names() {
        let robot = lewis_robot::parse(
            "[robot]\nname = \"r\"\n[[services]]\nname = \"laser\"\nkind = \"k\"\nprovides = [{ interface = \"RangeFinder\", quality = 1, cost = 1 }]\n",
            std::path::Path::new("r.toml"),
            &["RangeFinder"],
        )
        .unwrap();
        let check = |topic: &str, expected: Route| assert_eq!(route(topic, &robot), expected);
        check(
            "/laser/RangeFinder",
            Route::Data {
                service: "laser".into(),
                interface: "RangeFinder".into(),
            },
        );
        check(
            "/lewis/health/laser",
            Route::Health {
                service: "laser".into(),
            },
        );
        check(
            "/lewis/commands/laser",
            Route::Commands {
                service: "laser".into(),
            },
        );
        check("/lewis/broker", Route::Broker);
        check("/lewis/broker/cpu", Route::Cpu);
        check("/lewis/hosts", Route::Hosts);
        check("/laser/Distance", Route::Other);
        check("/lewis/health/sonar", Route::Other);
        check("/lewis/log", Route::Other);
    }
}
