//! The joint choice of providers: every client's interface that needs a decision is
//! given its provider together with the others, so that the set as a whole keeps the
//! robot's constraints.
//!
//! Constraints (each broken one counts one):
//! - exclusion: at most one service of an `excludes` group serves clients (one pan-tilt);
//! - rate: a provider that declares a `data_rate_hz` below a client's `min_rate_hz`;
//! - budget: starting a process that takes the CPU of the running services (measured, or
//!   declared until measured) beyond the robot's `cpu_budget_percent`.
//!
//! A client that can have a provider always gets one: a broken constraint is reported in
//! the reason, never a reason to leave a client waiting.
//!
//! The search is exhaustive over the choices of the clients being decided, up to
//! [`MAX_PLANS`] combinations (a robot has a few clients with a few providers each); beyond
//! it the core decides client by client, as it did before the joint choice. Two passes:
//! - The first decides the clients that wait or whose provider cannot serve, and offers the
//!   others only their own provider or, where fail back is on, a proven strictly better one.
//!   Plans are ordered by fewest broken constraints, then highest total quality, then least
//!   CPU of the processes to start, then fewest starts (a running process is reused), then
//!   lowest declared cost, then names.
//! - Only when that plan breaks a constraint, a second pass may move clients whose provider
//!   serves, if that breaks fewer: ordered by fewest broken constraints, then fewest moves,
//!   then as the first. So a client is moved only for a reason it is told.
//!
//! With no budget, no group and no least rate, the first pass chooses what the per-client
//! rule chose (quality, then a running process, then cost, then name), except that
//! clients decided at the same time may share a process started for one of them.

use super::BrokerCore;
use super::decision::fmt_cpu;
use super::service::Entry;

/// The most combinations a pass looks at before the core decides client by client.
pub(super) const MAX_PLANS: usize = 4096;

/// One client's interface: where it is bound and what it may be given.
#[derive(Debug, Clone)]
pub(super) struct Pair {
    pub client: String,
    pub interface: String,
    pub current: Option<String>,
    /// Whether its current provider serves (it needs no decision of its own).
    pub serving: bool,
    /// What the first pass may give it (its current provider first when it serves).
    pub options: Vec<String>,
    /// What the second pass may give it (every provider that can serve).
    pub free: Vec<String>,
    pub min_rate_hz: Option<f64>,
}

/// How good a plan is, compared field by field (lower is better).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
struct Score {
    broken: usize,
    /// Only counted in the second pass.
    moves: usize,
    quality: std::cmp::Reverse<u64>,
    new_milli_cores: u64,
    starts: usize,
    cost: u64,
    names: Vec<usize>,
}

/// A constraint a plan breaks, for people.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Broken {
    /// Two or more services of a group serve clients.
    Group {
        group: String,
        services: Vec<String>,
    },
    /// A provider slower than its client needs.
    Rate {
        client: String,
        interface: String,
        service: String,
    },
    /// Starting these goes beyond the budget: the total, in thousandths of a core.
    Budget { starts: Vec<String>, total: u64 },
}

impl BrokerCore {
    /// Whether the robot file gives the joint choice anything to keep.
    pub(super) fn constrained(&self) -> bool {
        self.cpu_budget_milli_cores.is_some()
            || !self.min_rates_hz.is_empty()
            || self.services.values().any(|e| e.excludes.is_some())
    }

    /// The plan for `pairs`: one provider (or none) per pair, in the same order. `None`
    /// when there are too many combinations: the caller decides pair by pair.
    pub(super) fn plan(&self, pairs: &[Pair]) -> Option<Vec<Option<String>>> {
        let first = self.search(pairs, false)?;
        let unchanged = pairs.iter().zip(&first).all(|(p, c)| p.current == *c);
        let broken = self.broken(pairs, &first).len();
        // Clients whose provider serves are moved only when something is being decided
        // anyway (a new client, a failure, a fail back), never on a heartbeat.
        if broken == 0 || unchanged || !self.constrained() {
            return Some(first);
        }
        match self.search(pairs, true) {
            Some(second) if self.broken(pairs, &second).len() < broken => Some(second),
            _ => Some(first),
        }
    }

