//! What the tuning page shows: the colour classes as they are now, the held frames, the
//! pixels marked per class, and the last sweep over the recording.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard};
use std::time::Instant;

use lewis_perception::ColorConfig;
use lewis_perception::cmvision::ChannelRange;
use lewis_perception::labels::Labels;
use lewis_perception::sweep::{self, ClassCount, FrameStore, HeldFrame, Samples};
use serde::Serialize;

/// Levels added on each side of the marked pixels' values when refitting (the camera's
/// pixel noise).
const REFIT_MARGIN: u8 = 3;

/// Locks the state; a handler that panicked left it consistent (every change is one
/// assignment), so a poisoned lock is taken as it is.
pub fn lock(state: &Mutex<State>) -> MutexGuard<'_, State> {
    state
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The tuning session.
pub struct State {
    /// The recording or images, as given.
    pub source: String,
    /// The colour file started from.
    pub colors_path: PathBuf,
    /// Where Save writes.
    pub save_path: PathBuf,
    /// The classes as they are now.
    pub config: ColorConfig,
    /// The held frames.
    pub store: FrameStore,
    /// Whether the sign detector runs on the frame shown (`--signs`).
    pub signs: bool,
    /// Whether frames are still being read.
    pub loading: bool,
    /// Why reading the frames stopped early.
    pub load_error: Option<String>,
    /// Per class: the pixels marked.
    pub samples: Vec<Samples>,
    /// Per class: the frames its pixels were marked on.
    pub sampled_frames: Vec<BTreeSet<String>>,
    /// Per class: whether its ranges were moved by hand since the last refit.
    pub moved_by_hand: Vec<bool>,
    /// The labelled frames: loaded from the labels file, changed by the page's boxes.
    pub labels: Labels,
    /// The labels file: where they were read from and Save labels writes.
    pub labels_path: PathBuf,
    /// Whether the labels were changed since they were read or saved.
    pub labels_changed: bool,
    /// Each frame's size as the camera took it (held frames are half of it), by name.
    pub full_sizes: BTreeMap<String, [u32; 2]>,
    /// The last sweep and the frames it covered.
    sweep: Option<(usize, Vec<Vec<ClassCount>>)>,
}

/// One class as the page shows it.
#[derive(Debug, Serialize)]
pub struct ClassView {
    /// Its name.
    pub name: String,
    /// Its display colour.
    pub rgb: [u8; 3],
    /// Y range, inclusive.
    pub y: [u8; 2],
    /// U range.
    pub u: [u8; 2],
    /// V range.
    pub v: [u8; 2],
    /// Pixels marked in.
    pub inside: usize,
    /// Pixels marked out.
    pub outside: usize,
}

/// The per-class plots over the recording.
#[derive(Debug, Serialize)]
pub struct Plots {
    /// Each held frame's time from the first, s.
    pub times_s: Vec<f64>,
    /// Per class.
    pub classes: Vec<ClassPlot>,
    /// How long the sweep took, ms (0 when it was cached).
    pub sweep_ms: f64,
}

/// One class's plot.
#[derive(Debug, Serialize)]
pub struct ClassPlot {
    /// Its name.
    pub name: String,
    /// Its display colour.
    pub rgb: [u8; 3],
    /// Blobs per held frame.
    pub blobs: Vec<u32>,
    /// Largest blob's area per held frame, in full-frame px.
    pub largest_px: Vec<u32>,
}

fn pair(range: ChannelRange) -> [u8; 2] {
    [range.lo, range.hi]
}

fn range([lo, hi]: [u8; 2]) -> ChannelRange {
    ChannelRange { lo, hi }
}

impl State {
    /// A session starting from `config`, holding at most `max_bytes` of frames, with no
    /// labels (to be set from the labels file) saved to `labels.json`.
    pub fn new(
        source: String,
        colors_path: PathBuf,
        save_path: PathBuf,
        config: ColorConfig,
        max_bytes: usize,
    ) -> Self {
        let classes = config.colors.len();
        Self {
            source,
            colors_path,
            save_path,
            config,
            store: FrameStore::new(max_bytes),
            signs: false,
            loading: true,
            load_error: None,
            samples: vec![Samples::default(); classes],
            sampled_frames: vec![BTreeSet::new(); classes],
            moved_by_hand: vec![false; classes],
            labels: Labels {
                version: lewis_perception::labels::LABELS_VERSION,
                source: String::new(),
                min_area_px: 1,
                frames: Vec::new(),
            },
            labels_path: PathBuf::from("labels.json"),
            labels_changed: false,
            full_sizes: BTreeMap::new(),
            sweep: None,
        }
    }

    /// Holds one more frame of the recording, `full_size` as the camera took it.
    pub fn add_frame(&mut self, frame: HeldFrame, full_size: [u32; 2]) {
        self.full_sizes.insert(frame.name.clone(), full_size);
        self.store.offer(frame);
    }

    /// The classes as the page shows them.
    pub fn classes(&self) -> Vec<ClassView> {
        self.config
            .colors
            .iter()
            .zip(&self.samples)
            .map(|(c, s)| ClassView {
                name: c.name.clone(),
                rgb: c.display_rgb,
                y: pair(c.y),
                u: pair(c.u),
                v: pair(c.v),
                inside: s.inside.len(),
                outside: s.outside.len(),
            })
            .collect()
    }

