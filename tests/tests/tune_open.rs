//! `lewis tune open`'s page in a real browser: headless Chromium, driven by Playwright
//! (`tools/node/tune.mjs`), on a recording of the simulated robot's camera. The
//! script drags a slider and sees the overlay and the plots change without a reload,
//! marks the red cap's pixels and sees Red's ranges refitted, and saves; here the saved
//! colour file must read back, say where its ranges came from, and hold every marked
//! pixel's YUV value in Red. Then the script drags a box of class Red around the cap and
//! saves the labels; here the labels file must read back with `tune check`'s parser, hold
//! the box where it was dragged, and `lewis tune check` must score the colour file on it.
//!
//! Needs what the supervisor page's test needs (see `lewis_tests::browser`). Screenshots
//! go to `$TMPDIR/lewis-tune-open/` (`first.png`, `slider.png`, `marked.png`,
//! `labelled.png`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::io::{BufRead as _, BufReader};
use std::process::{Command, Stdio};

use lewis_perception::ColorConfig;
use lewis_perception::labels::Labels;
use lewis_tests::browser::{browser_tools, gui_test_dir};
use lewis_tests::{lewis_exe, repo_root};

use crate::tune_labels::record_sim;

/// Kills the server when the test ends, whichever way.
struct Server(std::process::Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn the_tuning_page_redraws_refits_and_saves_in_a_real_browser() {
    let chromium = browser_tools();
    let dir = tempfile::tempdir().unwrap();
    let recording = record_sim(dir.path());
    let saved = dir.path().join("tuned.txt");
    let labels = dir.path().join("cap.labels.json");
    let shots = std::env::temp_dir().join("lewis-tune-open");
    std::fs::create_dir_all(&shots).unwrap();
    let _ = std::fs::remove_file(shots.join("marked.json"));
    let _ = std::fs::remove_file(shots.join("box.json"));
    let colors = repo_root().join("robots/colors/conference.txt");

    let mut server = Server(
        Command::new(lewis_exe())
            .args(["tune", "open"])
            .arg(&recording)
            .arg("--colors")
            .arg(&colors)
            .arg("--save")
            .arg(&saved)
            .arg("--labels")
            .arg(&labels)
            .args(["--port", "0", "--no-browser"])
            .stdout(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let mut line = String::new();
    let mut said = BufReader::new(server.0.stdout.take().unwrap());
    said.read_line(&mut line).unwrap();
    let mut labels_line = String::new();
    said.read_line(&mut labels_line).unwrap();
    assert_eq!(
        labels_line.trim_end(),
        format!(
            "labels: none yet; \"Save labels\" writes {}",
            labels.display()
        )
    );
    let url = line
        .split_whitespace()
        .find(|w| w.starts_with("http://127.0.0.1:"))
        .unwrap_or_else(|| panic!("no address in {line:?}"))
        .to_owned();

    let browser = Command::new("node")
        .arg(gui_test_dir().join("tune.mjs"))
        .arg(&url)
        .arg(&shots)
        .env("LEWIS_CHROMIUM", &chromium)
        .current_dir(gui_test_dir())
        .output()
        .unwrap();
    drop(server);
    let stdout = String::from_utf8_lossy(&browser.stdout);
    let stderr = String::from_utf8_lossy(&browser.stderr);
    assert!(
        browser.status.success() && stdout.contains("gui-test: ok"),
        "the browser test failed:\n{stdout}\n{stderr}"
    );
    for shot in ["first.png", "slider.png", "marked.png", "labelled.png"] {
        assert!(shots.join(shot).is_file(), "no screenshot {shot}");
    }

    let marked: Vec<[u8; 3]> =
        serde_json::from_str(&std::fs::read_to_string(shots.join("marked.json")).unwrap()).unwrap();
    assert!(marked.len() >= 2, "{marked:?}");
    let text = std::fs::read_to_string(&saved).unwrap();
    assert!(
        text.starts_with("# Tuned with `lewis tune open` on "),
        "{text}"
    );
    assert!(text.contains("# Red: refitted to "), "{text}");
    assert!(text.contains("# Yellow: unchanged."), "{text}");
    let config = ColorConfig::load(&saved).unwrap();
    let red = config.colors.iter().find(|c| c.name == "Red").unwrap();
    for yuv in &marked {
        assert!(
            red.contains_yuv(*yuv),
            "{yuv:?} outside the saved Red {red:?}"
        );
    }
    // The other classes are as they were.
    let shipped = ColorConfig::load(&colors).unwrap();
    assert_eq!(config.colors[1..], shipped.colors[1..]);

    // The box dragged, in the labels file as `tune check` reads it.
    let dragged: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(shots.join("box.json")).unwrap()).unwrap();
    let frame = dragged["frame"].as_str().unwrap();
    let dragged: Vec<u32> = serde_json::from_value(dragged["box"].clone()).unwrap();
    let classes: Vec<&str> = shipped.colors.iter().map(|c| c.name.as_str()).collect();
    let read = Labels::load(&labels, &classes).unwrap();
    assert_eq!(read.frames.len(), 1, "{read:?}");
    let labelled = read.frame(frame).unwrap();
    assert_eq!(labelled.objects.len(), 1, "{labelled:?}");
    let cap = &labelled.objects[0];
    assert_eq!(cap.class, "Red");
    let got: [u32; 4] = cap.bounds.into();
    for (g, d) in got.iter().zip(&dragged) {
        assert!(g.abs_diff(*d) <= 2, "box {got:?}, dragged {dragged:?}");
    }
    let check = Command::new(lewis_exe())
        .args(["tune", "check"])
        .arg(&recording)
        .arg("--colors")
        .arg(&colors)
        .arg("--labels")
        .arg(&labels)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&check.stdout);
    assert!(
        check.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&check.stderr)
    );
    assert!(
        stdout.starts_with("1 labelled frames of ") && stdout.contains("\nRed: precision "),
        "{stdout}"
    );
}

#[test]
fn a_bad_labels_file_stops_the_tuning_page_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let images = dir.path().join("images");
    std::fs::create_dir(&images).unwrap();
    std::fs::copy(
        repo_root().join("docs/src/images/challenge-run.png"),
        images.join("a.png"),
    )
    .unwrap();
    let labels = dir.path().join("bad.json");
    std::fs::write(
        &labels,
        "{\"version\": 1,\n \"frames\": [{\"frame\": \"a\", \"objects\": [\n {\"class\": \"Cap\", \"box\": [1, 2, 3, 4]}]}]}",
    )
    .unwrap();
    let output = Command::new(lewis_exe())
        .args(["tune", "open"])
        .arg(&images)
        .arg("--colors")
        .arg(repo_root().join("robots/colors/conference.txt"))
        .arg("--labels")
        .arg(&labels)
        .args(["--port", "0", "--no-browser"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "{}:3:12: class `Cap` (frame a) is not a class of the colour file: its classes are Red, Yellow, Blue, Pink, White, Black",
            labels.display()
        )),
        "{stderr}"
    );
}
