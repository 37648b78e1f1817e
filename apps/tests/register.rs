//! Register with the simulated registrar (`sim-speech`): at the head of the queue the
//! clerk hears the robot and registers it; far from the desk nobody answers.

use lewis_apps::register::{REQUIRES, Register, RegisterConfig};
use lewis_interfaces::msg::Speech;

use crate::support::{S, scene, sim_robot};

/// Runs Register from `start`: its exit code and when it ended, in s.
fn register_from(start: (f64, f64, f64)) -> (Option<i32>, f64, Vec<Speech>) {
    let robot = sim_robot(start, (320, 240));
    let program = Box::new(Register::new(RegisterConfig::default()));
    let mut scene = scene(&robot, &["base", "speech"], "register", program, REQUIRES);
    scene.tap("Speech");
    scene.run_until(60 * S, |s| s.exit_code("register").is_some());
    let speech = scene
        .tapped_as::<Speech>()
        .into_iter()
        .map(|(_, s)| s)
        .collect();
    (
        scene.exit_code("register"),
        scene.now_ns() as f64 * 1e-9,
        speech,
    )
}

#[test]
fn at_the_head_of_the_queue_the_registrar_answers_yes_within_5_s() {
    let (code, seconds, speech) = register_from((16.1, 22.1, 180.0));
    assert_eq!(code, Some(0), "after {seconds:.1} s");
    assert!(seconds < 5.0, "took {seconds:.1} s");
    let last = speech.last().unwrap();
    assert_eq!(last.said_count, 1, "said once");
    assert!(last.last_said.contains("register"), "{}", last.last_said);
}

#[test]
fn far_from_the_desk_nobody_answers_and_register_gives_up_after_asking_twice() {
    let (code, seconds, speech) = register_from((3.0, 12.5, 0.0));
    assert_eq!(code, Some(4), "after {seconds:.1} s");
    assert!((40.0..45.0).contains(&seconds), "after {seconds:.1} s");
    assert_eq!(speech.last().unwrap().said_count, 2, "asked twice");
}
