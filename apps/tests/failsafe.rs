//! The fail-safe: a program whose required input goes silent stops the robot and ends
//! with 3.

use lewis_apps::common::exit;
use lewis_apps::common::watch::DEFAULT_STALE_NS;
use lewis_apps::door::{DoorConfig, DoorNavigator, REQUIRES};
use lewis_interfaces::msg::MoverStop;
use lewis_testkit::scene::calls_of;

use crate::support::{S, scene, sim_robot};

#[test]
fn without_its_range_finder_door_navigator_stops_the_robot_and_exits_3() {
    let robot = sim_robot((3.0, 12.5, 0.0), (320, 240));
    // No sonar: when the laser fails, nothing else gives RangeFinder.
    let services = ["base", "laser", "vector_mover", "obstacle_avoider"];
    let program = Box::new(DoorNavigator::new(DoorConfig::default()));
    let mut scene = scene(&robot, &services, "door", program, REQUIRES);
    scene.run_until(2 * S, |_| false);
    assert_eq!(
        scene.exit_code("door"),
        None,
        "it works while the laser does"
    );
    scene.fail("laser");
    let failed_at = scene.now_ns();
    scene.run_until(failed_at + DEFAULT_STALE_NS + 3 * S, |s| {
        s.exit_code("door").is_some()
    });
    assert_eq!(scene.exit_code("door"), Some(exit::INPUT_LOST));
    let waited = scene.now_ns() - failed_at;
    assert!(
        (DEFAULT_STALE_NS..DEFAULT_STALE_NS + S).contains(&waited),
        "it gave the laser its {DEFAULT_STALE_NS} ns, no more: {waited} ns"
    );
    let stops: Vec<_> = calls_of::<MoverStop>(&scene)
        .into_iter()
        .filter(|(at, client, _)| client == "door" && *at >= failed_at)
        .collect();
    assert_eq!(stops.len(), 1, "one stop, at the end: {stops:?}");
}
