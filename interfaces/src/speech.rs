//! What a Speech provider does with its state, whoever speaks and listens (the simulator's
//! registrar, espeak-ng and a supervisor): an utterance said is counted and kept, an answer
//! heard is `yes` or `no` (anything else is refused) and is counted and kept. Written once
//! here, beside the message, so every provider answers `say` and `hear` alike.

use crate::msg::{Speech, SpeechAnswer};

/// An answer `hear` refuses: neither `yes` nor `no`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("hear: answer `{0}`, expected yes or no")]
pub struct NotAnAnswer(pub String);

impl Speech {
    /// The state of a provider that has said nothing and heard nothing (`answer` is `none`).
    #[must_use]
    pub fn silent() -> Self {
        Self {
            answer: SpeechAnswer::None.as_str().to_owned(),
            ..Self::default()
        }
    }

    /// Counts and keeps an utterance; returns its number (`said_count` now).
    pub fn said(&mut self, text: &str) -> i32 {
        self.said_count = self.said_count.saturating_add(1);
        text.clone_into(&mut self.last_said);
        self.said_count
    }

    /// Takes the answer of a `hear` command: `answer` must be `yes` or `no`; it is counted
    /// and kept with its words `text`.
    ///
    /// # Errors
    /// When `answer` is neither `yes` nor `no` (the state is then unchanged).
    pub fn hear(&mut self, answer: &str, text: &str) -> Result<SpeechAnswer, NotAnAnswer> {
        match SpeechAnswer::parse(answer) {
            Some(heard @ (SpeechAnswer::Yes | SpeechAnswer::No)) => {
                self.heard(heard, text);
                Ok(heard)
            }
            _ => Err(NotAnAnswer(answer.to_owned())),
        }
    }

    /// Counts and keeps an answer heard (`answer` with its words `text`).
    pub fn heard(&mut self, answer: SpeechAnswer, text: &str) {
        self.heard_count = self.heard_count.saturating_add(1);
        self.answer = answer.as_str().to_owned();
        text.clone_into(&mut self.last_heard);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yes_and_no_are_heard_and_anything_else_is_refused_unchanged() {
        let mut speech = Speech::silent();
        assert_eq!(speech.answer, "none");
        assert_eq!(speech.said("Hello, I am Lewis"), 1);
        assert_eq!(speech.hear("yes", "registered"), Ok(SpeechAnswer::Yes));
        assert_eq!(
            (
                speech.heard_count,
                speech.answer.as_str(),
                speech.last_heard.as_str()
            ),
            (1, "yes", "registered")
        );
        let before = speech.clone();
        let refused = speech.hear("maybe", "hm").unwrap_err();
        assert_eq!(
            refused.to_string(),
            "hear: answer `maybe`, expected yes or no"
        );
        assert_eq!(speech.hear("none", ""), Err(NotAnAnswer("none".into())));
        assert_eq!(speech, before);
        assert_eq!(speech.hear("no", ""), Ok(SpeechAnswer::No));
        assert_eq!((speech.heard_count, speech.said_count), (2, 1));
        assert_eq!(speech.last_said, "Hello, I am Lewis");
    }
}
