//! Who serves whom: clients' requests, the choice of providers, rebinding, fail back and
//! asking for help.

use std::cmp::Reverse;
use std::collections::BTreeSet;

use super::service::{AfterStop, Entry, Offer, ServiceState};
use super::{Action, BrokerCore, Health, Need};

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
    /// back where configured, and asks for help where nothing is left. Clients in name
    /// order, then interfaces in name order.
    pub(super) fn reconcile(&mut self) {
        let pairs: Vec<(String, String, Option<String>)> = self
            .clients
            .iter()
            .flat_map(|(client, bindings)| {
                bindings.iter().map(move |(interface, service)| {
                    (client.clone(), interface.clone(), service.clone())
                })
            })
            .collect();
        for (client, interface, current) in pairs {
            let serving = current
                .as_ref()
                .filter(|s| self.services.get(s.as_str()).is_some_and(Entry::serves));
            if let Some(current) = serving {
                self.maybe_fail_back(&client, &interface, current);
            } else {
                self.replace(&client, &interface, current.as_deref());
            }
        }
        let waiting: BTreeSet<&String> = self
            .clients
            .values()
            .flat_map(|b| b.iter().filter(|(_, s)| s.is_none()).map(|(i, _)| i))
            .collect();
        self.help_asked.retain(|i| waiting.contains(i));
    }

    pub(super) fn maybe_fail_back(&mut self, client: &str, interface: &str, current: &str) {
        if !self.fail_back_for(interface) {
            return;
        }
        let Some(current_offer) = self
            .services
            .get(current)
            .and_then(|e| e.offers.get(interface).copied())
        else {
            return;
        };
        let Some((best, offer)) = self.best(client, interface, Entry::proven) else {
            return;
        };
        let better = offer.quality > current_offer.quality
            || (offer.quality == current_offer.quality && offer.cost < current_offer.cost);
        if better {
            self.set_binding(client, interface, Some(&best));
            self.decide(
                Action::Rebind {
                    client: client.to_owned(),
                    interface: interface.to_owned(),
                    from: current.to_owned(),
                    to: best.clone(),
                },
                format!(
                    "fail back: {best} is ready and better for {interface} (quality {}, cost {}) than {current} (quality {}, cost {})",
                    offer.quality, offer.cost, current_offer.quality, current_offer.cost
                ),
            );
        }
    }

    /// Gives a client whose provider is missing or cannot serve the best provider left.
    pub(super) fn replace(&mut self, client: &str, interface: &str, current: Option<&str>) {
        let why = current.map(|s| self.why_unavailable(s));
        match self.best(client, interface, Entry::can_serve) {
            Some((best, offer)) => {
                let idle = self
                    .services
                    .get(&best)
                    .is_some_and(|e| e.state == ServiceState::Idle);
                let scores = format!("quality {}, cost {}", offer.quality, offer.cost);
                let choice = match &why {
                    Some(why) => {
                        format!("{why}; {best} is the best provider of {interface} left ({scores})")
                    }
                    None => format!("{best} is the best provider of {interface} ({scores})"),
                };
                if idle {
                    let reason = match &why {
                        Some(_) => choice.clone(),
                        None => format!(
                            "{client} needs {interface} and {best} is its best provider ({scores})"
                        ),
                    };
                    self.start(&best, reason);
                }
                self.set_binding(client, interface, Some(&best));
                self.help_asked.remove(interface);
                match current {
                    Some(from) => self.decide(
                        Action::Rebind {
                            client: client.to_owned(),
                            interface: interface.to_owned(),
                            from: from.to_owned(),
                            to: best,
                        },
                        choice,
                    ),
                    _ => self.decide(
                        Action::Bind {
                            client: client.to_owned(),
                            interface: interface.to_owned(),
                            service: best,
                        },
                        choice,
                    ),
                }
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
