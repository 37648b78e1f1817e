//! Who serves whom: clients' requests, the choice of providers, rebinding, fail back and
//! asking for help.

use std::cmp::Reverse;
use std::collections::BTreeSet;

use super::plan::{Broken, Pair};
use super::service::{AfterStop, Entry, Offer, ServiceState};
use super::{Action, BrokerCore, Need};
use lewis_service::Health;

impl BrokerCore {
    pub(super) fn request(&mut self, client: &str, interface: &str) {
        let provided = self
            .services
            .iter()
            .any(|(name, e)| name != client && e.offers.contains_key(interface));
        if !provided {
            self.decide(
                Action::Reject {
                    client: client.to_owned(),
                    interface: interface.to_owned(),
                },
                format!("no service of this robot provides {interface} to {client}"),
            );
            return;
        }
        let bindings = self.clients.entry(client.to_owned()).or_default();
        match bindings.get(interface) {
            Some(Some(service)) => {
                let service = service.clone();
                self.decide(
                    Action::Bind {
                        client: client.to_owned(),
                        interface: interface.to_owned(),
                        service,
                    },
                    "repeated request: the binding is unchanged".to_owned(),
                );
            }
            // Still waiting: help has been asked already.
            Some(None) => {}
            None => {
                bindings.insert(interface.to_owned(), None);
            }
        }
    }

    pub(super) fn client_gone(&mut self, client: &str) {
        let Some(bindings) = self.clients.remove(client) else {
            return;
        };
        for (interface, service) in bindings {
            if let Some(service) = service {
                self.decide(
                    Action::Unbind {
                        client: client.to_owned(),
                        interface,
                        service,
                    },
                    format!("client {client} is gone"),
                );
            }
        }
    }

    pub(super) fn fail_back_for(&self, interface: &str) -> bool {
        self.fail_back
            .get(interface)
            .copied()
            .unwrap_or(self.fail_back_default)
    }

    /// The best provider of `interface` for `client` among those `eligible` says may be
    /// chosen: quality, then an already running process, then cost, then name.
    pub(super) fn best(
        &self,
        client: &str,
        interface: &str,
        eligible: fn(&Entry) -> bool,
    ) -> Option<(String, Offer)> {
        self.services
            .iter()
            .filter(|(name, e)| name.as_str() != client && eligible(e))
            .filter_map(|(name, e)| e.offers.get(interface).map(|offer| (name, e, *offer)))
            .min_by_key(|(name, e, offer)| {
                (Reverse(offer.quality), !e.is_active(), offer.cost, *name)
            })
            .map(|(name, _, offer)| (name.clone(), offer))
    }

    /// Why a service cannot serve, for people.
    pub(super) fn why_unavailable(&self, service: &str) -> String {
        let Some(entry) = self.services.get(service) else {
            return format!("{service} is unknown");
        };
        match (&entry.state, &entry.health) {
            (
                ServiceState::Failed { .. }
                | ServiceState::Stopping {
                    then: AfterStop::Failed { .. },
                },
                _,
            ) => entry
                .last_failure
                .clone()
                .unwrap_or_else(|| format!("{service} failed")),
            (
                ServiceState::Stopped
                | ServiceState::Stopping {
                    then: AfterStop::Stopped,
                },
                _,
            ) => format!("{service} was stopped by the operator"),
            (_, Health::OutOfService(why)) => format!("{service} is out of service ({why})"),
            _ => format!("{service} cannot serve"),
        }
    }

    /// Binds every waiting client, moves every client whose provider cannot serve, fails
    /// back where configured, and asks for help where nothing is left: jointly
    /// ([`plan`](super::plan)), or client by client when there are too many combinations.
    /// Decisions come in client name order, then interfaces in name order.
    pub(super) fn reconcile(&mut self) {
        let pairs = self.pairs();
        if pairs.iter().any(|p| !p.serving || p.options.len() > 1) {
            match self.plan(&pairs) {
                Some(plan) => self.carry_out_plan(&pairs, &plan),
                None => self.reconcile_one_by_one(&pairs),
            }
        }
        let waiting: BTreeSet<&String> = self
            .clients
            .values()
            .flat_map(|b| b.iter().filter(|(_, s)| s.is_none()).map(|(i, _)| i))
            .collect();
        self.help_asked.retain(|i| waiting.contains(i));
    }