    fn search(&self, pairs: &[Pair], free: bool) -> Option<Vec<Option<String>>> {
        let choices: Vec<&[String]> = pairs
            .iter()
            .map(|p| {
                if free && p.serving {
                    p.free.as_slice()
                } else {
                    p.options.as_slice()
                }
            })
            .collect();
        let mut count: usize = 1;
        for c in &choices {
            count = count.checked_mul(c.len().max(1))?;
        }
        if count > MAX_PLANS {
            return None;
        }
        let mut digits = vec![0usize; pairs.len()];
        let mut best: Option<(Score, Vec<Option<String>>)> = None;
        loop {
            let plan: Vec<Option<String>> = choices
                .iter()
                .zip(&digits)
                .map(|(c, d)| c.get(*d).cloned())
                .collect();
            let score = self.score(pairs, &plan, free);
            if best.as_ref().is_none_or(|(b, _)| score < *b) {
                best = Some((score, plan));
            }
            // The next combination, as an odometer.
            let mut i = 0;
            loop {
                if i == digits.len() {
                    return best.map(|(_, plan)| plan);
                }
                digits[i] += 1;
                if digits[i] < choices[i].len() {
                    break;
                }
                digits[i] = 0;
                i += 1;
            }
        }
    }

    fn score(&self, pairs: &[Pair], plan: &[Option<String>], count_moves: bool) -> Score {
        let mut quality = 0u64;
        let mut cost = 0u64;
        let mut moves = 0;
        let mut names = Vec::with_capacity(plan.len());
        for (pair, chosen) in pairs.iter().zip(plan) {
            let Some(chosen) = chosen else { continue };
            if let Some(offer) = self
                .services
                .get(chosen)
                .and_then(|e| e.offers.get(&pair.interface))
            {
                quality += u64::from(offer.quality);
                cost += u64::from(offer.cost);
            }
            if count_moves && pair.serving && pair.current.as_ref() != Some(chosen) {
                moves += 1;
            }
            names.push(self.services.keys().position(|n| n == chosen).unwrap_or(0));
        }
        let starts = self.starts(plan);
        Score {
            broken: self.broken(pairs, plan).len(),
            moves,
            quality: std::cmp::Reverse(quality),
            new_milli_cores: starts
                .iter()
                .map(|s| u64::from(self.services.get(s).map_or(0, Entry::milli_cores)))
                .sum(),
            starts: starts.len(),
            cost,
            names,
        }
    }

    /// The services a plan starts (chosen and without a process), in name order.
    pub(super) fn starts(&self, plan: &[Option<String>]) -> Vec<String> {
        let mut starts: Vec<String> = plan
            .iter()
            .flatten()
            .filter(|s| {
                self.services
                    .get(s.as_str())
                    .is_some_and(|e| !e.is_active())
            })
            .cloned()
            .collect();
        starts.sort();
        starts.dedup();
        starts
    }

    /// The CPU of every service with a process, in thousandths of a core.
    pub(super) fn running_milli_cores(&self) -> u64 {
        self.services
            .values()
            .filter(|e| e.is_active())
            .map(|e| u64::from(e.milli_cores()))
            .sum()
    }

