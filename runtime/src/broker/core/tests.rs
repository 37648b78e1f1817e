//! Table-driven scenarios: a robot, a timed event sequence, and the transcript of every
//! decision and the final state, inline.

use std::fmt::Write as _;
use std::path::Path;

use expect_test::{Expect, expect};

use super::decision::fmt_time;
use super::*;
use lewis_robot as robot;
use lewis_service::Health;

pub(super) const KNOWN: &[&str] = &[
    "RangeFinder",
    "Distance",
    "Synchrodrive",
    "Egomotion",
    "Power",
    "ImageSource",
    "CameraControl",
    "Mover",
    "Blobs",
    "Blobs3D",
    "Signs",
];

const MS: i64 = 1_000_000;

/// The laser (quality 10) and the sonar (quality 5), both RangeFinder and Distance, on
/// demand; restarts: 2 within 10 s, backoff 20 ms doubling to 200 ms.
const LASER_SONAR: &str = r#"
[robot]
name = "bench"
[broker]
heartbeat_period_ms = 10
heartbeat_deadline_ms = 50
startup_deadline_ms = 1000
restart = { max_restarts = 2, window_ms = 10000, backoff_initial_ms = 20, backoff_max_ms = 200 }
[[services]]
name = "laser"
kind = "test-range"
provides = [
    { interface = "RangeFinder", quality = 10, cost = 2 },
    { interface = "Distance", quality = 10, cost = 2 },
]
[[services]]
name = "sonar"
kind = "test-range"
provides = [
    { interface = "RangeFinder", quality = 5, cost = 1 },
    { interface = "Distance", quality = 5, cost = 1 },
]
"#;

pub(super) fn core_for(robot_toml: &str) -> BrokerCore {
    let robot = robot::parse(robot_toml, Path::new("robot.toml"), KNOWN)
        .unwrap_or_else(|e| panic!("test robot is invalid:\n{e}"));
    BrokerCore::new(&robot)
}

/// Runs `events` (time in milliseconds, event) on a core for `robot_toml`, checking the
/// invariants after each, and compares the transcript (each event, its decisions, then the
/// final state and next deadline) with `expected`.
fn check(robot_toml: &str, events: &[(i64, Event)], expected: &Expect) {
    let mut core = core_for(robot_toml);
    let mut transcript = String::new();
    for (at_ms, event) in events {
        let decisions = core.handle(at_ms * MS, event);
        let _ = writeln!(transcript, "@{at_ms} {event}");
        for d in &decisions {
            assert_eq!(d.at_ns, at_ms * MS);
            let _ = writeln!(transcript, "  {d}");
        }
        if let Err(broken) = invariants(&core) {
            panic!("invariant broken after {event} at {at_ms} ms: {broken}\n{transcript}");
        }
    }
    let _ = writeln!(transcript, "== state");
    let _ = write!(transcript, "{}", core.snapshot());
    let _ = writeln!(
        transcript,
        "next deadline: {}",
        core.next_deadline()
            .map_or_else(|| "none".to_owned(), fmt_time)
    );
    expected.assert_eq(&transcript);
}

/// What must hold after every event: every bound client is bound to another service that
/// provides the interface and can serve it; help is asked only for interfaces with
/// waiting clients.
pub(super) fn invariants(core: &BrokerCore) -> Result<(), String> {
    for (client, bindings) in &core.clients {
        for (interface, service) in bindings {
            let Some(service) = service else {
                continue;
            };
            let Some(entry) = core.services.get(service) else {
                return Err(format!("{client} bound to unknown {service}"));
            };
            if service == client {
                return Err(format!("{client} bound to itself"));
            }
            if !entry.offers.contains_key(interface) {
                return Err(format!(
                    "{client} bound to {service} which lacks {interface}"
                ));
            }
            let gone = matches!(
                entry.state,
                ServiceState::Idle
                    | ServiceState::Stopped
                    | ServiceState::Failed { .. }
                    | ServiceState::Stopping {
                        then: AfterStop::Stopped | AfterStop::Failed { .. }
                    }
            );
            if gone || entry.health.is_out_of_service() || entry.host_down {
                return Err(format!(
                    "{client} bound to {service} which cannot serve ({:?}, {:?})",
                    entry.state, entry.health
                ));
            }
        }
    }
    for interface in &core.help_asked {
        let waiting = core
            .clients
            .values()
            .any(|b| b.get(interface).is_some_and(Option::is_none));
        if !waiting {
            return Err(format!("help asked for {interface} with nobody waiting"));
        }
    }
    Ok(())
}

fn s(x: &str) -> String {
    x.to_owned()
}
fn boot() -> Event {
    Event::BrokerStarted
}
fn req(client: &str, interface: &str) -> Event {
    Event::ClientRequest {
        client: s(client),
        interface: s(interface),
    }
}
fn gone(client: &str) -> Event {
    Event::ClientGone { client: s(client) }
}
fn spawned(service: &str) -> Event {
    Event::ProviderStarted {
        service: s(service),
    }
}
fn ready(service: &str) -> Event {
    Event::ProviderReady {
        service: s(service),
    }
}
fn beat(service: &str) -> Event {
    Event::Heartbeat {
        service: s(service),
        health: Health::Ok,
    }
}
fn degraded(service: &str, why: &str) -> Event {
    Event::Heartbeat {
        service: s(service),
        health: Health::Degraded(s(why)),
    }
}
fn out_of_service(service: &str, why: &str) -> Event {
    Event::Heartbeat {
        service: s(service),
        health: Health::OutOfService(s(why)),
    }
}
fn killed(service: &str) -> Event {
    Event::ProcessExited {
        service: s(service),
        status: ExitStatus::Signal(9),
    }
}
fn exited(service: &str, code: i32) -> Event {
    Event::ProcessExited {
        service: s(service),
        status: ExitStatus::Code(code),
    }
}
fn start_failed(service: &str, error: &str) -> Event {
    Event::StartFailed {
        service: s(service),
        error: s(error),
    }
}
fn bad_data(service: &str, check: &str, reason: &str) -> Event {
    Event::DataCheckFailed {
        service: s(service),
        interface: s("RangeFinder"),
        check: s(check),
        reason: s(reason),
    }
}

fn tick() -> Event {
    Event::TimePassed
}
fn stop(service: &str) -> Event {
    Event::StopService {
        service: s(service),
    }
}
fn restart(service: &str) -> Event {
    Event::RestartService {
        service: s(service),
    }
}

#[test]
fn a_request_binds_the_best_provider_started_on_demand() {
    check(
        LASER_SONAR,
        &[
            (0, req("app", "RangeFinder")),
            (1, spawned("laser")),
            (5, ready("laser")),
            (10, beat("laser")),
        ],
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @1 laser process started
            @5 laser ready
            @10 laser heartbeat: ok
            == state
            service laser: ready, last heartbeat 10 ms, health ok, 0 restarts, 1 clients
            service sonar: idle, health ok, 0 restarts, 0 clients
            client app RangeFinder -> laser
            next deadline: 60 ms
        "#]],
    );
}

/// The laser is up and serving `app` at 10 ms.
fn laser_serving() -> Vec<(i64, Event)> {
    vec![
        (0, req("app", "RangeFinder")),
        (5, ready("laser")),
        (10, beat("laser")),
    ]
}

fn with(mut first: Vec<(i64, Event)>, then: &[(i64, Event)]) -> Vec<(i64, Event)> {
    first.extend_from_slice(then);
    first
}