    /// Every client's interface, with what the planner may give it.
    fn pairs(&self) -> Vec<Pair> {
        let mut pairs = Vec::new();
        // Only a constrained robot's second pass gives a serving client another provider:
        // otherwise the list is not made (this runs at every heartbeat).
        let constrained = self.constrained();
        for (client, bindings) in &self.clients {
            for (interface, current) in bindings {
                let serving = current
                    .as_ref()
                    .filter(|s| self.services.get(s.as_str()).is_some_and(Entry::serves));
                let can: Vec<String> = if serving.is_none() || constrained {
                    self.services
                        .iter()
                        .filter(|(name, e)| {
                            *name != client && e.can_serve() && e.offers.contains_key(interface)
                        })
                        .map(|(name, _)| name.clone())
                        .collect()
                } else {
                    Vec::new()
                };
                let (options, free) = match serving {
                    Some(current) => {
                        let mut options = vec![current.clone()];
                        options.extend(self.fail_back_options(client, interface, current));
                        let mut free = vec![current.clone()];
                        free.extend(can.into_iter().filter(|s| s != current));
                        (options, free)
                    }
                    None => (can.clone(), can),
                };
                pairs.push(Pair {
                    client: client.clone(),
                    interface: interface.clone(),
                    current: current.clone(),
                    serving: serving.is_some(),
                    options,
                    free,
                    min_rate_hz: self
                        .min_rates_hz
                        .get(&(client.clone(), interface.clone()))
                        .copied(),
                });
            }
        }
        pairs
    }

    /// The proven providers a client of `interface` on `current` may fail back to: strictly
    /// better (higher quality, or equal quality and lower cost), where fail back is on.
    fn fail_back_options(&self, client: &str, interface: &str, current: &str) -> Vec<String> {
        if !self.fail_back_for(interface) {
            return Vec::new();
        }
        let Some(now) = self
            .services
            .get(current)
            .and_then(|e| e.offers.get(interface).copied())
        else {
            return Vec::new();
        };
        self.services
            .iter()
            .filter(|(name, e)| name.as_str() != client && e.proven())
            .filter_map(|(name, e)| e.offers.get(interface).map(|o| (name, *o)))
            .filter(|(_, o)| better(o, &now))
            .map(|(name, _)| name.clone())
            .collect()
    }

    /// What the core did before the joint choice: each client on its own.
    fn reconcile_one_by_one(&mut self, pairs: &[Pair]) {
        for pair in pairs {
            match (&pair.current, pair.serving) {
                (Some(current), true) => {
                    self.maybe_fail_back(&pair.client, &pair.interface, current);
                }
                _ => self.replace(&pair.client, &pair.interface, pair.current.as_deref()),
            }
        }
    }

