//! What the generated vocabularies mean beyond their words, where every reader would
//! otherwise decide it again. The words themselves are declared once, as `<value>`s in
//! `idl/*.xml`, and generated into [`crate::msg`] (`MoverStatus`, `HealthState`, ...).

use crate::msg::MoverStatus;

impl MoverStatus {
    /// The goal is over (arrived or failed): nothing more will happen without a new goal.
    #[must_use]
    pub const fn is_final(self) -> bool {
        matches!(self, Self::Arrived | Self::Failed)
    }
}

#[cfg(test)]
mod tests {
    use std::str::FromStr;

    use crate::msg::{
        BrokerAction, BrokerRequestReplyStatus, CommandLogStatus, HealthState, HostLinkEvent,
        LogLineLevel, LogLineStream, MoverStatus, SequencerEntry, SequencerKind,
        SequencerSupervision, UnansweredCallStatus,
    };

    /// Every value of a vocabulary goes to its word and back, by `parse`, `FromStr` and
    /// `Display`, and compares equal to its word.
    macro_rules! round_trip {
        ($($vocabulary:ty),*) => {$(
            assert_eq!(<$vocabulary>::ALL.len(), <$vocabulary>::WORDS.len());
            for (value, word) in <$vocabulary>::ALL.into_iter().zip(<$vocabulary>::WORDS) {
                assert_eq!(value.as_str(), word);
                assert_eq!(<$vocabulary>::parse(word), Some(value));
                assert_eq!(<$vocabulary>::from_str(word), Ok(value));
                assert_eq!(value.to_string(), word);
                assert_eq!(String::from(value), word);
                let owned: String = word.into();
                assert!(word == value && *word == value && owned == value);
            }
            assert_eq!(<$vocabulary>::parse(""), None);
        )*};
    }

    #[test]
    fn every_vocabulary_round_trips_through_its_words() {
        round_trip!(
            BrokerAction,
            BrokerRequestReplyStatus,
            CommandLogStatus,
            HealthState,
            HostLinkEvent,
            LogLineLevel,
            LogLineStream,
            MoverStatus,
            SequencerEntry,
            SequencerKind,
            SequencerSupervision,
            UnansweredCallStatus
        );
    }

    #[test]
    fn the_words_are_those_on_the_wire() {
        assert_eq!(
            MoverStatus::WORDS,
            ["idle", "moving", "arrived", "blocked", "failed"]
        );
        assert_eq!(HealthState::OutOfService.as_str(), "out-of-service");
        assert_eq!(BrokerAction::AskForHelp.as_str(), "ask-for-help");
        assert_eq!(SequencerEntry::MissionStarted.as_str(), "mission_started");
        assert_eq!(MoverStatus::FIELD, "Mover.status");
        assert_eq!(BrokerRequestReplyStatus::FIELD, "BrokerRequestReply.status");
    }

    #[test]
    fn an_unknown_word_is_an_error_that_lists_the_words() {
        let err = "arived".parse::<MoverStatus>().unwrap_err();
        assert_eq!(
            err.to_string(),
            "`arived` is not a value of `Mover.status`; it holds one of: idle, moving, arrived, blocked, failed"
        );
        assert_eq!(err.word, "arived");
        assert!("".parse::<HealthState>().is_err());
        assert!("Arrived".parse::<MoverStatus>().is_err());
    }

    #[test]
    fn only_arrived_and_failed_are_final() {
        let finals: Vec<MoverStatus> = MoverStatus::ALL
            .into_iter()
            .filter(|s| s.is_final())
            .collect();
        assert_eq!(finals, [MoverStatus::Arrived, MoverStatus::Failed]);
    }

    #[test]
    fn the_schema_constants_are_read_by_the_dynamic_decoder() {
        use crate::Struct;
        let schema = crate::dynamic::MessageSchema::parse(
            crate::msg::Mover::SCHEMA_NAME,
            crate::msg::Mover::SCHEMA_TEXT,
        )
        .unwrap();
        let root = schema.definition(schema.root()).unwrap();
        let constants: Vec<String> = root
            .constants
            .iter()
            .map(|c| format!("{}={}", c.name, c.value.display_limited(4)))
            .collect();
        assert_eq!(
            constants,
            [
                "STATUS_IDLE=\"idle\"",
                "STATUS_MOVING=\"moving\"",
                "STATUS_ARRIVED=\"arrived\"",
                "STATUS_BLOCKED=\"blocked\"",
                "STATUS_FAILED=\"failed\""
            ]
        );
        let message = crate::msg::Mover {
            status: MoverStatus::Blocked.into(),
            ..crate::msg::Mover::default()
        };
        let decoded = crate::dynamic::Decoder::from_schema(&schema)
            .unwrap()
            .decode(&crate::cdr::to_vec(&message))
            .unwrap();
        assert_eq!(
            decoded.get("status").and_then(|v| v.as_str()),
            Some("blocked")
        );
    }
}
