//! How an error reaches the terminal: its whole chain of causes on one line, each said once.

/// The error and its causes, joined by `: `. A cause already said by the message before it
/// is left out: many of our errors name their cause in their own text (`cannot read FILE:
/// No such file or directory`) and also keep it as their `source`, so that a program can
/// still walk the chain; printed in full, the person would read the cause twice.
#[must_use]
pub fn error_text(err: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in err.chain() {
        let said = cause.to_string();
        if text.ends_with(&said) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&said);
    }
    text
}

#[cfg(test)]
mod tests {
    use super::error_text;

    #[derive(Debug, thiserror::Error)]
    #[error("cannot read robot file r.toml: {source}")]
    struct Naming {
        source: std::io::Error,
    }

    #[test]
    fn a_cause_named_by_its_error_is_said_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let err = anyhow::Error::new(Naming { source: io }).context("cannot start the robot");
        assert_eq!(
            error_text(&err),
            "cannot start the robot: cannot read robot file r.toml: no such file"
        );
    }

    #[test]
    fn a_cause_not_named_is_added() {
        let err = anyhow::anyhow!("disk full").context("cannot write run.mcap");
        assert_eq!(error_text(&err), "cannot write run.mcap: disk full");
    }
}
