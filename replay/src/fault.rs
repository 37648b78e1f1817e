//! Fault specifications (`--inject-fault SPEC`): which provider fails, when, how, and
//! whether it recovers.
//!
//! `PROVIDER[@START[-END]][:KIND]`: `laser` (stalls half-way through the recording),
//! `laser@12.5s`, `laser@12.5s:crash`, `laser@12.5s-20s` (a window, then recovery). Times
//! are from the start of the recording, in seconds (`12.5s`, `12.5`) or milliseconds
//! (`500ms`). Kinds:
//!
//! | kind | what the provider does from START | what the broker sees |
//! |---|---|---|
//! | `stall` (default) | no data, no heartbeat | a missed heartbeat deadline |
//! | `crash` | its process exits (SIGABRT), again at every restart until END | exits, restarts, then failure |
//! | `garbage` | publishes bytes that do not decode, same sizes | its values check fails |
//! | `frozen` | publishes its last good payload again (new headers) | its frozen check fails |
//! | `slow` | drops two samples of three | its rate check fails |
//! | `out-of-service` | no data; heartbeats declare it out of service | clients moved away at once |
//! | `stuck` | its event loop sticks in one step: no data; its heartbeat thread says so, then nothing | failed at once, its process stopped |
//! | `host-lost` | a host of a robot on more than one (PROVIDER names it): none of its services is heard | its services failed, clients moved; from END it joins again |
//!
//! A `crash` or `stuck` that finds its provider between a death and the restart after it
//! strikes the restarted process at its start: there is a process to strike, only later.
//! A host is lost by naming it: `workstation@12s-20s` (the kind may be left out).
//! Heartbeats go on under `garbage`, `frozen` and `slow`: only the broker's checks of the
//! data see them (where the robot file has them on for the interface).

use std::str::FromStr;

use lewis_robot::Robot;
use serde::Serialize;

pub use lewis_service::fault::REPLAY_FAULTS;
/// How a provider fails: a fault of a service, of the one fault vocabulary; replay takes
/// the kinds of [`REPLAY_FAULTS`].
pub use lewis_service::fault::ServiceFault as FaultKind;

/// A fault as written on the command line, times relative to the recording's start.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FaultSpec {
    /// The text it was parsed from.
    pub text: String,
    /// The service that fails.
    pub provider: String,
    /// When, in nanoseconds from the start (`None`: half-way through).
    pub at_ns: Option<i64>,
    /// When it recovers, in nanoseconds from the start (`None`: never).
    pub until_ns: Option<i64>,
    /// How it fails.
    pub kind: FaultKind,
    /// Whether the kind was written (else it is the default: a stall, or a host lost).
    pub kind_given: bool,
}

/// A fault placed on the recording's clock.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Fault {
    /// The SPEC it came from.
    pub spec: String,
    /// The service that fails.
    pub provider: String,
    /// How it fails.
    pub kind: FaultKind,
    /// When it starts, on the recording's log-time clock, in nanoseconds.
    pub at_ns: i64,
    /// When it ends, on the same clock (`None`: never).
    pub until_ns: Option<i64>,
}

impl Fault {
    /// Whether the fault holds at `now_ns`.
    #[must_use]
    pub fn active_at(&self, now_ns: i64) -> bool {
        now_ns >= self.at_ns && self.until_ns.is_none_or(|end| now_ns < end)
    }
}

/// Why a fault SPEC is not valid.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FaultError {
    /// The text does not follow the syntax.
    #[error(
        "fault `{spec}`: {reason}; write PROVIDER[@START[-END]][:KIND] with KIND one of {kinds}, e.g. laser@12.5s:crash",
        kinds = REPLAY_FAULTS.names()
    )]
    Syntax {
        /// The SPEC.
        spec: String,
        /// What is wrong.
        reason: String,
    },
    /// A host named where only a service fails that way, or the robot host, which holds
    /// the broker and cannot be lost.
    #[error("fault `{spec}`: {reason}")]
    Host {
        /// The SPEC.
        spec: String,
        /// What is wrong.
        reason: String,
    },
    /// The robot has no such service.
    #[error("fault `{spec}`: the recorded robot has no service `{provider}`; it has: {known}")]
    UnknownProvider {
        /// The SPEC.
        spec: String,
        /// The name given.
        provider: String,
        /// The services it has, comma-separated.
        known: String,
    },
    /// A time falls outside the recording.
    #[error(
        "fault `{spec}`: {time} is outside the recording; choose times from 0s to {duration} (its length)"
    )]
    OutsideRecording {
        /// The SPEC.
        spec: String,
        /// The time, for people.
        time: String,
        /// The recording's length, for people.
        duration: String,
    },
    /// A time falls after the latest a mission lived again may run to.
    #[error(
        "fault `{spec}`: {time} is past the end of the replay; choose times from 0s to {latest} (the recording's {duration}, and as long again for the mission lived again to run over)"
    )]
    OutsideReplay {
        /// The SPEC.
        spec: String,
        /// The time, for people.
        time: String,
        /// The recording's length, for people.
        duration: String,
        /// The latest time a fault may take, for people.
        latest: String,
    },
}

