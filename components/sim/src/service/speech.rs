//! `sim-speech`: the robot's voice in the simulator, and the registrar who answers it.
//!
//! `say` makes the robot speak (Speech's `speaking`, `said_count` and `last_said`); when the
//! robot's true pose (the latest GroundTruth) is within `hear_within_m` of the registrar
//! (a person of the world, the desk's clerk), the registrar answers `answer_delay_ms` later:
//! `answer = yes` and `last_heard` = `answer_text`. Farther away nobody hears it and
//! nothing comes back. `hear` (someone answering on the registrar's behalf: the
//! supervisor) is taken as an answer at once. Speech is published at every tick, so a
//! client that comes late sees the state.
//!
//! ```toml
//! [services.parameters]
//! world = "robots/worlds/conference"
//! registrar = "clerk"
//! hear_within_m = 3.5
//! answer_delay_ms = 1500
//! answer_text = "You are registered. Welcome!"
//! rate_hz = 10.0
//! seed = 5                 # accepted like every sim-* service's; nothing here is random
//! ```

use std::path::PathBuf;

use lewis_geometry::Vec2;
use lewis_interfaces::msg::{Speech, SpeechAnswer, SpeechCommand, SpeechHearReply, SpeechSayReply};
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Input, Reply, Service, ServiceConfig,
};
use serde::Deserialize;

use super::{TruthFollower, invalid, load_world, period_ns, publish};
use crate::world::{ObjectKind, World};

/// The kind name in robot files.
pub const KIND: &str = "sim-speech";

/// How long the robot speaks per character of text, in ns (some 15 characters a second).
const SPEAKING_NS_PER_CHAR: i64 = 65_000_000;

/// The parameters of `sim-speech`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeechParams {
    /// The world folder (`world.toml` and its map).
    pub world: PathBuf,
    /// The person who answers: a person object of the world.
    #[serde(default = "defaults::registrar")]
    pub registrar: String,
    /// The registrar hears the robot within this distance of the robot's centre, in m.
    #[serde(default = "defaults::hear_within_m")]
    pub hear_within_m: f64,
    /// The registrar answers this long after the robot spoke, in ms.
    #[serde(default = "defaults::answer_delay_ms")]
    pub answer_delay_ms: u64,
    /// The registrar's words.
    #[serde(default = "defaults::answer_text")]
    pub answer_text: String,
    /// Speech publications per second.
    #[serde(default = "defaults::rate_hz")]
    pub rate_hz: f64,
    /// Accepted like every simulated device's seed (`lewis demo --seed` sets them all);
    /// nothing here is random.
    #[serde(default)]
    pub seed: Option<u64>,
}

mod defaults {
    pub(super) fn registrar() -> String {
        "clerk".to_owned()
    }
    pub(super) fn hear_within_m() -> f64 {
        3.5
    }
    pub(super) fn answer_delay_ms() -> u64 {
        1500
    }
    pub(super) fn answer_text() -> String {
        "You are registered. Welcome!".to_owned()
    }
    pub(super) fn rate_hz() -> f64 {
        10.0
    }
}

/// The `sim-speech` service.
#[derive(Debug)]
pub struct SimSpeechService {
    world: World,
    truth: TruthFollower,
    registrar: Vec2,
    hear_within_m: f64,
    answer_delay_ns: i64,
    answer_text: String,
    period_ns: i64,
    state: Speech,
    /// Until when the robot speaks, in ns.
    speaking_until_ns: i64,
    /// When the registrar's answer is due, if one is coming.
    answer_due_ns: Option<i64>,
}

/// Builds a `sim-speech` service from its robot-file entry.
///
/// # Errors
/// When a parameter is missing, unknown or cannot work, the world does not load, or the
/// registrar is no person of it.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: SpeechParams = config.parameters()?;
    let period_ns = period_ns(config, "rate_hz", params.rate_hz)?;
    if !(params.hear_within_m.is_finite() && params.hear_within_m >= 0.0) {
        return Err(invalid(
            config,
            format!(
                "`hear_within_m` is {}: give a distance of zero or more, in m",
                params.hear_within_m
            ),
        ));
    }
    let answer_delay_ns = i64::try_from(params.answer_delay_ms)
        .ok()
        .and_then(|ms| ms.checked_mul(1_000_000))
        .ok_or_else(|| invalid(config, "`answer_delay_ms` is too large"))?;
    let world = load_world(config, &params.world)?;
    let registrar = match world.object(&params.registrar).map(|o| &o.kind) {
        Some(ObjectKind::Person(p)) => p.centre,
        _ => {
            let people: Vec<&str> = world
                .objects()
                .iter()
                .filter(|o| matches!(o.kind, ObjectKind::Person(_)))
                .map(|o| o.name.as_str())
                .collect();
            return Err(invalid(
                config,
                format!(
                    "`registrar` `{}` is no person of world `{}`: its people are {}",
                    params.registrar,
                    world.name(),
                    people.join(", ")
                ),
            ));
        }
    };
    Ok(Box::new(SimSpeechService {
        world,
        truth: TruthFollower::default(),
        registrar,
        hear_within_m: params.hear_within_m,
        answer_delay_ns,
        answer_text: params.answer_text,
        period_ns,
        state: Speech::silent(),
        speaking_until_ns: 0,
        answer_due_ns: None,
    }))
}

impl Service for SimSpeechService {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(self.period_ns)
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        publish(ctx, &mut self.state.clone());
        Ok(())
    }

    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        self.truth.take(ctx, input);
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        let now = ctx.now();
        // Names the latest true pose as the provenance of what follows.
        let _ = self.truth.pose_for_rendering(ctx, &mut self.world);
        if self.answer_due_ns.is_some_and(|due| now >= due) {
            self.answer_due_ns = None;
            self.state.heard(SpeechAnswer::Yes, &self.answer_text);
            ctx.info(&format!("the registrar answers: {}", self.answer_text));
        }
        self.state.speaking = now < self.speaking_until_ns;
        publish(ctx, &mut self.state.clone());
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        match command.interface {
            "Speech" => match command.decode::<Speech>()? {
                SpeechCommand::Say(c) => {
                    let now = ctx.now();
                    let utterance = self.state.said(&c.text);
                    self.state.speaking = true;
                    let chars = i64::try_from(c.text.chars().count()).unwrap_or(i64::MAX);
                    self.speaking_until_ns =
                        now.saturating_add(chars.saturating_mul(SPEAKING_NS_PER_CHAR));
                    let robot = self.truth.pose_for_rendering(ctx, &mut self.world);
                    let near = robot.is_some_and(|pose| {
                        pose.position().distance(self.registrar) <= self.hear_within_m
                    });
                    if near {
                        self.answer_due_ns = Some(now.saturating_add(self.answer_delay_ns));
                    }
                    ctx.info(&format!(
                        "says \"{}\"{}",
                        c.text,
                        if near {
                            ""
                        } else {
                            ": nobody is near enough to hear it"
                        }
                    ));
                    publish(ctx, &mut self.state.clone());
                    Ok(ctx.reply(SpeechSayReply {
                        utterance,
                        ..SpeechSayReply::default()
                    }))
                }
                SpeechCommand::Hear(c) => {
                    self.state
                        .hear(&c.answer, &c.text)
                        .map_err(|e| CommandError::new(e.to_string()))?;
                    publish(ctx, &mut self.state.clone());
                    Ok(ctx.reply(SpeechHearReply::default()))
                }
            },
            other => Err(CommandError::new(format!("{KIND} does not serve {other}"))),
        }
    }
}
