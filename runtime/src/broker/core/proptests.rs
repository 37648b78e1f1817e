//! Random event sequences: the core never panics, keeps its invariants, starts only
//! services without a process, stops only services with one, and decides the same way
//! every time.

use std::collections::{BTreeMap, BTreeSet};

use proptest::prelude::*;

use super::tests::{core_for, invariants};
use super::*;
use lewis_service::Health;
use service::Entry;

const MS: i64 = 1_000_000;

/// Four services over five interfaces: on demand, hot standby and always; small restart
/// limits so that every path (restart, give up, retry) is reached by short sequences.
fn robot(fail_back: bool, retry: bool) -> String {
    let retry = if retry {
        "retry_failed_after_ms = 300\n"
    } else {
        ""
    };
    format!(
        r#"
[robot]
name = "random"
[broker]
heartbeat_period_ms = 10
heartbeat_deadline_ms = 50
startup_deadline_ms = 200
fail_back = {fail_back}
{retry}restart = {{ max_restarts = 2, window_ms = 1000, backoff_initial_ms = 0, backoff_max_ms = 40 }}
[[services]]
name = "laser"
kind = "test-range"
provides = [
    {{ interface = "RangeFinder", quality = 10, cost = 2 }},
    {{ interface = "Distance", quality = 10, cost = 2 }},
]
[[services]]
name = "sonar"
kind = "test-range"
start = "standby"
provides = [
    {{ interface = "RangeFinder", quality = 5, cost = 1 }},
    {{ interface = "Distance", quality = 5, cost = 1 }},
]
[[services]]
name = "base"
kind = "rflex"
start = "always"
restart = {{ max_restarts = 1, window_ms = 500 }}
provides = [
    {{ interface = "Synchrodrive", quality = 5, cost = 3 }},
    {{ interface = "Power", quality = 5, cost = 3 }},
    {{ interface = "RangeFinder", quality = 5, cost = 3 }},
]
[[services]]
name = "avoider"
kind = "obstacle-avoider"
requires = ["RangeFinder"]
provides = [{{ interface = "Mover", quality = 5, cost = 1 }}]
"#
    )
}

const SERVICES: &[&str] = &["laser", "sonar", "base", "avoider", "ghost"];
const CLIENTS: &[&str] = &["app", "mapper", "avoider", "laser", ""];
const INTERFACES: &[&str] = &["RangeFinder", "Distance", "Power", "Mover", "Signs", "Nope"];

fn name(list: &'static [&'static str]) -> impl Strategy<Value = String> {
    proptest::sample::select(list).prop_map(str::to_owned)
}

fn health() -> impl Strategy<Value = Health> {
    prop_oneof![
        3 => Just(Health::Ok),
        1 => ".{0,8}".prop_map(Health::Degraded),
        1 => ".{0,8}".prop_map(Health::OutOfService),
    ]
}

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        1 => Just(Event::BrokerStarted),
        3 => (name(CLIENTS), name(INTERFACES))
            .prop_map(|(client, interface)| Event::ClientRequest { client, interface }),
        1 => name(CLIENTS).prop_map(|client| Event::ClientGone { client }),
        1 => name(SERVICES).prop_map(|service| Event::ProviderStarted { service }),
        2 => name(SERVICES).prop_map(|service| Event::ProviderReady { service }),
        4 => (name(SERVICES), health()).prop_map(|(service, health)| Event::Heartbeat { service, health }),
        1 => (name(SERVICES), ".{0,8}").prop_map(|(service, why)| Event::LoopStuck { service, why }),
        2 => (name(SERVICES), any::<i32>(), any::<bool>()).prop_map(|(service, n, signal)| {
            let status = if signal { ExitStatus::Signal(n) } else { ExitStatus::Code(n) };
            Event::ProcessExited { service, status }
        }),
        1 => (name(SERVICES), ".{0,8}").prop_map(|(service, error)| Event::StartFailed { service, error }),
        2 => Just(Event::TimePassed),
        1 => name(SERVICES).prop_map(|service| Event::StopService { service }),
        1 => name(SERVICES).prop_map(|service| Event::RestartService { service }),
        1 => (name(SERVICES), name(INTERFACES), name(&["rate", "values", "frozen"]), ".{0,8}")
            .prop_map(|(service, interface, check, reason)| Event::DataCheckFailed {
                service,
                interface,
                check,
                reason,
            }),
    ]
}

