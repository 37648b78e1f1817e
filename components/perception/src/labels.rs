//! Labelled frames: where the true objects of each colour class are, a box per object, so
//! that a colour file can be scored ([`crate::scoring`]) and fitted against them.
//!
//! The file is JSON (`lewis tune check --labels FILE.json`):
//!
//! ```json
//! {
//!   "version": 1,
//!   "source": "run.mcap, labelled from the simulator's ground truth",
//!   "min_area_px": 30,
//!   "frames": [
//!     { "frame": "camera_ImageSource-000012",
//!       "objects": [
//!         { "class": "Red", "box": [301, 120, 318, 131] },
//!         { "class": "White", "box": [40, 80, 95, 120], "optional": true }
//!       ] },
//!     { "frame": "camera_ImageSource-000013", "objects": [] }
//!   ]
//! }
//! ```
//!
//! - `frame` names a frame as `lewis tune blobfinder --png` names its pictures: a recorded
//!   image is `TOPIC-SEQ` (the topic without its leading slash, other characters than
//!   letters and digits as `_`, the sequence number in 6 digits), an image file its stem.
//! - `box` is `[left, top, right, bottom]` in pixels, right and bottom included, as
//!   CMVision's regions are.
//! - `optional` objects (too small, mostly hidden) are neither required nor held against a
//!   blob that finds them (PASCAL VOC's "difficult").
//! - A frame listed with no objects is a frame where no class has anything: every blob
//!   there is a false positive. Frames not listed are not scored.
//! - Blobs smaller than `min_area_px` (default 1) are not scored.
//! - A class that no object anywhere in the file is labelled with is not scored by
//!   `lewis tune check` and `lewis tune fit`: there is no truth to judge it by.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// The version of the labels format this code reads and writes.
pub const LABELS_VERSION: u32 = 1;

/// A labels file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Labels {
    /// Format version: [`LABELS_VERSION`].
    pub version: u32,
    /// Where the frames and the labels came from, for people.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub source: String,
    /// Blobs smaller than this are not scored.
    #[serde(default = "default_min_area_px")]
    pub min_area_px: u32,
    /// The labelled frames.
    pub frames: Vec<LabelledFrame>,
}

fn default_min_area_px() -> u32 {
    1
}

/// One labelled frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LabelledFrame {
    /// The frame's name (see the module's documentation).
    pub frame: String,
    /// The objects on it.
    pub objects: Vec<LabelledObject>,
}

/// One true object of one colour class.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LabelledObject {
    /// The colour class's name, as the colour file spells it.
    pub class: String,
    /// Its box: `[left, top, right, bottom]`, px, inclusive.
    #[serde(rename = "box")]
    pub bounds: PixelBox,
    /// Whether a blob may or may not find it.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub optional: bool,
}

/// A box of pixels: `[left, top, right, bottom]`, right and bottom included.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(from = "[u32; 4]", into = "[u32; 4]")]
pub struct PixelBox {
    /// Leftmost column.
    pub left: u32,
    /// Top row.
    pub top: u32,
    /// Rightmost column (included).
    pub right: u32,
    /// Bottom row (included).
    pub bottom: u32,
}

impl From<[u32; 4]> for PixelBox {
    fn from([left, top, right, bottom]: [u32; 4]) -> Self {
        Self {
            left,
            top,
            right,
            bottom,
        }
    }
}

impl From<PixelBox> for [u32; 4] {
    fn from(b: PixelBox) -> Self {
        [b.left, b.top, b.right, b.bottom]
    }
}

impl PixelBox {
    /// Whether the box has its corners in order (left <= right, top <= bottom).
    #[must_use]
    pub fn is_ordered(&self) -> bool {
        self.left <= self.right && self.top <= self.bottom
    }

    /// Its area, in px (0 for a box whose corners are out of order).
    #[must_use]
    pub fn area_px(&self) -> u64 {
        if !self.is_ordered() {
            return 0;
        }
        u64::from(self.right - self.left + 1) * u64::from(self.bottom - self.top + 1)
    }

    /// Intersection over union with `other`: 0 when they do not overlap, 1 when equal.
    #[must_use]
    pub fn iou(&self, other: &Self) -> f64 {
        let overlap = Self {
            left: self.left.max(other.left),
            top: self.top.max(other.top),
            right: self.right.min(other.right),
            bottom: self.bottom.min(other.bottom),
        }
        .area_px();
        let union = self.area_px() + other.area_px() - overlap;
        if union == 0 {
            return 0.0;
        }
        // areas far below 2^52
        overlap as f64 / union as f64
    }
}

