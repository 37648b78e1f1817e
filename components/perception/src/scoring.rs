//! Scoring blobs against labelled frames ([`crate::labels`]): per colour class, a blob
//! matches a labelled box when their intersection over union is at least [`MATCH_IOU`],
//! each blob and each box matching at most once (the best pairs first); then precision
//! (the share of blobs that found an object) and recall (the share of objects found).

use std::fmt;

use super::cmvision::Region;
use super::labels::{LabelledFrame, PixelBox};

/// The intersection over union at which a blob finds a labelled object (PASCAL VOC's).
pub const MATCH_IOU: f64 = 0.5;

/// The counts of one colour class over the frames scored.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ClassScore {
    /// The class's name.
    pub name: String,
    /// Blobs that found a labelled object.
    pub true_positives: u64,
    /// Blobs that found none.
    pub false_positives: u64,
    /// Labelled objects that no blob found.
    pub false_negatives: u64,
}

impl ClassScore {
    /// The share of blobs that found an object; `None` without blobs.
    #[must_use]
    pub fn precision(&self) -> Option<f64> {
        ratio(
            self.true_positives,
            self.true_positives + self.false_positives,
        )
    }

    /// The share of labelled objects found; `None` without labelled objects.
    #[must_use]
    pub fn recall(&self) -> Option<f64> {
        ratio(
            self.true_positives,
            self.true_positives + self.false_negatives,
        )
    }

    /// The harmonic mean of precision and recall (0 when either is 0 or missing), what
    /// `lewis tune fit` maximises: one number that neither a class finding everything nor
    /// a class finding nothing scores well on.
    #[must_use]
    pub fn f1(&self) -> f64 {
        let found = 2 * self.true_positives;
        let all = found + self.false_positives + self.false_negatives;
        ratio(found, all).unwrap_or(0.0)
    }

    /// Whether the class was scored at all (it had a blob or a labelled object).
    #[must_use]
    pub fn is_scored(&self) -> bool {
        self.true_positives + self.false_positives + self.false_negatives > 0
    }
}

fn ratio(part: u64, whole: u64) -> Option<f64> {
    // counts far below 2^52
    (whole > 0).then(|| part as f64 / whole as f64)
}

fn share(value: Option<f64>) -> String {
    value.map_or_else(|| "-".to_owned(), |v| format!("{v:.3}"))
}

impl fmt::Display for ClassScore {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: precision {} recall {} ({} found, {} false, {} missed)",
            self.name,
            share(self.precision()),
            share(self.recall()),
            self.true_positives,
            self.false_positives,
            self.false_negatives
        )
    }
}

/// The score of a colour configuration over labelled frames, per class.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Score {
    classes: Vec<ClassScore>,
    frames: u64,
}

impl Score {
    /// An empty score for the classes `names` (in colour id order).
    #[must_use]
    pub fn new<'a>(names: impl IntoIterator<Item = &'a str>) -> Self {
        Self {
            classes: names
                .into_iter()
                .map(|name| ClassScore {
                    name: name.to_owned(),
                    ..ClassScore::default()
                })
                .collect(),
            frames: 0,
        }
    }

    /// Adds one labelled frame: its `regions` (as CMVision found them; their `color` is the
    /// class index) against its labels. Regions smaller than `min_area_px` are left out,
    /// and so are labels of classes this score does not have. Returns the frame's mistakes.
    pub fn add_frame(
        &mut self,
        regions: &[Region],
        labels: &LabelledFrame,
        min_area_px: u32,
    ) -> Vec<Mistake> {
        self.frames += 1;
        let mut mistakes = Vec::new();
        for (color, class) in self.classes.iter_mut().enumerate() {
            let blobs: Vec<PixelBox> = regions
                .iter()
                .filter(|r| usize::from(r.color) == color && r.area_px >= min_area_px)
                .map(box_of)
                .collect();
            let objects: Vec<(PixelBox, bool)> = labels
                .objects
                .iter()
                .filter(|o| o.class == class.name)
                .map(|o| (o.bounds, o.optional))
                .collect();
            let (counts, wrong) = match_boxes_listing(&blobs, &objects);
            class.true_positives += counts.true_positives;
            class.false_positives += counts.false_positives;
            class.false_negatives += counts.false_negatives;
            mistakes.extend(wrong.into_iter().map(|(kind, bounds)| Mistake {
                class: class.name.clone(),
                kind,
                bounds,
            }));
        }
        mistakes
    }

    /// Per class, in colour id order.
    #[must_use]
    pub fn classes(&self) -> &[ClassScore] {
        &self.classes
    }

    /// The class named `name`.
    #[must_use]
    pub fn class(&self, name: &str) -> Option<&ClassScore> {
        self.classes.iter().find(|c| c.name == name)
    }

    /// Frames scored.
    #[must_use]
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// The mean F1 of the classes scored (0 when none was).
    #[must_use]
    pub fn mean_f1(&self) -> f64 {
        let scored: Vec<f64> = self
            .classes
            .iter()
            .filter(|c| c.is_scored())
            .map(ClassScore::f1)
            .collect();
        if scored.is_empty() {
            return 0.0;
        }
        // a handful of classes
        scored.iter().sum::<f64>() / scored.len() as f64
    }
}

