//! QueueStander in the hall: the queue at the registration desk is served while the robot
//! waits in it, and the robot ends at its head without touching anyone.

use lewis_apps::queue::{QueueConfig, QueueStander, REQUIRES};
use lewis_interfaces::msg::WorldState;

use crate::support::{S, SEEING, scene, sim_robot, truth};

#[test]
fn queue_stander_waits_its_turn_and_ends_at_the_head_of_the_queue() {
    // Where SignFollower leaves it: west along the hall, the desk's sign in sight.
    let robot = sim_robot((23.0, 23.2, 180.0), (320, 240));
    let program = Box::new(QueueStander::new(QueueConfig::default()));
    let mut scene = scene(&robot, SEEING, "queue", program, REQUIRES);
    scene.tap("WorldState");
    scene.run_until(120 * S, |s| s.exit_code("queue").is_some());
    let end = truth(&scene);
    assert_eq!(
        scene.exit_code("queue"),
        Some(0),
        "ended at {:.2},{:.2} after {} s",
        end.pose.x,
        end.pose.y,
        scene.now_ns() / S
    );
    assert_eq!(end.collisions, 0);
    // At the head: before the desk (its east edge at x 15), by the clerk.
    assert!(
        (15.3..17.5).contains(&end.pose.x) && (20.0..23.0).contains(&end.pose.y),
        "at {:.2},{:.2}",
        end.pose.x,
        end.pose.y
    );
    // Never closer than 0.2 m body to body (robot 0.26 m, people 0.22 m in radius).
    let truths = scene.tapped_as::<lewis_interfaces::msg::GroundTruth>();
    let worlds = scene.tapped_as::<WorldState>();
    let mut nearest = f64::INFINITY;
    for ((_, t), (_, w)) in truths.iter().zip(worlds.iter()) {
        for p in w.people.iter().filter(|p| p.present) {
            let d = (p.position.x - t.pose.x).hypot(p.position.y - t.pose.y) - 0.48;
            nearest = nearest.min(d);
        }
    }
    assert!(nearest > 0.2, "came {nearest:.2} m from someone");
}
