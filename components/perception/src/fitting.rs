//! Choosing colour classes' YUV ranges from labelled frames (`lewis tune fit`): a
//! deterministic coordinate ascent from a starting colour file, one bound at a time, over
//! CMVision (the live code) and the score of [`crate::scoring`].
//!
//! Each round tries moving every bound of every fitted class (Y, U and V, low and high)
//! by a step, down and up, and keeps each move that raises the mean F1 of the fitted
//! classes; rounds repeat at the same step until nothing improves, then the step halves,
//! from 32 levels to 1. The F1 of whole blobs is flat over most moves of one bound (an
//! object is found only once all three channels take it in), so where it ties, the move is
//! judged by the pixels, channel by channel: the share of the labelled boxes' pixels whose
//! value the range takes in, less the share of the other pixels'. It finds a local optimum near the starting file, which is what a
//! person tuning by hand wants: the classes they had, made better on what they labelled.

use super::cmvision::{ChannelRange, CmVision, ColorConfig, ConfigError, FrameError, RgbFrame};
use super::labels::LabelledFrame;
use super::scoring::Score;

/// The steps of the search, in levels, largest first.
const STEPS: [u8; 6] = [32, 16, 8, 4, 2, 1];

/// Rounds at one step before moving to the next, whatever still improves.
const MAX_ROUNDS_PER_STEP: usize = 4;

/// A decoded frame and its labels.
#[derive(Debug, Clone)]
pub struct LabelledImage {
    /// Width, in px.
    pub width_px: u32,
    /// Height, in px.
    pub height_px: u32,
    /// rgb8 pixels, rows top first.
    pub rgb: Vec<u8>,
    /// Its labels.
    pub labels: LabelledFrame,
}

/// Why frames cannot be scored.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ScoreError {
    /// The colour configuration cannot be used.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A frame's pixels are not an image CMVision takes.
    #[error("frame {frame}: {source}")]
    Frame {
        /// The frame's name.
        frame: String,
        /// What is wrong.
        source: FrameError,
    },
}

/// The score of `config` over `images`, blobs under `min_area_px` left out.
///
/// # Errors
/// When the configuration has too many classes or a frame's pixels do not fit its size.
pub fn score(
    config: &ColorConfig,
    images: &[LabelledImage],
    min_area_px: u32,
) -> Result<Score, ScoreError> {
    Ok(evaluate(config, images, min_area_px, &[])?.0)
}

/// What the search maximises: the mean F1 of the fitted classes, then, between equals,
/// how well their ranges separate the labelled boxes' pixels from the rest.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Objective {
    mean_f1: f64,
    pixels: f64,
}

impl Objective {
    fn beats(self, other: Self) -> bool {
        const EPSILON: f64 = 1e-12;
        self.mean_f1 > other.mean_f1 + EPSILON
            || (self.mean_f1 > other.mean_f1 - EPSILON && self.pixels > other.pixels + EPSILON)
    }
}

/// Per fitted class and channel, how many pixels of each value lie inside the class's
/// labelled boxes and outside them, over all frames: the tie-breaker of the search. One
/// bound's move changes it even when no blob changes, in the direction of the labelled
/// pixels (a range that takes in more of the boxes' values and fewer of the rest's).
struct ChannelHistograms {
    /// `[class][channel][value]`: (inside, outside).
    counts: Vec<[[(u64, u64); 256]; 3]>,
    /// Per class: pixels inside, outside.
    totals: Vec<(u64, u64)>,
}