    /// Carries out a plan, pair by pair. The reasons that compare the plan with another
    /// choice are found first, on the state before the plan.
    fn carry_out_plan(&mut self, pairs: &[Pair], plan: &[Option<String>]) {
        let constrained = self.constrained();
        let broken = if constrained {
            self.broken(pairs, plan)
        } else {
            Vec::new()
        };
        let mut notes: Vec<Option<String>> = Vec::with_capacity(pairs.len());
        for (i, (pair, chosen)) in pairs.iter().zip(plan).enumerate() {
            let note = match (chosen, &pair.current) {
                (Some(chosen), Some(current)) if pair.serving && chosen != current => {
                    Some(self.why_not(pairs, plan, i, current))
                }
                (Some(chosen), _) if !pair.serving => self
                    .best(&pair.client, &pair.interface, Entry::can_serve)
                    .filter(|(greedy, _)| greedy != chosen)
                    .map(|(greedy, _)| self.why_not(pairs, plan, i, &greedy)),
                _ => None,
            };
            notes.push(note);
        }
        for ((pair, chosen), note) in pairs.iter().zip(plan).zip(notes) {
            let Some(chosen) = chosen else {
                if !pair.serving {
                    self.replace(&pair.client, &pair.interface, pair.current.as_deref());
                }
                continue;
            };
            let shortfall = broken
                .iter()
                .find(|b| {
                    matches!(b, Broken::Rate { client, interface, .. }
                        if *client == pair.client && *interface == pair.interface)
                })
                .map(|b| self.describe(b));
            match &pair.current {
                Some(current) if pair.serving => {
                    if current == chosen {
                        continue;
                    }
                    let fail_back = self.fail_back_for(&pair.interface)
                        && self.services.get(chosen).is_some_and(Entry::proven)
                        && self.offer(chosen, &pair.interface).is_some_and(|o| {
                            self.offer(current, &pair.interface)
                                .is_some_and(|now| better(&o, &now))
                        });
                    if fail_back {
                        self.fail_back_to(&pair.client, &pair.interface, current, chosen);
                    } else {
                        let why = note.unwrap_or_default();
                        self.move_for_constraint(pair, current, chosen, &why);
                    }
                }
                _ => {
                    let greedy = self
                        .best(&pair.client, &pair.interface, Entry::can_serve)
                        .map(|(name, _)| name);
                    let note = match (greedy.as_deref() == Some(chosen.as_str()), note) {
                        (true, _) | (false, None) => None,
                        (false, Some(why)) => greedy.map(|g| (g, why)),
                    };
                    self.bind_chosen(pair, chosen, note.as_ref(), shortfall.as_deref());
                }
            }
        }
    }

    fn offer(&self, service: &str, interface: &str) -> Option<Offer> {
        self.services
            .get(service)
            .and_then(|e| e.offers.get(interface).copied())
    }

    /// Moves a client whose provider serves, because the plan keeps a constraint that way.
    fn move_for_constraint(&mut self, pair: &Pair, from: &str, to: &str, why: &str) {
        let (q_to, q_from) = (
            self.offer(to, &pair.interface).map_or(0, |o| o.quality),
            self.offer(from, &pair.interface).map_or(0, |o| o.quality),
        );
        let reason = format!(
            "{to} for {}: {why} (quality {q_to} against {q_from} of {from})",
            pair.client
        );
        if self.services.get(to).is_some_and(|e| !e.is_active()) {
            self.start(to, reason.clone());
        }
        self.set_binding(&pair.client, &pair.interface, Some(to));
        self.decide(
            Action::Rebind {
                client: pair.client.clone(),
                interface: pair.interface.clone(),
                from: from.to_owned(),
                to: to.to_owned(),
            },
            reason,
        );
    }

    pub(super) fn maybe_fail_back(&mut self, client: &str, interface: &str, current: &str) {
        if !self.fail_back_for(interface) {
            return;
        }
        let Some(current_offer) = self.offer(current, interface) else {
            return;
        };
        let Some((best, offer)) = self.best(client, interface, Entry::proven) else {
            return;
        };
        if better(&offer, &current_offer) {
            self.fail_back_to(client, interface, current, &best);
        }
    }

    fn fail_back_to(&mut self, client: &str, interface: &str, current: &str, best: &str) {
        let (Some(offer), Some(current_offer)) =
            (self.offer(best, interface), self.offer(current, interface))
        else {
            return;
        };
        self.set_binding(client, interface, Some(best));
        self.decide(
            Action::Rebind {
                client: client.to_owned(),
                interface: interface.to_owned(),
                from: current.to_owned(),
                to: best.to_owned(),
            },
            format!(
                "fail back: {best} is ready and better for {interface} (quality {}, cost {}) than {current} (quality {}, cost {})",
                offer.quality, offer.cost, current_offer.quality, current_offer.cost
            ),
        );
    }

