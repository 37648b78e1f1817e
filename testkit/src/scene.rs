//! A closed loop of [`Harness`]es on one virtual clock: the services of a robot file and
//! the programs under test, wired as the broker would wire them, with no processes.
//!
//! Each member ticks at its own period; every publication is handed at once (first in,
//! first out) to the members bound to its provider; every call is served by the bound
//! provider's [`Harness::command_bytes`] and answered with [`Harness::reply`] at the same
//! instant. Bindings follow the broker's rule (the best quality, then the lowest cost, then
//! the name; never a member to itself), [`Scene::fail`] takes a member out and rebinds its
//! clients, [`Scene::bind`] overrides one binding. A program that finishes
//! ([`Harness::exit_code`]) gets its `on_stop` and no events after it.
//!
//! Everything happens in one order fixed by the members' order and the clock, so the same
//! members with the same seeds give the same run, bit for bit.

use std::collections::{BTreeMap, VecDeque};

use lewis_interfaces::{Interface, cdr};
use lewis_robot::Robot;
use lewis_service::{BuildError, CallFailure, Service, ServiceRegistry};

use crate::{Call, Harness, Publication};

/// One service or program of the scene.
struct Member {
    harness: Harness,
    requires: Vec<String>,
    /// (interface, quality, cost).
    provides: Vec<(String, u32, u32)>,
    period_ns: Option<i64>,
    next_tick_ns: Option<i64>,
    failed: bool,
    /// The program's exit code once it finished (its `on_stop` ran).
    finished: Option<i32>,
}

impl Member {
    fn active(&self) -> bool {
        !self.failed && self.finished.is_none()
    }
}

/// Something a member did that the scene must route.
enum Pending {
    Publication {
        from: usize,
        publication: Publication,
    },
    Call {
        from: usize,
        call: Call,
    },
}

/// A publication the test asked to keep ([`Scene::tap`]).
#[derive(Debug, Clone)]
pub struct Tapped {
    /// When it was published, in ns of the scene's clock.
    pub time_ns: i64,
    /// Who published it.
    pub provider: String,
    /// The message.
    pub publication: Publication,
}

/// A call a member made, kept for the test.
#[derive(Debug, Clone)]
pub struct SentCall {
    /// When it was sent, in ns.
    pub time_ns: i64,
    /// Who called.
    pub client: String,
    /// The provider that served it; `None` when there was none.
    pub provider: Option<String>,
    /// The call.
    pub call: Call,
}

/// Members on one virtual clock (see the module documentation).
pub struct Scene {
    now_ns: i64,
    members: Vec<Member>,
    started: bool,
    overrides: BTreeMap<(String, String), String>,
    taps: BTreeMap<String, Vec<Tapped>>,
    calls: Vec<SentCall>,
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("now_ns", &self.now_ns)
            .field(
                "members",
                &self
                    .members
                    .iter()
                    .map(|m| m.harness.name())
                    .collect::<Vec<_>>(),
            )
            .finish_non_exhaustive()
    }
}

impl Scene {
    /// The services `names` of `robot`, built with `registry`'s kinds, in that order (the
    /// order in which they run at each instant).
    ///
    /// # Errors
    /// The first service that does not build.
    ///
    /// # Panics
    /// When the robot has no service of one of the names.
    pub fn new(
        robot: &Robot,
        registry: &ServiceRegistry,
        names: &[&str],
    ) -> Result<Self, BuildError> {
        let mut scene = Self {
            now_ns: 0,
            members: Vec::new(),
            started: false,
            overrides: BTreeMap::new(),
            taps: BTreeMap::new(),
            calls: Vec::new(),
        };
        for name in names {
            let harness = Harness::build(robot, name, registry)?;
            let spec = robot
                .service(name)
                .unwrap_or_else(|| panic!("the robot has no service `{name}`"));
            scene.push(
                harness,
                spec.requires.clone(),
                spec.provides
                    .iter()
                    .map(|p| (p.interface.clone(), p.quality, p.cost))
                    .collect(),
            );
        }
        Ok(scene)
    }

    /// Adds a program (a service that no registry builds, provides nothing and finishes
    /// itself) that asks for `requires`; started at once when the scene runs already (a
    /// mission's next state).
    ///
    /// # Panics
    /// When it does not start.
    pub fn add_program(
        &mut self,
        name: &str,
        program: Box<dyn Service>,
        requires: &[&str],
        seed: u64,
    ) {
        let harness = Harness::from_service(name, program, seed);
        self.push(
            harness,
            requires.iter().map(|s| (*s).to_owned()).collect(),
            Vec::new(),
        );
        if self.started {
            let i = self.members.len() - 1;
            let now = self.now_ns;
            let member = &mut self.members[i];
            member
                .harness
                .start(now)
                .unwrap_or_else(|e| panic!("{name} does not start: {e}"));
            member.next_tick_ns = member.period_ns.map(|p| now + p);
            self.settle(i);
        }
    }