impl ChannelHistograms {
    fn new(config: &ColorConfig, images: &[LabelledImage], fitted: &[usize]) -> Self {
        let mut counts = vec![[[(0u64, 0u64); 256]; 3]; fitted.len()];
        let mut totals = vec![(0u64, 0u64); fitted.len()];
        for image in images {
            let width = image.width_px as usize;
            for (slot, &class) in fitted.iter().enumerate() {
                let Some(name) = config.colors.get(class).map(|c| c.name.as_str()) else {
                    continue;
                };
                let boxes: Vec<_> = image
                    .labels
                    .objects
                    .iter()
                    .filter(|o| o.class == name)
                    .map(|o| o.bounds)
                    .collect();
                for (i, pixel) in image.rgb.chunks_exact(3).enumerate() {
                    // within a frame of at most 2^15 px a side
                    let (x, y) = ((i % width.max(1)) as u32, (i / width.max(1)) as u32);
                    let inside = boxes.iter().any(|b| {
                        (b.left..=b.right).contains(&x) && (b.top..=b.bottom).contains(&y)
                    });
                    let yuv = super::cmvision::rgb_to_yuv(pixel[0], pixel[1], pixel[2]);
                    for (channel, value) in yuv.into_iter().enumerate() {
                        let cell = &mut counts[slot][channel][usize::from(value)];
                        if inside {
                            cell.0 += 1;
                        } else {
                            cell.1 += 1;
                        }
                    }
                    if inside {
                        totals[slot].0 += 1;
                    } else {
                        totals[slot].1 += 1;
                    }
                }
            }
        }
        Self { counts, totals }
    }

    /// The mean over fitted classes of, per channel, the share of inside pixels its range
    /// takes in less the share of outside pixels.
    fn separation(&self, config: &ColorConfig, fitted: &[usize]) -> f64 {
        let mut sum = 0.0;
        for (slot, &class) in fitted.iter().enumerate() {
            let Some(color) = config.colors.get(class) else {
                continue;
            };
            let (inside_total, outside_total) = self.totals[slot];
            for (channel, range) in [color.y, color.u, color.v].into_iter().enumerate() {
                if range.lo > range.hi {
                    continue;
                }
                let cells =
                    &self.counts[slot][channel][usize::from(range.lo)..=usize::from(range.hi)];
                let (inside, outside) = cells
                    .iter()
                    .fold((0u64, 0u64), |(i, o), &(ci, co)| (i + ci, o + co));
                // pixel counts far below 2^52
                sum += inside as f64 / inside_total.max(1) as f64
                    - outside as f64 / outside_total.max(1) as f64;
            }
        }
        sum / fitted.len().max(1) as f64
    }
}

/// The score of `config` over `images` and the mean F1 of the classes `fitted`.
fn evaluate(
    config: &ColorConfig,
    images: &[LabelledImage],
    min_area_px: u32,
    fitted: &[usize],
) -> Result<(Score, f64), ScoreError> {
    let mut cmvision = CmVision::new(config)?;
    let mut score = Score::new(config.colors.iter().map(|c| c.name.as_str()));
    for image in images {
        let frame =
            RgbFrame::new(image.width_px, image.height_px, &image.rgb).map_err(|source| {
                ScoreError::Frame {
                    frame: image.labels.frame.clone(),
                    source,
                }
            })?;
        let regions = cmvision.process(frame);
        let _ = score.add_frame(regions, &image.labels, min_area_px);
    }
    let classes = score.classes();
    let f1: f64 = fitted
        .iter()
        .filter_map(|&i| classes.get(i))
        .map(super::scoring::ClassScore::f1)
        .sum();
    // a handful of classes
    let mean_f1 = f1 / fitted.len().max(1) as f64;
    Ok((score, mean_f1))
}

/// What [`fit`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The fitted configuration (the classes not fitted as they were).
    pub config: ColorConfig,
    /// The starting configuration's score.
    pub before: Score,
    /// The fitted configuration's score.
    pub after: Score,
    /// The configurations scored.
    pub evaluations: usize,
}

