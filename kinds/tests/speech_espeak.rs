//! `espeak-speech` through the `Service` trait with the real espeak-ng: `say` writes one
//! WAV per utterance without blocking the handler, `speaking` ends when the child is
//! reaped, and answers come only from `hear`. Skipped, saying so, when espeak-ng is not
//! installed (CI installs it).

#![allow(clippy::unwrap_used, clippy::print_stderr)]

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use lewis_interfaces::msg::{Speech, SpeechHear, SpeechSay};
use lewis_service::ServiceRegistry;
use lewis_testkit::Harness;

const MS: i64 = 1_000_000;

fn espeak_installed() -> bool {
    Command::new("espeak-ng")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

fn speech(audio_dir: &std::path::Path) -> Harness {
    speech_with(audio_dir, "")
}

/// `espeak-speech` writing into `audio_dir`, with more parameters (TOML lines).
fn speech_with(audio_dir: &std::path::Path, parameters: &str) -> Harness {
    let text = format!(
        "[robot]\nname = \"t\"\n\n[[services]]\nname = \"speech\"\nkind = \"espeak-speech\"\n\
         provides = [{{ interface = \"Speech\", quality = 5, cost = 1 }}]\n\n\
         [services.parameters]\naudio_dir = {:?}\n{parameters}",
        audio_dir.display().to_string()
    );
    let mut registry = ServiceRegistry::new();
    lewis_drivers::speech::register(&mut registry);
    Harness::build(&lewis_testkit::robot(&text), "speech", &registry).unwrap()
}

#[test]
fn espeak_speech_writes_a_wav_per_utterance_and_hears_only_the_supervisor() {
    if !espeak_installed() {
        lewis_testkit::skip_unless_ci!("espeak-ng is not installed (apt-get install espeak-ng)");
    }
    let dir = tempfile::tempdir().unwrap();
    let audio = dir.path().join("speech");
    let mut h = speech(&audio);
    h.start(0).unwrap();
    let reply = h
        .command(
            10 * MS,
            &SpeechSay {
                text: "Hello, I am Lewis.".to_owned(),
                ..SpeechSay::default()
            },
        )
        .unwrap();
    assert_eq!(reply.utterance, 1);
    let said = h.take::<Speech>().pop().unwrap();
    assert!(said.speaking);
    assert_eq!(said.last_said, "Hello, I am Lewis.");
    // Ticks reap the child once espeak-ng is done (real time: a child process).
    let started = Instant::now();
    let mut t = 10 * MS;
    let done = loop {
        t += 100 * MS;
        h.tick(t);
        let state = h.take::<Speech>().pop().unwrap();
        if !state.speaking {
            break state;
        }
        assert!(
            started.elapsed() < Duration::from_secs(30),
            "espeak-ng never ended"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let wav = std::fs::read(audio.join("utterance-0001.wav")).unwrap();
    assert!(
        wav.len() > 44 && &wav[..4] == b"RIFF",
        "{} bytes",
        wav.len()
    );
    // Nobody answered on the robot's side; the supervisor does.
    assert_eq!((done.heard_count, done.answer.as_str()), (0, "none"));
    h.command(
        t,
        &SpeechHear {
            answer: "yes".to_owned(),
            text: "Registered.".to_owned(),
            ..SpeechHear::default()
        },
    )
    .unwrap();
    let heard = h.take::<Speech>().pop().unwrap();
    assert_eq!((heard.heard_count, heard.answer.as_str()), (1, "yes"));
    h.stop(t + 100 * MS);
}

/// Ticks until the voice is free (espeak-ng and the player are real child processes).
fn until_silent(h: &mut Harness, mut t: i64) -> i64 {
    let started = Instant::now();
    loop {
        t += 100 * MS;
        h.tick(t);
        if !h.take::<Speech>().pop().unwrap().speaking {
            return t;
        }
        assert!(
            started.elapsed() < Duration::from_secs(30),
            "the voice never fell silent"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn a_player_that_cannot_play_leaves_the_voice_working_and_the_wavs_written() {
    if !espeak_installed() {
        lewis_testkit::skip_unless_ci!("espeak-ng is not installed (apt-get install espeak-ng)");
    }
    let dir = tempfile::tempdir().unwrap();
    let audio = dir.path().join("speech");
    // A robot without a player (or a sound card): playing fails, speaking goes on.
    let mut h = speech_with(&audio, "play = true\nplayer = \"/nonexistent/aplay\"\n");
    h.start(0).unwrap();
    let mut t = 10 * MS;
    for n in 1..=2 {
        let say = SpeechSay {
            text: format!("Utterance {n}."),
            ..SpeechSay::default()
        };
        assert_eq!(h.command(t, &say).unwrap().utterance, n);
        t = until_silent(&mut h, t);
        let wav = std::fs::read(audio.join(format!("utterance-{n:04}.wav"))).unwrap();
        assert_eq!(&wav[..4], b"RIFF");
    }
    // A player that plays: the voice is busy until it is done, then free.
    let mut h = speech_with(&audio, "play = true\nplayer = \"true\"\n");
    h.start(t).unwrap();
    let say = SpeechSay {
        text: "Played.".to_owned(),
        ..SpeechSay::default()
    };
    h.command(t, &say).unwrap();
    until_silent(&mut h, t);
    h.stop(t + 100 * MS);
}
