//! `espeak-speech`: the robot's voice through espeak-ng, as the Speech interface.
//!
//! `say` spawns `espeak-ng -w AUDIO_DIR/utterance-NNNN.wav TEXT` as a child process: the
//! handler does not wait for it; the child is reaped at a later tick, and the next queued
//! utterance starts then (one voice, one utterance at a time). `speaking` is true while an
//! utterance is queued or being synthesised. Nobody answers on the robot's side: answers
//! come only from `hear` (a person at the supervisor's page or terminal), taken at once.
//! Speech is published at every tick.
//!
//! ```toml
//! [services.parameters]
//! audio_dir = "logs/speech"   # created when missing; one WAV per utterance
//! program = "espeak-ng"       # looked up on PATH
//! voice = "en"                # optional: espeak-ng's -v
//! rate_hz = 10.0
//! ```

use std::collections::VecDeque;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};

use lewis_interfaces::msg::{Speech, SpeechCommand, SpeechHearReply, SpeechSayReply};
use lewis_runtime::service::{
    BuildError, CommandError, Context, IncomingCommand, Reply, Service, ServiceConfig,
    ServiceRegistry,
};
use serde::Deserialize;

/// The kind name in robot files.
pub const KIND: &str = "espeak-speech";

/// Registers `espeak-speech`.
pub fn register(registry: &mut ServiceRegistry) {
    registry.register_with_parameters::<Params>(KIND, build);
}

/// The parameters of `espeak-speech`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Where the WAV files go (created when missing).
    pub audio_dir: PathBuf,
    /// The synthesiser, looked up on PATH.
    #[serde(default = "default_program")]
    pub program: String,
    /// The voice (espeak-ng's `-v`), if not its default.
    #[serde(default)]
    pub voice: Option<String>,
    /// Speech publications per second.
    #[serde(default = "default_rate_hz")]
    pub rate_hz: f64,
}

fn default_program() -> String {
    "espeak-ng".to_owned()
}

fn default_rate_hz() -> f64 {
    10.0
}

/// The `espeak-speech` service.
#[derive(Debug)]
pub struct EspeakSpeech {
    params: Params,
    period_ns: i64,
    state: Speech,
    /// Utterances waiting for the voice: (number, text).
    queue: VecDeque<(i32, String)>,
    /// The utterance being synthesised.
    child: Option<(i32, Child)>,
}

/// Builds an `espeak-speech` service from its robot-file entry.
///
/// # Errors
/// When a parameter is missing, unknown or cannot work.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: Params = config.parameters()?;
    if !(params.rate_hz.is_finite() && (0.1..=100.0).contains(&params.rate_hz)) {
        return Err(BuildError::Parameters {
            service: config.name().to_owned(),
            reason: format!(
                "`rate_hz` is {}: give a rate between 0.1 and 100 Hz",
                params.rate_hz
            ),
        });
    }
    // 1e9 / rate is at most 1e10 for a rate in range: it fits an i64.
    let period_ns = (1e9 / params.rate_hz).round() as i64;
    Ok(Box::new(EspeakSpeech {
        params,
        period_ns,
        state: Speech::silent(),
        queue: VecDeque::new(),
        child: None,
    }))
}

impl EspeakSpeech {
    /// The WAV file of utterance `n`.
    #[must_use]
    pub fn wav_path(&self, n: i32) -> PathBuf {
        self.params.audio_dir.join(format!("utterance-{n:04}.wav"))
    }

    /// Reaps a finished child and starts the next utterance if the voice is free.
    fn pump(&mut self, ctx: &mut Context<'_>) {
        if let Some((n, child)) = &mut self.child {
            match child.try_wait() {
                Ok(None) => return,
                Ok(Some(status)) => {
                    if !status.success() {
                        ctx.warn(&format!(
                            "{} failed on utterance {n}: {status}",
                            self.params.program
                        ));
                    }
                }
                Err(e) => ctx.warn(&format!("cannot wait for {}: {e}", self.params.program)),
            }
            self.child = None;
        }
        while let Some((n, text)) = self.queue.pop_front() {
            let mut command = Command::new(&self.params.program);
            if let Some(voice) = &self.params.voice {
                command.arg("-v").arg(voice);
            }
            command
                .arg("-w")
                .arg(self.wav_path(n))
                .arg("--")
                .arg(&text)
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .stderr(Stdio::null());
            match command.spawn() {
                Ok(child) => {
                    self.child = Some((n, child));
                    return;
                }
                Err(e) => ctx.warn(&format!(
                    "cannot start {} for utterance {n}: {e}",
                    self.params.program
                )),
            }
        }
    }

    fn publish(&mut self, ctx: &mut Context<'_>) {
        self.state.speaking = self.child.is_some() || !self.queue.is_empty();
        if let Err(e) = ctx.publish(&mut self.state.clone()) {
            ctx.warn(&format!("cannot publish Speech: {e}"));
        }
    }
}

impl Service for EspeakSpeech {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(self.period_ns)
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        std::fs::create_dir_all(&self.params.audio_dir).map_err(|e| {
            format!(
                "cannot create the audio folder {}: {e}",
                self.params.audio_dir.display()
            )
        })?;
        self.publish(ctx);
        Ok(())
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        self.pump(ctx);
        self.publish(ctx);
    }

    fn on_stop(&mut self, _ctx: &mut Context<'_>) {
        // A child left running would outlive the service: stop it and reap it.
        if let Some((_, mut child)) = self.child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        match command.interface {
            "Speech" => match command.decode::<Speech>()? {
                SpeechCommand::Say(c) => {
                    let n = self.state.said(&c.text);
                    self.queue.push_back((n, c.text));
                    self.pump(ctx);
                    self.publish(ctx);
                    Ok(ctx.reply(SpeechSayReply {
                        utterance: n,
                        ..SpeechSayReply::default()
                    }))
                }
                SpeechCommand::Hear(c) => {
                    self.state
                        .hear(&c.answer, &c.text)
                        .map_err(|e| CommandError::new(e.to_string()))?;
                    self.publish(ctx);
                    Ok(ctx.reply(SpeechHearReply::default()))
                }
            },
            other => Err(CommandError::new(format!("{KIND} does not serve {other}"))),
        }
    }
}