    fn push(&mut self, harness: Harness, requires: Vec<String>, provides: Vec<(String, u32, u32)>) {
        let period_ns = harness.tick_period_ns().filter(|p| *p > 0);
        self.members.push(Member {
            harness,
            requires,
            provides,
            period_ns,
            next_tick_ns: None,
            failed: false,
            finished: None,
        });
    }

    /// The scene's clock, in ns.
    #[must_use]
    pub fn now_ns(&self) -> i64 {
        self.now_ns
    }

    /// The harness of member `name`.
    ///
    /// # Panics
    /// When there is no such member.
    #[must_use]
    pub fn harness(&self, name: &str) -> &Harness {
        &self.members[self.index(name)].harness
    }

    /// The harness of member `name`, to hand it something by hand.
    ///
    /// # Panics
    /// When there is no such member.
    pub fn harness_mut(&mut self, name: &str) -> &mut Harness {
        let i = self.index(name);
        &mut self.members[i].harness
    }

    fn index(&self, name: &str) -> usize {
        self.members
            .iter()
            .position(|m| m.harness.name() == name)
            .unwrap_or_else(|| panic!("the scene has no member `{name}`"))
    }

    /// The exit code of program `name`, once it finished.
    #[must_use]
    pub fn exit_code(&self, name: &str) -> Option<i32> {
        self.members[self.index(name)].finished
    }

    /// Keeps every publication of `interface` from now on ([`Scene::tapped`]).
    pub fn tap(&mut self, interface: &str) {
        self.taps.entry(interface.to_owned()).or_default();
    }

    /// The publications of `interface` kept since [`Scene::tap`].
    #[must_use]
    pub fn tapped(&self, interface: &str) -> &[Tapped] {
        self.taps.get(interface).map_or(&[], Vec::as_slice)
    }

    /// The decoded publications of `T` kept since [`Scene::tap`], with their times.
    #[must_use]
    pub fn tapped_as<T: Interface>(&self) -> Vec<(i64, T)> {
        self.tapped(T::NAME)
            .iter()
            .map(|t| (t.time_ns, t.publication.decode()))
            .collect()
    }

    /// Every call made so far, in order.
    #[must_use]
    pub fn calls(&self) -> &[SentCall] {
        &self.calls
    }

    /// Takes member `name` out, as a service that failed for good: no events to it, nothing
    /// from it, its clients bound to the next best provider.
    pub fn fail(&mut self, name: &str) {
        let i = self.index(name);
        self.members[i].failed = true;
    }

    /// Binds `client`'s `interface` to `provider` whatever the rule says.
    pub fn bind(&mut self, client: &str, interface: &str, provider: &str) {
        self.overrides.insert(
            (client.to_owned(), interface.to_owned()),
            provider.to_owned(),
        );
    }

    /// The provider `client`'s `interface` is bound to now.
    #[must_use]
    pub fn provider(&self, client: &str, interface: &str) -> Option<&str> {
        self.binding(self.index(client), interface)
            .map(|p| self.members[p].harness.name())
    }

    fn binding(&self, client: usize, interface: &str) -> Option<usize> {
        let name = self.members[client].harness.name();
        if let Some(provider) = self.overrides.get(&(name.to_owned(), interface.to_owned())) {
            return self
                .members
                .iter()
                .position(|m| m.harness.name() == provider && m.active());
        }
        self.members
            .iter()
            .enumerate()
            .filter(|(i, m)| *i != client && m.active())
            .filter_map(|(i, m)| {
                m.provides
                    .iter()
                    .find(|(iface, _, _)| iface == interface)
                    .map(|(_, quality, cost)| (i, *quality, *cost, m.harness.name()))
            })
            .min_by(|a, b| b.1.cmp(&a.1).then(a.2.cmp(&b.2)).then(a.3.cmp(b.3)))
            .map(|(i, ..)| i)
    }

    /// Starts every member at the scene's clock (once; [`Scene::step`] does it first).
    ///
    /// # Errors
    /// The first member's reason not to start.
    pub fn start(&mut self) -> Result<(), String> {
        if self.started {
            return Ok(());
        }
        self.started = true;
        for i in 0..self.members.len() {
            let now = self.now_ns;
            let member = &mut self.members[i];
            member
                .harness
                .start(now)
                .map_err(|e| format!("{}: {e}", member.harness.name()))?;
            member.next_tick_ns = member.period_ns.map(|p| now + p);
            self.settle(i);
        }
        Ok(())
    }

