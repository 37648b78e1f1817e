//! From the written description to a [`Robot`]: every semantic check, each problem placed
//! at the value it is about. All problems are collected, not only the first.

use std::collections::{BTreeMap, BTreeSet};
use std::ops::Range;
use std::path::Path;

use toml::Spanned;

use lewis_stdx::Diagnostic;

use super::error::{RobotError, line_column};
use super::raw::{
    RawBroker, RawChecks, RawProvision, RawRequirement, RawRequirementTable, RawRobot, RawService,
};
use super::{
    BrokerSettings, DEFAULT_HEARTBEAT_PRIORITY, DataChecks, Kinds, Known, Launch, MIN_FROZEN_COUNT,
    Provision, RetryPolicy, Robot, SCORE_RANGE, ServiceSpec, StartMode,
};
use crate::RestartPolicy;

pub(super) const DEFAULT_HEARTBEAT_PERIOD_MS: u64 = 20;
pub(super) const DEFAULT_HEARTBEAT_DEADLINE_MS: u64 = 100;
pub(super) const DEFAULT_STARTUP_DEADLINE_MS: u64 = 5_000;

/// The largest CPU budget a robot file may give, in percent of one core: 64 cores.
const MAX_CPU_BUDGET_PERCENT: u32 = 6_400;

/// Names (robot, service, kind) become parts of IPC names and file names.
const MAX_NAME_LEN: usize = 64;

pub(super) fn parse(text: &str, origin: &Path, known: Known<'_>) -> Result<Robot, RobotError> {
    let mut checker = Checker {
        text,
        origin,
        known: known.interfaces.iter().copied().collect(),
        kinds: known.kinds,
        problems: Vec::new(),
    };
    let raw: RawRobot = match toml::from_str(text) {
        Ok(raw) => raw,
        Err(error) => {
            let span = error.span().unwrap_or(0..0);
            checker.report(&span, error.message().trim_end().trim_end_matches('.'));
            return Err(checker.into_error());
        }
    };
    let robot = checker.robot(raw);
    if checker.problems.is_empty() {
        Ok(robot)
    } else {
        Err(checker.into_error())
    }
}

pub(super) struct Checker<'a> {
    pub(super) text: &'a str,
    pub(super) origin: &'a Path,
    known: BTreeSet<&'a str>,
    kinds: Option<&'a dyn Kinds>,
    problems: Vec<(usize, Diagnostic)>,
}

