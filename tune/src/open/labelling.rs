//! Labelled frames on the tuning page: boxes the user draws on frames, a box per true
//! object and class, held here in the labels format `lewis tune check` and `lewis tune fit`
//! read (`lewis_perception::labels`), saved to the labels file, and the live score of the
//! classes as they are now against them (`lewis_perception::scoring`, `tune check`'s code).
//!
//! Boxes are in the camera's full-frame pixels, as the labels file holds them; the page
//! converts its mouse positions with the frame's full size. Labels of frames that the page
//! does not hold (the recording thinned under the memory bound, or frames of another
//! recording) are kept as they were and saved again.

use std::path::{Path, PathBuf};

use lewis_perception::cmvision::Region;
use lewis_perception::labels::{LabelledFrame, LabelledObject, Labels, PixelBox};
use lewis_perception::scoring::Score;
use lewis_perception::sweep::{self, HeldFrame};
use serde::Serialize;

use super::state::State;
use crate::check::{labelled_classes, load_labels};
use crate::label_sim::DEFAULT_MIN_PIXELS;

/// Where the labels of `input` are saved when no `--labels` is given: beside the input,
/// `RUN.labels.json` for `RUN.mcap` (an image file likewise), `labels.json` inside a
/// folder of images, and `labels.json` in the current folder for a glob.
#[must_use]
pub fn default_labels_path(input: &str) -> PathBuf {
    let path = Path::new(input);
    if path.is_dir() {
        return path.join("labels.json");
    }
    if path.is_file() {
        return path.with_extension("labels.json");
    }
    PathBuf::from("labels.json")
}

/// The labels to start from: those of `path` when it exists (read with `tune check`'s
/// parser, checked against `config`'s classes), else none, to be written there by Save.
///
/// # Errors
/// When the file exists but cannot be read or is not a labels file of these classes.
pub fn start_labels(
    path: &Path,
    config: &lewis_perception::ColorConfig,
    source: &str,
) -> anyhow::Result<(Labels, bool)> {
    if path.exists() {
        return Ok((load_labels(path, config)?, true));
    }
    let labels = Labels {
        version: lewis_perception::labels::LABELS_VERSION,
        source: format!("{source}, boxes drawn with `lewis tune open`"),
        min_area_px: DEFAULT_MIN_PIXELS,
        frames: Vec::new(),
    };
    Ok((labels, false))
}

/// One box of a frame, as the page draws it.
#[derive(Debug, Serialize)]
pub struct BoxView {
    /// Its index among the frame's objects (what a removal names).
    pub index: usize,
    /// The class's name.
    pub class: String,
    /// The class's index in the colour file (`None` for a class it does not have).
    pub class_index: Option<usize>,
    /// `[left, top, right, bottom]`, full-frame px, inclusive.
    #[serde(rename = "box")]
    pub bounds: [u32; 4],
    /// Whether the object is optional.
    pub optional: bool,
}

/// The live score of one class.
#[derive(Debug, Serialize)]
pub struct ClassScoreView {
    /// The class's name.
    pub name: String,
    /// Share of blobs that found an object (`None` without blobs).
    pub precision: Option<f64>,
    /// Share of objects found (`None` without objects).
    pub recall: Option<f64>,
    /// Blobs that found an object.
    pub found: u64,
    /// Blobs that found none.
    pub false_blobs: u64,
    /// Objects no blob found.
    pub missed: u64,
}

/// The live score over the labelled frames the page holds.
#[derive(Debug, Serialize)]
pub struct ScoreView {
    /// Labelled frames scored (those held).
    pub frames: u64,
    /// Labelled frames not held, not scored.
    pub not_held: usize,
    /// The classes labelled somewhere, in the colour file's order.
    pub classes: Vec<ClassScoreView>,
}

impl State {
    /// The held frame `frame` and its full-frame size.
    fn labelled_target(&self, frame: usize) -> Result<(&HeldFrame, [u32; 2]), String> {
        let held = self
            .store
            .frames()
            .get(frame)
            .ok_or_else(|| format!("no frame {frame}"))?;
        Ok((held, self.full_size(held)))
    }

    /// The camera's size of a held frame (as recorded; twice the held size when unknown).
    pub fn full_size(&self, held: &HeldFrame) -> [u32; 2] {
        self.full_sizes
            .get(&held.name)
            .copied()
            .unwrap_or([held.width_px * 2, held.height_px * 2])
    }

    /// The boxes of held frame `frame`.
    pub fn boxes(&self, frame: usize) -> Vec<BoxView> {
        let Some(held) = self.store.frames().get(frame) else {
            return Vec::new();
        };
        let Some(labelled) = self.labels.frame(&held.name) else {
            return Vec::new();
        };
        labelled
            .objects
            .iter()
            .enumerate()
            .map(|(index, o)| BoxView {
                index,
                class: o.class.clone(),
                class_index: self.config.colors.iter().position(|c| c.name == o.class),
                bounds: o.bounds.into(),
                optional: o.optional,
            })
            .collect()
    }

