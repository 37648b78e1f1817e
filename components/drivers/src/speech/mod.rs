//! `espeak-speech`: the robot's voice through espeak-ng, as the Speech interface.
//!
//! `say` spawns `espeak-ng -w AUDIO_DIR/utterance-NNNN.wav TEXT` as a child process, then,
//! with `play`, the player on that WAV (`aplay -q FILE`): what the robot says aloud is
//! what is kept. The handler does not wait for them; each child is reaped at a later
//! tick, and the next step starts then (one voice, one utterance at a time). `speaking` is
//! true while an utterance is queued, synthesised or played. A player that cannot start
//! or fails is one warning, not a fault: the WAVs are still written. Nobody answers on the
//! robot's side: answers come only from `hear` (a person at the supervisor's page or
//! terminal), taken at once. Speech is published at every tick.
//!
//! The audio goes beside the recording: when the robot is recorded, `lewis up` names the
//! recording in [`RECORDING_ENV`] and the WAVs go to `<recording's stem>.speech/` beside it
//! (`logs/b21r-20260101T120000Z.speech/utterance-0001.wav`); an `audio_dir` given wins;
//! unrecorded and without one, they go to `logs/speech/`.
//!
//! ```toml
//! [services.parameters]
//! audio_dir = "logs/speech"   # optional (see above); created when missing
//! program = "espeak-ng"       # looked up on PATH
//! voice = "en"                # optional: espeak-ng's -v
//! play = true                 # play each utterance aloud (default false)
//! player = "aplay"            # looked up on PATH; run as `aplay -q FILE`
//! rate_hz = 10.0
//! ```

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

pub use lewis_service::RECORDING_ENV;

use lewis_interfaces::msg::{Speech, SpeechCommand, SpeechHearReply, SpeechSayReply};
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Reply, Role, Service, ServiceConfig,
    ServiceRegistry,
};
use serde::Deserialize;

/// The kind name in robot files.
pub const KIND: &str = "espeak-speech";

/// Registers `espeak-speech`, a device (a replay feeds it from the recording).
pub fn register(registry: &mut ServiceRegistry) {
    registry.register_with_parameters::<Params>(KIND, build);
    registry.set_role(KIND, Role::Device);
}

/// Where the audio goes when the robot is not recorded and no `audio_dir` is given.
pub const UNRECORDED_AUDIO_DIR: &str = "logs/speech";

/// The parameters of `espeak-speech`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Where the WAV files go (created when missing); default: beside the recording
    /// ([`audio_dir`]).
    #[serde(default)]
    pub audio_dir: Option<PathBuf>,
    /// The synthesiser, looked up on PATH.
    #[serde(default = "default_program")]
    pub program: String,
    /// The voice (espeak-ng's `-v`), if not its default.
    #[serde(default)]
    pub voice: Option<String>,
    /// Play each utterance aloud once written.
    #[serde(default)]
    pub play: bool,
    /// The player, looked up on PATH and run as `PLAYER -q FILE`.
    #[serde(default = "default_player")]
    pub player: String,
    /// Speech publications per second.
    #[serde(default = "default_rate_hz")]
    pub rate_hz: f64,
}

fn default_program() -> String {
    "espeak-ng".to_owned()
}

fn default_player() -> String {
    "aplay".to_owned()
}

/// Where the audio goes: `given` when there is one, else beside `recording`
/// (`<folder>/<stem>.speech/`) when the robot is recorded, else [`UNRECORDED_AUDIO_DIR`].
#[must_use]
pub fn audio_dir(given: Option<&Path>, recording: Option<&Path>) -> PathBuf {
    if let Some(given) = given {
        return given.to_path_buf();
    }
    match recording.and_then(|r| Some((r.parent()?, r.file_stem()?))) {
        Some((folder, stem)) => {
            let mut name = stem.to_os_string();
            name.push(".speech");
            folder.join(name)
        }
        None => PathBuf::from(UNRECORDED_AUDIO_DIR),
    }
}

/// What a child of the service is doing for utterance `n`.
#[derive(Debug)]
struct Running {
    n: i32,
    child: Child,
    /// Playing the WAV (else synthesising it).
    playing: bool,
}

fn default_rate_hz() -> f64 {
    10.0
}