    /// Sets a class's ranges (from the page's sliders).
    ///
    /// # Errors
    /// When there is no such class.
    pub fn set_ranges(&mut self, class: usize, yuv: [[u8; 2]; 3]) -> Result<(), String> {
        let color = self
            .config
            .colors
            .get_mut(class)
            .ok_or_else(|| format!("no class {class}"))?;
        [color.y, color.u, color.v] = yuv.map(range);
        if let Some(moved) = self.moved_by_hand.get_mut(class) {
            *moved = true;
        }
        self.sweep = None;
        Ok(())
    }

    /// Marks the held pixels of a rectangle of frame `frame` as in (or out of) `class`,
    /// and refits the class's ranges. Returns the YUV values marked.
    ///
    /// # Errors
    /// When there is no such frame or class, or the rectangle holds no pixel.
    pub fn mark(
        &mut self,
        frame: usize,
        class: usize,
        [x, y, w, h]: [u32; 4],
        outside: bool,
    ) -> Result<Vec<[u8; 3]>, String> {
        let held = self
            .store
            .frames()
            .get(frame)
            .ok_or_else(|| format!("no frame {frame}"))?;
        let color = self
            .config
            .colors
            .get_mut(class)
            .ok_or_else(|| format!("no class {class}"))?;
        let mut marked = Vec::new();
        // A drag past the frame is cut at its edge; a rectangle is at most the frame.
        for py in y..y.saturating_add(h.max(1)).min(held.height_px) {
            for px in x..x.saturating_add(w.max(1)).min(held.width_px) {
                marked.extend(held.yuv_at(px, py));
            }
        }
        if marked.is_empty() {
            return Err(format!("no pixel of frame {frame} at {x},{y} {w}x{h}"));
        }
        let (Some(samples), Some(frames)) = (
            self.samples.get_mut(class),
            self.sampled_frames.get_mut(class),
        ) else {
            return Err(format!("no class {class}"));
        };
        if outside {
            samples.outside.extend_from_slice(&marked);
        } else {
            samples.inside.extend_from_slice(&marked);
        }
        frames.insert(held.name.clone());
        [color.y, color.u, color.v] =
            sweep::refit([color.y, color.u, color.v], samples, REFIT_MARGIN);
        if let Some(moved) = self.moved_by_hand.get_mut(class) {
            *moved = false;
        }
        self.sweep = None;
        Ok(marked)
    }

    /// The plots over every held frame, swept again when a range has moved.
    pub fn plots(&mut self) -> Plots {
        let held = self.store.frames();
        let started = Instant::now();
        let fresh = self
            .sweep
            .as_ref()
            .is_some_and(|(covered, _)| *covered == held.len());
        if !fresh {
            // The classes' count was checked at the start: the sweep cannot fail.
            let counts = sweep::sweep(&self.config, held).unwrap_or_default();
            self.sweep = Some((held.len(), counts));
        }
        let sweep_ms = if fresh {
            0.0
        } else {
            started.elapsed().as_secs_f64() * 1e3
        };
        let counts = self
            .sweep
            .as_ref()
            .map(|(_, c)| c.as_slice())
            .unwrap_or_default();
        let first = held.first().map_or(0, |f| f.time_ns);
        // nanoseconds of a recording, far below 2^52 after the subtraction
        let times_s = held
            .iter()
            .map(|f| (f.time_ns - first) as f64 / 1e9)
            .collect();
        let classes = self
            .config
            .colors
            .iter()
            .enumerate()
            .map(|(k, c)| ClassPlot {
                name: c.name.clone(),
                rgb: c.display_rgb,
                blobs: counts
                    .iter()
                    .map(|f| f.get(k).map_or(0, |c| c.blobs))
                    .collect(),
                largest_px: counts
                    .iter()
                    .map(|f| f.get(k).map_or(0, |c| c.largest_px))
                    .collect(),
            })
            .collect();
        Plots {
            times_s,
            classes,
            sweep_ms,
        }
    }

    /// The colour file as Save writes it: Player's format, with a comment saying where
    /// each class's ranges came from.
    pub fn colour_file(&self) -> String {
        let mut comment = format!(
            "Tuned with `lewis tune open` on {}, from {}.",
            self.source,
            self.colors_path.display()
        );
        for (k, color) in self.config.colors.iter().enumerate() {
            let samples = self.samples.get(k).cloned().unwrap_or_default();
            let frames = self.sampled_frames.get(k).cloned().unwrap_or_default();
            let by_hand = self.moved_by_hand.get(k).copied().unwrap_or(false);
            let origin = if samples.inside.is_empty() && samples.outside.is_empty() {
                if by_hand {
                    "set by hand".to_owned()
                } else {
                    "unchanged".to_owned()
                }
            } else {
                let mut origin = format!(
                    "refitted to {} pixels marked in and {} out, on {}",
                    samples.inside.len(),
                    samples.outside.len(),
                    frames.into_iter().collect::<Vec<_>>().join(", ")
                );
                if by_hand {
                    origin.push_str(", then moved by hand");
                }
                origin
            };
            let _ = write!(comment, "\n{}: {origin}.", color.name);
        }
        self.config.to_player_string(&comment)
    }
}