impl Checker<'_> {
    pub(super) fn report(&mut self, span: &Range<usize>, message: impl Into<String>) {
        self.problems.push((
            span.start,
            Diagnostic::plain_at_offset(self.origin, self.text, span.start, message),
        ));
    }

    fn into_error(mut self) -> RobotError {
        // Stable: problems at one place keep the order in which they were found.
        self.problems.sort_by_key(|(offset, _)| *offset);
        RobotError::Invalid {
            path: self.origin.to_path_buf(),
            problems: self.problems.into_iter().map(|(_, p)| p).collect(),
        }
    }

    fn robot(&mut self, raw: RawRobot) -> Robot {
        let header = raw.robot;
        self.identifier(&header.name, "robot name");
        let broker = self.broker(raw.broker);
        let mut services = Vec::with_capacity(raw.services.len());
        let mut requirement_spans = Vec::with_capacity(raw.services.len());
        let mut seen: BTreeMap<String, usize> = BTreeMap::new();
        let host_spans: Vec<Option<Range<usize>>> = raw
            .services
            .iter()
            .map(|s| s.host.as_ref().map(Spanned::span))
            .collect();
        for service in raw.services {
            let name = service.name.clone();
            if let Some(first_line) = seen.get(name.get_ref()) {
                let message = format!(
                    "duplicate service name `{}` (first declared on line {first_line}): give each service its own name",
                    name.get_ref()
                );
                self.report(&name.span(), message);
            } else {
                let (line, _) = line_column(self.text, name.span().start);
                seen.insert(name.get_ref().clone(), line);
            }
            let (spec, spans) = self.service(service, &broker);
            services.push(spec);
            requirement_spans.push(spans);
        }
        self.requirements(&services, &requirement_spans);
        let first_encrypted = super::hosts::first_encrypted_endpoint(&raw.hosts);
        let hosts = self.hosts(raw.hosts);
        self.service_hosts(&services, &hosts, &host_spans);
        let network = self.network(raw.network, &broker, &hosts, first_encrypted.as_ref());
        Robot {
            name: header.name.into_inner(),
            description: header.description,
            broker,
            services,
            hosts,
            network,
        }
    }

    fn broker(&mut self, raw: RawBroker) -> BrokerSettings {
        let retry = self.retry(&raw);
        let heartbeat_period_ms = raw
            .heartbeat_period_ms
            .and_then(|v| self.positive_ms(&v, "heartbeat_period_ms"))
            .unwrap_or(DEFAULT_HEARTBEAT_PERIOD_MS);
        let heartbeat_deadline_ms = match &raw.heartbeat_deadline_ms {
            Some(deadline) => self.deadline(deadline, heartbeat_period_ms),
            None => None,
        }
        .unwrap_or(DEFAULT_HEARTBEAT_DEADLINE_MS);
        let startup_deadline_ms = raw
            .startup_deadline_ms
            .and_then(|v| self.positive_ms(&v, "startup_deadline_ms"))
            .unwrap_or(DEFAULT_STARTUP_DEADLINE_MS);
        let restart = match raw.restart {
            Some(policy) => self.restart_policy(&policy),
            None => RestartPolicy::default(),
        };
        let mut fail_back_per_interface = BTreeMap::new();
        let mut checks_per_interface = BTreeMap::new();
        for (interface, settings) in raw.interfaces {
            self.interface_name(&interface, "broker settings for");
            if let Some(fail_back) = settings.fail_back {
                fail_back_per_interface.insert(interface.get_ref().clone(), fail_back);
            }
            if let Some(checks) = settings.checks {
                let base = DataChecks::default_for(interface.get_ref());
                let checks = self.checks(base, interface.get_ref(), checks.get_ref());
                checks_per_interface.insert(interface.into_inner(), checks);
            }
        }
        let cpu_budget_percent = raw.cpu_budget_percent.and_then(|budget| {
            match u32::try_from(*budget.get_ref()) {
                Ok(percent) if (1..=MAX_CPU_BUDGET_PERCENT).contains(&percent) => Some(percent),
                _ => {
                    self.report(
                        &budget.span(),
                        format!(
                            "cpu_budget_percent is {}: give the CPU the robot's services may use together, in percent of one core (1 to {MAX_CPU_BUDGET_PERCENT}; 150 is one and a half cores)",
                            budget.get_ref()
                        ),
                    );
                    None
                }
            }
        });
        BrokerSettings {
            cpu_budget_percent,
            heartbeat_period_ms,
            heartbeat_deadline_ms,
            startup_deadline_ms,
            fail_back: raw.fail_back,
            fail_back_per_interface,
            restart,
            retry,
            data_checks: raw.data_checks.unwrap_or(false),
            checks_per_interface,
            nice: raw.nice.and_then(|nice| self.nice(&nice)),
            keep_cores_awake: raw.keep_cores_awake.unwrap_or(false),
            heartbeat_priority: raw
                .heartbeat_priority
                .map_or(Some(DEFAULT_HEARTBEAT_PRIORITY), |p| {
                    self.heartbeat_priority(&p)
                })
                .unwrap_or(DEFAULT_HEARTBEAT_PRIORITY),
        }
    }

    /// A nice value, -20 to 19.
    fn nice(&mut self, value: &Spanned<i64>) -> Option<i32> {
        match i32::try_from(*value.get_ref()) {
            Ok(nice) if (-20..=19).contains(&nice) => Some(nice),
            _ => {
                self.report(
                    &value.span(),
                    format!(
                        "nice {} is out of range: nice values run from -20 (first) to 19 (last)",
                        value.get_ref()
                    ),
                );
                None
            }
        }
    }

    /// A `SCHED_FIFO` priority for the heartbeat threads, 1 to 99, or 0 for none.
    fn heartbeat_priority(&mut self, value: &Spanned<i64>) -> Option<u8> {
        match u8::try_from(*value.get_ref()) {
            Ok(priority) if priority <= 99 => Some(priority),
            _ => {
                self.report(
                    &value.span(),
                    format!(
                        "heartbeat_priority {} is out of range: real-time priorities run from 1 \
                         (lowest) to 99, and 0 leaves heartbeats to the normal scheduler",
                        value.get_ref()
                    ),
                );
                None
            }
        }
    }

    /// The retry of failed services: none unless the file gives its first cool-down.
    fn retry(&mut self, raw: &RawBroker) -> Option<RetryPolicy> {
        let max_ms = raw
            .retry_failed_max_ms
            .as_ref()
            .map(|v| (v, self.positive_ms(v, "retry_failed_max_ms")));
        let probation_ms = raw
            .retry_probation_ms
            .as_ref()
            .map(|v| self.positive_ms(v, "retry_probation_ms"));
        let Some(after) = &raw.retry_failed_after_ms else {
            for (key, value) in [
                ("retry_failed_max_ms", &raw.retry_failed_max_ms),
                ("retry_probation_ms", &raw.retry_probation_ms),
            ] {
                if let Some(value) = value {
                    self.report(
                        &value.span(),
                        format!("{key} means nothing without retry_failed_after_ms, the first cool-down: give it too, or remove {key}"),
                    );
                }
            }
            return None;
        };
        let after_ms = self.positive_ms(after, "retry_failed_after_ms")?;
        let max_ms = match max_ms {
            None => after_ms.saturating_mul(RetryPolicy::DEFAULT_MAX_FACTOR),
            Some((_, None)) => return None,
            Some((value, Some(max_ms))) if max_ms < after_ms => {
                self.report(
                    &value.span(),
                    format!("retry_failed_max_ms {max_ms} is shorter than retry_failed_after_ms {after_ms}: the longest cool-down cannot be shorter than the first"),
                );
                return None;
            }
            Some((_, Some(max_ms))) => max_ms,
        };
        let probation_ms = match probation_ms {
            None => RetryPolicy::DEFAULT_PROBATION_MS,
            Some(ms) => ms?,
        };
        Some(RetryPolicy {
            after_ms,
            max_ms,
            probation_ms,
        })
    }

    /// An interface's data checks: its defaults with the file's overrides, each checked.
    /// `base` with the file's overrides `raw` of `interface`'s checks, each checked.
    fn checks(&mut self, base: DataChecks, interface: &str, raw: &RawChecks) -> DataChecks {
        let mut checks = base;
        if let Some(rate) = &raw.rate {
            let fraction = *rate.get_ref();
            if (0.0..=1.0).contains(&fraction) {
                checks.min_rate_fraction = fraction;
            } else {
                self.report(
                    &rate.span(),
                    format!(
                        "checks of `{interface}`: rate {fraction} is not a fraction of the declared data_rate_hz: give a value from 0 (off) to 1"
                    ),
                );
            }
        }
        if let Some(window) = &raw.window_ms
            && let Some(ms) =
                self.positive_ms(window, &format!("checks of `{interface}`: window_ms"))
        {
            checks.window_ms = ms;
        }
        if let Some(freshness) = &raw.freshness_ms {
            match u64::try_from(*freshness.get_ref()) {
                Ok(0) => checks.freshness_ms = None,
                Ok(ms) => checks.freshness_ms = Some(ms),
                Err(_) => self.report(
                    &freshness.span(),
                    format!(
                        "checks of `{interface}`: freshness_ms is {}: give how old a sample may be in milliseconds, or 0 (off)",
                        freshness.get_ref()
                    ),
                ),
            }
        }
        if let Some(values) = raw.values {
            checks.values = values;
        }
        if let Some(frozen) = &raw.frozen {
            match u32::try_from(*frozen.get_ref()) {
                Ok(0) => checks.frozen_count = None,
                Ok(count) if count >= MIN_FROZEN_COUNT => checks.frozen_count = Some(count),
                _ => self.report(
                    &frozen.span(),
                    format!(
                        "checks of `{interface}`: frozen is {}: give how many identical payloads in a row make a frozen stream (at least {MIN_FROZEN_COUNT}), or 0 (off)",
                        frozen.get_ref()
                    ),
                ),
            }
        }
        if let Some(on_failure) = raw.on_failure {
            checks.on_failure = on_failure;
        }
        checks
    }

    /// The service, and the places of its required interfaces.
    fn service(
        &mut self,
        raw: RawService,
        broker: &BrokerSettings,
    ) -> (ServiceSpec, Vec<Range<usize>>) {
        let name = raw.name.get_ref().clone();
        self.identifier(&raw.name, "service name");
        let launch = self.launch(&name, &raw.name.span(), raw.kind, raw.command);
        let parameters = raw.parameters.map_or_else(
            || (0..0, toml::Table::new()),
            |p| (p.span(), p.into_inner()),
        );
        if let Launch::Kind(kind) = &launch {
            self.parameters_fit(&name, kind, &parameters.0, &parameters.1);
        }

        let mut provides = Vec::with_capacity(raw.provides.len());
        let mut provided: BTreeSet<String> = BTreeSet::new();
        for provision in raw.provides {
            let interface = provision.get_ref().interface.clone();
            if !provided.insert(interface.get_ref().clone()) {
                self.report(
                    &interface.span(),
                    format!(
                        "service `{name}` provides `{}` twice: keep one entry",
                        interface.get_ref()
                    ),
                );
            }
            provides.push(self.provision(&name, provision.into_inner(), broker));
        }
        let mut requires = Vec::with_capacity(raw.requires.len());
        let mut min_rates_hz = BTreeMap::new();
        let mut required: BTreeSet<String> = BTreeSet::new();
        for requirement in &raw.requires {
            let interface = Spanned::new(
                requirement.span(),
                requirement.get_ref().interface().to_owned(),
            );
            self.interface_name(&interface, &format!("service `{name}` requires"));
            if !required.insert(interface.get_ref().clone()) {
                self.report(
                    &interface.span(),
                    format!(
                        "service `{name}` requires `{}` twice: keep one entry",
                        interface.get_ref()
                    ),
                );
            }
            if let RawRequirement::Table(RawRequirementTable {
                min_rate_hz: Some(hz),
                ..
            }) = requirement.get_ref()
            {
                if hz.is_finite() && *hz > 0.0 && *hz <= 1e6 {
                    min_rates_hz.insert(interface.get_ref().clone(), *hz);
                } else {
                    self.report(
                        &requirement.span(),
                        format!(
                            "min_rate_hz {hz} of `{}` in service `{name}` is out of range: give a rate above 0 and at most 1000000",
                            interface.get_ref()
                        ),
                    );
                }
            }
            requires.push(interface.into_inner());
        }
        let excludes = raw.excludes.map(|group| {
            self.identifier(&group, &format!("service `{name}` excludes group"));
            group.into_inner()
        });
        if provides.is_empty() && raw.start == StartMode::OnDemand {
            self.report(
                &raw.name.span(),
                format!(
                    "service `{name}` provides no interface and starts on demand, so nothing would ever start it: add `provides` or set `start = \"always\"`"
                ),
            );
        }

        let restart = match raw.restart {
            Some(policy) => self.restart_policy(&policy),
            None => broker.restart,
        };
        let heartbeat_deadline_ms = match &raw.heartbeat_deadline_ms {
            Some(deadline) => self.deadline(deadline, broker.heartbeat_period_ms),
            None => None,
        }
        .unwrap_or(broker.heartbeat_deadline_ms);
        let startup_deadline_ms = raw
            .startup_deadline_ms
            .and_then(|v| self.positive_ms(&v, "startup_deadline_ms"))
            .unwrap_or(broker.startup_deadline_ms);
        let mut environment = BTreeMap::new();
        for (key, value) in raw.environment {
            if key.get_ref().is_empty() || key.get_ref().contains(['=', '\0']) {
                self.report(
                    &key.span(),
                    format!(
                        "environment variable name `{}` of service `{name}` is empty or contains `=` or a NUL byte",
                        key.get_ref().escape_debug()
                    ),
                );
            }
            if value.get_ref().contains('\0') {
                self.report(
                    &value.span(),
                    format!(
                        "environment variable `{}` of service `{name}` contains a NUL byte",
                        key.get_ref().escape_debug()
                    ),
                );
            }
            environment.insert(key.into_inner(), value.into_inner());
        }
        let requirement_spans = raw.requires.iter().map(Spanned::span).collect();
        let spec = ServiceSpec {
            name,
            description: raw.description,
            launch,
            parameters: parameters.1,
            provides,
            requires,
            min_rates_hz,
            excludes,
            restart,
            heartbeat_deadline_ms,
            startup_deadline_ms,
            start: raw.start,
            environment,
            host: raw.host.map(Spanned::into_inner),
        };
        (spec, requirement_spans)
    }

    fn launch(
        &mut self,
        name: &str,
        name_span: &Range<usize>,
        kind: Option<Spanned<String>>,
        command: Option<Spanned<Vec<Spanned<String>>>>,
    ) -> Launch {
        match (kind, command) {
            (Some(kind), Some(command)) => {
                self.report(
                    &command.span(),
                    format!(
                        "service `{name}` has both `kind` and `command`: give one (a built-in kind, or a command line)"
                    ),
                );
                Launch::Kind(kind.into_inner())
            }
            (None, None) => {
                self.report(
                    name_span,
                    format!(
                        "service `{name}` says neither `kind` (a built-in service) nor `command` (a command line): give one"
                    ),
                );
                Launch::Command(Vec::new())
            }
            (Some(kind), None) => {
                if self.identifier(&kind, "service kind") {
                    self.known_kind(name, &kind);
                }
                Launch::Kind(kind.into_inner())
            }
            (None, Some(command)) => {
                let span = command.span();
                let argv = command.into_inner();
                match argv.first() {
                    None => self.report(
                        &span,
                        format!("the command of service `{name}` is empty: give the program and its arguments"),
                    ),
                    Some(program) if program.get_ref().trim().is_empty() => self.report(
                        &program.span(),
                        format!("the command of service `{name}` has an empty program: give the program's path or name first"),
                    ),
                    Some(_) => {}
                }
                for arg in &argv {
                    if arg.get_ref().contains('\0') {
                        self.report(
                            &arg.span(),
                            format!(
                                "an argument of service `{name}`'s command contains a NUL byte"
                            ),
                        );
                    }
                }
                Launch::Command(argv.into_iter().map(Spanned::into_inner).collect())
            }
        }
    }

    /// A kind the binary knows, or a problem with the closest known one.
    fn known_kind(&mut self, service: &str, kind: &Spanned<String>) {
        let Some(kinds) = self.kinds else { return };
        let names = kinds.kind_names();
        if names.contains(&kind.get_ref().as_str()) {
            return;
        }
        let hint = match lewis_stdx::closest(kind.get_ref(), names.iter().copied()) {
            Some(near) => format!("did you mean `{near}`?"),
            None => format!("known kinds: {}", names.join(", ")),
        };
        self.report(
            &kind.span(),
            format!(
                "service `{service}` has kind `{}`, which this lewis does not know: {hint}",
                kind.get_ref()
            ),
        );
    }

    /// The parameters of a known kind, checked by its own parameter type. The problem is
    /// placed at the parameter it names when the file has it, else at the table.
    fn parameters_fit(
        &mut self,
        service: &str,
        kind: &str,
        span: &Range<usize>,
        parameters: &toml::Table,
    ) {
        let Some(kinds) = self.kinds else { return };
        let Some(Err(reason)) = kinds.check_parameters(kind, parameters) else {
            return;
        };
        let place = parameters
            .keys()
            .filter(|key| reason.contains(&format!("`{key}`")))
            .find_map(|key| key_offset(self.text, span, key))
            .map_or_else(|| span.clone(), |offset| offset..offset);
        self.report(
            &place,
            format!("parameters of service `{service}` (kind `{kind}`): {reason}"),
        );
    }

    fn provision(
        &mut self,
        service: &str,
        raw: RawProvision,
        broker: &BrokerSettings,
    ) -> Provision {
        self.interface_name(&raw.interface, &format!("service `{service}` provides"));
        let quality = self.score(&raw.quality, "quality", service);
        let cost = self.score(&raw.cost, "cost", service);
        let data_rate_hz = raw.data_rate_hz.map(|rate| {
            let hz = *rate.get_ref();
            if !(hz.is_finite() && hz > 0.0 && hz <= 1e6) {
                self.report(
                    &rate.span(),
                    format!(
                        "data_rate_hz {hz} of `{}` in service `{service}` is out of range: give a rate above 0 and at most 1000000",
                        raw.interface.get_ref()
                    ),
                );
            }
            hz
        });
        // Over the interface's checks as the robot file gives them, field by field.
        let checks = raw.checks.map(|c| {
            let base = broker.interface_checks(raw.interface.get_ref());
            self.checks(base, raw.interface.get_ref(), c.get_ref())
        });
        Provision {
            interface: raw.interface.into_inner(),
            quality,
            cost,
            data_rate_hz,
            checks,
        }
    }

    fn score(&mut self, value: &Spanned<i64>, what: &str, service: &str) -> u32 {
        let v = *value.get_ref();
        if SCORE_RANGE.contains(&v) {
            u32::try_from(v).unwrap_or(0)
        } else {
            self.report(
                &value.span(),
                format!(
                    "{what} {v} in service `{service}` is out of range: give a value from {} to {}",
                    SCORE_RANGE.start(),
                    SCORE_RANGE.end()
                ),
            );
            0
        }
    }

    fn restart_policy(&mut self, policy: &Spanned<RestartPolicy>) -> RestartPolicy {
        let p = *policy.get_ref();
        if p.window_ms == 0 {
            self.report(
                &policy.span(),
                "restart window_ms is 0: give the window over which restarts are counted, in milliseconds",
            );
        }
        if p.backoff_initial_ms > p.backoff_max_ms {
            self.report(
                &policy.span(),
                format!(
                    "restart backoff_initial_ms {} is above backoff_max_ms {}: the first delay cannot exceed the cap",
                    p.backoff_initial_ms, p.backoff_max_ms
                ),
            );
        }
        p
    }

    /// The value in milliseconds when given and positive; `None` (and a problem) when not positive.
    pub(super) fn positive_ms(&mut self, value: &Spanned<i64>, what: &str) -> Option<u64> {
        match u64::try_from(*value.get_ref()) {
            Ok(ms) if ms > 0 => Some(ms),
            _ => {
                self.report(
                    &value.span(),
                    format!(
                        "{what} is {}: give a positive number of milliseconds",
                        value.get_ref()
                    ),
                );
                None
            }
        }
    }

    /// A heartbeat deadline: positive and longer than the heartbeat period.
    fn deadline(&mut self, deadline: &Spanned<i64>, period_ms: u64) -> Option<u64> {
        let deadline_ms = self.positive_ms(deadline, "heartbeat_deadline_ms")?;
        if deadline_ms <= period_ms {
            self.report(
                &deadline.span(),
                format!(
                    "heartbeat_deadline_ms {deadline_ms} is not longer than the heartbeat period {period_ms} ms, so every service would be seen as stalled: give a deadline of a few periods"
                ),
            );
            return None;
        }
        Some(deadline_ms)
    }

    /// Whether `name` is a valid name; a problem when it is not.
    pub(super) fn identifier(&mut self, name: &Spanned<String>, what: &str) -> bool {
        let n = name.get_ref();
        let valid = n.len() <= MAX_NAME_LEN
            && n.starts_with(|c: char| c.is_ascii_alphabetic())
            && n.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
        if !valid {
            self.report(
                &name.span(),
                format!(
                    "{what} `{}` is not a valid name: use a letter then letters, digits, `-` or `_`, at most {MAX_NAME_LEN} characters",
                    n.escape_debug()
                ),
            );
        }
        valid
    }

    fn interface_name(&mut self, name: &Spanned<String>, context: &str) {
        if !self.known.contains(name.get_ref().as_str()) {
            let known: Vec<&str> = self.known.iter().copied().collect();
            self.report(
                &name.span(),
                format!(
                    "{context} unknown interface `{}`: known interfaces are {}",
                    name.get_ref().escape_debug(),
                    known.join(", ")
                ),
            );
        }
    }

    /// Every required interface must be provided by another service: a service that
    /// provides what it requires (an obstacle avoider that is a Mover and drives through a
    /// Mover) is never bound to itself.
    fn requirements(&mut self, services: &[ServiceSpec], spans: &[Vec<Range<usize>>]) {
        for (service, spans) in services.iter().zip(spans) {
            let mut checked = BTreeSet::new();
            for (interface, span) in service.requires.iter().zip(spans) {
                if !self.known.contains(interface.as_str()) || !checked.insert(interface) {
                    continue; // already reported: unknown, or required twice
                }
                let provided_elsewhere = services.iter().any(|other| {
                    other.name != service.name && other.provision(interface).is_some()
                });
                if !provided_elsewhere {
                    self.report(
                        span,
                        format!(
                            "service `{}` requires `{interface}` but no other service provides it: add a provider or remove the requirement",
                            service.name
                        ),
                    );
                }
            }
        }
    }
}

/// Where `key = ...` is in the parameters table that starts at `span`: within an inline
/// table, or on a line of a `[...parameters]` table before the next table header.
fn key_offset(text: &str, span: &Range<usize>, key: &str) -> Option<usize> {
    let rest = text.get(span.start..)?;
    let mut offset = span.start;
    for (i, line) in rest.split_inclusive('\n').enumerate() {
        if i > 0 && line.trim_start().starts_with('[') {
            return None;
        }
        let mut from = 0;
        while let Some(found) = line[from..].find(key) {
            let at = from + found;
            let before_ok = line[..at]
                .chars()
                .next_back()
                .is_none_or(|c| c.is_whitespace() || c == '{' || c == ',');
            let after = &line[at + key.len()..];
            if before_ok && after.trim_start().starts_with('=') {
                return Some(offset + at);
            }
            from = at + key.len();
        }
        offset += line.len();
    }
    None
}
