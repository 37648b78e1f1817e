//! A whole recording's frames held for interactive tuning (`lewis tune open`): every frame
//! re-segmented by CMVision (the live code) each time a class's range moves, per-class blob
//! counts and areas per frame for the plots, and the ranges refitted from pixels a person
//! marked as in or out of a class.
//!
//! Frames are held 2x2-decimated (every other pixel of every other row: each kept pixel is
//! a real camera value, so a sample is what the camera saw), a quarter of the frame's
//! bytes, under a memory bound: beyond it every other held frame is dropped and the stride
//! doubles, so a recording of any length is held in the bound, evenly thinned. Blob areas
//! are reported in full-frame pixels (the decimated area times 4).

use super::cmvision::{
    ChannelRange, CmVision, ColorConfig, ConfigError, FrameError, Region, RgbFrame, rgb_to_yuv,
};

/// How many full-frame pixels one held pixel stands for (2x2 decimation).
pub const PIXELS_PER_HELD_PIXEL: u32 = 4;

/// One held frame.
#[derive(Debug, Clone)]
pub struct HeldFrame {
    /// A name for it (`camera_ImageSource-000012`).
    pub name: String,
    /// Its recorded time, ns.
    pub time_ns: i64,
    /// Held width, px (half the camera's, rounded up).
    pub width_px: u32,
    /// Held height, px.
    pub height_px: u32,
    /// rgb8, rows top first.
    pub rgb: Vec<u8>,
}

impl HeldFrame {
    /// The 2x2-decimated copy of an rgb8 frame (`rgb.len() == width * height * 3`).
    ///
    /// # Errors
    /// When the pixels do not fit the size.
    pub fn decimate(
        name: String,
        time_ns: i64,
        width_px: u32,
        height_px: u32,
        rgb: &[u8],
    ) -> Result<Self, FrameError> {
        let frame = RgbFrame::new(width_px, height_px, rgb)?;
        let (w, h) = (frame.width_px() as usize, frame.height_px() as usize);
        let (hw, hh) = (w.div_ceil(2), h.div_ceil(2));
        let mut held = Vec::with_capacity(hw * hh * 3);
        for row in frame.data().chunks_exact(w * 3).step_by(2) {
            for pixel in row.chunks_exact(3).step_by(2) {
                held.extend_from_slice(pixel);
            }
        }
        Ok(Self {
            name,
            time_ns,
            // at most MAX_SIDE_PX
            width_px: hw as u32,
            height_px: hh as u32,
            rgb: held,
        })
    }

    /// The frame for CMVision.
    ///
    /// # Errors
    /// Never for a frame made by [`Self::decimate`].
    pub fn rgb_frame(&self) -> Result<RgbFrame<'_>, FrameError> {
        RgbFrame::new(self.width_px, self.height_px, &self.rgb)
    }

    /// The YUV value of the held pixel at (x, y), when inside.
    #[must_use]
    pub fn yuv_at(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        if x >= self.width_px || y >= self.height_px {
            return None;
        }
        let i = (y as usize * self.width_px as usize + x as usize) * 3;
        let p = self.rgb.get(i..i + 3)?;
        Some(rgb_to_yuv(p[0], p[1], p[2]))
    }
}

/// The held frames of a recording, within a memory bound.
#[derive(Debug, Clone)]
pub struct FrameStore {
    frames: Vec<HeldFrame>,
    /// Of the frames offered, every `stride`-th is held.
    stride: usize,
    offered: usize,
    max_bytes: usize,
}

impl FrameStore {
    /// An empty store holding at most `max_bytes` of pixels.
    #[must_use]
    pub fn new(max_bytes: usize) -> Self {
        Self {
            frames: Vec::new(),
            stride: 1,
            offered: 0,
            max_bytes,
        }
    }