#[test]
fn laser_crash_is_restarted_and_the_client_stays_bound() {
    check(
        LASER_SONAR,
        &with(
            laser_serving(),
            &[
                (12, killed("laser")),
                (32, tick()),
                (35, ready("laser")),
                (40, beat("laser")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @12 laser exited with signal 9
              restart laser (attempt 1): laser exited with signal 9; restart 1 of at most 2 within 10000 ms, after 20 ms of backoff; its clients stay bound
            @32 time passed
              start laser: restart 1 of laser after its backoff
            @35 laser ready
            @40 laser heartbeat: ok
            == state
            service laser: ready, last heartbeat 40 ms, health ok, 1 restarts, 1 clients
            service sonar: idle, health ok, 0 restarts, 0 clients
            client app RangeFinder -> laser
            next deadline: 90 ms
        "#]],
    );
}

#[test]
fn laser_crash_beyond_limit_rebinds_client_to_sonar() {
    check(
        LASER_SONAR,
        &with(
            laser_serving(),
            &[
                (12, killed("laser")),
                (32, tick()),
                (35, ready("laser")),
                (40, exited("laser", 1)),
                (80, tick()),
                (81, exited("laser", 1)),
                (90, ready("sonar")),
                (95, beat("sonar")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @12 laser exited with signal 9
              restart laser (attempt 1): laser exited with signal 9; restart 1 of at most 2 within 10000 ms, after 20 ms of backoff; its clients stay bound
            @32 time passed
              start laser: restart 1 of laser after its backoff
            @35 laser ready
            @40 laser exited with exit code 1
              restart laser (attempt 2): laser exited with exit code 1; restart 2 of at most 2 within 10000 ms, after 40 ms of backoff; its clients stay bound
            @80 time passed
              start laser: restart 2 of laser after its backoff
            @81 laser exited with exit code 1
              laser failed: laser exited with exit code 1, its failure 3 within 10000 ms: beyond its restart policy
              start sonar: laser exited with exit code 1, its failure 3 within 10000 ms: beyond its restart policy; sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser exited with exit code 1, its failure 3 within 10000 ms: beyond its restart policy; sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @90 sonar ready
            @95 sonar heartbeat: ok
            == state
            service laser: failed, health ok, 2 restarts, 0 clients, last failure: laser exited with exit code 1, its failure 3 within 10000 ms: beyond its restart policy
            service sonar: ready, last heartbeat 95 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            next deadline: 145 ms
        "#]],
    );
}

#[test]
fn laser_stall_without_exiting_rebinds_after_the_heartbeat_deadline() {
    check(
        LASER_SONAR,
        &with(
            laser_serving(),
            &[
                (59, beat("sonar")), // not running: ignored
                (60, tick()),
                (61, killed("laser")),
                (70, ready("sonar")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @59 sonar heartbeat: ok
            @60 time passed
              laser failed: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms)
              stop laser: laser has failed: its process must go
              start sonar: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @61 laser exited with signal 9
            @70 sonar ready
            == state
            service laser: failed, health ok, 0 restarts, 0 clients, last failure: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms)
            service sonar: ready, last heartbeat 70 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            next deadline: 120 ms
        "#]],
    );
}

#[test]
fn a_loop_its_heartbeat_thread_reports_stuck_is_failed_at_once() {
    let stuck = |service: &str| Event::LoopStuck {
        service: service.to_owned(),
        why: "its event loop is blocked in one step for longer than its deadline (50 ms)"
            .to_owned(),
    };
    check(
        LASER_SONAR,
        &with(
            laser_serving(),
            &[
                (30, stuck("laser")),
                (31, stuck("laser")),
                (40, ready("sonar")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @30 laser stalled: its event loop is blocked in one step for longer than its deadline (50 ms)
              laser failed: laser stalled: its event loop is blocked in one step for longer than its deadline (50 ms)
              stop laser: laser has failed: its process must go
              start sonar: laser stalled: its event loop is blocked in one step for longer than its deadline (50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser stalled: its event loop is blocked in one step for longer than its deadline (50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @31 laser stalled: its event loop is blocked in one step for longer than its deadline (50 ms)
            @40 sonar ready
            == state
            service laser: stopping, failed, health ok, 0 restarts, 0 clients, last failure: laser stalled: its event loop is blocked in one step for longer than its deadline (50 ms)
            service sonar: ready, last heartbeat 40 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            next deadline: 90 ms
        "#]],
    );
}

#[test]
fn a_heartbeat_at_the_deadline_is_late_and_one_before_it_is_in_time() {
    check(
        LASER_SONAR,
        &with(
            laser_serving(),
            &[(59, beat("laser")), (109, beat("laser"))],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @59 laser heartbeat: ok
            @109 laser heartbeat: ok
              laser failed: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms)
              stop laser: laser has failed: its process must go
              start sonar: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            == state
            service laser: stopping, failed, health ok, 0 restarts, 0 clients, last failure: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms)
            service sonar: starting since 109 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            next deadline: 1109 ms
        "#]],
    );
}

#[test]
fn a_provider_silent_after_its_start_stalls_at_its_startup_deadline() {
    check(
        LASER_SONAR,
        &[
            (0, req("app", "RangeFinder")),
            (1, spawned("laser")),
            (1000, tick()),
        ],
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @1 laser process started
            @1000 time passed
              laser failed: laser stalled: no first heartbeat within its startup deadline of 1000 ms
              stop laser: laser has failed: its process must go
              start sonar: laser stalled: no first heartbeat within its startup deadline of 1000 ms; sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser stalled: no first heartbeat within its startup deadline of 1000 ms; sonar is the best provider of RangeFinder left (quality 5, cost 1)
            == state
            service laser: stopping, failed, health ok, 0 restarts, 0 clients, last failure: laser stalled: no first heartbeat within its startup deadline of 1000 ms
            service sonar: starting since 1000 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            next deadline: 2000 ms
        "#]],
    );
}

#[test]
fn out_of_service_rebinds_at_once_and_keeps_the_process() {
    check(
        LASER_SONAR,
        &with(
            laser_serving(),
            &[
                (20, out_of_service("laser", "mirror blocked")),
                (25, ready("sonar")),
                (30, beat("laser")),
                (35, req("app2", "RangeFinder")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @20 laser heartbeat: out of service (mirror blocked)
              start sonar: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @25 sonar ready
            @30 laser heartbeat: ok
            @35 client app2 requests RangeFinder
              bind app2 to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            == state
            service laser: ready, last heartbeat 30 ms, health ok, 0 restarts, 1 clients
            service sonar: ready, last heartbeat 25 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            client app2 RangeFinder -> laser
            next deadline: 75 ms
        "#]],
    );
}

#[test]
fn a_degraded_provider_keeps_its_clients() {
    check(
        LASER_SONAR,
        &with(laser_serving(), &[(20, degraded("laser", "dusty window"))]),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @20 laser heartbeat: degraded (dusty window)
            == state
            service laser: ready, last heartbeat 20 ms, health degraded (dusty window), 0 restarts, 1 clients
            service sonar: idle, health ok, 0 restarts, 0 clients
            client app RangeFinder -> laser
            next deadline: 70 ms
        "#]],
    );
}

fn fail_back_robot(setting: &str) -> String {
    LASER_SONAR.replace("[broker]\n", &format!("[broker]\n{setting}\n"))
}

#[test]
fn fail_back_moves_clients_to_the_better_provider_once_it_is_ready_again() {
    check(
        &fail_back_robot("fail_back = true"),
        &with(
            laser_serving(),
            &[
                (20, out_of_service("laser", "mirror blocked")),
                (25, ready("sonar")),
                (30, beat("laser")),
                (35, beat("sonar")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @20 laser heartbeat: out of service (mirror blocked)
              start sonar: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @25 sonar ready
            @30 laser heartbeat: ok
              rebind app from sonar to laser for RangeFinder: fail back: laser is ready and better for RangeFinder (quality 10, cost 2) than sonar (quality 5, cost 1)
            @35 sonar heartbeat: ok
            == state
            service laser: ready, last heartbeat 30 ms, health ok, 0 restarts, 1 clients
            service sonar: ready, last heartbeat 35 ms, health ok, 0 restarts, 0 clients
            client app RangeFinder -> laser
            next deadline: 80 ms
        "#]],
    );
}

#[test]
fn fail_back_after_an_operator_restart_of_a_failed_provider() {
    check(
        &fail_back_robot("fail_back = true"),
        &with(
            laser_serving(),
            &[
                (60, tick()),
                (61, killed("laser")),
                (65, ready("sonar")),
                (100, restart("laser")),
                (105, spawned("laser")),
                (110, beat("sonar")),
                (120, ready("laser")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @60 time passed
              laser failed: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms)
              stop laser: laser has failed: its process must go
              start sonar: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @61 laser exited with signal 9
            @65 sonar ready
            @100 operator restarts laser
              start laser: the operator restarts laser
            @105 laser process started
            @110 sonar heartbeat: ok
            @120 laser ready
              rebind app from sonar to laser for RangeFinder: fail back: laser is ready and better for RangeFinder (quality 10, cost 2) than sonar (quality 5, cost 1)
            == state
            service laser: ready, last heartbeat 120 ms, health ok, 0 restarts, 1 clients, last failure: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms)
            service sonar: ready, last heartbeat 110 ms, health ok, 0 restarts, 0 clients
            client app RangeFinder -> laser
            next deadline: 160 ms
        "#]],
    );
}

#[test]
fn no_fail_back_when_not_configured() {
    check(
        LASER_SONAR,
        &with(
            laser_serving(),
            &[
                (20, out_of_service("laser", "mirror blocked")),
                (25, ready("sonar")),
                (30, beat("laser")),
                (35, beat("sonar")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @20 laser heartbeat: out of service (mirror blocked)
              start sonar: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @25 sonar ready
            @30 laser heartbeat: ok
            @35 sonar heartbeat: ok
            == state
            service laser: ready, last heartbeat 30 ms, health ok, 0 restarts, 0 clients
            service sonar: ready, last heartbeat 35 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            next deadline: 80 ms
        "#]],
    );
}

#[test]
fn fail_back_can_be_set_per_interface() {
    check(
        &(fail_back_robot("fail_back = true")
            + "[broker.interfaces.Distance]\nfail_back = false\n"),
        &[
            (0, req("app", "RangeFinder")),
            (0, req("app", "Distance")),
            (5, ready("laser")),
            (20, out_of_service("laser", "mirror blocked")),
            (25, ready("sonar")),
            (30, beat("laser")),
        ],
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @0 client app requests Distance
              bind app to laser for Distance: laser is the best provider of Distance (quality 10, cost 2)
            @5 laser ready
            @20 laser heartbeat: out of service (mirror blocked)
              start sonar: laser is out of service (mirror blocked); sonar is the best provider of Distance left (quality 5, cost 1)
              rebind app from laser to sonar for Distance: laser is out of service (mirror blocked); sonar is the best provider of Distance left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @25 sonar ready
            @30 laser heartbeat: ok
              rebind app from sonar to laser for RangeFinder: fail back: laser is ready and better for RangeFinder (quality 10, cost 2) than sonar (quality 5, cost 1)
            == state
            service laser: ready, last heartbeat 30 ms, health ok, 0 restarts, 1 clients
            service sonar: ready, last heartbeat 25 ms, health ok, 0 restarts, 1 clients
            client app Distance -> sonar
            client app RangeFinder -> laser
            next deadline: 75 ms
        "#]],
    );
}

#[test]
fn no_provider_left_asks_for_help_once_then_binds_when_one_returns() {
    check(
        LASER_SONAR,
        &with(
            laser_serving(),
            &[
                (20, out_of_service("laser", "mirror blocked")),
                (25, out_of_service("sonar", "transducers wet")),
                (30, beat("laser")),
                (31, req("app2", "RangeFinder")),
                (40, beat("sonar")),
                (45, beat("laser")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @20 laser heartbeat: out of service (mirror blocked)
              start sonar: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @25 sonar heartbeat: out of service (transducers wet)
              unbind app from sonar for RangeFinder: no provider of RangeFinder is left (laser is out of service (mirror blocked); sonar is out of service (transducers wet))
              ask for help with RangeFinder: no provider of RangeFinder is left (laser is out of service (mirror blocked); sonar is out of service (transducers wet)); clients wait for it
            @30 laser heartbeat: ok
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @31 client app2 requests RangeFinder
              bind app2 to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @40 sonar heartbeat: ok
            @45 laser heartbeat: ok
            == state
            service laser: ready, last heartbeat 45 ms, health ok, 0 restarts, 2 clients
            service sonar: ready, last heartbeat 40 ms, health ok, 0 restarts, 0 clients
            client app RangeFinder -> laser
            client app2 RangeFinder -> laser
            next deadline: 90 ms
        "#]],
    );
}

#[test]
fn a_missing_binary_is_reported_not_retried_and_the_next_provider_is_used() {
    check(
        LASER_SONAR,
        &[
            (0, req("app", "RangeFinder")),
            (
                1,
                start_failed("laser", "No such file or directory (os error 2)"),
            ),
            (
                2,
                start_failed("sonar", "No such file or directory (os error 2)"),
            ),
            (60_000, tick()),
        ],
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @1 laser could not start: No such file or directory (os error 2)
              laser failed: laser could not be started (No such file or directory (os error 2)); not retried, it would fail the same way: fix it, then restart it
              start sonar: laser could not be started (No such file or directory (os error 2)); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser could not be started (No such file or directory (os error 2)); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @2 sonar could not start: No such file or directory (os error 2)
              sonar failed: sonar could not be started (No such file or directory (os error 2)); not retried, it would fail the same way: fix it, then restart it
              unbind app from sonar for RangeFinder: no provider of RangeFinder is left (laser could not be started (No such file or directory (os error 2)); sonar could not be started (No such file or directory (os error 2)))
              ask for help with RangeFinder: no provider of RangeFinder is left (laser could not be started (No such file or directory (os error 2)); sonar could not be started (No such file or directory (os error 2))); clients wait for it
            @60000 time passed
            == state
            service laser: failed, health ok, 0 restarts, 0 clients, last failure: laser could not be started (No such file or directory (os error 2))
            service sonar: failed, health ok, 0 restarts, 0 clients, last failure: sonar could not be started (No such file or directory (os error 2))
            client app RangeFinder -> (waiting)
            help asked for RangeFinder
            next deadline: none
        "#]],
    );
}

#[test]
fn several_clients_on_one_interface_are_all_rebound() {
    check(
        LASER_SONAR,
        &[
            (0, req("app", "RangeFinder")),
            (1, req("avoider", "RangeFinder")),
            (2, req("mapper", "RangeFinder")),
            (5, ready("laser")),
            (20, out_of_service("laser", "mirror blocked")),
        ],
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @1 client avoider requests RangeFinder
              bind avoider to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @2 client mapper requests RangeFinder
              bind mapper to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @20 laser heartbeat: out of service (mirror blocked)
              start sonar: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind avoider from laser to sonar for RangeFinder: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind mapper from laser to sonar for RangeFinder: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            == state
            service laser: ready, last heartbeat 20 ms, health out of service (mirror blocked), 0 restarts, 0 clients
            service sonar: starting since 20 ms, health ok, 0 restarts, 3 clients
            client app RangeFinder -> sonar
            client avoider RangeFinder -> sonar
            client mapper RangeFinder -> sonar
            next deadline: 70 ms
        "#]],
    );
}

#[test]
fn a_service_providing_two_interfaces_fails_and_both_interfaces_clients_are_rebound() {
    check(
        LASER_SONAR,
        &[
            (0, req("app", "RangeFinder")),
            (1, req("avoider", "Distance")),
            (5, ready("laser")),
            (10, killed("laser")),
            (30, tick()),
            (31, killed("laser")),
            (71, tick()),
            (72, killed("laser")),
        ],
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @1 client avoider requests Distance
              bind avoider to laser for Distance: laser is the best provider of Distance (quality 10, cost 2)
            @5 laser ready
            @10 laser exited with signal 9
              restart laser (attempt 1): laser exited with signal 9; restart 1 of at most 2 within 10000 ms, after 20 ms of backoff; its clients stay bound
            @30 time passed
              start laser: restart 1 of laser after its backoff
            @31 laser exited with signal 9
              restart laser (attempt 2): laser exited with signal 9; restart 2 of at most 2 within 10000 ms, after 40 ms of backoff; its clients stay bound
            @71 time passed
              start laser: restart 2 of laser after its backoff
            @72 laser exited with signal 9
              laser failed: laser exited with signal 9, its failure 3 within 10000 ms: beyond its restart policy
              start sonar: laser exited with signal 9, its failure 3 within 10000 ms: beyond its restart policy; sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser exited with signal 9, its failure 3 within 10000 ms: beyond its restart policy; sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind avoider from laser to sonar for Distance: laser exited with signal 9, its failure 3 within 10000 ms: beyond its restart policy; sonar is the best provider of Distance left (quality 5, cost 1)
            == state
            service laser: failed, health ok, 2 restarts, 0 clients, last failure: laser exited with signal 9, its failure 3 within 10000 ms: beyond its restart policy
            service sonar: starting since 72 ms, health ok, 0 restarts, 2 clients
            client app RangeFinder -> sonar
            client avoider Distance -> sonar
            next deadline: 1072 ms
        "#]],
    );
}

#[test]
fn a_hot_standby_starts_with_the_broker_and_takes_over_without_a_start() {
    check(
        &LASER_SONAR.replace(
            "name = \"sonar\"\nkind = \"test-range\"\n",
            "name = \"sonar\"\nkind = \"test-range\"\nstart = \"standby\"\n",
        ),
        &[
            (0, boot()),
            (3, ready("sonar")),
            (4, req("app", "RangeFinder")),
            (8, ready("laser")),
            (10, beat("sonar")),
            (20, out_of_service("laser", "mirror blocked")),
        ],
        &expect![[r#"
            @0 broker started
              start sonar: the broker started and it is a hot standby
            @3 sonar ready
            @4 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @8 laser ready
            @10 sonar heartbeat: ok
            @20 laser heartbeat: out of service (mirror blocked)
              rebind app from laser to sonar for RangeFinder: laser is out of service (mirror blocked); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            == state
            service laser: ready, last heartbeat 20 ms, health out of service (mirror blocked), 0 restarts, 0 clients
            service sonar: ready, last heartbeat 10 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            next deadline: 60 ms
        "#]],
    );
}

const BASE_AND_SONAR: &str = r#"
[robot]
name = "b21r"
[broker]
heartbeat_period_ms = 10
heartbeat_deadline_ms = 50
restart = { max_restarts = 0, window_ms = 10000 }
[[services]]
name = "base"
kind = "rflex"
start = "always"
provides = [
    { interface = "Synchrodrive", quality = 5, cost = 3 },
    { interface = "Power", quality = 5, cost = 3 },
    { interface = "RangeFinder", quality = 5, cost = 3 },
]
[[services]]
name = "sonar-sim"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 5, cost = 1 }]
[[services]]
name = "laser"
kind = "sick"
provides = [{ interface = "RangeFinder", quality = 10, cost = 2 }]
"#;

#[test]
fn at_equal_quality_a_running_provider_is_chosen_over_a_cheaper_new_process() {
    check(
        BASE_AND_SONAR,
        &[
            (0, boot()),
            (5, ready("base")),
            (6, req("app", "Synchrodrive")),
            (7, req("app", "RangeFinder")),
            (8, start_failed("laser", "permission denied")),
        ],
        &expect![[r#"
            @0 broker started
              start base: the broker started and it must always run
            @5 base ready
            @6 client app requests Synchrodrive
              bind app to base for Synchrodrive: base is the best provider of Synchrodrive (quality 5, cost 3)
            @7 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @8 laser could not start: permission denied
              laser failed: laser could not be started (permission denied); not retried, it would fail the same way: fix it, then restart it
              rebind app from laser to base for RangeFinder: laser could not be started (permission denied); base is the best provider of RangeFinder left (quality 5, cost 3)
            == state
            service base: ready, last heartbeat 5 ms, health ok, 0 restarts, 2 clients
            service laser: failed, health ok, 0 restarts, 0 clients, last failure: laser could not be started (permission denied)
            service sonar-sim: idle, health ok, 0 restarts, 0 clients
            client app RangeFinder -> base
            client app Synchrodrive -> base
            next deadline: 55 ms
        "#]],
    );
}

#[test]
fn an_always_service_that_fails_for_good_asks_for_help() {
    check(
        BASE_AND_SONAR,
        &[
            (0, boot()),
            (5, ready("base")),
            (6, req("app", "Power")),
            (7, killed("base")),
        ],
        &expect![[r#"
            @0 broker started
              start base: the broker started and it must always run
            @5 base ready
            @6 client app requests Power
              bind app to base for Power: base is the best provider of Power (quality 5, cost 3)
            @7 base exited with signal 9
              base failed: base exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
              ask for help with service base: base must always run and has failed: base exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
              unbind app from base for Power: no provider of Power is left (base exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy)
              ask for help with Power: no provider of Power is left (base exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy); clients wait for it
            == state
            service base: failed, health ok, 0 restarts, 0 clients, last failure: base exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
            service laser: idle, health ok, 0 restarts, 0 clients
            service sonar-sim: idle, health ok, 0 restarts, 0 clients
            client app Power -> (waiting)
            help asked for Power
            next deadline: none
        "#]],
    );
}

#[test]
fn clients_come_and_go_and_unknown_requests_are_rejected() {
    check(
        LASER_SONAR,
        &[
            (0, req("app", "RangeFinder")),
            (1, req("app", "Distance")),
            (2, req("app", "RangeFinder")),
            (3, req("app", "Signs")),
            (4, req("app", "NoSuchInterface")),
            (5, gone("app")),
            (6, gone("app")),
            (7, beat("ghost")),
            (8, restart("ghost")),
        ],
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @1 client app requests Distance
              bind app to laser for Distance: laser is the best provider of Distance (quality 10, cost 2)
            @2 client app requests RangeFinder
              bind app to laser for RangeFinder: repeated request: the binding is unchanged
            @3 client app requests Signs
              reject app's request for Signs: no service of this robot provides Signs to app
            @4 client app requests NoSuchInterface
              reject app's request for NoSuchInterface: no service of this robot provides NoSuchInterface to app
            @5 client app gone
              unbind app from laser for Distance: client app is gone
              unbind app from laser for RangeFinder: client app is gone
            @6 client app gone
            @7 ghost heartbeat: ok
            @8 operator restarts ghost
            == state
            service laser: starting since 0 ms, health ok, 0 restarts, 0 clients
            service sonar: idle, health ok, 0 restarts, 0 clients
            next deadline: 1000 ms
        "#]],
    );
}

#[test]
fn a_service_asking_for_an_interface_it_provides_gets_another_provider() {
    check(
        LASER_SONAR,
        &[(0, req("laser", "RangeFinder")), (1, req("sonar", "Signs"))],
        &expect![[r#"
            @0 client laser requests RangeFinder
              start sonar: laser needs RangeFinder and sonar is its best provider (quality 5, cost 1)
              bind laser to sonar for RangeFinder: sonar is the best provider of RangeFinder (quality 5, cost 1)
            @1 client sonar requests Signs
              reject sonar's request for Signs: no service of this robot provides Signs to sonar
            == state
            service laser: idle, health ok, 0 restarts, 0 clients
            service sonar: starting since 0 ms, health ok, 0 restarts, 1 clients
            client laser RangeFinder -> sonar
            next deadline: 1000 ms
        "#]],
    );
}

#[test]
fn a_retried_service_that_dies_on_trial_gets_no_clients_back() {
    check(
        &fail_back_robot("retry_failed_after_ms = 100\nfail_back = true"),
        &with(
            laser_serving(),
            &[
                (60, tick()),
                (61, killed("laser")),
                (65, ready("sonar")),
                (100, beat("sonar")),
                (140, beat("sonar")),
                (160, tick()),
                (170, ready("laser")),
                (180, killed("laser")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @60 time passed
              laser failed: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); it will be retried in 100 ms
              stop laser: laser has failed: its process must go
              start sonar: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @61 laser exited with signal 9
            @65 sonar ready
            @100 sonar heartbeat: ok
            @140 sonar heartbeat: ok
            @160 time passed
              start laser: retry laser, failed long enough ago; clients fail back to it once it has stayed up 5 s
            @170 laser ready
            @180 laser exited with signal 9
              restart laser (attempt 1): laser exited with signal 9; restart 1 of at most 2 within 10000 ms, after 20 ms of backoff; its clients stay bound
            == state
            service laser: restarting at 200 ms (attempt 1), health ok, 0 restarts, 0 clients, last failure: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms)
            service sonar: ready, last heartbeat 140 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            next deadline: 190 ms
        "#]],
    );
}

/// The laser stalls at 60 ms; retried after 100 ms, on trial for 50 ms.
const RETRY: &str = "retry_failed_after_ms = 100\nretry_probation_ms = 50\nfail_back = true";

#[test]
fn a_retried_service_that_stays_up_through_its_probation_gets_its_clients_back() {
    check(
        &fail_back_robot(RETRY),
        &with(
            laser_serving(),
            &[
                (60, tick()),
                (61, killed("laser")),
                (65, ready("sonar")),
                (100, beat("sonar")),
                (140, beat("sonar")),
                (160, tick()),
                (170, ready("laser")),
                (180, beat("sonar")),
                (200, beat("laser")),
                (215, beat("sonar")),
                // On trial until 220: the client stays on the sonar until then.
                (220, tick()),
                (240, beat("laser")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @60 time passed
              laser failed: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); it will be retried in 100 ms
              stop laser: laser has failed: its process must go
              start sonar: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @61 laser exited with signal 9
            @65 sonar ready
            @100 sonar heartbeat: ok
            @140 sonar heartbeat: ok
            @160 time passed
              start laser: retry laser, failed long enough ago; clients fail back to it once it has stayed up 50 ms
            @170 laser ready
            @180 sonar heartbeat: ok
            @200 laser heartbeat: ok
            @215 sonar heartbeat: ok
            @220 time passed
              rebind app from sonar to laser for RangeFinder: fail back: laser is ready and better for RangeFinder (quality 10, cost 2) than sonar (quality 5, cost 1)
            @240 laser heartbeat: ok
            == state
            service laser: ready, last heartbeat 240 ms, health ok, 0 restarts, 1 clients, last failure: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms)
            service sonar: ready, last heartbeat 215 ms, health ok, 0 restarts, 0 clients
            client app RangeFinder -> laser
            next deadline: 265 ms
        "#]],
    );
}

#[test]
fn the_status_says_until_when_a_retried_service_is_on_trial() {
    let mut core = core_for(&fail_back_robot(RETRY));
    for (at_ms, event) in with(
        laser_serving(),
        &[
            (60, tick()),
            (61, killed("laser")),
            (160, tick()),
            (170, ready("laser")),
        ],
    ) {
        core.handle(at_ms * 1_000_000, &event);
    }
    let laser = core.snapshot().services.remove(0);
    assert_eq!(
        laser.detail(),
        "ready, last heartbeat 170 ms, on probation until 220 ms"
    );
}

#[test]
fn each_retry_that_fails_on_trial_doubles_the_cool_down_and_a_passed_one_resets_it() {
    check(
        &fail_back_robot(&format!("{RETRY}\nretry_failed_max_ms = 300")),
        &with(
            laser_serving(),
            &[
                // Stalls: retried 100 ms later; stalls on trial: 200 ms; again: 300 (the
                // longest), then it stays up and its next stall waits 100 ms again. (The
                // sonar, with a startup deadline of 1 s, stays starting throughout.)
                (60, tick()),
                (61, killed("laser")),
                (160, tick()),
                (165, ready("laser")),
                (216, tick()),
                (217, killed("laser")),
                (416, tick()),
                (420, ready("laser")),
                (471, tick()),
                (472, killed("laser")),
                (771, tick()),
                (775, ready("laser")),
                (800, beat("laser")),
                (825, beat("laser")),
                (826, tick()),
                (877, tick()),
                (878, killed("laser")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @60 time passed
              laser failed: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); it will be retried in 100 ms
              stop laser: laser has failed: its process must go
              start sonar: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser stalled: no heartbeat for 50 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @61 laser exited with signal 9
            @160 time passed
              start laser: retry laser, failed long enough ago; clients fail back to it once it has stayed up 50 ms
            @165 laser ready
            @216 time passed
              laser failed: laser stalled: no heartbeat for 51 ms (its deadline: 50 ms); it will be retried in 200 ms (longer each time a retry fails on trial: 1 so far)
              stop laser: laser has failed: its process must go
            @217 laser exited with signal 9
            @416 time passed
              start laser: retry laser, failed long enough ago; clients fail back to it once it has stayed up 50 ms
            @420 laser ready
            @471 time passed
              laser failed: laser stalled: no heartbeat for 51 ms (its deadline: 50 ms); it will be retried in 300 ms (longer each time a retry fails on trial: 2 so far)
              stop laser: laser has failed: its process must go
            @472 laser exited with signal 9
            @771 time passed
              start laser: retry laser, failed long enough ago; clients fail back to it once it has stayed up 50 ms
            @775 laser ready
            @800 laser heartbeat: ok
            @825 laser heartbeat: ok
              rebind app from sonar to laser for RangeFinder: fail back: laser is ready and better for RangeFinder (quality 10, cost 2) than sonar (quality 5, cost 1)
            @826 time passed
            @877 time passed
              laser failed: laser stalled: no heartbeat for 52 ms (its deadline: 50 ms); it will be retried in 100 ms
              stop laser: laser has failed: its process must go
              rebind app from laser to sonar for RangeFinder: laser stalled: no heartbeat for 52 ms (its deadline: 50 ms); sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @878 laser exited with signal 9
            == state
            service laser: failed, retry at 977 ms, health ok, 0 restarts, 0 clients, last failure: laser stalled: no heartbeat for 52 ms (its deadline: 50 ms)
            service sonar: starting since 60 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            next deadline: 977 ms
        "#]],
    );
}

#[test]
fn an_operator_stop_moves_clients_away_and_a_restart_brings_the_service_back() {
    check(
        LASER_SONAR,
        &with(
            laser_serving(),
            &[
                (20, stop("laser")),
                (21, exited("laser", 0)),
                (25, ready("sonar")),
                (30, restart("laser")),
                (35, ready("laser")),
                (40, restart("sonar")),
                (41, killed("sonar")),
                (45, beat("laser")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @20 operator stops laser
              stop laser: the operator stops laser
              start sonar: laser was stopped by the operator; sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser was stopped by the operator; sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @21 laser exited with exit code 0
            @25 sonar ready
            @30 operator restarts laser
              start laser: the operator restarts laser
            @35 laser ready
            @40 operator restarts sonar
              stop sonar: the operator restarts sonar: stop it first
            @41 sonar exited with signal 9
              start sonar: the operator restarts sonar
            @45 laser heartbeat: ok
            == state
            service laser: ready, last heartbeat 45 ms, health ok, 0 restarts, 0 clients
            service sonar: starting since 41 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            next deadline: 95 ms
        "#]],
    );
}

#[test]
fn the_test_robot_file_fails_over_from_laser_to_sonar() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/test.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    check(
        &text,
        &[
            (0, req("app", "RangeFinder")),
            (5, ready("laser")),
            (10, killed("laser")),
            (30, tick()),
            (31, killed("laser")),
            (71, tick()),
            (72, killed("laser")),
        ],
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser exited with signal 9
              restart laser (attempt 1): laser exited with signal 9; restart 1 of at most 2 within 10000 ms, after 20 ms of backoff; its clients stay bound
            @30 time passed
              start laser: restart 1 of laser after its backoff
            @31 laser exited with signal 9
              restart laser (attempt 2): laser exited with signal 9; restart 2 of at most 2 within 10000 ms, after 40 ms of backoff; its clients stay bound
            @71 time passed
              start laser: restart 2 of laser after its backoff
            @72 laser exited with signal 9
              laser failed: laser exited with signal 9, its failure 3 within 10000 ms: beyond its restart policy
              start sonar: laser exited with signal 9, its failure 3 within 10000 ms: beyond its restart policy; sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser exited with signal 9, its failure 3 within 10000 ms: beyond its restart policy; sonar is the best provider of RangeFinder left (quality 5, cost 1)
            == state
            service laser: failed, health ok, 2 restarts, 0 clients, last failure: laser exited with signal 9, its failure 3 within 10000 ms: beyond its restart policy
            service sonar: starting since 72 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            next deadline: 5072 ms
        "#]],
    );
}

#[test]
fn the_same_events_give_the_same_decisions() {
    let events = with(
        laser_serving(),
        &[
            (20, out_of_service("laser", "x")),
            (60, tick()),
            (70, killed("laser")),
        ],
    );
    let run = || {
        let mut core = core_for(LASER_SONAR);
        events
            .iter()
            .flat_map(|(t, e)| core.handle(t * MS, e))
            .collect::<Vec<_>>()
    };
    assert_eq!(run(), run());
}

#[test]
fn a_failed_data_check_fails_the_provider_and_rebinds_at_once() {
    check(
        LASER_SONAR,
        &with(
            laser_serving(),
            &[
                (
                    20,
                    bad_data("laser", "values", "`ranges[3]` is NaN, not a finite number"),
                ),
                (21, killed("laser")),
                (30, ready("sonar")),
                // A late report about a process that is gone changes nothing.
                (31, bad_data("laser", "rate", "late")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @20 laser failed its values check on RangeFinder: `ranges[3]` is NaN, not a finite number
              laser failed: laser failed its values check on RangeFinder: `ranges[3]` is NaN, not a finite number
              stop laser: laser has failed: its process must go
              start sonar: laser failed its values check on RangeFinder: `ranges[3]` is NaN, not a finite number; sonar is the best provider of RangeFinder left (quality 5, cost 1)
              rebind app from laser to sonar for RangeFinder: laser failed its values check on RangeFinder: `ranges[3]` is NaN, not a finite number; sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @21 laser exited with signal 9
            @30 sonar ready
            @31 laser failed its rate check on RangeFinder: late
            == state
            service laser: failed, health ok, 0 restarts, 0 clients, last failure: laser failed its values check on RangeFinder: `ranges[3]` is NaN, not a finite number
            service sonar: ready, last heartbeat 30 ms, health ok, 0 restarts, 1 clients
            client app RangeFinder -> sonar
            next deadline: 80 ms
        "#]],
    );
}

#[test]
fn a_data_check_the_robot_file_degrades_keeps_the_clients() {
    let robot = LASER_SONAR
        .replacen("[broker]", "[broker]\ndata_checks = true", 1)
        .replacen(
            "[[services]]",
            "[broker.interfaces.RangeFinder]\nchecks = { on_failure = \"degraded\" }\n[[services]]",
            1,
        );
    check(
        &robot,
        &with(
            laser_serving(),
            &[
                (
                    20,
                    bad_data("laser", "frozen", "5 identical payloads in a row"),
                ),
                // Once per process; the service's own "ok" does not hide it.
                (
                    25,
                    bad_data("laser", "frozen", "5 identical payloads in a row"),
                ),
                (30, beat("laser")),
            ],
        ),
        &expect![[r#"
            @0 client app requests RangeFinder
              start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
              bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
            @5 laser ready
            @10 laser heartbeat: ok
            @20 laser failed its frozen check on RangeFinder: 5 identical payloads in a row
              laser degraded: laser failed its frozen check on RangeFinder: 5 identical payloads in a row; the robot file says to degrade it: its clients stay
            @25 laser failed its frozen check on RangeFinder: 5 identical payloads in a row
            @30 laser heartbeat: ok
            == state
            service laser: ready, last heartbeat 30 ms, health degraded (laser failed its frozen check on RangeFinder: 5 identical payloads in a row), 0 restarts, 1 clients
            service sonar: idle, health ok, 0 restarts, 0 clients
            client app RangeFinder -> laser
            next deadline: 80 ms
        "#]],
    );
}

#[test]
fn spans_read_as_a_person_reads_them() {
    use super::decision::fmt_span;
    let ms = |ms: i64| fmt_span(ms * 1_000_000);
    assert_eq!(ms(-5), "0 ms");
    assert_eq!(ms(300), "300 ms");
    assert_eq!(ms(20_000), "20 s");
    assert_eq!(ms(4_250), "4.2 s");
    assert_eq!(ms(200_000), "3 min 20 s");
}

/// Two cameras on one pan-tilt mount: camera1 is better (quality 9) but slower (10 Hz) and
/// dearer (40% of a core) than camera2 (quality 8, 30 Hz, 30%). `extra` goes under
/// `[broker]`; `camera` is added to each camera's service.
fn stereo(extra: &str, camera: &str) -> String {
    format!(
        r#"
[robot]
name = "stereo"
[broker]
heartbeat_period_ms = 10
heartbeat_deadline_ms = 50
startup_deadline_ms = 1000
restart = {{ max_restarts = 0, window_ms = 10000 }}
{extra}
[[services]]
name = "camera1"
kind = "camera"
{camera}
provides = [{{ interface = "ImageSource", quality = 9, cost = 40, data_rate_hz = 10.0 }}]
[[services]]
name = "camera2"
kind = "camera"
{camera}
provides = [{{ interface = "ImageSource", quality = 8, cost = 30, data_rate_hz = 30.0 }}]
[[services]]
name = "signs"
kind = "sign-detector"
requires = [{{ interface = "ImageSource", min_rate_hz = 20 }}]
provides = [{{ interface = "Signs", quality = 5, cost = 5 }}]
[[services]]
name = "blobs"
kind = "blob-finder"
requires = ["ImageSource"]
provides = [{{ interface = "Blobs", quality = 5, cost = 5 }}]
"#
    )
}

#[test]
fn two_clients_share_one_camera_when_a_second_would_break_the_cpu_budget() {
    check(
        &stereo("cpu_budget_percent = 50", ""),
        &[
            (0, req("blobs", "ImageSource")),
            (1, ready("camera1")),
            (2, req("signs", "ImageSource")),
        ],
        &expect![[r#"
            @0 client blobs requests ImageSource
              start camera1: blobs needs ImageSource and camera1 is its best provider (quality 9, cost 40)
              bind blobs to camera1 for ImageSource: camera1 is the best provider of ImageSource (quality 9, cost 40)
            @1 camera1 ready
            @2 client signs requests ImageSource
              bind signs to camera1 for ImageSource: camera1 is the best provider of ImageSource (quality 9, cost 40); its least rate is not kept: camera1 gives 10 Hz of ImageSource, signs asks for at least 20 Hz
            == state
            service blobs: idle, health ok, 0 restarts, 0 clients
            service camera1: ready, last heartbeat 1 ms, health ok, 0 restarts, 2 clients
            service camera2: idle, health ok, 0 restarts, 0 clients
            service signs: idle, health ok, 0 restarts, 0 clients
            client blobs ImageSource -> camera1
            client signs ImageSource -> camera1
            next deadline: 51 ms
        "#]],
    );
}

#[test]
fn a_running_camera_is_chosen_within_the_budget_until_it_is_measured_to_use_less() {
    check(
        &stereo("cpu_budget_percent = 60", ""),
        &[
            (0, restart("camera2")),
            (1, ready("camera2")),
            (2, req("blobs", "ImageSource")),
            (
                3,
                Event::CpuMeasured {
                    service: s("camera2"),
                    milli_cores: 100,
                },
            ),
            (4, req("blobs2", "ImageSource")),
        ],
        &expect![[r#"
            @0 operator restarts camera2
              start camera2: the operator restarts camera2
            @1 camera2 ready
            @2 client blobs requests ImageSource
              bind blobs to camera2 for ImageSource: camera2 for blobs: starting camera1 would take the robot to 70% of a core, beyond its budget of 60% (quality 8 against 9 of camera1)
            @3 camera2 used 10% of a core
            @4 client blobs2 requests ImageSource
              start camera1: blobs2 needs ImageSource and camera1 is its best provider (quality 9, cost 40)
              bind blobs2 to camera1 for ImageSource: camera1 is the best provider of ImageSource (quality 9, cost 40)
            == state
            service blobs: idle, health ok, 0 restarts, 0 clients
            service camera1: starting since 4 ms, health ok, 0 restarts, 1 clients
            service camera2: ready, last heartbeat 1 ms, health ok, 0 restarts, 1 clients
            service signs: idle, health ok, 0 restarts, 0 clients
            client blobs ImageSource -> camera2
            client blobs2 ImageSource -> camera1
            next deadline: 51 ms
        "#]],
    );
}

#[test]
fn a_client_that_needs_20_hz_gets_the_faster_camera_and_is_told_when_none_is_left() {
    check(
        &stereo("", ""),
        &[
            (0, req("signs", "ImageSource")),
            (1, ready("camera2")),
            (2, killed("camera2")),
        ],
        &expect![[r#"
            @0 client signs requests ImageSource
              start camera2: camera2 for signs: camera1 gives 10 Hz of ImageSource, signs asks for at least 20 Hz (quality 8 against 9 of camera1)
              bind signs to camera2 for ImageSource: camera2 for signs: camera1 gives 10 Hz of ImageSource, signs asks for at least 20 Hz (quality 8 against 9 of camera1)
            @1 camera2 ready
            @2 camera2 exited with signal 9
              camera2 failed: camera2 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
              start camera1: camera2 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy; camera1 is the best provider of ImageSource left (quality 9, cost 40); its least rate is not kept: camera1 gives 10 Hz of ImageSource, signs asks for at least 20 Hz
              rebind signs from camera2 to camera1 for ImageSource: camera2 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy; camera1 is the best provider of ImageSource left (quality 9, cost 40); its least rate is not kept: camera1 gives 10 Hz of ImageSource, signs asks for at least 20 Hz
            == state
            service blobs: idle, health ok, 0 restarts, 0 clients
            service camera1: starting since 2 ms, health ok, 0 restarts, 1 clients
            service camera2: failed, health ok, 0 restarts, 0 clients, last failure: camera2 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
            service signs: idle, health ok, 0 restarts, 0 clients
            client signs ImageSource -> camera1
            next deadline: 1002 ms
        "#]],
    );
}

#[test]
fn cameras_that_exclude_each_other_serve_one_at_a_time_and_a_failure_replans_both_clients() {
    check(
        &stereo("", "excludes = \"pan-tilt\""),
        &[
            (0, req("blobs", "ImageSource")),
            (1, ready("camera1")),
            (2, req("signs", "ImageSource")),
            (3, ready("camera2")),
            (4, beat("camera1")),
            (5, killed("camera2")),
        ],
        &expect![[r#"
            @0 client blobs requests ImageSource
              start camera1: blobs needs ImageSource and camera1 is its best provider (quality 9, cost 40)
              bind blobs to camera1 for ImageSource: camera1 is the best provider of ImageSource (quality 9, cost 40)
            @1 camera1 ready
            @2 client signs requests ImageSource
              start camera2: camera2 for blobs: camera1 and camera2 exclude each other (pan-tilt) and would serve at once (quality 8 against 9 of camera1)
              rebind blobs from camera1 to camera2 for ImageSource: camera2 for blobs: camera1 and camera2 exclude each other (pan-tilt) and would serve at once (quality 8 against 9 of camera1)
              bind signs to camera2 for ImageSource: camera2 for signs: camera1 and camera2 exclude each other (pan-tilt) and would serve at once; camera1 gives 10 Hz of ImageSource, signs asks for at least 20 Hz (quality 8 against 9 of camera1)
            @3 camera2 ready
            @4 camera1 heartbeat: ok
            @5 camera2 exited with signal 9
              camera2 failed: camera2 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
              rebind blobs from camera2 to camera1 for ImageSource: camera2 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy; camera1 is the best provider of ImageSource left (quality 9, cost 40)
              rebind signs from camera2 to camera1 for ImageSource: camera2 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy; camera1 is the best provider of ImageSource left (quality 9, cost 40); its least rate is not kept: camera1 gives 10 Hz of ImageSource, signs asks for at least 20 Hz
            == state
            service blobs: idle, health ok, 0 restarts, 0 clients
            service camera1: ready, last heartbeat 4 ms, health ok, 0 restarts, 2 clients
            service camera2: failed, health ok, 0 restarts, 0 clients, last failure: camera2 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
            service signs: idle, health ok, 0 restarts, 0 clients
            client blobs ImageSource -> camera1
            client signs ImageSource -> camera1
            next deadline: 54 ms
        "#]],
    );
}

#[test]
fn a_measurement_is_smoothed() {
    let robot = stereo("cpu_budget_percent = 60", "");
    let mut core = core_for(&robot);
    let measure = |milli_cores| Event::CpuMeasured {
        service: s("camera1"),
        milli_cores,
    };
    let mut seen = Vec::new();
    for (i, m) in [400, 0, 0, 800].into_iter().enumerate() {
        let _ = core.handle(i64::try_from(i).unwrap_or(0) * MS, &measure(m));
        seen.push(core.services["camera1"].milli_cores());
    }
    assert_eq!(seen, [400, 300, 225, 368]);
}

#[test]
fn a_recovered_camera_on_the_same_mount_takes_both_clients_back_together() {
    check(
        &stereo("fail_back = true", "excludes = \"pan-tilt\""),
        &[
            (0, req("blobs", "ImageSource")),
            (1, ready("camera1")),
            (2, killed("camera1")),
            (3, ready("camera2")),
            (4, req("blobs2", "ImageSource")),
            (5, restart("camera1")),
            (6, ready("camera1")),
        ],
        &expect![[r#"
            @0 client blobs requests ImageSource
              start camera1: blobs needs ImageSource and camera1 is its best provider (quality 9, cost 40)
              bind blobs to camera1 for ImageSource: camera1 is the best provider of ImageSource (quality 9, cost 40)
            @1 camera1 ready
            @2 camera1 exited with signal 9
              camera1 failed: camera1 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
              start camera2: camera1 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy; camera2 is the best provider of ImageSource left (quality 8, cost 30)
              rebind blobs from camera1 to camera2 for ImageSource: camera1 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy; camera2 is the best provider of ImageSource left (quality 8, cost 30)
            @3 camera2 ready
            @4 client blobs2 requests ImageSource
              bind blobs2 to camera2 for ImageSource: camera2 is the best provider of ImageSource (quality 8, cost 30)
            @5 operator restarts camera1
              start camera1: the operator restarts camera1
            @6 camera1 ready
              rebind blobs from camera2 to camera1 for ImageSource: fail back: camera1 is ready and better for ImageSource (quality 9, cost 40) than camera2 (quality 8, cost 30)
              rebind blobs2 from camera2 to camera1 for ImageSource: fail back: camera1 is ready and better for ImageSource (quality 9, cost 40) than camera2 (quality 8, cost 30)
            == state
            service blobs: idle, health ok, 0 restarts, 0 clients
            service camera1: ready, last heartbeat 6 ms, health ok, 0 restarts, 2 clients, last failure: camera1 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
            service camera2: ready, last heartbeat 3 ms, health ok, 0 restarts, 0 clients
            service signs: idle, health ok, 0 restarts, 0 clients
            client blobs ImageSource -> camera1
            client blobs2 ImageSource -> camera1
            next deadline: 53 ms
        "#]],
    );
}

#[test]
fn no_fail_back_to_a_camera_too_slow_for_one_of_the_clients_it_would_take() {
    check(
        &stereo("fail_back = true", "excludes = \"pan-tilt\""),
        &[
            (0, req("blobs", "ImageSource")),
            (1, ready("camera1")),
            (2, killed("camera1")),
            (3, ready("camera2")),
            (4, req("signs", "ImageSource")),
            (5, restart("camera1")),
            (6, ready("camera1")),
        ],
        &expect![[r#"
            @0 client blobs requests ImageSource
              start camera1: blobs needs ImageSource and camera1 is its best provider (quality 9, cost 40)
              bind blobs to camera1 for ImageSource: camera1 is the best provider of ImageSource (quality 9, cost 40)
            @1 camera1 ready
            @2 camera1 exited with signal 9
              camera1 failed: camera1 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
              start camera2: camera1 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy; camera2 is the best provider of ImageSource left (quality 8, cost 30)
              rebind blobs from camera1 to camera2 for ImageSource: camera1 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy; camera2 is the best provider of ImageSource left (quality 8, cost 30)
            @3 camera2 ready
            @4 client signs requests ImageSource
              bind signs to camera2 for ImageSource: camera2 is the best provider of ImageSource (quality 8, cost 30)
            @5 operator restarts camera1
              start camera1: the operator restarts camera1
            @6 camera1 ready
            == state
            service blobs: idle, health ok, 0 restarts, 0 clients
            service camera1: ready, last heartbeat 6 ms, health ok, 0 restarts, 0 clients, last failure: camera1 exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
            service camera2: ready, last heartbeat 3 ms, health ok, 0 restarts, 2 clients
            service signs: idle, health ok, 0 restarts, 0 clients
            client blobs ImageSource -> camera2
            client signs ImageSource -> camera2
            next deadline: 53 ms
        "#]],
    );
}

/// The laser (quality 10, always running) on the workstation, the sonar (quality 5) on the
/// robot host; clients fail back.
const TWO_HOSTS: &str = r#"
[robot]
name = "bench"
[broker]
heartbeat_period_ms = 10
heartbeat_deadline_ms = 50
startup_deadline_ms = 1000
fail_back = true
[[hosts]]
name = "robot"
listen = ["tcp/10.0.0.1:7447"]
[[hosts]]
name = "workstation"
[[services]]
name = "laser"
kind = "test-range"
host = "workstation"
start = "always"
provides = [{ interface = "RangeFinder", quality = 10, cost = 2 }]
[[services]]
name = "sonar"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 5, cost = 1 }]
"#;

#[test]
fn a_host_lost_takes_its_providers_and_they_rejoin_through_the_broker() {
    let lost = |why: &str| Event::HostLost {
        host: "workstation".to_owned(),
        why: why.to_owned(),
    };
    let joined = || Event::HostJoined {
        host: "workstation".to_owned(),
    };
    check(
        TWO_HOSTS,
        &[
            // The workstation starts lost: nobody has to say so.
            (0, Event::BrokerStarted),
            (0, req("app", "RangeFinder")),
            (5, ready("sonar")),
            (10, joined()),
            (15, ready("laser")),
            (20, beat("sonar")),
            (30, lost("silent for 50 ms")),
            (31, lost("its session closed")),
            (35, beat("sonar")),
            (60, joined()),
            (62, beat("sonar")),
            (65, ready("laser")),
        ],
        &expect![[r#"
            @0 broker started
            @0 client app requests RangeFinder
              start sonar: app needs RangeFinder and sonar is its best provider (quality 5, cost 1)
              bind app to sonar for RangeFinder: sonar is the best provider of RangeFinder (quality 5, cost 1)
            @5 sonar ready
            @10 host workstation joined
              start laser: host workstation joined and it must always run
            @15 laser ready
              rebind app from sonar to laser for RangeFinder: fail back: laser is ready and better for RangeFinder (quality 10, cost 2) than sonar (quality 5, cost 1)
            @20 sonar heartbeat: ok
            @30 host workstation lost: silent for 50 ms
              laser failed: laser runs on host workstation, which is lost: silent for 50 ms; its clients move, and it rejoins through the broker when workstation is back
              rebind app from laser to sonar for RangeFinder: laser runs on host workstation, which is lost: silent for 50 ms; sonar is the best provider of RangeFinder left (quality 5, cost 1)
            @31 host workstation lost: its session closed
            @35 sonar heartbeat: ok
            @60 host workstation joined
              start laser: host workstation joined and it must always run
            @62 sonar heartbeat: ok
            @65 laser ready
              rebind app from sonar to laser for RangeFinder: fail back: laser is ready and better for RangeFinder (quality 10, cost 2) than sonar (quality 5, cost 1)
            == state
            service laser: ready, last heartbeat 65 ms, health ok, 0 restarts, 1 clients, last failure: laser runs on host workstation, which is lost: silent for 50 ms
            service sonar: ready, last heartbeat 62 ms, health ok, 0 restarts, 0 clients
            client app RangeFinder -> laser
            next deadline: 112 ms
        "#]],
    );
}

/// The sonar renders from the base's pose (it is a client of Egomotion), as the simulated
/// sonar does; the laser is better; the base is not restarted after a crash.
const SONAR_ON_BASE: &str = r#"
[robot]
name = "bench"
[broker]
heartbeat_period_ms = 10
heartbeat_deadline_ms = 50
startup_deadline_ms = 1000
restart = { max_restarts = 0, window_ms = 10000, backoff_initial_ms = 20, backoff_max_ms = 200 }
[[services]]
name = "base"
kind = "test-range"
provides = [{ interface = "Egomotion", quality = 10, cost = 1 }]
[[services]]
name = "laser"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 10, cost = 2 }]
[[services]]
name = "sonar"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 5, cost = 1 }]
"#;

#[test]
fn a_provider_silent_for_want_of_its_input_waits_and_the_blame_goes_to_the_input() {
    let mut core = core_for(SONAR_ON_BASE);
    let events = [
        (0, req("app", "RangeFinder")),
        (5, ready("laser")),
        // The laser dies for good: the app moves to the sonar, which asks for its input.
        (10, killed("laser")),
        (11, req("sonar", "Egomotion")),
        (15, ready("base")),
        (16, ready("sonar")),
        // Then the base dies for good: the sonar falls silent and fails its rate check.
        (20, killed("base")),
        (30, beat("sonar")),
        (40, bad_data("sonar", "rate", "no data for 1 s")),
        (45, beat("sonar")),
        // A second report of the same silence says nothing new.
        (50, bad_data("sonar", "rate", "no data for 1 s")),
    ];
    let mut transcript = String::new();
    for (at_ms, event) in &events {
        for d in core.handle(at_ms * MS, event) {
            let _ = writeln!(transcript, "@{at_ms} {d}");
        }
        invariants(&core).unwrap_or_else(|e| panic!("{e}\n{transcript}"));
    }
    assert!(!core.data_is_judged("sonar"), "{transcript}");
    // The operator brings the base back: the sonar serves again, with no restart.
    for (at_ms, event) in [(60, restart("base")), (65, ready("base"))] {
        for d in core.handle(at_ms * MS, &event) {
            let _ = writeln!(transcript, "@{at_ms} {d}");
        }
    }
    assert!(core.data_is_judged("sonar"), "{transcript}");
    expect![[r#"
        @0 start laser: app needs RangeFinder and laser is its best provider (quality 10, cost 2)
        @0 bind app to laser for RangeFinder: laser is the best provider of RangeFinder (quality 10, cost 2)
        @10 laser failed: laser exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
        @10 start sonar: laser exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy; sonar is the best provider of RangeFinder left (quality 5, cost 1)
        @10 rebind app from laser to sonar for RangeFinder: laser exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy; sonar is the best provider of RangeFinder left (quality 5, cost 1)
        @11 start base: sonar needs Egomotion and base is its best provider (quality 10, cost 1)
        @11 bind sonar to base for Egomotion: base is the best provider of Egomotion (quality 10, cost 1)
        @20 base failed: base exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy
        @20 unbind sonar from base for Egomotion: no provider of Egomotion is left (base exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy)
        @20 ask for help with Egomotion: no provider of Egomotion is left (base exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy); clients wait for it
        @40 sonar waits for Egomotion: sonar's rate check failed (no data for 1 s), but it waits for Egomotion: no provider of Egomotion serves (base failed: base exited with signal 9, its failure 1 within 10000 ms: beyond its restart policy); not failed, its clients stay
        @60 start base: the operator restarts base
        @60 bind sonar to base for Egomotion: base is the best provider of Egomotion (quality 10, cost 1)
        @65 sonar resumed: sonar's input Egomotion is served again by base: its data is judged again
    "#]].assert_eq(&transcript);
    assert!(
        transcript.contains("@40 sonar waits for Egomotion:")
            && !transcript.contains("sonar failed"),
        "{transcript}"
    );
}

#[test]
fn values_out_of_range_fail_a_provider_whatever_its_inputs_do() {
    let mut core = core_for(SONAR_ON_BASE);
    for (at_ms, event) in [
        (0, req("app", "RangeFinder")),
        (1, stop("laser")),
        (11, req("sonar", "Egomotion")),
        (16, ready("sonar")),
        (20, start_failed("base", "no such program")),
    ] {
        core.handle(at_ms * MS, &event);
    }
    let decisions = core.handle(40 * MS, &bad_data("sonar", "values", "range -1 m"));
    assert!(
        decisions.iter().any(|d| d.action
            == Action::ServiceFailed {
                service: s("sonar")
            }),
        "{decisions:?}"
    );
}
