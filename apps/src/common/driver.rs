//! The part every moving program shares: the staleness watch, the odometry, the Mover
//! client, the start time and the exit code, and the `Service` methods built on them. A
//! program keeps only what it decides: its own inputs and its periodic step.

use lewis_interfaces::msg::{Egomotion, Mover};
use lewis_service::{Context, Input};

use super::frames::Odometry;
use super::mover::MoverClient;
use super::watch::Watch;

/// How often a moving program steps, in ns.
pub const TICK_PERIOD_NS: i64 = 100_000_000;

/// What a moving program keeps besides its own decisions.
#[derive(Debug)]
pub struct Driver {
    /// When each required input last spoke.
    pub watch: Watch,
    /// The robot's latest pose, from Egomotion.
    pub odometry: Odometry,
    /// The program's side of the Mover.
    pub mover: MoverClient,
    /// When the program started, in ns; a program may move it on (its timeout counts from it).
    pub started_ns: Option<i64>,
    exit: Option<i32>,
}

impl Driver {
    /// Watches `interfaces`, each allowed `stale_ns` of silence.
    #[must_use]
    pub fn new(interfaces: &[&'static str], stale_ns: i64) -> Self {
        Self {
            watch: Watch::new(interfaces, stale_ns),
            odometry: Odometry::default(),
            mover: MoverClient::default(),
            started_ns: None,
            exit: None,
        }
    }

    /// The program starts now.
    pub fn start(&mut self, ctx: &mut Context<'_>) {
        self.watch.start(ctx.now());
        self.started_ns = Some(ctx.now());
    }

    /// Takes an input: true when nothing is left for the program to do with it (it has
    /// finished, or it was Egomotion or Mover).
    pub fn input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) -> bool {
        if self.exit.is_some() {
            return true;
        }
        self.watch.saw(input.interface, ctx.now());
        match input.interface {
            "Egomotion" => {
                if let Ok(m) = input.decode::<Egomotion>() {
                    self.odometry.update(&m.pose);
                }
                true
            }
            "Mover" => {
                if let Ok(m) = input.decode::<Mover>() {
                    self.mover.on_status(ctx, input.provider, m);
                }
                true
            }
            _ => false,
        }
    }

    /// Ends the program with `code`, saying why; only the first word counts.
    pub fn finish(&mut self, ctx: &mut Context<'_>, code: i32, why: &str) {
        if self.exit.is_none() {
            ctx.info(&format!("exit {code}: {why}"));
            self.exit = Some(code);
        }
    }

    /// Whether the program has finished.
    #[must_use]
    pub fn exited(&self) -> bool {
        self.exit.is_some()
    }

    /// The code the program finished with.
    #[must_use]
    pub fn exit_code(&self) -> Option<i32> {
        self.exit
    }
}

/// Implements `Service` for a moving program: a type with a `driver: Driver` field and the
/// methods `other_input(ctx, input)` (any input but Egomotion and Mover) and `step(ctx)`
/// (the periodic step, until it finishes). `moving_service!(Type, then method)` also calls
/// `method(ctx)` once the driver has started.
macro_rules! moving_service {
    ($program:ty $(, then $started:ident)?) => {
        impl ::lewis_service::Service for $program {
            fn tick_period_ns(&self) -> Option<i64> {
                Some($crate::common::driver::TICK_PERIOD_NS)
            }

            fn on_start(
                &mut self,
                ctx: &mut ::lewis_service::Context<'_>,
            ) -> Result<(), String> {
                self.driver.start(ctx);
                $(self.$started(ctx);)?
                Ok(())
            }

            fn on_input(
                &mut self,
                ctx: &mut ::lewis_service::Context<'_>,
                input: &::lewis_service::Input<'_>,
            ) {
                if !self.driver.input(ctx, input) {
                    self.other_input(ctx, input);
                }
            }

            fn on_reply(
                &mut self,
                ctx: &mut ::lewis_service::Context<'_>,
                reply: &::lewis_service::ReplyEvent<'_>,
            ) {
                self.driver.mover.on_reply(ctx, reply);
            }

            fn on_tick(&mut self, ctx: &mut ::lewis_service::Context<'_>) {
                if !self.driver.exited() {
                    self.step(ctx);
                }
            }

            fn on_stop(&mut self, ctx: &mut ::lewis_service::Context<'_>) {
                self.driver.mover.stop_now(ctx);
            }

            fn exit_code(&self) -> Option<i32> {
                self.driver.exit_code()
            }
        }
    };
}
pub(crate) use moving_service;
