//! SignFollower along the conference world's corridor, as the mission runs it: one program
//! after another from the same robot, each reading its sign and turning as it says.

use lewis_apps::sign::{REQUIRES, SignConfig, SignFollower};
use lewis_testkit::scene::Scene;

use crate::support::{Idle, SEEING, run_program, scene, sim_robot, truth};

/// Runs one SignFollower named `name` to its end (or `limit_s`): its exit code and what
/// it said.
fn visit(scene: &mut Scene, name: &str, limit_s: i64) -> (Option<i32>, Vec<String>) {
    let program = Box::new(SignFollower::new(SignConfig::default()));
    run_program(scene, name, program, REQUIRES, limit_s)
}

#[test]
fn sign_follower_reads_the_corridor_signs_and_turns_as_they_say() {
    // Just past the entrance door, facing east along the corridor.
    let robot = sim_robot((9.5, 12.5, 0.0), (320, 240));
    let mut scene = scene(&robot, SEEING, "door", Box::new(Idle), &[]);
    // The corridor's sign says straight on, the corner's left, the hall's left, and then
    // the desk's sign is in sight (exit 1).
    let expected = [("up", 0), ("left", 0), ("left", 1)];
    for (k, (arrow, code)) in expected.iter().enumerate() {
        let name = format!("sign-{}", k + 1);
        let (exit, said) = visit(&mut scene, &name, 70);
        let t = truth(&scene);
        assert_eq!(exit, Some(*code), "{name}: {said:#?}");
        assert!(
            said.iter()
                .any(|line| line.contains(&format!("it says {}", capitalised(arrow)))),
            "{name} read {arrow}: {said:#?}"
        );
        assert_eq!(t.collisions, 0, "{name}");
        // Each next sign is in view when the program starts: no look around.
        assert!(
            !said.iter().any(|line| line.contains("looking around")),
            "{name}: {said:#?}"
        );
    }
}

#[test]
fn sign_follower_looks_around_for_a_sign_out_of_view_when_it_starts() {
    // Where Recovery leaves the robot in the hall, facing west-south-west: the desk's sign
    // (15.03, 22.1) is 40 degrees to the right, out of the camera's view, and nothing is
    // ahead but the hall's wall. Looking around finds the desk's sign (exit 1).
    let robot = sim_robot((20.5, 18.9, 190.0), (320, 240));
    let mut scene = scene(&robot, SEEING, "recovery", Box::new(Idle), &[]);
    let (exit, said) = visit(&mut scene, "sign", 70);
    assert_eq!(exit, Some(1), "{said:#?}");
    assert!(
        said.iter().any(|line| line.contains("looking around")),
        "{said:#?}"
    );
    assert_eq!(truth(&scene).collisions, 0);
}

fn capitalised(word: &str) -> String {
    let mut chars = word.chars();
    chars
        .next()
        .map(|c| c.to_ascii_uppercase().to_string() + chars.as_str())
        .unwrap_or_default()
}

#[test]
fn on_the_sonar_ring_alone_sign_follower_turns_on_the_axis_it_started_on() {
    // The laser dead from the start: the sonar ring is the range finder, too sparse to
    // learn the building's axes from; the heading each run starts with (on the door's
    // normal, then on the turns the signs asked for) is the axis.
    let robot = sim_robot((9.5, 12.5, 0.0), (320, 240));
    let services = &[
        "base",
        "sonar",
        "camera",
        "sign_detector",
        "vector_mover",
        "obstacle_avoider",
    ];
    let mut scene = scene(&robot, services, "door", Box::new(Idle), &[]);
    for (k, code) in [0, 0, 1].into_iter().enumerate() {
        let name = format!("sign-{}", k + 1);
        let (exit, said) = visit(&mut scene, &name, 70);
        assert_eq!(exit, Some(code), "{name}: {said:#?}");
        assert!(
            said.iter()
                .any(|l| l.contains("on the axis of the heading it started with")),
            "{name}: {said:#?}"
        );
        assert_eq!(truth(&scene).collisions, 0, "{name}");
    }
}

#[test]
fn in_the_hall_at_any_heading_the_hall_sign_is_read_square_to_its_wall() {
    // Where Recovery may leave the robot, at any heading: the hall sign (on the hall's
    // north wall, facing south) is seen 50 degrees off its face; its "left" is west, to
    // the desk, whatever the line of sight.
    for heading in [0.0, 45.0, 100.0, 200.0, 260.0, 330.0] {
        let robot = sim_robot((23.4, 18.9, heading), (320, 240));
        let mut scene = scene(&robot, SEEING, "recovery", Box::new(Idle), &[]);
        let (exit, said) = visit(&mut scene, "sign", 70);
        assert_eq!(exit, Some(1), "from {heading} deg: {said:#?}");
        assert_eq!(truth(&scene).collisions, 0);
    }
}