/// The `espeak-speech` service.
#[derive(Debug)]
pub struct EspeakSpeech {
    params: Params,
    audio_dir: PathBuf,
    period_ns: i64,
    state: Speech,
    /// Utterances waiting for the voice: (number, text).
    queue: VecDeque<(i32, String)>,
    /// The utterance being synthesised or played.
    child: Option<Running>,
    /// The player failed once (and said so): it is not warned about again.
    player_warned: bool,
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
    let recording = std::env::var_os(RECORDING_ENV).map(PathBuf::from);
    let audio_dir = audio_dir(params.audio_dir.as_deref(), recording.as_deref());
    Ok(Box::new(EspeakSpeech {
        params,
        audio_dir,
        period_ns,
        state: Speech::silent(),
        queue: VecDeque::new(),
        child: None,
        player_warned: false,
    }))
}

impl EspeakSpeech {
    /// The WAV file of utterance `n`.
    #[must_use]
    pub fn wav_path(&self, n: i32) -> PathBuf {
        self.audio_dir.join(format!("utterance-{n:04}.wav"))
    }

    /// The folder the WAV files go to.
    #[must_use]
    pub fn audio_dir(&self) -> &Path {
        &self.audio_dir
    }

    /// Reaps a finished child, plays a WAV just written (with `play`), and starts the next
    /// utterance if the voice is free.
    fn pump(&mut self, ctx: &mut Context<'_>) {
        if let Some(running) = self.child.as_mut() {
            let status = match running.child.try_wait() {
                Ok(None) => return,
                Ok(Some(status)) => Ok(status),
                Err(e) => Err(e),
            };
            let Some(Running { n, playing, .. }) = self.child.take() else {
                return;
            };
            let program = if playing {
                self.params.player.clone()
            } else {
                self.params.program.clone()
            };
            let success = match status {
                Ok(status) if status.success() => true,
                Ok(status) => {
                    self.failed(
                        ctx,
                        playing,
                        &format!("{program} failed on utterance {n}: {status}"),
                    );
                    false
                }
                Err(e) => {
                    self.failed(ctx, playing, &format!("cannot wait for {program}: {e}"));
                    false
                }
            };
            if success && !playing && self.params.play {
                self.play(ctx, n);
                if self.child.is_some() {
                    return;
                }
            }
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
                    self.child = Some(Running {
                        n,
                        child,
                        playing: false,
                    });
                    return;
                }
                Err(e) => ctx.warn(&format!(
                    "cannot start {} for utterance {n}: {e}",
                    self.params.program
                )),
            }
        }
    }

    /// Starts the player on utterance `n`'s WAV.
    fn play(&mut self, ctx: &mut Context<'_>, n: i32) {
        let spawned = Command::new(&self.params.player)
            .arg("-q")
            .arg(self.wav_path(n))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn();
        match spawned {
            Ok(child) => {
                self.child = Some(Running {
                    n,
                    child,
                    playing: true,
                });
            }
            Err(e) => {
                let failure = format!("cannot start {} for utterance {n}: {e}", self.params.player);
                self.failed(ctx, true, &failure);
            }
        }
    }

    /// Says that a child failed: always for the synthesiser, once for the player (the
    /// robot may have no sound card; the WAVs are still written).
    fn failed(&mut self, ctx: &mut Context<'_>, playing: bool, failure: &str) {
        if !playing {
            ctx.warn(failure);
        } else if !self.player_warned {
            self.player_warned = true;
            ctx.warn(&format!(
                "{failure}; the utterances are not played aloud (their WAVs are in {})",
                self.audio_dir.display()
            ));
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
        std::fs::create_dir_all(&self.audio_dir).map_err(|e| {
            format!(
                "cannot create the audio folder {}: {e}",
                self.audio_dir.display()
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
        if let Some(mut running) = self.child.take() {
            let _ = running.child.kill();
            let _ = running.child.wait();
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_audio_goes_beside_the_recording_unless_a_folder_is_given() {
        let recording = Path::new("logs/b21r-20260101T120000Z.mcap");
        assert_eq!(
            audio_dir(None, Some(recording)),
            Path::new("logs/b21r-20260101T120000Z.speech")
        );
        assert_eq!(
            audio_dir(Some(Path::new("/tmp/voice")), Some(recording)),
            Path::new("/tmp/voice")
        );
        assert_eq!(audio_dir(None, None), Path::new(UNRECORDED_AUDIO_DIR));
    }
}