impl FromStr for FaultSpec {
    type Err = FaultError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let syntax = |reason: &str| FaultError::Syntax {
            spec: text.to_owned(),
            reason: reason.to_owned(),
        };
        let (rest, kind, kind_given) = match text.split_once(':') {
            Some((rest, kind)) => (
                rest,
                REPLAY_FAULTS
                    .parse(kind)
                    .map_err(|unknown| {
                        syntax(&match unknown.suggestion {
                            Some(near) => format!("unknown kind `{kind}` (did you mean `{near}`?)"),
                            None => format!("unknown kind `{kind}`"),
                        })
                    })?
                    // Replay has no word for no fault: every word it takes is a kind.
                    .unwrap_or(FaultKind::Stall),
                true,
            ),
            None => (text, FaultKind::Stall, false),
        };
        let (provider, window) = match rest.split_once('@') {
            Some((provider, window)) => (provider, Some(window)),
            None => (rest, None),
        };
        if provider.is_empty()
            || !provider
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return Err(syntax("the provider must be a service or host name"));
        }
        let (at_ns, until_ns) = match window {
            None => (None, None),
            Some(window) => {
                let (start, end) = match window.split_once('-') {
                    Some((start, end)) => (start, Some(end)),
                    None => (window, None),
                };
                let time = |text: &str| {
                    lewis_stdx::parse_duration_ns(text).map_err(|e| {
                        syntax(&format!(
                            "`{text}` is not a time ({}): {}",
                            e.reason,
                            e.hint()
                        ))
                    })
                };
                let start = time(start)?;
                let end = end.map(time).transpose()?;
                if end.is_some_and(|end| end <= start) {
                    return Err(syntax("the window ends before it starts"));
                }
                (Some(start), end)
            }
        };
        Ok(Self {
            text: text.to_owned(),
            provider: provider.to_owned(),
            at_ns,
            until_ns,
            kind,
            kind_given,
        })
    }
}

impl FaultSpec {
    /// Places the fault on a recording of `robot` spanning `start_ns..=end_ns` (log time),
    /// or up to `overtime_ns` past its end: a mission lived again may run on after the
    /// recording ends (it arrives later than it did live), and a fault may fall there.
    ///
    /// # Errors
    /// When the robot has no such service or a time is outside the recording and its
    /// overtime.
    pub fn resolve(
        &self,
        robot: &Robot,
        start_ns: i64,
        end_ns: i64,
        overtime_ns: i64,
    ) -> Result<Fault, FaultError> {
        let kind = self.kind_of(robot)?;
        if kind != FaultKind::HostLost && robot.service(&self.provider).is_none() {
            return Err(FaultError::UnknownProvider {
                spec: self.text.clone(),
                provider: self.provider.clone(),
                known: robot.service_names(),
            });
        }
        let length_ns = end_ns.saturating_sub(start_ns).max(0);
        let latest_ns = length_ns.saturating_add(overtime_ns.max(0));
        let outside = |t: i64| {
            if latest_ns == length_ns {
                FaultError::OutsideRecording {
                    spec: self.text.clone(),
                    time: format_seconds(t),
                    duration: format_seconds(length_ns),
                }
            } else {
                FaultError::OutsideReplay {
                    spec: self.text.clone(),
                    time: format_seconds(t),
                    duration: format_seconds(length_ns),
                    latest: format_seconds(latest_ns),
                }
            }
        };
        let at = self.at_ns.unwrap_or(length_ns / 2);
        if at > latest_ns {
            return Err(outside(at));
        }
        if let Some(until) = self.until_ns
            && until > latest_ns
        {
            return Err(outside(until));
        }
        Ok(Fault {
            spec: self.text.clone(),
            provider: self.provider.clone(),
            kind,
            at_ns: start_ns.saturating_add(at),
            until_ns: self.until_ns.map(|u| start_ns.saturating_add(u)),
        })
    }
}