    /// Every constraint the plan breaks, clients not in `pairs` counted as bound where
    /// they are.
    pub(super) fn broken(&self, pairs: &[Pair], plan: &[Option<String>]) -> Vec<Broken> {
        let mut broken = Vec::new();
        // Groups: every service that serves a client after the plan.
        let mut serving: Vec<&str> = plan.iter().flatten().map(String::as_str).collect();
        for (client, bindings) in &self.clients {
            for (interface, service) in bindings {
                let decided = pairs
                    .iter()
                    .any(|p| p.client == *client && p.interface == *interface);
                if !decided && let Some(service) = service {
                    serving.push(service);
                }
            }
        }
        serving.sort_unstable();
        serving.dedup();
        let mut groups: std::collections::BTreeMap<&str, Vec<String>> =
            std::collections::BTreeMap::new();
        for service in serving {
            if let Some(group) = self
                .services
                .get(service)
                .and_then(|e| e.excludes.as_deref())
            {
                groups.entry(group).or_default().push(service.to_owned());
            }
        }
        for (group, services) in groups {
            if services.len() > 1 {
                broken.push(Broken::Group {
                    group: group.to_owned(),
                    services,
                });
            }
        }
        for (pair, chosen) in pairs.iter().zip(plan) {
            let (Some(min), Some(chosen)) = (pair.min_rate_hz, chosen) else {
                continue;
            };
            let rate = self
                .services
                .get(chosen)
                .and_then(|e| e.offers.get(&pair.interface))
                .and_then(|o| o.rate_hz);
            if rate.is_some_and(|hz| hz < min) {
                broken.push(Broken::Rate {
                    client: pair.client.clone(),
                    interface: pair.interface.clone(),
                    service: chosen.clone(),
                });
            }
        }
        if let Some(budget) = self.cpu_budget_milli_cores {
            let starts = self.starts(plan);
            let total = self.running_milli_cores()
                + starts
                    .iter()
                    .map(|s| u64::from(self.services.get(s).map_or(0, Entry::milli_cores)))
                    .sum::<u64>();
            if !starts.is_empty() && total > u64::from(budget) {
                broken.push(Broken::Budget { starts, total });
            }
        }
        broken
    }

    /// What a constraint is, for people.
    pub(super) fn describe(&self, broken: &Broken) -> String {
        match broken {
            Broken::Group { group, services } => format!(
                "{} exclude each other ({group}) and would serve at once",
                services.join(" and ")
            ),
            Broken::Rate {
                client,
                interface,
                service,
            } => {
                let min = self
                    .min_rates_hz
                    .get(&(client.clone(), interface.clone()))
                    .copied()
                    .unwrap_or(0.0);
                let rate = self
                    .services
                    .get(service)
                    .and_then(|e| e.offers.get(interface))
                    .and_then(|o| o.rate_hz)
                    .unwrap_or(0.0);
                format!(
                    "{service} gives {rate} Hz of {interface}, {client} asks for at least {min} Hz"
                )
            }
            Broken::Budget { starts, total } => format!(
                "starting {} would take the robot to {} of a core, beyond its budget of {}",
                starts.join(" and "),
                fmt_cpu(u32::try_from(*total).unwrap_or(u32::MAX)),
                fmt_cpu(self.cpu_budget_milli_cores.unwrap_or(0))
            ),
        }
    }

    /// Why `plan` gives `pairs[i]` its provider rather than `instead`: what the plan with
    /// `instead` there breaks that this one does not, or the CPU it saves.
    pub(super) fn why_not(
        &self,
        pairs: &[Pair],
        plan: &[Option<String>],
        i: usize,
        instead: &str,
    ) -> String {
        let mut other = plan.to_vec();
        other[i] = Some(instead.to_owned());
        let kept = self.broken(pairs, plan);
        let new: Vec<String> = self
            .broken(pairs, &other)
            .into_iter()
            .filter(|b| !kept.contains(b))
            .map(|b| self.describe(&b))
            .collect();
        if !new.is_empty() {
            return new.join("; ");
        }
        let cpu = |p: &[Option<String>]| -> u64 {
            self.starts(p)
                .iter()
                .map(|s| u64::from(self.services.get(s).map_or(0, Entry::milli_cores)))
                .sum()
        };
        let saved = cpu(&other).saturating_sub(cpu(plan));
        if saved > 0 {
            format!(
                "saves {} CPU",
                fmt_cpu(u32::try_from(saved).unwrap_or(u32::MAX))
            )
        } else {
            "it serves other clients chosen with it".to_owned()
        }
    }
}