    /// The held frames that are labelled (by index), and how many labelled frames are not
    /// held.
    pub fn labelled_frames(&self) -> (Vec<usize>, usize) {
        let held: Vec<usize> = self
            .store
            .frames()
            .iter()
            .enumerate()
            .filter(|(_, f)| self.labels.frame(&f.name).is_some())
            .map(|(i, _)| i)
            .collect();
        let not_held = self.labels.frames.len().saturating_sub(held.len());
        (held, not_held)
    }

    /// Adds a box of class `class` (its index in the colour file) to held frame `frame`;
    /// `bounds` is `[left, top, right, bottom]` in full-frame px, cut at the frame's edge.
    ///
    /// # Errors
    /// When there is no such frame or class, or the box is not on the frame.
    pub fn add_box(&mut self, frame: usize, class: usize, bounds: [u32; 4]) -> Result<(), String> {
        let (held, [width, height]) = self.labelled_target(frame)?;
        let name = held.name.clone();
        let class_name = self
            .config
            .colors
            .get(class)
            .map(|c| c.name.clone())
            .ok_or_else(|| format!("no class {class}"))?;
        let [left, top, right, bottom] = bounds;
        if left > right || top > bottom {
            return Err(format!(
                "box {bounds:?} is not [left, top, right, bottom] with left <= right and top <= bottom"
            ));
        }
        if left >= width || top >= height {
            return Err(format!(
                "box {bounds:?} is outside frame {name} ({width}x{height} px)"
            ));
        }
        let bounds = PixelBox {
            left,
            top,
            right: right.min(width - 1),
            bottom: bottom.min(height - 1),
        };
        let object = LabelledObject {
            class: class_name,
            bounds,
            optional: false,
        };
        match self.labels.frames.iter_mut().find(|f| f.frame == name) {
            Some(labelled) => labelled.objects.push(object),
            None => self.labels.frames.push(LabelledFrame {
                frame: name,
                objects: vec![object],
            }),
        }
        self.labels_changed = true;
        Ok(())
    }

    /// Removes box `index` of held frame `frame`; a frame left without boxes is no longer
    /// labelled (a frame labelled as empty says every blob on it is false, which removing
    /// boxes one by one does not mean).
    ///
    /// # Errors
    /// When there is no such frame or box.
    pub fn remove_box(&mut self, frame: usize, index: usize) -> Result<(), String> {
        let (held, _) = self.labelled_target(frame)?;
        let name = held.name.clone();
        let position = self
            .labels
            .frames
            .iter()
            .position(|f| f.frame == name)
            .ok_or_else(|| format!("frame {name} has no boxes"))?;
        let labelled = &mut self.labels.frames[position];
        if index >= labelled.objects.len() {
            return Err(format!("frame {name} has no box {index}"));
        }
        labelled.objects.remove(index);
        if labelled.objects.is_empty() {
            self.labels.frames.remove(position);
        }
        self.labels_changed = true;
        Ok(())
    }

    /// Writes the labels file (atomically), then reads it back with `tune check`'s parser,
    /// so what was written is known to be what `tune check` and `tune fit` read.
    ///
    /// # Errors
    /// When the file cannot be written, or does not read back as the labels held.
    pub fn save_labels(&mut self) -> anyhow::Result<usize> {
        self.labels.save(&self.labels_path)?;
        let back = load_labels(&self.labels_path, &self.config)?;
        anyhow::ensure!(
            back == self.labels,
            "{}: the labels written do not read back as the labels held",
            self.labels_path.display()
        );
        self.labels_changed = false;
        Ok(self.labels.frames.iter().map(|f| f.objects.len()).sum())
    }

    /// The score of the classes as they are now over the labelled frames held: CMVision on
    /// the held frames (2x2-decimated), each blob's box scaled to full-frame px, scored by
    /// `tune check`'s code. On the full frames `tune check` may differ by a pixel's width at
    /// the blobs' edges.
    ///
    /// # Errors
    /// When the classes cannot be used by CMVision.
    pub fn score(&self) -> anyhow::Result<ScoreView> {
        let scored = labelled_classes(&self.config, &self.labels);
        let mut score = Score::new(self.config.colors.iter().map(|c| c.name.as_str()));
        let mut frames = 0;
        for held in self.store.frames() {
            let Some(labelled) = self.labels.frame(&held.name) else {
                continue;
            };
            let [width, height] = self.full_size(held);
            let regions: Vec<Region> = sweep::regions(&self.config, held)?
                .iter()
                .map(|r| to_full(r, width, height))
                .collect();
            score.add_frame(&regions, labelled, self.labels.min_area_px);
            frames += 1;
        }
        let classes = score
            .classes()
            .iter()
            .filter(|c| scored.contains(&c.name))
            .map(|c| ClassScoreView {
                name: c.name.clone(),
                precision: c.precision(),
                recall: c.recall(),
                found: c.true_positives,
                false_blobs: c.false_positives,
                missed: c.false_negatives,
            })
            .collect();
        Ok(ScoreView {
            frames: score.frames(),
            not_held: self.labels.frames.len().saturating_sub(frames),
            classes,
        })
    }
}