impl FaultSpec {
    /// The kind of fault on `robot`: a host's name means the host is lost.
    fn kind_of(&self, robot: &Robot) -> Result<FaultKind, FaultError> {
        let host_error = |reason: String| FaultError::Host {
            spec: self.text.clone(),
            reason,
        };
        let name = &self.provider;
        if robot.service(name).is_some() {
            if self.kind == FaultKind::HostLost {
                return Err(host_error(format!(
                    "`{name}` is a service; host-lost takes a host, one of: {}",
                    robot.host_names()
                )));
            }
            return Ok(self.kind);
        }
        if robot.host(name).is_none() {
            if self.kind != FaultKind::HostLost {
                // Neither: the caller says the robot has no such service.
                return Ok(self.kind);
            }
            let known = robot.host_names();
            return Err(host_error(if known.is_empty() {
                format!("the recorded robot has no host `{name}`: it runs on one")
            } else {
                format!("the recorded robot has no host `{name}`; its hosts are {known}")
            }));
        }
        if self.kind_given && self.kind != FaultKind::HostLost {
            return Err(host_error(format!(
                "`{name}` is a host: a host can only be lost (`{name}@12s-20s`, or `:host-lost`); {} is a service's fault",
                self.kind
            )));
        }
        if robot.robot_host().is_some_and(|h| h.name == *name) {
            return Err(host_error(format!(
                "`{name}` is the robot host, where the broker and the recorder run: it cannot be lost; name another host"
            )));
        }
        Ok(FaultKind::HostLost)
    }
}