    /// Gives a client whose provider is missing or cannot serve the best provider left.
    pub(super) fn replace(&mut self, client: &str, interface: &str, current: Option<&str>) {
        match self.best(client, interface, Entry::can_serve) {
            Some((best, _)) => {
                let pair = Pair {
                    client: client.to_owned(),
                    interface: interface.to_owned(),
                    current: current.map(str::to_owned),
                    serving: false,
                    options: Vec::new(),
                    free: Vec::new(),
                    min_rate_hz: None,
                };
                self.bind_chosen(&pair, &best, None, None);
            }
            None => {
                let providers: Vec<String> = self
                    .services
                    .iter()
                    .filter(|(name, e)| name.as_str() != client && e.offers.contains_key(interface))
                    .map(|(name, _)| self.why_unavailable(name))
                    .collect();
                let left = format!(
                    "no provider of {interface} is left ({})",
                    providers.join("; ")
                );
                if let Some(from) = current {
                    self.set_binding(client, interface, None);
                    self.decide(
                        Action::Unbind {
                            client: client.to_owned(),
                            interface: interface.to_owned(),
                            service: from.to_owned(),
                        },
                        left.clone(),
                    );
                }
                if self.help_asked.insert(interface.to_owned()) {
                    self.decide(
                        Action::AskForHelp {
                            need: Need::Interface(interface.to_owned()),
                        },
                        format!("{left}; clients wait for it"),
                    );
                }
            }
        }
    }

    /// Binds a client that waits or whose provider cannot serve to `chosen`, starting it
    /// if needed. `instead`: the provider the client would have had on its own and why the
    /// joint choice gave it another; `shortfall`: a least rate the choice does not meet.
    fn bind_chosen(
        &mut self,
        pair: &Pair,
        chosen: &str,
        instead: Option<&(String, String)>,
        shortfall: Option<&str>,
    ) {
        let (client, interface) = (pair.client.as_str(), pair.interface.as_str());
        let current = pair.current.as_deref();
        let Some(offer) = self.offer(chosen, interface) else {
            return;
        };
        let why = current.map(|s| self.why_unavailable(s));
        let idle = self
            .services
            .get(chosen)
            .is_some_and(|e| e.state == ServiceState::Idle);
        let scores = format!("quality {}, cost {}", offer.quality, offer.cost);
        let mut choice = match (&why, instead) {
            (_, Some((other, because))) => {
                let theirs = self.offer(other, interface).map_or(0, |o| o.quality);
                let joint = format!(
                    "{chosen} for {client}: {because} (quality {} against {theirs} of {other})",
                    offer.quality
                );
                match &why {
                    Some(why) => format!("{why}; {joint}"),
                    None => joint,
                }
            }
            (Some(why), None) => {
                format!("{why}; {chosen} is the best provider of {interface} left ({scores})")
            }
            (None, None) => format!("{chosen} is the best provider of {interface} ({scores})"),
        };
        if let Some(shortfall) = shortfall {
            choice = format!("{choice}; its least rate is not kept: {shortfall}");
        }
        if idle {
            let reason = match (&why, instead) {
                (None, None) => {
                    let mut reason = format!(
                        "{client} needs {interface} and {chosen} is its best provider ({scores})"
                    );
                    if let Some(shortfall) = shortfall {
                        reason = format!("{reason}; its least rate is not kept: {shortfall}");
                    }
                    reason
                }
                _ => choice.clone(),
            };
            self.start(chosen, reason);
        }
        self.set_binding(client, interface, Some(chosen));
        self.help_asked.remove(interface);
        match current {
            Some(from) => self.decide(
                Action::Rebind {
                    client: client.to_owned(),
                    interface: interface.to_owned(),
                    from: from.to_owned(),
                    to: chosen.to_owned(),
                },
                choice,
            ),
            _ => self.decide(
                Action::Bind {
                    client: client.to_owned(),
                    interface: interface.to_owned(),
                    service: chosen.to_owned(),
                },
                choice,
            ),
        }
    }

    pub(super) fn set_binding(&mut self, client: &str, interface: &str, service: Option<&str>) {
        if let Some(slot) = self
            .clients
            .get_mut(client)
            .and_then(|b| b.get_mut(interface))
        {
            *slot = service.map(str::to_owned);
        }
    }
}

/// Whether a client is better off on `offer` than on `now`: higher quality, or equal
/// quality and lower cost (the rule of fail back).
fn better(offer: &Offer, now: &Offer) -> bool {
    offer.quality > now.quality || (offer.quality == now.quality && offer.cost < now.cost)
}
