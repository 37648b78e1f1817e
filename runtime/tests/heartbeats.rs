//! A service working through a backlog keeps beating: the live harness sends a due
//! heartbeat after each handler, not only when it has nothing left to do. Real IPC, its own
//! namespace, the service under the live harness in a thread of this process.

#![allow(
    clippy::unwrap_used,
    reason = "helpers shared by the tests: a failure there is a test failure"
)]

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{DistanceSetSectorCount, Health};
use lewis_runtime::ipc::{Ipc, Namespace, WaitSet, WakeMode};
use lewis_runtime::live::{ClockSource, run_service};
use lewis_runtime::names;
use lewis_service::wire;
use lewis_service::{CommandError, Context, IncomingCommand, Reply, Service, ServiceRegistry};

/// Commands sent at once.
const BURST: usize = 6;

/// Each command takes longer than the heartbeat period (10 ms) to answer.
const HANDLER: Duration = Duration::from_millis(25);

/// Answers commands slowly, noting when each was taken up; ends after the burst.
struct Slow {
    handled_ns: Arc<Mutex<Vec<i64>>>,
}

impl Service for Slow {
    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        _command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        self.handled_ns.lock().unwrap().push(ctx.now());
        // The work the command takes.
        std::thread::sleep(HANDLER);
        Err(CommandError::new("busy".to_owned()))
    }

    fn exit_code(&self) -> Option<i32> {
        (self.handled_ns.lock().unwrap().len() >= BURST).then_some(0)
    }
}

const ROBOT: &str = r#"
[robot]
name = "backlog"

[broker]
heartbeat_period_ms = 10
heartbeat_deadline_ms = 1000

[[services]]
name = "slow"
kind = "slow"
start = "always"
provides = [{ interface = "Distance", quality = 1, cost = 1 }]
"#;

#[test]
fn a_service_working_through_a_backlog_beats_between_handlers() {
    let robot = lewis_robot::parse(ROBOT, "robot.toml".as_ref(), &["Distance"]).unwrap();
    let namespace = Namespace::unique("backlog");
    let handled_ns = Arc::new(Mutex::new(Vec::new()));
    let mut registry = ServiceRegistry::new();
    let handled = Arc::clone(&handled_ns);
    registry.register("slow", move |_| {
        Ok(Box::new(Slow {
            handled_ns: Arc::clone(&handled),
        }))
    });
    let ipc = Ipc::open(&namespace, "test").unwrap();
    let mut beats = ipc
        .subscriber(&names::health_channel("slow"), &names::health_config())
        .unwrap();
    let service = {
        let namespace = namespace.clone();
        std::thread::spawn(move || {
            run_service(&robot, "slow", &registry, &namespace, ClockSource::Wall)
        })
    };
    // The first heartbeat says it is ready: its command server is open.
    let waits = WaitSet::new(WakeMode::Event);
    let watchdog = Instant::now() + Duration::from_secs(30);
    let mut heard = Vec::new();
    while heard.is_empty() {
        assert!(Instant::now() < watchdog, "no heartbeat from the service");
        waits.wait(&[&beats], Some(watchdog)).unwrap();
        while let Some(sample) = beats.receive().unwrap() {
            heard.push(cdr::from_bytes::<Health>(sample.bytes()).unwrap());
        }
    }
    let mut commands = ipc
        .command_client(
            &names::command_channel("slow", "Distance"),
            &names::command_config(),
        )
        .unwrap();
    let frame = wire::request_to_vec(
        "set_sector_count",
        &cdr::to_vec(&DistanceSetSectorCount::default()),
    );
    for _ in 0..BURST {
        commands.call(&frame, Duration::from_secs(30)).unwrap();
    }
    service.join().unwrap().unwrap();
    while let Some(sample) = beats.receive().unwrap() {
        heard.push(cdr::from_bytes::<Health>(sample.bytes()).unwrap());
    }
    let handled = handled_ns.lock().unwrap().clone();
    assert_eq!(handled.len(), BURST);
    // Each handler outlasts the period, so a heartbeat is due after each one: the first
    // five are followed by one before the next handler starts.
    let (first, last) = (handled[0], handled[BURST - 1]);
    let during: Vec<i64> = heard
        .iter()
        .map(|h| h.header.publish_time_ns)
        .filter(|t| (first..last).contains(t))
        .collect();
    assert!(
        during.len() >= BURST - 1,
        "{} heartbeats while {BURST} commands were answered: {during:?} between {handled:?}",
        during.len()
    );
}
