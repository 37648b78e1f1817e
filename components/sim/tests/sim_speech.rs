//! `sim-speech` through the `Service` trait: the registrar (the clerk) answers yes 1.5 s
//! after the robot speaks within 3.5 m of them, nobody answers farther away, and a
//! supervisor's `hear` is taken at once.

#![allow(clippy::unwrap_used)]

use lewis_interfaces::msg::{GroundTruth, Pose2D, Speech, SpeechHear, SpeechSay};
use lewis_service::ServiceRegistry;
use lewis_testkit::{Harness, repository_path, robot};

const MS: i64 = 1_000_000;
const S: i64 = 1_000_000_000;

fn speech(parameters: &str) -> Result<Harness, String> {
    let world = repository_path("robots/worlds/conference")
        .to_string_lossy()
        .into_owned();
    let text = format!(
        "[robot]\nname = \"t\"\n\n[[services]]\nname = \"speech\"\nkind = \"sim-speech\"\n\
         requires = [\"GroundTruth\"]\n\
         provides = [{{ interface = \"Speech\", quality = 5, cost = 1 }}]\n\n\
         [services.parameters]\nworld = {world:?}\n{parameters}\n\n\
         [[services]]\nname = \"base\"\nkind = \"sim-base\"\n\
         provides = [{{ interface = \"GroundTruth\", quality = 5, cost = 1 }}]\n\n\
         [services.parameters]\nworld = {world:?}\nstart = {{ x_m = 3.0, y_m = 12.5 }}\n"
    );
    let mut registry = ServiceRegistry::new();
    lewis_sim::service::register(&mut registry);
    Harness::build(&robot(&text), "speech", &registry).map_err(|e| e.to_string())
}

fn truth(x_m: f64, y_m: f64) -> GroundTruth {
    let mut truth = GroundTruth {
        pose: Pose2D {
            x: x_m,
            y: y_m,
            theta: std::f64::consts::PI,
        },
        ..GroundTruth::default()
    };
    truth.header.seq = 3;
    truth
}

fn say(h: &mut Harness, now: i64, text: &str) -> i32 {
    h.command(
        now,
        &SpeechSay {
            text: text.to_owned(),
            ..SpeechSay::default()
        },
    )
    .unwrap()
    .utterance
}

/// Ticks every 100 ms from `from` to `to`; the last Speech published.
fn run(h: &mut Harness, from: i64, to: i64) -> Speech {
    let mut t = from;
    while t <= to {
        h.tick(t);
        t += 100 * MS;
    }
    h.take::<Speech>().pop().unwrap()
}

#[test]
fn the_registrar_answers_yes_when_the_robot_speaks_near_them() {
    let mut h = speech("").unwrap();
    h.start(0).unwrap();
    let first = h.take::<Speech>().pop().unwrap();
    assert_eq!((first.said_count, first.heard_count), (0, 0));
    assert_eq!(first.answer, "none");
    // At the head of the queue, 2.8 m from the clerk at (13.4, 21).
    h.send(50 * MS, "base", &truth(16.2, 21.0));
    assert_eq!(say(&mut h, S, "Hello, I would like to register."), 1);
    let said = h.take::<Speech>().pop().unwrap();
    assert_eq!(said.said_count, 1);
    assert_eq!(said.last_said, "Hello, I would like to register.");
    assert!(said.speaking);
    // Nothing before 1.5 s; the answer then.
    let before = run(&mut h, 1100 * MS, 2400 * MS);
    assert_eq!((before.heard_count, before.answer.as_str()), (0, "none"));
    let after = run(&mut h, 2500 * MS, 3200 * MS);
    assert_eq!(after.heard_count, 1);
    assert_eq!(after.answer, "yes");
    assert_eq!(after.last_heard, "You are registered. Welcome!");
    assert!(!after.speaking);
    // Publications name the true pose they were judged from.
    assert_eq!(after.header.inputs.len(), 1);
}

#[test]
fn nobody_answers_far_from_the_registrar_but_a_supervisor_may() {
    let mut h = speech("hear_within_m = 3.5\nanswer_delay_ms = 1500\nseed = 9").unwrap();
    h.start(0).unwrap();
    // Behind the queue, 5.8 m from the clerk.
    h.send(50 * MS, "base", &truth(19.2, 21.0));
    assert_eq!(say(&mut h, S, "Hello?"), 1);
    let later = run(&mut h, 1100 * MS, 10 * S);
    assert_eq!((later.said_count, later.heard_count), (1, 0));
    assert_eq!(later.answer, "none");
    // Without any true pose, nobody hears either.
    let mut blind = speech("").unwrap();
    blind.start(0).unwrap();
    say(&mut blind, S, "Hello?");
    assert_eq!(run(&mut blind, S, 5 * S).heard_count, 0);
    // The supervisor answers on the registrar's behalf.
    h.command(
        11 * S,
        &SpeechHear {
            answer: "no".to_owned(),
            text: "Come back tomorrow.".to_owned(),
            ..SpeechHear::default()
        },
    )
    .unwrap();
    let heard = h.take::<Speech>().pop().unwrap();
    assert_eq!(heard.heard_count, 1);
    assert_eq!(heard.answer, "no");
    assert_eq!(heard.last_heard, "Come back tomorrow.");
    let refused = h
        .command(
            12 * S,
            &SpeechHear {
                answer: "maybe".to_owned(),
                ..SpeechHear::default()
            },
        )
        .unwrap_err();
    assert!(
        refused.to_string().contains("expected yes or no"),
        "{refused}"
    );
}

#[test]
fn a_registrar_who_is_no_person_is_refused_with_the_people_named() {
    let error = speech("registrar = \"registration\"").unwrap_err();
    assert!(
        error.contains("`registrar` `registration` is no person") && error.contains("clerk"),
        "{error}"
    );
}