/// Time steps: mostly forward by up to 120 ms, sometimes anything (backwards, huge).
fn step() -> impl Strategy<Value = i64> {
    prop_oneof![
        12 => (0i64..120).prop_map(|ms| ms * MS),
        1 => any::<i64>(),
    ]
}

fn has_process(core: &BrokerCore) -> BTreeMap<String, bool> {
    core.services
        .iter()
        .map(|(name, e)| (name.clone(), e.has_process()))
        .collect()
}

/// Which process the event says has ended, if the core believes it exists.
fn ended(core: &BrokerCore, event: &Event) -> Option<String> {
    let (Event::ProcessExited { service, .. } | Event::StartFailed { service, .. }) = event else {
        return None;
    };
    let entry = core.services.get(service)?;
    let ends = match event {
        Event::StartFailed { .. } => matches!(entry.state, ServiceState::Starting { .. }),
        _ => entry.has_process(),
    };
    ends.then(|| service.clone())
}

/// Handles one event, checking that every `Start` is for a service without a process and
/// every `Stop` for one with a process, and that the result agrees with the core's state.
///
/// Within an hour of the end of time, deadlines saturate at `i64::MAX` and fall due as soon
/// as they are set, even before the event: there only the invariants are checked.
fn handle_checked(
    core: &mut BrokerCore,
    now_ns: i64,
    event: &Event,
) -> Result<Vec<Decision>, TestCaseError> {
    if now_ns > i64::MAX - 3_600_000 * MS {
        let decisions = core.handle(now_ns, event);
        if let Err(broken) = invariants(core) {
            return Err(TestCaseError::fail(format!("after {event}: {broken}")));
        }
        return Ok(decisions);
    }
    let mut alive = has_process(core);
    if let Some(service) = ended(core, event) {
        alive.insert(service, false);
    }
    let decisions = core.handle(now_ns, event);
    for d in &decisions {
        match &d.action {
            Action::Start { service } => {
                prop_assert!(
                    !alive[service],
                    "start of {service} which has a process: {d}"
                );
                alive.insert(service.clone(), true);
            }
            Action::Stop { service } => {
                prop_assert!(
                    alive[service],
                    "stop of {service} which has no process: {d}"
                );
            }
            _ => {}
        }
        prop_assert_eq!(d.at_ns, now_ns);
    }
    prop_assert_eq!(
        &alive,
        &has_process(core),
        "after {} with {:?}",
        event,
        decisions
    );
    if let Err(broken) = invariants(core) {
        return Err(TestCaseError::fail(format!("after {event}: {broken}")));
    }
    Ok(decisions)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn random_event_sequences_keep_the_invariants_and_replay_identically(
        fail_back in any::<bool>(),
        retry in any::<bool>(),
        events in prop::collection::vec((step(), event()), 0..80),
    ) {
        let text = robot(fail_back, retry);
        let mut core = core_for(&text);
        let mut replay = core_for(&text);
        let mut now_ns = 0i64;
        for (step, event) in &events {
            now_ns = now_ns.saturating_add(*step);
            // Deadlines first, on their own, so that the event's effect on processes is
            // seen before the decisions that follow it.
            let mut decisions = handle_checked(&mut core, now_ns, &Event::TimePassed)?;
            decisions.extend(handle_checked(&mut core, now_ns, event)?);
            let mut again = replay.handle(now_ns, &Event::TimePassed);
            again.extend(replay.handle(now_ns, event));
            prop_assert_eq!(decisions, again);
            if let Some(deadline) = core.next_deadline() {
                // A deadline is never left behind: it is after the time just handled,
                // unless time itself is at its end.
                prop_assert!(deadline > now_ns || now_ns == i64::MAX, "deadline {deadline} at {now_ns}");
            }
        }
        prop_assert_eq!(core.snapshot(), replay.snapshot());
    }
}

