//! No input makes the parser, the checker or the FSM panic.

use std::path::Path;

use lewis_sequencer::{
    Decision, Event, MemorySources, Sequencer, Supervision, TrustingResolver, check_with,
};
use proptest::prelude::*;

/// Words that make lines the parser has to think about.
const WORDS: &[&str] = &[
    "start",
    "restart",
    "recovery",
    "use",
    "gui",
    "state",
    "action",
    "trans",
    "stop",
    "timeout",
    "env",
    "include",
    "a",
    "b",
    "oops",
    "./a",
    "/bin/b",
    "0",
    "1",
    "7",
    "101",
    "255",
    "256",
    "-1",
    "3",
    "30s",
    "1.5s",
    "500ms",
    "0s",
    "2m",
    "9999999999999h",
    "K=V",
    "=",
    "1K=V",
    "\"a b\"",
    "\"\\n\\u{e9}\"",
    "\"open",
    "\"\\q\"",
    "\"\\u{110000}\"",
    "\"x\"y",
    "a\"b",
    "#",
    "# comment",
    "b.seq",
    "\"a.seq\"",
    "../b.seq",
    "\u{feff}",
    "\t",
    "é",
    "\"\\0\"",
];

fn line() -> impl Strategy<Value = String> {
    (
        0..4usize,
        prop::collection::vec(prop::sample::select(WORDS), 0..6),
    )
        .prop_map(|(indent, words)| format!("{}{}", " ".repeat(indent), words.join(" ")))
}

fn script() -> impl Strategy<Value = String> {
    prop::collection::vec(line(), 0..24).prop_map(|lines| lines.join("\n"))
}

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        (-2..260i32).prop_map(|code| Event::Exited { code }),
        (0..40i32).prop_map(|signal| Event::Signalled { signal }),
        Just(Event::TimedOut),
        Just(Event::SpawnFailed {
            error: "gone".into()
        }),
        prop::sample::select(&["a", "b", "oops", "stop", "nowhere"][..]).prop_map(|state| {
            Event::SupervisorChose {
                state: state.into(),
            }
        }),
        Just(Event::SupervisorStopped),
    ]
}

/// Parses and checks `main` (which may include `b.seq` or itself) and, when it is a valid
/// mission, runs `events` through the FSM, checking what must always hold.
fn exercise(main: &str, other: &str, events: &[Event]) {
    for supervision in [Supervision::Page, Supervision::Unattended] {
        exercise_supervised(main, other, events, supervision);
    }
}

fn exercise_supervised(main: &str, other: &str, events: &[Event], supervision: Supervision) {
    let sources = MemorySources::new()
        .with("a.seq", main)
        .with("b.seq", other);
    let checked = match check_with(Path::new("a.seq"), &sources, &TrustingResolver) {
        Ok(checked) => checked,
        Err(diagnostics) => {
            assert!(diagnostics.has_errors());
            // Rendering must not panic either.
            let _ = diagnostics.to_string();
            return;
        }
    };
    let _ = checked.warnings.to_string();
    let (mut sequencer, mut decisions) = Sequencer::start(checked.mission.clone(), supervision);
    for event in events {
        let was_over = sequencer.is_over();
        let before = format!("{:?} {:?}", sequencer.running(), sequencer.is_asking());
        match sequencer.handle(event) {
            Ok(next) => {
                assert!(!was_over, "an event was accepted after the end");
                assert!(!next.is_empty(), "an accepted event gave no decision");
                decisions.extend(next);
            }
            Err(_) => {
                let after = format!("{:?} {:?}", sequencer.running(), sequencer.is_asking());
                assert_eq!(before, after, "a refused event changed the sequencer");
            }
        }
    }
    // Restarts within one visit never exceed the state's limit.
    for decision in &decisions {
        if let Decision::Restart { state, attempt, .. } = decision {
            let limit = checked.mission.state(state).map(|s| s.restart_limit);
            assert!(
                *attempt >= 2 && limit.is_some_and(|limit| attempt - 1 <= limit),
                "{decision}"
            );
        }
        assert!(!decision.reason().is_empty(), "{decision:?}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn arbitrary_text_never_panics(main in any::<String>(), other in ".{0,64}") {
        exercise(&main, &other, &[]);
    }

    #[test]
    fn arbitrary_mixes_of_keywords_never_panic(
        main in script(),
        other in script(),
        events in prop::collection::vec(event(), 0..24),
    ) {
        exercise(&main, &other, &events);
    }

    #[test]
    fn valid_missions_run_any_events_without_panicking(
        extra in prop_oneof![Just(String::new()), prop::collection::vec(line(), 0..4).prop_map(|l| l.join("\n"))],
        events in prop::collection::vec(event(), 0..40),
    ) {
        // A valid base keeps the FSM busy; the extra lines sometimes break it.
        let main = format!(
            "start a\nrestart 2\nrecovery oops\nuse gui\nstate a ./a\n  action 0 trans b\n  action 1 trans stop\nstate b ./b\n  restart 0\n  action 0 trans a\n  action 2 trans stop\nstate oops ./r\n  action 0 trans stop\n{extra}"
        );
        exercise(&main, "", &events);
    }
}
