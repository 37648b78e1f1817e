//! The report as JUnit XML, as CI systems read it (the schema of Jenkins' JUnit and xUnit
//! plugins): one `testsuite` per run, one `testcase` per case with its verdict, its reason
//! and the command that reproduces it; the inputs skipped in a `testsuite` of their own.
//! Times are the recordings' lengths, so the same report gives the same bytes.

use std::fmt::Write as _;

use crate::report::{Case, SuiteReport, Verdict};

/// The report as a JUnit XML document.
#[must_use]
pub fn to_junit(report: &SuiteReport) -> String {
    let mut x = String::new();
    x.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let t = &report.totals;
    let _ = writeln!(
        x,
        "<testsuites name=\"lewis test\" tests=\"{}\" failures=\"{}\" errors=\"{}\">",
        t.cases + t.skipped,
        t.failed,
        t.errors
    );
    for run in &report.runs {
        let count = |v: Verdict| run.cases.iter().filter(|c| c.verdict == v).count();
        let _ = writeln!(
            x,
            "  <testsuite name=\"{}\" tests=\"{}\" failures=\"{}\" errors=\"{}\" skipped=\"{}\" \
             time=\"{}\">",
            attr(&run.name),
            run.cases.len(),
            count(Verdict::Failed),
            count(Verdict::Error),
            count(Verdict::KnownFailure),
            seconds(run.duration_ns)
        );
        for case in &run.cases {
            test_case(&mut x, &run.name, case, run.duration_ns);
        }
        x.push_str("  </testsuite>\n");
    }
    if !report.skipped.is_empty() {
        let errors = report.skipped.iter().filter(|s| s.error).count();
        let _ = writeln!(
            x,
            "  <testsuite name=\"skipped inputs\" tests=\"{}\" failures=\"0\" errors=\"{errors}\" \
             skipped=\"{}\" time=\"0\">",
            report.skipped.len(),
            report.skipped.len() - errors
        );
        for skipped in &report.skipped {
            let _ = writeln!(
                x,
                "    <testcase name=\"{}\" classname=\"skipped inputs\" time=\"0\">",
                attr(&skipped.what)
            );
            let element = if skipped.error { "error" } else { "skipped" };
            let _ = writeln!(
                x,
                "      <{element} message=\"{}\"/>",
                attr(&skipped.reason)
            );
            x.push_str("    </testcase>\n");
        }
        x.push_str("  </testsuite>\n");
    }
    x.push_str("</testsuites>\n");
    x
}

fn test_case(x: &mut String, run: &str, case: &Case, duration_ns: i64) {
    let _ = writeln!(
        x,
        "    <testcase name=\"{}\" classname=\"{}\" time=\"{}\">",
        attr(&case.name),
        attr(run),
        seconds(duration_ns)
    );
    let detail = format!(
        "{}\nrun: {run}\n{}{}reproduce: {}",
        case.reason,
        case.fault_at_ns
            .map(|t| format!("time: {}\n", lewis_replay::fault::format_seconds(t)))
            .unwrap_or_default(),
        case.state_at_fault
            .as_deref()
            .map(|s| format!("state: {s}\n"))
            .unwrap_or_default(),
        case.command
    );
    match case.verdict {
        Verdict::Passed => {}
        Verdict::Failed => {
            let _ = writeln!(
                x,
                "      <failure type=\"expectation\" message=\"{}\">{}</failure>",
                attr(&case.reason),
                text(&detail)
            );
        }
        Verdict::Error => {
            let _ = writeln!(
                x,
                "      <error type=\"replay\" message=\"{}\">{}</error>",
                attr(&case.reason),
                text(&detail)
            );
        }
        Verdict::KnownFailure => {
            let _ = writeln!(
                x,
                "      <skipped message=\"known failure: {}\">{}</skipped>",
                attr(case.known_failure.as_deref().unwrap_or_default()),
                text(&detail)
            );
        }
    }
    let _ = writeln!(
        x,
        "      <system-out>{}</system-out>",
        text(&format!("{}\nreproduce: {}", case.reason, case.command))
    );
    x.push_str("    </testcase>\n");
}

/// Seconds with millisecond precision, as the schema's time pattern takes them.
fn seconds(ns: i64) -> String {
    let ms = ns.max(0) / 1_000_000;
    format!("{}.{:03}", ms / 1000, ms % 1000)
}

/// Text content: `&`, `<` and `>` escaped, characters XML 1.0 cannot hold dropped.
fn text(s: &str) -> String {
    escape(s, false)
}

/// An attribute's value, quotes and line ends escaped too.
fn attr(s: &str) -> String {
    escape(s, true)
}

fn escape(s: &str, attribute: bool) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' if attribute => out.push_str("&quot;"),
            '\n' if attribute => out.push_str("&#10;"),
            '\t' if attribute => out.push_str("&#9;"),
            '\r' => out.push_str("&#13;"),
            // XML 1.0 has no place for the other control characters, even escaped.
            c if (c as u32) < 0x20 && c != '\n' && c != '\t' => out.push('\u{fffd}'),
            '\u{fffe}' | '\u{ffff}' => out.push('\u{fffd}'),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_and_attributes_are_escaped_and_control_characters_replaced() {
        assert_eq!(attr("a<b & \"c\"\nd"), "a&lt;b &amp; &quot;c&quot;&#10;d");
        assert_eq!(text("x > y\n\u{1}z"), "x &gt; y\n\u{fffd}z");
        assert_eq!(seconds(12_345_678_901), "12.345");
        assert_eq!(seconds(-5), "0.000");
    }
}