/// A duration in seconds for people: `12.5s`.
#[must_use]
pub fn format_seconds(ns: i64) -> String {
    // For display only: the rounding of large values does not matter.
    let seconds = ns as f64 / 1e9;
    let text = format!("{seconds:.3}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    format!("{text}s")
}

#[cfg(test)]
mod tests {
    use super::*;

    type Parsed<'a> = (&'a str, Option<i64>, Option<i64>, FaultKind);

    fn check(text: &str, expected: Result<Parsed<'_>, &str>) {
        let got = text.parse::<FaultSpec>();
        match (got, expected) {
            (Ok(spec), Ok((provider, at, until, kind))) => {
                assert_eq!(
                    (spec.provider.as_str(), spec.at_ns, spec.until_ns, spec.kind),
                    (provider, at, until, kind),
                    "{text}"
                );
            }
            (Err(e), Err(part)) => assert!(e.to_string().contains(part), "{text}: {e}"),
            (got, expected) => panic!("{text}: got {got:?}, expected {expected:?}"),
        }
    }

    #[test]
    fn specs_name_a_provider_a_time_a_window_and_a_kind() {
        check("laser", Ok(("laser", None, None, FaultKind::Stall)));
        check(
            "laser@12.5s",
            Ok(("laser", Some(12_500_000_000), None, FaultKind::Stall)),
        );
        check(
            "laser@12.5s:crash",
            Ok(("laser", Some(12_500_000_000), None, FaultKind::Crash)),
        );
        check(
            "sim-laser@500ms-2s:garbage",
            Ok((
                "sim-laser",
                Some(500_000_000),
                Some(2_000_000_000),
                FaultKind::Garbage,
            )),
        );
        check(
            "laser:out-of-service",
            Ok(("laser", None, None, FaultKind::OutOfService)),
        );
    }

    #[test]
    fn malformed_specs_say_what_is_wrong_and_how_to_write_one() {
        check("laser:explode", Err("unknown kind `explode`; write"));
        check(
            "laser:crsh",
            Err("unknown kind `crsh` (did you mean `crash`?); write PROVIDER"),
        );
        check("laser@soon", Err("`soon` is not a time"));
        // Durations are written one way everywhere: with a unit.
        check(
            "laser@12.5:crash",
            Err("`12.5` is not a time (it has no unit)"),
        );
        check("laser@5s-2s", Err("ends before it starts"));
        check("@5s", Err("the provider must be a service or host name"));
        check("laser@-1s", Err("is not a time"));
        check("laser:x", Err("e.g. laser@12.5s:crash"));
    }

    #[test]
    fn resolving_checks_the_provider_and_the_recording_length() {
        let robot = lewis_robot::parse(
            "[robot]\nname = \"r\"\n[[services]]\nname = \"laser\"\nkind = \"k\"\nprovides = [{ interface = \"RangeFinder\", quality = 1, cost = 1 }]\n",
            std::path::Path::new("r.toml"),
            &["RangeFinder"],
        )
        .unwrap();
        let spec: FaultSpec = "laser".parse().unwrap();
        let fault = spec.resolve(&robot, 100, 10_000_000_100, 0).unwrap();
        assert_eq!(fault.at_ns, 5_000_000_100);
        let late: FaultSpec = "laser@12s".parse().unwrap();
        let e = late.resolve(&robot, 100, 10_000_000_100, 0).unwrap_err();
        assert_eq!(
            e.to_string(),
            "fault `laser@12s`: 12s is outside the recording; choose times from 0s to 10s (its length)"
        );
        // A mission lived again may run on past the recording's end, and a fault with it.
        let fault = late
            .resolve(&robot, 100, 10_000_000_100, 10_000_000_000)
            .unwrap();
        assert_eq!(fault.at_ns, 12_000_000_100);
        let later: FaultSpec = "laser@21s".parse().unwrap();
        let e = later
            .resolve(&robot, 100, 10_000_000_100, 10_000_000_000)
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "fault `laser@21s`: 21s is past the end of the replay; choose times from 0s to 20s (the recording's 10s, and as long again for the mission lived again to run over)"
        );
        let unknown: FaultSpec = "sonar".parse().unwrap();
        let e = unknown.resolve(&robot, 0, 1, 0).unwrap_err();
        assert!(e.to_string().contains("it has: laser"), "{e}");
        let host: FaultSpec = "workstation@0s:host-lost".parse().unwrap();
        let e = host.resolve(&robot, 0, 1, 0).unwrap_err();
        assert_eq!(
            e.to_string(),
            "fault `workstation@0s:host-lost`: the recorded robot has no host `workstation`: it runs on one"
        );
    }

    #[test]
    fn a_host_named_is_lost_and_only_lost() {
        let robot = lewis_robot::parse(
            "[robot]\nname = \"r\"\n\
             [[hosts]]\nname = \"robot\"\nlisten = [\"tcp/10.0.0.1:7447\"]\n\
             [[hosts]]\nname = \"workstation\"\n\
             [[services]]\nname = \"laser\"\nkind = \"k\"\nhost = \"workstation\"\n\
             provides = [{ interface = \"RangeFinder\", quality = 1, cost = 1 }]\n",
            std::path::Path::new("r.toml"),
            &["RangeFinder"],
        )
        .unwrap();
        let resolve = |text: &str| {
            text.parse::<FaultSpec>()
                .unwrap()
                .resolve(&robot, 0, 30_000_000_000, 0)
        };
        let lost = resolve("workstation@12s-20s").unwrap();
        assert_eq!(
            (lost.kind, lost.at_ns, lost.until_ns),
            (FaultKind::HostLost, 12_000_000_000, Some(20_000_000_000))
        );
        assert_eq!(
            resolve("workstation@1s:host-lost").unwrap().kind,
            FaultKind::HostLost
        );
        assert_eq!(resolve("laser@1s").unwrap().kind, FaultKind::Stall);
        let e = |text: &str| resolve(text).unwrap_err().to_string();
        assert!(
            e("workstation@1s:crash").contains(
                "`workstation` is a host: a host can only be lost (`workstation@12s-20s`, or `:host-lost`); crash is a service's fault"
            ),
            "{}",
            e("workstation@1s:crash")
        );
        assert!(
            e("robot@1s").contains("`robot` is the robot host, where the broker and the recorder run: it cannot be lost"),
            "{}",
            e("robot@1s")
        );
        assert!(
            e("laser@1s:host-lost").contains(
                "`laser` is a service; host-lost takes a host, one of: robot, workstation"
            ),
            "{}",
            e("laser@1s:host-lost")
        );
        assert!(
            e("moon@1s:host-lost").contains("no host `moon`; its hosts are robot, workstation"),
            "{}",
            e("moon@1s:host-lost")
        );
    }
}
