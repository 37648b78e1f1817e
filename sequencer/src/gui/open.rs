//! Opening the supervisor's page in the desktop's browser, when there is a desktop: the
//! system's own opener (`xdg-open` on Linux and the BSDs, `open` on macOS), started and
//! not waited for; a machine without a display or without a browser gets one line saying
//! so, never an error (the URL is printed anyway).

use std::io::Write;
use std::process::{Command, Stdio};

/// The program that opens a URL in the desktop's browser here.
const OPENER: &str = if cfg!(target_os = "macos") {
    "open"
} else {
    "xdg-open"
};

/// Opens `url` in the desktop's browser. Says on `out` in one line why it did not, when
/// it did not (no display, no opener, the opener failed: then in the background).
pub fn open_in_browser(url: &str, out: impl Write + Send + 'static) {
    open_with(OPENER, has_display(), url, out);
}

/// Whether a browser can be shown: always on macOS, else with an X or Wayland display.
fn has_display() -> bool {
    cfg!(target_os = "macos")
        || ["DISPLAY", "WAYLAND_DISPLAY"]
            .iter()
            .any(|var| std::env::var_os(var).is_some_and(|v| !v.is_empty()))
}

/// [`open_in_browser`] with the opener and the display given (for tests).
pub(crate) fn open_with(
    opener: &str,
    display: bool,
    url: &str,
    mut out: impl Write + Send + 'static,
) {
    if !display {
        let _ = writeln!(
            out,
            "supervisor's page: no display here to open it on; open the URL above in a browser"
        );
        return;
    }
    let spawned = Command::new(opener)
        .arg(url)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn();
    let mut child = match spawned {
        Ok(child) => child,
        Err(e) => {
            let _ = writeln!(
                out,
                "supervisor's page: cannot start {opener} ({e}); open the URL above in a browser"
            );
            return;
        }
    };
    // Reaped in the background: the opener returns when the browser has the page, or
    // says it found none.
    let opener = opener.to_owned();
    let waited = std::thread::Builder::new()
        .name("lewis-seq-open".into())
        .spawn(move || match child.wait() {
            Ok(status) if status.success() => {}
            Ok(status) => {
                let _ = writeln!(
                    out,
                    "supervisor's page: {opener} found no browser ({status}); open the URL above in one"
                );
            }
            Err(e) => tracing::debug!("cannot wait for {opener}: {e}"),
        });
    if let Err(e) = waited {
        tracing::debug!("cannot wait for the browser's opener: {e}");
    }
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};
    use std::time::{Duration, Instant};

    use super::*;

    /// What was written, shared with the opener's thread.
    #[derive(Clone, Default)]
    struct Lines(Arc<Mutex<Vec<u8>>>);

    impl Write for Lines {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Lines {
        fn text(&self) -> String {
            String::from_utf8(self.0.lock().unwrap().clone()).unwrap()
        }

        /// The text once it has a line, within 10 s.
        fn wait(&self) -> String {
            let deadline = Instant::now() + Duration::from_secs(10);
            while self.text().is_empty() && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(10));
            }
            self.text()
        }
    }

    #[test]
    fn without_a_display_one_line_says_so() {
        let out = Lines::default();
        open_with("true", false, "http://127.0.0.1:8042/", out.clone());
        assert_eq!(
            out.text(),
            "supervisor's page: no display here to open it on; open the URL above in a browser\n"
        );
    }

    #[test]
    fn an_opener_that_is_missing_or_fails_is_one_line_and_one_that_works_is_none() {
        let out = Lines::default();
        open_with("/nonexistent/xdg-open", true, "http://x/", out.clone());
        let text = out.text();
        assert!(
            text.starts_with("supervisor's page: cannot start /nonexistent/xdg-open"),
            "{text}"
        );
        assert_eq!(text.lines().count(), 1);

        let out = Lines::default();
        open_with("false", true, "http://x/", out.clone());
        let text = out.wait();
        assert!(
            text.starts_with("supervisor's page: false found no browser"),
            "{text}"
        );

        let out = Lines::default();
        open_with("true", true, "http://x/", out.clone());
        std::thread::sleep(Duration::from_millis(200));
        assert_eq!(out.text(), "");
    }
}
