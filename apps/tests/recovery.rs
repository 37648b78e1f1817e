//! Recovery at the corridor's corner: it finds the guide in the red cap through the
//! opening to the hall, follows them at a distance as they walk away, and finishes once
//! they have left.

use lewis_apps::recovery::{REQUIRES, Recovery, RecoveryConfig};
use lewis_interfaces::msg::{GroundTruth, WorldState};

use crate::support::{S, scene, sim_robot, truth};

const SERVICES: &[&str] = &[
    "base",
    "laser",
    "camera",
    "blobfinder",
    "blobfinder3d",
    "vector_mover",
    "obstacle_avoider",
];

#[test]
fn recovery_follows_the_red_cap_at_a_distance_and_ends_when_it_has_gone() {
    // At the corner, facing up the opening to the hall: the cap is to the left.
    let robot = sim_robot((28.7, 15.5, 90.0), (320, 240));
    let program = Box::new(Recovery::new(RecoveryConfig::default()));
    let mut scene = scene(&robot, SERVICES, "recovery", program, REQUIRES);
    scene.tap("WorldState");
    scene.run_until(120 * S, |s| s.exit_code("recovery").is_some());
    let end = truth(&scene);
    let said: Vec<String> = scene
        .harness("recovery")
        .backend
        .logs
        .iter()
        .map(|(_, t)| t.clone())
        .collect();
    assert_eq!(
        scene.exit_code("recovery"),
        Some(0),
        "ended at {:.2},{:.2} after {} s: {said:#?}",
        end.pose.x,
        end.pose.y,
        scene.now_ns() / S
    );
    assert_eq!(end.collisions, 0);
    let truths = scene.tapped_as::<GroundTruth>();
    let worlds = scene.tapped_as::<WorldState>();
    let mut nearest = f64::INFINITY;
    let mut followed = 0.0_f64;
    for ((_, t), (_, w)) in truths.iter().zip(worlds.iter()) {
        for p in w.people.iter().filter(|p| p.present && p.name == "red-cap") {
            nearest = nearest.min((p.position.x - t.pose.x).hypot(p.position.y - t.pose.y));
        }
        followed = followed.max(28.7 - t.pose.x);
    }
    assert!(nearest >= 0.8, "came within {nearest:.2} m of the guide");
    assert!(followed > 2.0, "it followed west: {followed:.2} m");
}