    /// Offers the next frame of the recording: held when it falls on the stride.
    pub fn offer(&mut self, frame: HeldFrame) {
        let index = self.offered;
        self.offered += 1;
        if !index.is_multiple_of(self.stride) {
            return;
        }
        self.frames.push(frame);
        while self.frames.len() > 1 && self.bytes() > self.max_bytes {
            // Keep the frames on the doubled stride: those at even positions now.
            let mut position = 0;
            self.frames.retain(|_| {
                position += 1;
                position % 2 == 1
            });
            self.stride *= 2;
        }
    }

    /// The bytes of pixels held.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.frames.iter().map(|f| f.rgb.len()).sum()
    }

    /// The frames held, in recorded order.
    #[must_use]
    pub fn frames(&self) -> &[HeldFrame] {
        &self.frames
    }

    /// One frame in `stride` of the recording is held.
    #[must_use]
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Frames offered (the recording's frames so far).
    #[must_use]
    pub fn offered(&self) -> usize {
        self.offered
    }
}

/// One class's blobs in one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ClassCount {
    /// Blobs.
    pub blobs: u32,
    /// Area of the largest blob, in full-frame px.
    pub largest_px: u32,
    /// Area of all its blobs, in full-frame px.
    pub total_px: u32,
}

/// Re-segments every held frame with `config`: per frame, per class, its blob count and
/// areas. The work the page's plots wait for after a range moves.
///
/// # Errors
/// When the configuration has too many classes.
pub fn sweep(
    config: &ColorConfig,
    frames: &[HeldFrame],
) -> Result<Vec<Vec<ClassCount>>, ConfigError> {
    let mut cmvision = CmVision::new(config)?;
    let classes = config.colors.len();
    Ok(frames
        .iter()
        .map(|frame| {
            let mut counts = vec![ClassCount::default(); classes];
            if let Ok(rgb) = frame.rgb_frame() {
                for region in cmvision.process(rgb) {
                    if let Some(count) = counts.get_mut(usize::from(region.color)) {
                        let area = region.area_px.saturating_mul(PIXELS_PER_HELD_PIXEL);
                        count.blobs += 1;
                        count.largest_px = count.largest_px.max(area);
                        count.total_px = count.total_px.saturating_add(area);
                    }
                }
            }
            counts
        })
        .collect())
}

/// The regions of one held frame (coordinates in held pixels).
///
/// # Errors
/// When the configuration has too many classes or the frame's pixels do not fit its size.
pub fn regions(config: &ColorConfig, frame: &HeldFrame) -> Result<Vec<Region>, SweepError> {
    let mut cmvision = CmVision::new(config)?;
    Ok(cmvision.process(frame.rgb_frame()?).to_vec())
}

/// Why a frame cannot be segmented.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SweepError {
    /// The configuration cannot be used.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The frame's pixels do not fit its size.
    #[error(transparent)]
    Frame(#[from] FrameError),
}

/// Pixels marked on frames: in a class, or not in it.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Samples {
    /// YUV values of pixels in the class.
    pub inside: Vec<[u8; 3]>,
    /// YUV values of pixels not in the class.
    pub outside: Vec<[u8; 3]>,
}

/// The class's ranges refitted to its samples: the smallest box holding every pixel
/// marked in (widened by `margin` levels on each side, for the camera's noise), then, for
/// each pixel marked out that the box still holds, the one bound moved just past it that
/// gives up the fewest pixels marked in (none when some bound can). With no pixel marked
/// in, the box starts from `current`.
#[must_use]
pub fn refit(current: [ChannelRange; 3], samples: &Samples, margin: u8) -> [ChannelRange; 3] {
    let mut ranges = current;
    if !samples.inside.is_empty() {
        for (channel, range) in ranges.iter_mut().enumerate() {
            let values = samples.inside.iter().map(|p| p[channel]);
            let lo = values.clone().min().unwrap_or(0);
            let hi = values.max().unwrap_or(255);
            *range = ChannelRange {
                lo: lo.saturating_sub(margin),
                hi: hi.saturating_add(margin),
            };
        }
    }
    let contains = |r: &[ChannelRange; 3], p: &[u8; 3]| (0..3).all(|c| r[c].contains(p[c]));
    for out in &samples.outside {
        if !contains(&ranges, out) {
            continue;
        }
        // Every way to exclude `out` by one bound: (pixels in lost, the new ranges).
        let mut best: Option<(usize, [ChannelRange; 3])> = None;
        for channel in 0..3 {
            let value = out[channel];
            let mut candidates = Vec::with_capacity(2);
            if let Some(lo) = value.checked_add(1) {
                let mut r = ranges;
                r[channel].lo = lo;
                candidates.push(r);
            }
            if let Some(hi) = value.checked_sub(1) {
                let mut r = ranges;
                r[channel].hi = hi;
                candidates.push(r);
            }
            for r in candidates {
                let lost = samples.inside.iter().filter(|p| !contains(&r, p)).count();
                if best.as_ref().is_none_or(|(fewest, _)| lost < *fewest) {
                    best = Some((lost, r));
                }
            }
        }
        if let Some((_, r)) = best {
            ranges = r;
        }
    }
    ranges
}

