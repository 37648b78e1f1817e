//! Blame that follows the cause: a provider that falls silent because an input of its own
//! has no provider (the simulated sonar renders from the base's true pose; a blob finder
//! reads the camera) is not failed for that silence. It waits for its input: its clients
//! keep it, its process runs, its data is not judged, and the decision names the root
//! cause, following the chain of inputs (`blobfinder3d` waits for Blobs, `blobfinder` for
//! ImageSource, `camera` failed: ...). When the input is served again, so is it, with no
//! restart. Failing it would turn one fault into two, and retrying it could not help.
//!
//! Only silence is forgiven this way (the rate and freshness checks): values out of range
//! or a frozen stream are the provider's own, whatever its inputs do.

use super::BrokerCore;
use super::decision::Action;
use super::service::ServiceState;

/// The checks that a provider fails by falling silent.
const SILENCE_CHECKS: [&str; 2] = ["rate", "freshness"];

/// How deep a chain of inputs is followed for its root cause: deeper than any robot's, and
/// a bound on a cycle of services that are each other's inputs.
const MAX_CHAIN: usize = 8;

impl BrokerCore {
    /// Whether a failed `check` of `service`'s data (it `saw` this) is the silence of a service waiting
    /// for its input; if so, it is marked waiting (the decision said once) and must not
    /// be failed.
    pub(super) fn waits_for_input(&mut self, service: &str, check: &str, saw: &str) -> bool {
        if !SILENCE_CHECKS.contains(&check) {
            return false;
        }
        let Some((interface, root)) = self.missing_input(service, MAX_CHAIN) else {
            return false;
        };
        let Some(entry) = self.services.get_mut(service) else {
            return false;
        };
        if entry.waiting_for.is_none() {
            entry.waiting_for = Some(interface.clone());
            self.decide(
                Action::ServiceWaiting {
                    service: service.to_owned(),
                    interface: interface.clone(),
                },
                format!(
                    "{service}'s {check} check failed ({saw}), but it waits for {interface}: \
                     {root}; not failed, its clients stay"
                ),
            );
        }
        true
    }

    /// Ends the wait of every waiting service whose inputs are all served again (its data
    /// is judged again from now), and forgets the wait of one whose process has gone.
    pub(super) fn update_waiting(&mut self) {
        let waiting: Vec<(String, String)> = self
            .services
            .iter()
            .filter_map(|(name, e)| Some((name.clone(), e.waiting_for.clone()?)))
            .collect();
        for (service, interface) in waiting {
            let running = self.services.get(&service).is_some_and(|e| {
                matches!(
                    e.state,
                    ServiceState::Starting { .. } | ServiceState::Ready { .. }
                )
            });
            if !running {
                if let Some(entry) = self.services.get_mut(&service) {
                    entry.waiting_for = None;
                }
                continue;
            }
            if self.missing_input(&service, MAX_CHAIN).is_some() {
                continue;
            }
            let provider = self
                .clients
                .get(&service)
                .and_then(|b| b.get(&interface).cloned().flatten())
                .unwrap_or_default();
            if let Some(entry) = self.services.get_mut(&service) {
                entry.waiting_for = None;
            }
            self.decide(
                Action::ServiceResumed {
                    service: service.clone(),
                },
                format!(
                    "{service}'s input {interface} is served again by {provider}: \
                     its data is judged again"
                ),
            );
        }
    }

    /// The first of `service`'s own inputs (it is a client of them under its name) that no
    /// provider serves, with the root cause in words; `None` when every input is served.
    fn missing_input(&self, service: &str, depth: usize) -> Option<(String, String)> {
        let inputs = self.clients.get(service)?;
        inputs.iter().find_map(|(interface, provider)| {
            let root = match provider {
                None => self.why_no_provider(interface),
                Some(provider) => self.why_not_serving(provider, depth)?,
            };
            Some((interface.clone(), root))
        })
    }

    /// Why `provider`, bound as an input, does not serve now; `None` when it does.
    fn why_not_serving(&self, provider: &str, depth: usize) -> Option<String> {
        let entry = self.services.get(provider)?;
        if entry.ready_to_serve() {
            // Serving, unless it waits for an input itself: then that is the root.
            let upstream = entry.waiting_for.as_ref()?;
            let root = match depth.checked_sub(1) {
                Some(depth) => self
                    .missing_input(provider, depth)
                    .map_or_else(|| "its input is back".to_owned(), |(_, root)| root),
                None => "a cycle of inputs".to_owned(),
            };
            return Some(format!("{provider} waits for {upstream}: {root}"));
        }
        Some(match &entry.last_failure {
            Some(why) => format!("{provider} is {}: {why}", entry.state),
            None => format!("{provider} is {}", entry.state),
        })
    }

    /// Why no provider serves `interface`: its providers' last failures, in name order.
    fn why_no_provider(&self, interface: &str) -> String {
        let failures: Vec<String> = self
            .services
            .iter()
            .filter(|(_, e)| e.offers.contains_key(interface))
            .map(|(name, e)| match &e.last_failure {
                Some(why) => format!("{name} failed: {why}"),
                None => format!("{name} is {}", e.state),
            })
            .collect();
        if failures.is_empty() {
            format!("no service provides {interface}")
        } else {
            format!(
                "no provider of {interface} serves ({})",
                failures.join("; ")
            )
        }
    }
}