/// A region's bounding box.
#[must_use]
pub fn box_of(region: &Region) -> PixelBox {
    PixelBox {
        left: region.left_px,
        top: region.top_px,
        right: region.right_px,
        bottom: region.bottom_px,
    }
}

/// What went wrong with one box of a frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mistake {
    /// The class.
    pub class: String,
    /// A false blob, or a missed object.
    pub kind: MistakeKind,
    /// The blob's or the object's box.
    pub bounds: PixelBox,
}

/// The two kinds of [`Mistake`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MistakeKind {
    /// A blob that found no labelled object.
    FalseBlob,
    /// A labelled object that no blob found.
    Missed,
}

impl fmt::Display for Mistake {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = self.bounds;
        let what = match self.kind {
            MistakeKind::FalseBlob => "false blob",
            MistakeKind::Missed => "missed object",
        };
        write!(
            f,
            "{} {what} at [{}, {}, {}, {}]",
            self.class, b.left, b.top, b.right, b.bottom
        )
    }
}

/// [`match_boxes`], and the false blobs and the missed objects.
fn match_boxes_listing(
    blobs: &[PixelBox],
    objects: &[(PixelBox, bool)],
) -> (ClassScore, Vec<(MistakeKind, PixelBox)>) {
    let (score, blob_matched, object_matched) = matching(blobs, objects);
    let mut wrong = Vec::new();
    for (b, blob) in blobs.iter().enumerate() {
        if !blob_matched[b] && !near_optional(blob, objects) {
            wrong.push((MistakeKind::FalseBlob, *blob));
        }
    }
    for ((object, optional), matched) in objects.iter().zip(&object_matched) {
        if !optional && !matched {
            wrong.push((MistakeKind::Missed, *object));
        }
    }
    (score, wrong)
}

fn near_optional(blob: &PixelBox, objects: &[(PixelBox, bool)]) -> bool {
    objects
        .iter()
        .any(|(object, optional)| *optional && blob.iou(object) >= MATCH_IOU)
}

/// Matches the blobs of one class in one frame to its labelled objects (box, optional):
/// the pairs at [`MATCH_IOU`] or more, best first, each blob and object once. A blob
/// matched to an optional object, or left over but overlapping one at [`MATCH_IOU`], is
/// not counted; an optional object left over is not missed.
#[must_use]
pub fn match_boxes(blobs: &[PixelBox], objects: &[(PixelBox, bool)]) -> ClassScore {
    matching(blobs, objects).0
}

