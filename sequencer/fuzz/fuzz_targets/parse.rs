//! Feeds arbitrary bytes to the script parser and checker and, when they make a valid
//! mission, to the FSM: nothing may panic.
//!
//! The input is split at the first 0xFF byte: before it, the script (which may include
//! itself as `a.seq` or the second half as `b.seq`); after it, events for the FSM, one per
//! byte pair.

#![no_main]

use std::path::Path;

use lewis_sequencer::{Event, MemorySources, Sequencer, Supervision, TrustingResolver, check_with};
use libfuzzer_sys::fuzz_target;

fn event(kind: u8, value: u8) -> Event {
    match kind % 6 {
        0 => Event::Exited {
            code: i32::from(value),
        },
        1 => Event::Signalled {
            signal: i32::from(value % 32),
        },
        2 => Event::TimedOut,
        3 => Event::SpawnFailed {
            error: "fuzz".into(),
        },
        4 => Event::SupervisorChose {
            state: ["a", "b", "door", "oops", "stop", "x"][usize::from(value) % 6].into(),
        },
        _ => Event::SupervisorStopped,
    }
}

fuzz_target!(|data: &[u8]| {
    let (script, events) = match data.iter().position(|&b| b == 0xFF) {
        Some(split) => (&data[..split], &data[split + 1..]),
        None => (data, &[][..]),
    };
    let script = String::from_utf8_lossy(script);
    let other = String::from_utf8_lossy(events);
    let sources = MemorySources::new()
        .with("a.seq", script.as_ref())
        .with("b.seq", other.as_ref());
    match check_with(Path::new("a.seq"), &sources, &TrustingResolver) {
        Ok(checked) => {
            let _ = checked.warnings.to_string();
            let supervision = if events.len() % 2 == 0 {
                Supervision::Page
            } else {
                Supervision::Unattended
            };
            let (mut sequencer, _) = Sequencer::start(checked.mission, supervision);
            for pair in events.chunks(2) {
                let decisions =
                    sequencer.handle(&event(pair[0], pair.get(1).copied().unwrap_or(0)));
                if let Ok(decisions) = decisions {
                    for decision in decisions {
                        let _ = decision.to_string();
                    }
                }
            }
        }
        Err(diagnostics) => {
            let _ = diagnostics.to_string();
        }
    }
});
