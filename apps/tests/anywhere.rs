//! The Challenge's moving states one after another, as `robots/missions/challenge.seq`
//! chains them (door, then sign until the desk's sign is in sight, then queue), from starts
//! in the lobby that are not square to the building: the programs learn the building's
//! axes from the laser, not from the heading they started with.

use lewis_apps::door::{self, DoorConfig, DoorNavigator};
use lewis_apps::queue::{self, QueueConfig, QueueStander};
use lewis_apps::sign::{self, SignConfig, SignFollower};
use lewis_testkit::scene::Scene;

use crate::support::{Idle, SEEING, run_program as run, scene, sim_robot, truth};

/// The states from `start` to the queue's head: the states run, each with its exit code.
fn mission_from(start: (f64, f64, f64)) -> (Vec<(String, Option<i32>)>, Scene) {
    let robot = sim_robot(start, (320, 240));
    let mut scene = scene(&robot, SEEING, "idle", Box::new(Idle), &[]);
    let mut states = Vec::new();
    let (code, said) = run(
        &mut scene,
        "door",
        Box::new(DoorNavigator::new(DoorConfig::default())),
        door::REQUIRES,
        70,
    );
    states.push(("door".to_owned(), code));
    assert_eq!(code, Some(0), "door from {start:?}: {said:#?}");
    for k in 1..=5 {
        let name = format!("sign-{k}");
        let (code, said) = run(
            &mut scene,
            &name,
            Box::new(SignFollower::new(SignConfig::default())),
            sign::REQUIRES,
            70,
        );
        states.push((name.clone(), code));
        // With the laser, each turn is on the axis learned from the walls.
        assert!(
            said.iter()
                .filter(|l| l.contains("before the sign"))
                .all(|l| l.contains("learned from")),
            "{name} from {start:?}: {said:#?}"
        );
        match code {
            Some(0) => {}
            Some(1) => break,
            _ => panic!("{name} from {start:?}: {code:?}, {said:#?}"),
        }
    }
    let (code, said) = run(
        &mut scene,
        "queue",
        Box::new(QueueStander::new(QueueConfig::default())),
        queue::REQUIRES,
        120,
    );
    states.push(("queue".to_owned(), code));
    assert_eq!(code, Some(0), "queue from {start:?}: {said:#?}");
    assert!(
        said.iter().any(|l| l.contains("(on the building's axis)")),
        "queue from {start:?}: {said:#?}"
    );
    (states, scene)
}

#[test]
fn from_starts_at_30_45_and_135_degrees_the_robot_reaches_the_head_of_the_queue() {
    for start in [(3.0, 12.5, 30.0), (2.0, 9.0, 45.0), (5.0, 15.5, 135.0)] {
        let (states, scene) = mission_from(start);
        let end = truth(&scene);
        assert_eq!(end.collisions, 0, "from {start:?}: {states:?}");
        // At the head: before the desk (its east edge at x 15), by the clerk.
        assert!(
            (15.3..17.5).contains(&end.pose.x) && (20.0..23.0).contains(&end.pose.y),
            "from {start:?}: at {:.2},{:.2} after {states:?}",
            end.pose.x,
            end.pose.y
        );
    }
}
