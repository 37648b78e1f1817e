//! The report as one HTML page, self-contained (no server, no script, no file beside it):
//! the totals, then each run with its verdicts, its sweeps' plots (replay's
//! [`Sweep::write_png`](lewis_replay::sweep::Sweep::write_png), the same picture as
//! `lewis replay --sweep-fault`) and the mission's picture when the caller can draw one,
//! every image inlined as a data URL. The same report and pictures give the same bytes.

use std::fmt::Write as _;

use crate::report::{SuiteReport, Verdict};

/// Draws the picture of a run (a PNG's bytes), given its name; `None` when it cannot.
pub type Pictures<'a> = &'a dyn Fn(&str) -> Option<Vec<u8>>;

/// The page. `plots` draws a sweep's plot (as [`lewis_replay::sweep::Sweep::png`] does);
/// `pictures` a run's picture.
#[must_use]
pub fn to_html(
    report: &SuiteReport,
    plots: &dyn Fn(&lewis_replay::sweep::Sweep) -> Option<Vec<u8>>,
    pictures: Pictures<'_>,
) -> String {
    let mut h = String::new();
    let t = &report.totals;
    h.push_str(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>lewis test</title>\n<style>\n\
         body{font-family:sans-serif;margin:2em;color:#222;max-width:75em}\n\
         table{border-collapse:collapse;margin:.5em 0 1em}\n\
         td,th{border:1px solid #ccc;padding:.25em .6em;text-align:left;vertical-align:top}\n\
         .passed{color:#1a9641}.failed,.error{color:#d7191c;font-weight:bold}\n\
         .known{color:#b07000}\n\
         code{font-size:.85em;background:#f4f4f4;padding:0 .2em}\n\
         img{max-width:min(100%,60em);border:1px solid #ddd;margin:.3em 0}\n\
         section{border-top:2px solid #ddd;margin-top:1.5em}\n\
         </style>\n</head>\n<body>\n",
    );
    let _ = writeln!(
        h,
        "<h1>lewis test: <span class=\"{}\">{}</span></h1>",
        if report.passed { "passed" } else { "failed" },
        if report.passed { "passed" } else { "failed" }
    );
    let _ = writeln!(
        h,
        "<p>{} cases: {} passed, {} failed, {} known failures, {} errors; {} skipped.</p>",
        t.cases, t.passed, t.failed, t.known_failures, t.errors, t.skipped
    );
    h.push_str("<table>\n<tr><th>run</th><th>length</th><th>loop</th><th>recorded mission</th><th>cases</th></tr>\n");
    for (i, run) in report.runs.iter().enumerate() {
        let bad = run
            .cases
            .iter()
            .filter(|c| matches!(c.verdict, Verdict::Failed | Verdict::Error))
            .count();
        let _ = writeln!(
            h,
            "<tr><td><a href=\"#run-{i}\">{}</a></td><td>{}</td><td>{}</td><td>{}</td>\
             <td class=\"{}\">{} of {} passed</td></tr>",
            esc(&run.name),
            lewis_replay::fault::format_seconds(run.duration_ns),
            if run.closed_loop { "closed" } else { "open" },
            esc(run.recorded_mission.as_deref().unwrap_or("none")),
            if bad == 0 { "passed" } else { "failed" },
            run.cases
                .iter()
                .filter(|c| c.verdict == Verdict::Passed)
                .count(),
            run.cases.len()
        );
    }
    h.push_str("</table>\n");
    if !report.skipped.is_empty() {
        h.push_str("<h2>Skipped</h2>\n<table>\n<tr><th>what</th><th>why</th></tr>\n");
        for s in &report.skipped {
            let _ = writeln!(
                h,
                "<tr><td class=\"{}\">{}</td><td>{}</td></tr>",
                if s.error { "error" } else { "known" },
                esc(&s.what),
                esc(&s.reason)
            );
        }
        h.push_str("</table>\n");
    }
    for (i, run) in report.runs.iter().enumerate() {
        let _ = writeln!(h, "<section id=\"run-{i}\">\n<h2>{}</h2>", esc(&run.name));
        if let Some(from) = &run.imported_from {
            let _ = writeln!(h, "<p>Imported from a {} file.</p>", esc(from));
        }
        h.push_str(
            "<table>\n<tr><th>case</th><th>verdict</th><th>why</th><th>reproduce</th></tr>\n",
        );
        for case in &run.cases {
            let class = match case.verdict {
                Verdict::Passed => "passed",
                Verdict::Failed => "failed",
                Verdict::KnownFailure => "known",
                Verdict::Error => "error",
            };
            let known = case
                .known_failure
                .as_deref()
                .map(|k| format!(" (known: {})", esc(k)))
                .unwrap_or_default();
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td class=\"{class}\">{}</td><td>{}{known}</td><td><code>{}</code></td></tr>",
                esc(&case.name),
                case.verdict.word(),
                esc(&case.reason),
                esc(&case.command)
            );
        }
        h.push_str("</table>\n");
        for sweep in &run.sweeps {
            let _ = writeln!(h, "<h3>Sweep: {}</h3>", esc(&sweep.name));
            if let Some(png) = plots(&sweep.sweep) {
                let _ = writeln!(
                    h,
                    "<img alt=\"the sweep {}\" src=\"data:image/png;base64,{}\">",
                    esc(&sweep.name),
                    base64(&png)
                );
            }
        }
        if let Some(png) = pictures(&run.name) {
            let _ = writeln!(
                h,
                "<h3>The recorded run</h3>\n<img alt=\"the run {}\" src=\"data:image/png;base64,{}\">",
                esc(&run.name),
                base64(&png)
            );
        }
        h.push_str("</section>\n");
    }
    h.push_str("</body>\n</html>\n");
    h
}

fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            c => out.push(c),
        }
    }
    out
}

/// Standard base64 with padding, for data URLs.
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk.first().copied().unwrap_or(0),
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for (i, shift) in [18, 12, 6, 0].into_iter().enumerate() {
            if i <= chunk.len() {
                out.push(char::from(ALPHABET[((n >> shift) & 63) as usize]));
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_is_the_standard_alphabet_with_padding() {
        assert_eq!(base64(b""), "");
        assert_eq!(base64(b"f"), "Zg==");
        assert_eq!(base64(b"fo"), "Zm8=");
        assert_eq!(base64(b"foo"), "Zm9v");
        assert_eq!(base64(b"foobar"), "Zm9vYmFy");
        assert_eq!(base64(&[0xff, 0xfe]), "//4=");
    }
}