/// Fits the ranges of the classes `fitted` (indices into `start`'s classes) to `images`
/// by coordinate ascent (see the module's documentation), maximising their mean F1.
///
/// # Errors
/// As [`score`].
pub fn fit(
    start: &ColorConfig,
    images: &[LabelledImage],
    min_area_px: u32,
    fitted: &[usize],
) -> Result<Fit, ScoreError> {
    let histograms = ChannelHistograms::new(start, images, fitted);
    let (before, mean_f1) = evaluate(start, images, min_area_px, fitted)?;
    let mut best_value = Objective {
        mean_f1,
        pixels: histograms.separation(start, fitted),
    };
    let mut best = start.clone();
    let mut best_score = before.clone();
    let mut evaluations = 1;
    for step in STEPS {
        for _ in 0..MAX_ROUNDS_PER_STEP {
            let mut improved = false;
            for &class in fitted {
                for channel in 0..3 {
                    for high_end in [false, true] {
                        for up in [false, true] {
                            let Some(candidate) = moved(&best, class, channel, high_end, up, step)
                            else {
                                continue;
                            };
                            let (candidate_score, mean_f1) =
                                evaluate(&candidate, images, min_area_px, fitted)?;
                            evaluations += 1;
                            let value = Objective {
                                mean_f1,
                                pixels: histograms.separation(&candidate, fitted),
                            };
                            if value.beats(best_value) {
                                (best, best_score, best_value) =
                                    (candidate, candidate_score, value);
                                improved = true;
                            }
                        }
                    }
                }
            }
            if !improved {
                break;
            }
        }
    }
    Ok(Fit {
        config: best,
        before,
        after: best_score,
        evaluations,
    })
}

/// `config` with one bound of one class moved by `step` levels, or `None` when the move
/// leaves 0..=255, reverses the range, or the class does not exist.
fn moved(
    config: &ColorConfig,
    class: usize,
    channel: usize,
    high_end: bool,
    up: bool,
    step: u8,
) -> Option<ColorConfig> {
    let mut candidate = config.clone();
    let color = candidate.colors.get_mut(class)?;
    let range: &mut ChannelRange = match channel {
        0 => &mut color.y,
        1 => &mut color.u,
        _ => &mut color.v,
    };
    let bound = if high_end {
        &mut range.hi
    } else {
        &mut range.lo
    };
    *bound = if up {
        bound.checked_add(step)?
    } else {
        bound.checked_sub(step)?
    };
    (range.lo <= range.hi).then_some(candidate)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmvision::{ColorClass, rgb_to_yuv};
    use crate::labels::{LabelledObject, PixelBox};

    const RED: [u8; 3] = [200, 30, 30];
    const DARK_RED: [u8; 3] = [120, 20, 20];

    /// A 40x30 grey frame with a bright red square and a dark red square.
    fn image(name: &str) -> LabelledImage {
        let (w, h) = (40u32, 30u32);
        let mut rgb = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let pixel = match (x, y) {
                    (5..=14, 5..=14) => RED,
                    (25..=34, 5..=14) => DARK_RED,
                    _ => [128, 128, 128],
                };
                rgb.extend_from_slice(&pixel);
            }
        }
        let object = |l, r| LabelledObject {
            class: "Red".into(),
            bounds: PixelBox::from([l, 5, r, 14]),
            optional: false,
        };
        LabelledImage {
            width_px: w,
            height_px: h,
            rgb,
            labels: LabelledFrame {
                frame: name.into(),
                objects: vec![object(5, 14), object(25, 34)],
            },
        }
    }

    #[test]
    fn fitting_widens_a_class_to_take_in_what_was_labelled_and_no_more() {
        let [y, u, v] = rgb_to_yuv(RED[0], RED[1], RED[2]);
        let around = |c: u8| ChannelRange {
            lo: c - 3,
            hi: c + 3,
        };
        let start = ColorConfig {
            colors: vec![ColorClass {
                name: "Red".into(),
                display_rgb: RED,
                merge_density: 0.0,
                expected_regions: 0,
                y: around(y),
                u: around(u),
                v: around(v),
            }],
            min_area_px: 1,
        };
        let images = [image("a"), image("b")];
        let fit = fit(&start, &images, 10, &[0]).unwrap();
        let red = fit.before.class("Red").unwrap();
        assert_eq!((red.true_positives, red.false_negatives), (2, 2));
        let red = fit.after.class("Red").unwrap();
        assert_eq!(
            (red.true_positives, red.false_positives, red.false_negatives),
            (4, 0, 0)
        );
        let dark = rgb_to_yuv(DARK_RED[0], DARK_RED[1], DARK_RED[2]);
        assert!(fit.config.colors[0].contains_yuv(dark));
        assert!(!fit.config.colors[0].contains_yuv(rgb_to_yuv(128, 128, 128)));
        // The same input, the same search.
        assert_eq!(super::fit(&start, &images, 10, &[0]).unwrap(), fit);
    }
}
