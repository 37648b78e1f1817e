//! A sub-task program under the live harness: it ends itself with an exit code, and its
//! last word (`on_stop`) still runs. Real IPC, its own namespace; no broker is needed
//! while it requires nothing.

#![allow(
    clippy::unwrap_used,
    reason = "helpers shared by the tests: a failure there is a test failure"
)]

use lewis_runtime::ipc::Namespace;
use lewis_runtime::live::{ClockSource, ProgramSpec, run_program};
use lewis_service::{Context, Service};

/// Finishes with 7 after three ticks and counts what ran.
#[derive(Default)]
struct ThreeTicks {
    ticks: u32,
    last_tick_ns: Vec<i64>,
    stopped: bool,
}

impl Service for ThreeTicks {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(10_000_000)
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        self.ticks += 1;
        self.last_tick_ns.push(ctx.now());
    }

    fn on_stop(&mut self, _ctx: &mut Context<'_>) {
        self.stopped = true;
    }

    fn exit_code(&self) -> Option<i32> {
        (self.ticks >= 3).then_some(7)
    }
}

#[test]
fn a_program_ends_itself_with_its_exit_code_after_its_last_word() {
    let spec = ProgramSpec {
        name: "three-ticks".to_owned(),
        requires: Vec::new(),
        seed: 1,
    };
    let mut program = ThreeTicks::default();
    let code = run_program(
        &spec,
        &mut program,
        &Namespace::unique("program"),
        ClockSource::Wall,
    )
    .unwrap();
    assert_eq!(code, 7);
    // It stopped right after the handler that finished it: no fourth tick.
    assert_eq!(program.ticks, 3);
    assert!(program.stopped, "on_stop runs after the program finishes");
    assert!(
        program.last_tick_ns.windows(2).all(|w| w[1] > w[0]),
        "ticks move forward on the program's clock: {:?}",
        program.last_tick_ns
    );
}
