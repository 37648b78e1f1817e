//! What the tests of this crate share beside `lewis-testkit`'s harness: the registry of the
//! kinds they run and a robot file with one service under test.

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use lewis_service::ServiceRegistry;
use lewis_testkit::Harness;

/// Every perception and camera kind, as `lewis service` registers them.
pub fn registry() -> ServiceRegistry {
    let mut registry = ServiceRegistry::new();
    lewis_perception::register(&mut registry);
    lewis_drivers::camera::register(&mut registry);
    registry
}

/// Builds the service `name` of a robot file's text, through the registry.
pub fn build(robot_toml: &str, name: &str) -> Result<Harness, String> {
    let robot = lewis_testkit::robot(robot_toml);
    Harness::build(&robot, name, &registry()).map_err(|e| e.to_string())
}

/// A robot file with one service, `under-test`, and a source for each interface it requires.
pub fn robot(kind: &str, requires: &[&str], provides: &[&str], parameters: &str) -> String {
    let quote = |list: &[&str]| {
        list.iter()
            .map(|s| format!("\"{s}\""))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let provides = provides
        .iter()
        .map(|p| format!("{{ interface = \"{p}\", quality = 1, cost = 1 }}"))
        .collect::<Vec<_>>()
        .join(", ");
    // The robot file must have a provider for each required interface.
    let providers: String = requires
        .iter()
        .map(|r| {
            format!(
                "[[services]]\nname = \"{}\"\nkind = \"source\"\n\
                 provides = [{{ interface = \"{r}\", quality = 1, cost = 1 }}]\n\n",
                r.to_lowercase()
            )
        })
        .collect();
    // The heartbeat period these tests were written with.
    format!(
        "[robot]\nname = \"t\"\n\n[broker]\nheartbeat_period_ms = 100\n\n{providers}[[services]]\n\
         name = \"under-test\"\nkind = \"{kind}\"\nrequires = [{}]\nprovides = [{provides}]\n\n\
         [services.parameters]\n{parameters}\n",
        quote(requires)
    )
}