/// Why a labels file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum LabelsError {
    /// The file cannot be read.
    #[error("cannot read labels file {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The file is not a labels file, or something in it is wrong.
    #[error("{path}:{line}:{column}: {problem}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        problem: String,
    },
    /// The file cannot be written.
    #[error("cannot write labels file {path}: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
}

impl Labels {
    /// Reads a labels file and checks it against the colour classes it will be scored
    /// with: every class it names must be one of `classes`.
    ///
    /// # Errors
    /// When the file cannot be read, is not JSON of this format, has a box with its corners
    /// out of order, names a frame twice, or names a class not in `classes`; each at its
    /// line and column.
    pub fn load(path: &Path, classes: &[&str]) -> Result<Self, LabelsError> {
        let text = std::fs::read_to_string(path).map_err(|source| LabelsError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path, classes)
    }

    /// [`Labels::load`] on text already read; `path` names it in errors.
    ///
    /// # Errors
    /// As [`Labels::load`], but for reading.
    pub fn parse(text: &str, path: &Path, classes: &[&str]) -> Result<Self, LabelsError> {
        let invalid = |line, column, problem: String| LabelsError::Invalid {
            path: path.to_path_buf(),
            line,
            column,
            problem,
        };
        let labels: Self = serde_json::from_str(text)
            .map_err(|e| invalid(e.line(), e.column(), strip_position(&e.to_string())))?;
        // serde_json keeps no positions once parsed: a problem found now is placed at the
        // first place in the text where its value is written.
        let at = |needle: &str| {
            let offset = text.find(needle).unwrap_or(0);
            lewis_stdx::line_column(text, offset)
        };
        if labels.version != LABELS_VERSION {
            let (line, column) = at("\"version\"");
            return Err(invalid(
                line,
                column,
                format!(
                    "labels format version {} is not known: this Lewis reads version {LABELS_VERSION}",
                    labels.version
                ),
            ));
        }
        let mut seen = BTreeSet::new();
        for frame in &labels.frames {
            if !seen.insert(frame.frame.as_str()) {
                let quoted = serde_json::to_string(&frame.frame).unwrap_or_default();
                let first = text.find(&quoted).map_or(0, |i| i + quoted.len());
                let offset = text[first..].find(&quoted).map_or(first, |i| first + i);
                let (line, column) = lewis_stdx::line_column(text, offset);
                return Err(invalid(
                    line,
                    column,
                    format!(
                        "frame {} is labelled twice: keep one entry per frame",
                        frame.frame
                    ),
                ));
            }
            for object in &frame.objects {
                if !classes.contains(&object.class.as_str()) {
                    let quoted = serde_json::to_string(&object.class).unwrap_or_default();
                    let (line, column) = at(&quoted);
                    let hint = lewis_stdx::closest(&object.class, classes.iter().copied())
                        .map(|c| format!(" (did you mean `{c}`?)"))
                        .unwrap_or_default();
                    return Err(invalid(
                        line,
                        column,
                        format!(
                            "class `{}` (frame {}) is not a class of the colour file{hint}: its classes are {}",
                            object.class,
                            frame.frame,
                            classes.join(", ")
                        ),
                    ));
                }
                if !object.bounds.is_ordered() {
                    let b = object.bounds;
                    let (line, column) = at(&format!("{}", b.left));
                    return Err(invalid(
                        line,
                        column,
                        format!(
                            "box [{}, {}, {}, {}] of {} in frame {} is not [left, top, right, bottom] with left <= right and top <= bottom",
                            b.left, b.top, b.right, b.bottom, object.class, frame.frame
                        ),
                    ));
                }
            }
        }
        Ok(labels)
    }

    /// The labels as the file holds them: pretty JSON, ending in a newline.
    #[must_use]
    pub fn to_json(&self) -> String {
        let mut text = serde_json::to_string_pretty(self).unwrap_or_default();
        text.push('\n');
        text
    }

    /// Writes the labels as pretty JSON ([`Labels::to_json`]), atomically: into a
    /// temporary file beside `path`, then renamed over it, so that a failure half-way (a
    /// full disk, a kill) leaves the file as it was, never half-written.
    ///
    /// # Errors
    /// When the file cannot be written.
    pub fn save(&self, path: &Path) -> Result<(), LabelsError> {
        let error = |source| LabelsError::Write {
            path: path.to_path_buf(),
            source,
        };
        let mut temporary = path.as_os_str().to_owned();
        temporary.push(format!(".{}.tmp", std::process::id()));
        let temporary = PathBuf::from(temporary);
        let written = (|| {
            let mut file = std::fs::File::create(&temporary)?;
            std::io::Write::write_all(&mut file, self.to_json().as_bytes())?;
            // On disk before the rename, so the name never points at a file still empty.
            file.sync_all()?;
            std::fs::rename(&temporary, path)
        })();
        if written.is_err() {
            let _ = std::fs::remove_file(&temporary);
        }
        written.map_err(error)
    }