/// The counts of [`match_boxes`], and which blobs and objects were matched.
fn matching(
    blobs: &[PixelBox],
    objects: &[(PixelBox, bool)],
) -> (ClassScore, Vec<bool>, Vec<bool>) {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (b, blob) in blobs.iter().enumerate() {
        for (o, (object, _)) in objects.iter().enumerate() {
            let iou = blob.iou(object);
            if iou >= MATCH_IOU {
                pairs.push((iou, b, o));
            }
        }
    }
    // Best first; ties in the order given, so the result never depends on the sort.
    pairs.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let mut blob_matched = vec![false; blobs.len()];
    let mut object_matched = vec![false; objects.len()];
    let mut score = ClassScore::default();
    for (_, b, o) in pairs {
        if blob_matched[b] || object_matched[o] {
            continue;
        }
        blob_matched[b] = true;
        object_matched[o] = true;
        if !objects[o].1 {
            score.true_positives += 1;
        }
    }
    for (b, blob) in blobs.iter().enumerate() {
        if !blob_matched[b] && !near_optional(blob, objects) {
            score.false_positives += 1;
        }
    }
    score.false_negatives = objects
        .iter()
        .zip(&object_matched)
        .filter(|((_, optional), matched)| !optional && !**matched)
        .count() as u64;
    (score, blob_matched, object_matched)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::labels::LabelledObject;

    fn b(l: u32, t: u32, r: u32, bo: u32) -> PixelBox {
        PixelBox::from([l, t, r, bo])
    }

    /// (true positives, false positives, false negatives) of matching.
    fn check(blobs: &[PixelBox], objects: &[(PixelBox, bool)], expected: (u64, u64, u64)) {
        let s = match_boxes(blobs, objects);
        assert_eq!(
            (s.true_positives, s.false_positives, s.false_negatives),
            expected,
            "{blobs:?} against {objects:?}"
        );
    }

    #[test]
    fn a_blob_finds_an_object_at_half_overlap_or_more() {
        check(&[b(0, 0, 9, 9)], &[(b(0, 0, 9, 9), false)], (1, 0, 0));
        // IoU 1/3: a false blob and a missed object.
        check(&[b(0, 0, 9, 9)], &[(b(5, 0, 14, 9), false)], (0, 1, 1));
        // IoU exactly 0.5 (100 of 200 px).
        check(&[b(0, 0, 9, 19)], &[(b(0, 0, 9, 9), false)], (1, 0, 0));
        check(&[], &[(b(0, 0, 9, 9), false)], (0, 0, 1));
        check(&[b(0, 0, 9, 9)], &[], (0, 1, 0));
    }

    #[test]
    fn each_blob_and_object_match_once_best_pair_first() {
        // Two blobs over one object: the better one finds it, the other is false.
        check(
            &[b(0, 0, 9, 11), b(0, 0, 9, 9)],
            &[(b(0, 0, 9, 9), false)],
            (1, 1, 0),
        );
        // One blob over two objects: one found, one missed.
        check(
            &[b(0, 0, 9, 9)],
            &[(b(0, 0, 9, 9), false), (b(0, 0, 9, 10), false)],
            (1, 0, 1),
        );
    }

    #[test]
    fn optional_objects_are_neither_required_nor_held_against_a_blob() {
        check(&[], &[(b(0, 0, 9, 9), true)], (0, 0, 0));
        check(&[b(0, 0, 9, 9)], &[(b(0, 0, 9, 9), true)], (0, 0, 0));
        check(
            &[b(0, 0, 9, 9), b(0, 0, 9, 10)],
            &[(b(0, 0, 9, 9), true)],
            (0, 0, 0),
        );
    }

    #[test]
    fn a_score_counts_per_class_and_leaves_out_small_blobs() {
        let region = |color, l, t, r, bo, area_px| Region {
            color,
            area_px,
            left_px: l,
            top_px: t,
            right_px: r,
            bottom_px: bo,
            centroid_x_px: 0.0,
            centroid_y_px: 0.0,
        };
        let labels = LabelledFrame {
            frame: "f".into(),
            objects: vec![
                LabelledObject {
                    class: "Red".into(),
                    bounds: b(10, 10, 19, 19),
                    optional: false,
                },
                LabelledObject {
                    class: "White".into(),
                    bounds: b(100, 10, 119, 19),
                    optional: false,
                },
            ],
        };
        let mut score = Score::new(["Red", "White", "Black"]);
        let mistakes = score.add_frame(
            &[
                region(0, 10, 10, 19, 19, 100),
                region(0, 50, 50, 51, 51, 4),
                region(1, 0, 0, 5, 5, 36),
                region(2, 0, 0, 5, 5, 36),
            ],
            &labels,
            10,
        );
        let lines: Vec<String> = score.classes().iter().map(ToString::to_string).collect();
        assert_eq!(
            lines,
            [
                "Red: precision 1.000 recall 1.000 (1 found, 0 false, 0 missed)",
                "White: precision 0.000 recall 0.000 (0 found, 1 false, 1 missed)",
                "Black: precision 0.000 recall - (0 found, 1 false, 0 missed)",
            ]
        );
        assert!((score.mean_f1() - 1.0 / 3.0).abs() < 1e-12);
        let mistakes: Vec<String> = mistakes.iter().map(ToString::to_string).collect();
        assert_eq!(
            mistakes,
            [
                "White false blob at [0, 0, 5, 5]",
                "White missed object at [100, 10, 119, 19]",
                "Black false blob at [0, 0, 5, 5]",
            ]
        );
        assert_eq!(score.frames(), 1);
    }
}