    /// Moves the clock to the next tick of any member and runs every tick due then, each
    /// followed by everything it set off. Returns false when nothing is left to tick.
    ///
    /// # Panics
    /// When a member does not start.
    pub fn step(&mut self) -> bool {
        if !self.started {
            self.start()
                .unwrap_or_else(|e| panic!("the scene does not start: {e}"));
        }
        let Some(next) = self
            .members
            .iter()
            .filter(|m| m.active())
            .filter_map(|m| m.next_tick_ns)
            .min()
        else {
            return false;
        };
        self.now_ns = next;
        for i in 0..self.members.len() {
            let member = &mut self.members[i];
            if !member.active() || member.next_tick_ns != Some(next) {
                continue;
            }
            member.next_tick_ns = member.period_ns.map(|p| next + p);
            member.harness.tick(next);
            self.settle(i);
        }
        true
    }

    /// Steps until `done` says so (true) or the clock passes `limit_ns` (false).
    pub fn run_until(&mut self, limit_ns: i64, mut done: impl FnMut(&Self) -> bool) -> bool {
        loop {
            if done(self) {
                return true;
            }
            if self.now_ns >= limit_ns || !self.step() {
                return done(self);
            }
        }
    }

    /// Routes what member `from` did, and what that set off, until nothing is left.
    fn settle(&mut self, from: usize) {
        let mut pending = VecDeque::new();
        self.collect(from, &mut pending);
        while let Some(next) = pending.pop_front() {
            match next {
                Pending::Publication { from, publication } => {
                    self.deliver(from, &publication, &mut pending);
                }
                Pending::Call { from, call } => self.serve(from, &call, &mut pending),
            }
        }
    }

    /// Takes member `i`'s publications and calls into `pending`; finishes it if it ended.
    fn collect(&mut self, i: usize, pending: &mut VecDeque<Pending>) {
        let now = self.now_ns;
        let member = &mut self.members[i];
        if member.finished.is_none()
            && let Some(code) = member.harness.exit_code()
        {
            member.finished = Some(code);
            member.harness.stop(now);
        }
        if member.failed {
            member.harness.take_published();
            member.harness.take_calls();
            return;
        }
        for publication in member.harness.take_published() {
            pending.push_back(Pending::Publication {
                from: i,
                publication,
            });
        }
        for call in member.harness.take_calls() {
            pending.push_back(Pending::Call { from: i, call });
        }
    }

    fn deliver(&mut self, from: usize, publication: &Publication, pending: &mut VecDeque<Pending>) {
        let provider = self.members[from].harness.name().to_owned();
        if let Some(tap) = self.taps.get_mut(&publication.interface) {
            tap.push(Tapped {
                time_ns: self.now_ns,
                provider: provider.clone(),
                publication: publication.clone(),
            });
        }
        let channel = format!("/{provider}/{}", publication.interface);
        for client in 0..self.members.len() {
            let member = &self.members[client];
            if client == from
                || !member.active()
                || !member.requires.contains(&publication.interface)
                || self.binding(client, &publication.interface) != Some(from)
            {
                continue;
            }
            let now = self.now_ns;
            self.members[client]
                .harness
                .input(now, &provider, &channel, publication);
            self.collect(client, pending);
        }
    }

    fn serve(&mut self, from: usize, call: &Call, pending: &mut VecDeque<Pending>) {
        let now = self.now_ns;
        let provider = self.binding(from, &call.interface);
        self.calls.push(SentCall {
            time_ns: now,
            client: self.members[from].harness.name().to_owned(),
            provider: provider.map(|p| self.members[p].harness.name().to_owned()),
            call: call.clone(),
        });
        let result = match provider {
            None => Err(CallFailure::NoProvider {
                interface: call.interface.clone(),
            }),
            Some(p) => {
                let served = self.members[p].harness.command_bytes(
                    now,
                    &call.interface,
                    call.command,
                    &call.message,
                );
                self.collect(p, pending);
                served.map_err(|e| CallFailure::Refused(e.0))
            }
        };
        let client = &mut self.members[from];
        if !client.active() {
            return;
        }
        client.harness.reply(
            now,
            call.id,
            &call.interface,
            call.command,
            result.as_deref().map_err(Clone::clone),
        );
        self.collect(from, pending);
    }
}

/// The calls of `scene` to `interface`'s command `command`, decoded.
///
/// # Panics
/// When a call does not decode as `C`.
#[must_use]
pub fn calls_of<C: lewis_interfaces::Command>(scene: &Scene) -> Vec<(i64, String, C)> {
    scene
        .calls()
        .iter()
        .filter(|c| {
            c.call.interface == <C::Interface as Interface>::NAME && c.call.command == C::NAME
        })
        .map(|c| {
            (
                c.time_ns,
                c.client.clone(),
                cdr::from_bytes(&c.call.message).expect("a call decodes as its command"),
            )
        })
        .collect()
}