/// A random stereo head: four cameras with random quality, cost, rate, group and start
/// mode, and three clients (services that start only with the broker, which these
/// sequences never start) with random least rates.
/// A camera: quality, cost, data rate, group, and whether it is a hot standby.
type Camera = (u32, u32, Option<u32>, Option<&'static str>, bool);

#[derive(Debug, Clone)]
struct Joint {
    cameras: Vec<Camera>,
    rates: Vec<Option<u32>>,
}

fn joint() -> impl Strategy<Value = Joint> {
    let camera = (
        0u32..10,
        0u32..60,
        prop::option::of(5u32..40),
        prop::option::of(prop::sample::select(&["mount", "usb"][..])),
        any::<bool>(),
    );
    (
        prop::collection::vec(camera, 4),
        prop::collection::vec(prop::option::of(5u32..40), 3),
    )
        .prop_map(|(cameras, rates)| Joint { cameras, rates })
}

impl Joint {
    fn toml(&self) -> String {
        let mut text = String::from(
            "[robot]\nname = \"joint\"\n[broker]\nheartbeat_period_ms = 10\nheartbeat_deadline_ms = 50\nrestart = { max_restarts = 0, window_ms = 1000 }\n",
        );
        for (i, (quality, cost, rate, group, standby)) in self.cameras.iter().enumerate() {
            let rate = rate.map_or_else(String::new, |hz| format!(", data_rate_hz = {hz}.0"));
            let group = group.map_or_else(String::new, |g| format!("excludes = \"{g}\"\n"));
            let start = if *standby { "standby" } else { "on-demand" };
            text += &format!(
                "[[services]]\nname = \"camera{i}\"\nkind = \"camera\"\nstart = \"{start}\"\n{group}provides = [{{ interface = \"ImageSource\", quality = {quality}, cost = {cost}{rate} }}]\n"
            );
        }
        for (i, rate) in self.rates.iter().enumerate() {
            let need = rate.map_or_else(
                || "\"ImageSource\"".to_owned(),
                |hz| format!("{{ interface = \"ImageSource\", min_rate_hz = {hz} }}"),
            );
            text += &format!(
                "[[services]]\nname = \"client{i}\"\nkind = \"blob-finder\"\nstart = \"always\"\nrequires = [{need}]\n"
            );
        }
        text
    }
}

const CAMERAS: &[&str] = &["camera0", "camera1", "camera2", "camera3"];

fn joint_event() -> impl Strategy<Value = Event> {
    prop_oneof![
        3 => name(&["client0", "client1", "client2"]).prop_map(|client| Event::ClientRequest {
            client,
            interface: "ImageSource".to_owned(),
        }),
        1 => name(&["client0", "client1", "client2"]).prop_map(|client| Event::ClientGone { client }),
        2 => name(CAMERAS).prop_map(|service| Event::ProviderReady { service }),
        1 => name(CAMERAS).prop_map(|service| Event::ProcessExited {
            service,
            status: ExitStatus::Signal(9),
        }),
        1 => name(CAMERAS).prop_map(|service| Event::RestartService { service }),
        1 => name(CAMERAS).prop_map(|service| Event::LoopStuck {
            service,
            why: "its event loop is busy".to_owned(),
        }),
        1 => (name(CAMERAS), 0u32..800).prop_map(|(service, milli_cores)| Event::CpuMeasured {
            service,
            milli_cores,
        }),
        1 => Just(Event::BrokerStarted),
    ]
}

/// The groups and least rates the bindings break, counted as the planner counts them,
/// written again here so that the test does not take the planner's word for it.
fn broken_groups_and_rates(core: &BrokerCore, bindings: &[(String, Option<String>)]) -> usize {
    let mut serving: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    let mut broken = 0;
    for (client, service) in bindings {
        let Some(service) = service else { continue };
        let entry = &core.services[service];
        if let Some(group) = &entry.excludes {
            serving.entry(group).or_default().insert(service);
        }
        let need = core
            .min_rates_hz
            .get(&(client.clone(), "ImageSource".to_owned()));
        let rate = entry.offers["ImageSource"].rate_hz;
        if let (Some(need), Some(rate)) = (need, rate)
            && rate < *need
        {
            broken += 1;
        }
    }
    broken + serving.values().map(|s| s.len() - 1).sum::<usize>()
}

/// Whether some choice of serving providers for these clients breaks no group and no rate.
fn feasible(core: &BrokerCore, clients: &[String]) -> bool {
    let options: Vec<Vec<Option<String>>> = clients
        .iter()
        .map(|client| {
            let can: Vec<Option<String>> = core
                .services
                .iter()
                .filter(|(n, e)| {
                    *n != client && e.can_serve() && e.offers.contains_key("ImageSource")
                })
                .map(|(n, _)| Some(n.clone()))
                .collect();
            if can.is_empty() { vec![None] } else { can }
        })
        .collect();
    let mut digits = vec![0usize; clients.len()];
    loop {
        let bindings: Vec<(String, Option<String>)> = clients
            .iter()
            .zip(&digits)
            .zip(&options)
            .map(|((c, d), o)| (c.clone(), o[*d].clone()))
            .collect();
        if broken_groups_and_rates(core, &bindings) == 0 {
            return true;
        }
        let mut i = 0;
        loop {
            if i == digits.len() {
                return false;
            }
            digits[i] += 1;
            if digits[i] < options[i].len() {
                break;
            }
            digits[i] = 0;
            i += 1;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// When the broker binds or moves a client, the set it chose breaks no exclusion group
    /// and no least rate if some set of serving providers breaks none; and it never moves a
    /// client whose provider still serves without saying why (a fail back, or the
    /// constraint the move keeps).
    #[test]
    fn the_joint_choice_keeps_every_constraint_a_feasible_set_keeps(
        robot in joint(),
        events in prop::collection::vec(((0i64..40).prop_map(|ms| ms * MS), joint_event()), 0..40),
    ) {
        let mut core = core_for(&robot.toml());
        let mut now_ns = 0;
        for (step, event) in &events {
            now_ns += step;
            let decisions = core.handle(now_ns, event);
            if let Err(broken) = invariants(&core) {
                return Err(TestCaseError::fail(format!("after {event}: {broken}")));
            }
            let bindings: Vec<(String, Option<String>)> = core
                .clients
                .iter()
                .filter_map(|(c, b)| b.get("ImageSource").map(|s| (c.clone(), s.clone())))
                .collect();
            let decided = decisions.iter().any(|d| match &d.action {
                Action::Rebind { .. } => true,
                Action::Bind { .. } => !d.reason.starts_with("repeated request"),
                _ => false,
            });
            if decided {
                let clients: Vec<String> = bindings.iter().map(|(c, _)| c.clone()).collect();
                let broken = broken_groups_and_rates(&core, &bindings);
                prop_assert!(
                    broken == 0 || !feasible(&core, &clients),
                    "after {event}: {broken} constraints broken by {bindings:?} though a set keeps them all ({decisions:?})"
                );
            }
            for d in &decisions {
                if let Action::Rebind { client, from, to, .. } = &d.action
                    && core.services.get(from).is_some_and(Entry::serves)
                {
                    prop_assert!(
                        d.reason.starts_with("fail back:")
                            || d.reason.starts_with(&format!("{to} for {client}: ")),
                        "{client} moved from {from}, which serves, without a reason: {d}"
                    );
                }
            }
        }
    }
}