#[cfg(test)]
mod tests {
    use super::*;

    fn range(lo: u8, hi: u8) -> ChannelRange {
        ChannelRange { lo, hi }
    }

    #[test]
    fn decimation_keeps_every_other_pixel_of_every_other_row() {
        // 3x3 frame, pixel value = index
        let rgb: Vec<u8> = (0..9u8).flat_map(|i| [i, i, i]).collect();
        let held = HeldFrame::decimate("f".into(), 0, 3, 3, &rgb).unwrap();
        assert_eq!((held.width_px, held.height_px), (2, 2));
        let values: Vec<u8> = held.rgb.chunks(3).map(|p| p[0]).collect();
        assert_eq!(values, [0, 2, 6, 8]);
    }

    #[test]
    fn the_store_thins_evenly_to_stay_in_its_bound() {
        let frame = |i: i64| HeldFrame {
            name: format!("{i}"),
            time_ns: i,
            width_px: 1,
            height_px: 1,
            rgb: vec![0; 10],
        };
        let mut store = FrameStore::new(45);
        for i in 0..16 {
            store.offer(frame(i));
        }
        assert!(store.bytes() <= 45);
        let times: Vec<i64> = store.frames().iter().map(|f| f.time_ns).collect();
        assert_eq!(times, [0, 4, 8, 12]);
        assert_eq!(store.stride(), 4);
        assert_eq!(store.offered(), 16);
    }

    #[test]
    fn refit_holds_the_pixels_in_and_drops_the_pixels_out() {
        let samples = Samples {
            inside: vec![[60, 105, 200], [70, 110, 190]],
            outside: vec![[65, 108, 202]],
        };
        let r = refit([range(0, 255); 3], &samples, 3);
        for p in &samples.inside {
            assert!((0..3).all(|c| r[c].contains(p[c])), "{r:?} {p:?}");
        }
        let out = samples.outside[0];
        assert!(!(0..3).all(|c| r[c].contains(out[c])), "{r:?}");
        assert_eq!(r[0], range(57, 73));
        assert_eq!(r[2], range(187, 201));
    }

    #[test]
    fn sweep_counts_blobs_per_class_in_full_frame_pixels() {
        let config = ColorConfig::from_player_str(
            "[Colors]\n(255,0,0) 0.0 1 Red\n[Thresholds]\n(40:105,94:120,166:225)\n",
            "test",
        )
        .unwrap();
        // 4x2 held frame: two red pixels apart, grey elsewhere.
        let mut rgb = vec![128u8; 4 * 2 * 3];
        for i in [0usize, 3] {
            rgb[i * 3..i * 3 + 3].copy_from_slice(&[210, 25, 25]);
        }
        let frame = HeldFrame {
            name: "f".into(),
            time_ns: 0,
            width_px: 4,
            height_px: 2,
            rgb,
        };
        let counts = sweep(&config, &[frame]).unwrap();
        assert_eq!(
            counts[0][0],
            ClassCount {
                blobs: 2,
                largest_px: 4,
                total_px: 8
            }
        );
    }
}