    /// The labelled frame named `name`, if any.
    #[must_use]
    pub fn frame(&self, name: &str) -> Option<&LabelledFrame> {
        self.frames.iter().find(|f| f.frame == name)
    }
}

/// serde_json ends its messages with ` at line L column C`, which the error already says.
fn strip_position(message: &str) -> String {
    match message.rfind(" at line ") {
        Some(i) => message[..i].to_owned(),
        None => message.to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CLASSES: &[&str] = &["Red", "White", "Black"];

    fn check_error(text: &str, expected: &str) {
        let got = Labels::parse(text, Path::new("l.json"), CLASSES)
            .expect_err("the labels are refused")
            .to_string();
        assert_eq!(got, expected);
    }

    #[test]
    fn a_labels_file_parses_and_writes_back_the_same() {
        let text = r#"{
  "version": 1,
  "source": "test",
  "min_area_px": 30,
  "frames": [
    {
      "frame": "camera_ImageSource-000012",
      "objects": [
        {
          "class": "Red",
          "box": [
            301,
            120,
            318,
            131
          ]
        },
        {
          "class": "White",
          "box": [
            40,
            80,
            95,
            120
          ],
          "optional": true
        }
      ]
    }
  ]
}
"#;
        let labels = Labels::parse(text, Path::new("l.json"), CLASSES).unwrap();
        assert_eq!(labels.min_area_px, 30);
        let frame = labels.frame("camera_ImageSource-000012").unwrap();
        assert_eq!(frame.objects[0].bounds.area_px(), 18 * 12);
        assert!(frame.objects[1].optional);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("l.json");
        labels.save(&path).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), text);
    }

    #[test]
    fn errors_name_the_line_and_what_is_wrong() {
        check_error(
            "{\"version\": 1,\n \"frames\": [{\"frame\": \"a\", \"objects\": [\n {\"class\": \"Blu\", \"box\": [1, 2, 3, 4]}]}]}",
            "l.json:3:12: class `Blu` (frame a) is not a class of the colour file: its classes are Red, White, Black",
        );
        check_error(
            "{\"version\": 1,\n \"frames\": [{\"frame\": \"a\", \"objects\": [\n {\"class\": \"Whit\", \"box\": [1, 2, 3, 4]}]}]}",
            "l.json:3:12: class `Whit` (frame a) is not a class of the colour file (did you mean `White`?): its classes are Red, White, Black",
        );
        check_error(
            "{\"version\": 1,\n \"frames\": [{\"frame\": \"a\", \"objects\": [\n {\"class\": \"Red\", \"box\": [1, 2, 3]}]}]}",
            "l.json:3:34: invalid length 3, expected an array of length 4",
        );
        check_error(
            "{\"version\": 1,\n \"frames\": [{\"frame\": \"a\", \"objects\": [\n {\"class\": \"Red\", \"box\": [9, 2, 3, 4]}]}]}",
            "l.json:3:27: box [9, 2, 3, 4] of Red in frame a is not [left, top, right, bottom] with left <= right and top <= bottom",
        );
        check_error(
            "{\"version\": 1,\n \"frames\": [{\"frame\": \"a\", \"objects\": []},\n {\"frame\": \"a\", \"objects\": []}]}",
            "l.json:3:12: frame a is labelled twice: keep one entry per frame",
        );
        check_error(
            "{\"version\": 2, \"frames\": []}",
            "l.json:1:2: labels format version 2 is not known: this Lewis reads version 1",
        );
        check_error(
            "{\"version\": 1, \"frame\": []}",
            "l.json:1:22: unknown field `frame`, expected one of `version`, `source`, `min_area_px`, `frames`",
        );
        check_error("{\"version\": 1,", "l.json:1:14: EOF while parsing a value");
    }

    #[test]
    fn iou_is_overlap_over_union_of_inclusive_boxes() {
        let b = |l, t, r, bo| PixelBox::from([l, t, r, bo]);
        assert!((b(0, 0, 9, 9).iou(&b(0, 0, 9, 9)) - 1.0).abs() < 1e-12);
        assert!((b(0, 0, 9, 9).iou(&b(5, 0, 14, 9)) - 50.0 / 150.0).abs() < 1e-12);
        assert!(b(0, 0, 9, 9).iou(&b(10, 0, 19, 9)).abs() < 1e-12);
        assert!((b(3, 3, 3, 3).iou(&b(3, 3, 3, 3)) - 1.0).abs() < 1e-12);
    }
}