/// A region of a held frame in the full frame's pixels: each held pixel stands for the 2x2
/// block it was taken from.
fn to_full(region: &Region, width: u32, height: u32) -> Region {
    Region {
        area_px: region.area_px.saturating_mul(sweep::PIXELS_PER_HELD_PIXEL),
        left_px: region.left_px * 2,
        top_px: region.top_px * 2,
        right_px: (region.right_px * 2 + 1).min(width.saturating_sub(1)),
        bottom_px: (region.bottom_px * 2 + 1).min(height.saturating_sub(1)),
        centroid_x_px: region.centroid_x_px * 2.0,
        centroid_y_px: region.centroid_y_px * 2.0,
        ..*region
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lewis_perception::ColorConfig;

    const COLORS: &str = "[Colors]\n(255,0,0) 0.000000 1 Red\n(255,255,255) 0.000000 1 White\n\n[Thresholds]\n(0:255, 0:255, 200:255)\n(200:255, 0:255, 0:255)\n";

    fn state(dir: &Path) -> State {
        let config = ColorConfig::from_player_str(COLORS, "c.txt").unwrap();
        let mut state = State::new(
            "run.mcap".into(),
            "c.txt".into(),
            dir.join("tuned.txt"),
            config,
            1 << 20,
        );
        // A 4x4 camera frame, held as 2x2: one red held pixel at (0, 0).
        let mut rgb = vec![0u8; 4 * 4 * 3];
        rgb[..3].copy_from_slice(&[255, 0, 0]);
        let held = HeldFrame::decimate("cam-000001".into(), 0, 4, 4, &rgb).unwrap();
        state.add_frame(held, [4, 4]);
        state.labels_path = dir.join("l.json");
        state
    }

    #[test]
    fn boxes_drawn_are_saved_in_the_labels_format_and_scored() {
        let dir = tempfile::tempdir().unwrap();
        let mut state = state(dir.path());
        state.add_box(0, 0, [0, 0, 1, 9]).unwrap();
        state.add_box(0, 1, [2, 2, 3, 3]).unwrap();
        assert_eq!(state.labelled_frames(), (vec![0], 0));
        let boxes = state.boxes(0);
        // Cut at the frame's edge.
        assert_eq!(boxes[0].bounds, [0, 0, 1, 3]);
        assert_eq!(boxes[1].class, "White");
        state.remove_box(0, 1).unwrap();
        assert_eq!(state.save_labels().unwrap(), 1);
        let back = Labels::load(&state.labels_path, &["Red", "White"]).unwrap();
        assert_eq!(back, state.labels);
        assert_eq!(
            back.frames[0].objects[0].bounds,
            PixelBox::from([0, 0, 1, 3])
        );
        // The red held pixel is the 2x2 block at (0, 0): IoU 0.5 with the box.
        state.labels.min_area_px = 1;
        let score = state.score().unwrap();
        assert_eq!(score.frames, 1);
        assert_eq!(score.classes.len(), 1);
        assert_eq!(score.classes[0].found, 1);
        state.remove_box(0, 0).unwrap();
        assert!(state.labels.frames.is_empty());
    }

    #[test]
    fn bad_boxes_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let mut state = state(dir.path());
        assert_eq!(state.add_box(1, 0, [0, 0, 1, 1]).unwrap_err(), "no frame 1");
        assert_eq!(state.add_box(0, 5, [0, 0, 1, 1]).unwrap_err(), "no class 5");
        assert!(state.add_box(0, 0, [2, 0, 1, 1]).is_err());
        assert!(
            state
                .add_box(0, 0, [4, 0, 5, 1])
                .unwrap_err()
                .contains("outside")
        );
        assert!(state.remove_box(0, 0).is_err());
    }

    #[test]
    fn a_bad_labels_file_is_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.json");
        std::fs::write(&path, "{\"version\": 1, \"frames\": [{\"frame\": \"a\", \"objects\": [{\"class\": \"Blue\", \"box\": [0, 0, 1, 1]}]}]}").unwrap();
        let config = ColorConfig::from_player_str(COLORS, "c.txt").unwrap();
        let e = start_labels(&path, &config, "run.mcap")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with(&format!("{}:1:", path.display())), "{e}");
        assert!(e.contains("class `Blue`"), "{e}");
        let (labels, existed) =
            start_labels(&dir.path().join("new.json"), &config, "run.mcap").unwrap();
        assert!(!existed && labels.frames.is_empty());
    }
}
