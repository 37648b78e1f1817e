//! Register: asks the registrar to register the robot, and waits for the answer.
//!
//! It says its words once through Speech, then waits for an answer heard after them: `yes`
//! finishes with 0, `no` with 4. With no answer within `--wait` it says them once more,
//! then gives up (4). It does not move.

use lewis_interfaces::msg::{Speech, SpeechAnswer, SpeechSay};
use lewis_service::{CallId, Context, Input, ReplyEvent, Service};

use crate::common::exit;

/// What Register asks the broker for.
pub const REQUIRES: &[&str] = &["Speech"];

/// The words it says when none are given.
pub const DEFAULT_WORDS: &str = "Hello, I am Lewis. I would like to register.";

/// How soon a `say` that could not be sent is tried again, in ns.
const RETRY_NS: i64 = 500_000_000;

/// Register's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct RegisterConfig {
    /// What it says (`--badge-text`).
    pub words: String,
    /// How long it waits for an answer after saying them, in ns (`--wait`).
    pub wait_ns: i64,
    /// How many times it says them before giving up.
    pub attempts: u32,
}

impl Default for RegisterConfig {
    fn default() -> Self {
        Self {
            words: DEFAULT_WORDS.to_owned(),
            wait_ns: 20_000_000_000,
            attempts: 2,
        }
    }
}

/// What Register does next (the pure core).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// Say the words (again).
    Say,
    /// Wait for an answer.
    Wait,
    /// Finish with this code.
    Exit(i32),
}

/// The conversation: what was said, what was heard (the pure core of Register).
#[derive(Debug, Clone, PartialEq)]
pub struct Conversation {
    config: RegisterConfig,
    /// How many times it said the words (a `say` accepted).
    said: u32,
    /// When it last said them, in ns.
    said_at_ns: Option<i64>,
    /// The answers heard before it first spoke: answers after it are for it.
    heard_before: Option<i32>,
    answer: Option<SpeechAnswer>,
}

impl Conversation {
    /// A conversation not begun.
    #[must_use]
    pub fn new(config: RegisterConfig) -> Self {
        Self {
            config,
            said: 0,
            said_at_ns: None,
            heard_before: None,
            answer: None,
        }
    }

    /// A Speech sample.
    pub fn hear(&mut self, speech: &Speech) {
        let before = *self.heard_before.get_or_insert(speech.heard_count);
        if self.said > 0 && speech.heard_count > before {
            self.answer = speech.answer.parse().ok();
        }
    }

    /// The words were said at `now_ns`.
    pub fn said(&mut self, now_ns: i64) {
        // Said before any Speech sample came: every answer is for it.
        self.heard_before.get_or_insert(0);
        self.said += 1;
        self.said_at_ns = Some(now_ns);
    }

    /// Whether it has seen Speech (so it knows which answers are old).
    #[must_use]
    pub fn listening(&self) -> bool {
        self.heard_before.is_some()
    }

    /// What to do at `now_ns`.
    #[must_use]
    pub fn step(&self, now_ns: i64) -> Step {
        match self.answer {
            Some(SpeechAnswer::Yes) => return Step::Exit(exit::SUCCESS),
            Some(SpeechAnswer::No) => return Step::Exit(exit::GAVE_UP),
            Some(SpeechAnswer::None) | None => {}
        }
        match self.said_at_ns {
            None => Step::Say,
            Some(at) if now_ns - at > self.config.wait_ns => {
                if self.said >= self.config.attempts {
                    Step::Exit(exit::GAVE_UP)
                } else {
                    Step::Say
                }
            }
            Some(_) => Step::Wait,
        }
    }
}

/// The Register program.
#[derive(Debug)]
pub struct Register {
    conversation: Conversation,
    in_flight: Option<CallId>,
    retry_at_ns: i64,
    started_ns: Option<i64>,
    exit: Option<i32>,
}

impl Register {
    /// The program with its settings.
    #[must_use]
    pub fn new(config: RegisterConfig) -> Self {
        Self {
            conversation: Conversation::new(config),
            in_flight: None,
            retry_at_ns: 0,
            started_ns: None,
            exit: None,
        }
    }

    fn step(&mut self, ctx: &mut Context<'_>) {
        let now = ctx.now();
        let started = *self.started_ns.get_or_insert(now);
        // A Speech sample first tells which answers are old; a provider that publishes only
        // on a change may not send one: then it speaks after a second anyway.
        let ready = self.conversation.listening() || now - started >= 1_000_000_000;
        match self.conversation.step(now) {
            Step::Exit(code) => {
                ctx.info(&format!("exit {code}: the registrar answered, or did not"));
                self.exit = Some(code);
            }
            Step::Say if self.in_flight.is_none() && now >= self.retry_at_ns && ready => {
                let mut say = SpeechSay {
                    text: self.conversation.config.words.clone(),
                    ..SpeechSay::default()
                };
                match ctx.call(&mut say) {
                    Ok(id) => self.in_flight = Some(id),
                    Err(_) => self.retry_at_ns = now + RETRY_NS,
                }
            }
            Step::Say | Step::Wait => {}
        }
    }
}

impl Service for Register {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(100_000_000)
    }

    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        if self.exit.is_none()
            && input.interface == "Speech"
            && let Ok(speech) = input.decode::<Speech>()
        {
            self.conversation.hear(&speech);
            self.step(ctx);
        }
    }

    fn on_reply(&mut self, ctx: &mut Context<'_>, reply: &ReplyEvent<'_>) {
        if self.in_flight != Some(reply.call) {
            return;
        }
        self.in_flight = None;
        match reply.decode::<SpeechSay>() {
            Ok(_) => {
                ctx.info(&format!("said: {}", self.conversation.config.words));
                self.conversation.said(ctx.now());
            }
            Err(e) => {
                ctx.warn(&format!("could not say it: {e}"));
                self.retry_at_ns = ctx.now() + RETRY_NS;
            }
        }
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        if self.exit.is_none() {
            self.step(ctx);
        }
    }

    fn exit_code(&self) -> Option<i32> {
        self.exit
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: i64 = 1_000_000_000;

    fn speech(heard_count: i32, answer: &str) -> Speech {
        Speech {
            heard_count,
            answer: answer.to_owned(),
            ..Speech::default()
        }
    }

    #[test]
    fn a_yes_heard_after_the_words_registers_and_an_old_one_does_not() {
        let mut c = Conversation::new(RegisterConfig::default());
        // An answer from before (another robot, an earlier run) is not for it.
        c.hear(&speech(3, "yes"));
        assert_eq!(c.step(0), Step::Say);
        c.said(0);
        c.hear(&speech(3, "yes"));
        assert_eq!(c.step(S), Step::Wait);
        c.hear(&speech(4, "yes"));
        assert_eq!(c.step(2 * S), Step::Exit(0));
    }

    #[test]
    fn a_no_gives_up_and_silence_asks_once_more_then_gives_up() {
        let mut c = Conversation::new(RegisterConfig::default());
        c.hear(&speech(0, "none"));
        c.said(0);
        c.hear(&speech(1, "no"));
        assert_eq!(c.step(S), Step::Exit(4));

        let mut c = Conversation::new(RegisterConfig::default());
        c.hear(&speech(0, "none"));
        c.said(0);
        assert_eq!(c.step(20 * S), Step::Wait);
        assert_eq!(c.step(21 * S), Step::Say);
        c.said(21 * S);
        assert_eq!(c.step(41 * S), Step::Wait);
        assert_eq!(c.step(42 * S), Step::Exit(4));
    }
}
