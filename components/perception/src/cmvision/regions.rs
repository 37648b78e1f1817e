//! From runs to regions: union-find over 4-connected runs, region statistics, the minimum
//! area, sorting and density merging.

use std::cmp::Reverse;
use std::ops::Range;

use super::config::{ColorClass, MAX_COLORS};

/// Density merging compares every pair of regions of a colour, again after each merge; to
/// bound the time of a frame whatever it shows, only the largest regions of each colour
/// take part (the rest are kept as they are). CMVision merged the few blobs of one colour
/// that a robot's field has; this keeps that and refuses the cubic worst case.
pub const MERGE_LIMIT: usize = 256;

/// A horizontal run of pixels of one colour in one row.
#[derive(Debug, Clone, Copy)]
pub(super) struct Run {
    /// First column.
    pub start: u32,
    /// Last column (inclusive).
    pub end: u32,
    /// Colour id (runs of no colour are not stored).
    pub code: u8,
}

/// A connected region of one colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// Colour id: the index of its class in the [`super::ColorConfig`].
    pub color: u8,
    /// Number of pixels.
    pub area_px: u32,
    /// Leftmost column of the bounding box.
    pub left_px: u32,
    /// Top row of the bounding box.
    pub top_px: u32,
    /// Rightmost column of the bounding box (inclusive).
    pub right_px: u32,
    /// Bottom row of the bounding box (inclusive).
    pub bottom_px: u32,
    /// Mean column of its pixels (pixel x is at x, not x + 0.5).
    pub centroid_x_px: f64,
    /// Mean row of its pixels.
    pub centroid_y_px: f64,
}

impl Region {
    /// Width of the bounding box.
    #[must_use]
    pub fn width_px(&self) -> u32 {
        self.right_px - self.left_px + 1
    }

    /// Height of the bounding box.
    #[must_use]
    pub fn height_px(&self) -> u32 {
        self.bottom_px - self.top_px + 1
    }
}

/// Statistics of a region while it is built; sums stay exact for merging.
#[derive(Debug, Clone, Copy, Default)]
struct Stats {
    code: u8,
    area: u32,
    left: u32,
    top: u32,
    right: u32,
    bottom: u32,
    sum_x: u64,
    sum_y: u64,
    /// Rank of the region's first pixel in raster order: the tie-break of the sort.
    order: u32,
}

impl Stats {
    fn new(run: Run, y: u32, order: u32) -> Self {
        let mut stats = Self {
            code: run.code,
            left: run.start,
            top: y,
            right: run.end,
            bottom: y,
            order,
            ..Self::default()
        };
        stats.add(run, y);
        stats
    }

    #[inline]
    fn add(&mut self, run: Run, y: u32) {
        let len = run.end - run.start + 1;
        self.area += len;
        // The sum of start..=end is (start + end) * len / 2, exactly: one factor is even.
        self.sum_x += u64::from(run.start + run.end) * u64::from(len) / 2;
        self.sum_y += u64::from(y) * u64::from(len);
        self.left = self.left.min(run.start);
        self.right = self.right.max(run.end);
        self.bottom = y;
    }

    fn absorb(&mut self, other: &Self) {
        self.area += other.area;
        self.sum_x += other.sum_x;
        self.sum_y += other.sum_y;
        self.left = self.left.min(other.left);
        self.top = self.top.min(other.top);
        self.right = self.right.max(other.right);
        self.bottom = self.bottom.max(other.bottom);
        self.order = self.order.min(other.order);
    }

    /// `(area_a + area_b) / area of the union box`, CMVision's merge criterion.
    fn merged_density(&self, other: &Self) -> f64 {
        let width = self.right.max(other.right) - self.left.min(other.left) + 1;
        let height = self.bottom.max(other.bottom) - self.top.min(other.top) + 1;
        f64::from(self.area + other.area) / (f64::from(width) * f64::from(height))
    }

    fn region(&self) -> Region {
        let area = f64::from(self.area);
        Region {
            color: self.code,
            area_px: self.area,
            left_px: self.left,
            top_px: self.top,
            right_px: self.right,
            bottom_px: self.bottom,
            centroid_x_px: self.sum_x as f64 / area,
            centroid_y_px: self.sum_y as f64 / area,
        }
    }
}

/// Scratch space and output of the run-to-region stage, reused from frame to frame.
pub(super) struct RegionBuilder {
    parent: Vec<u32>,
    label: Vec<u32>,
    stats: Vec<Stats>,
    grouped: Vec<Stats>,
    regions: Vec<Region>,
    /// `regions[color_starts[c]..color_starts[c + 1]]` are the regions of colour c.
    color_starts: [u32; MAX_COLORS + 1],
}

impl Default for RegionBuilder {
    fn default() -> Self {
        Self {
            parent: Vec::new(),
            label: Vec::new(),
            stats: Vec::new(),
            grouped: Vec::new(),
            regions: Vec::new(),
            color_starts: [0; MAX_COLORS + 1],
        }
    }
}

impl RegionBuilder {
    pub(super) fn regions(&self) -> &[Region] {
        &self.regions
    }

    pub(super) fn regions_of_color(&self, color: u8) -> &[Region] {
        let c = usize::from(color);
        match (self.color_starts.get(c), self.color_starts.get(c + 1)) {
            (Some(&start), Some(&end)) => self
                .regions
                .get(start as usize..end as usize)
                .unwrap_or(&[]),
            _ => &[],
        }
    }

    /// Builds the regions of a frame's runs (`row_starts`: first run of each row, then the
    /// number of runs).
    pub(super) fn build(
        &mut self,
        runs: &[Run],
        row_starts: &[u32],
        colors: &[ColorClass],
        min_area_px: u32,
    ) {
        self.parent.clear();
        self.parent.extend(0..runs.len() as u32);
        let rows = || row_starts.windows(2).map(|w| w[0] as usize..w[1] as usize);
        for (above, below) in rows().zip(rows().skip(1)) {
            connect(runs, &mut self.parent, above, below);
        }
        self.collect_stats(runs, rows());
        self.group_by_color(min_area_px);
        self.sort_and_merge(colors);
    }

    /// One pass over the runs: resolve each run's root and add the run to its region.
    fn collect_stats(&mut self, runs: &[Run], rows: impl Iterator<Item = Range<usize>>) {
        self.stats.clear();
        self.label.clear();
        self.label.resize(runs.len(), 0);
        for (y, row) in rows.enumerate() {
            let y = y as u32;
            for i in row {
                // Roots are only ever linked below smaller indices, so parent[i] <= i and
                // parent[parent[i]] was resolved to its root earlier in this pass.
                let parent = self.parent[i] as usize;
                let root = self.parent[parent] as usize;
                self.parent[i] = root as u32;
                if root == i {
                    self.label[i] = self.stats.len() as u32;
                    self.stats
                        .push(Stats::new(runs[i], y, self.stats.len() as u32));
                } else {
                    let label = self.label[root];
                    self.label[i] = label;
                    self.stats[label as usize].add(runs[i], y);
                }
            }
        }
    }

    /// Counting sort of the regions of at least `min_area_px` by colour, keeping raster order.
    fn group_by_color(&mut self, min_area_px: u32) {
        let mut counts = [0u32; MAX_COLORS + 1];
        let large = |s: &&Stats| s.area >= min_area_px;
        for stats in self.stats.iter().filter(large) {
            counts[usize::from(stats.code)] += 1;
        }
        let mut next = [0u32; MAX_COLORS + 1];
        let mut total = 0;
        for (c, count) in counts.iter().enumerate() {
            self.color_starts[c] = total;
            next[c] = total;
            total += count;
        }
        self.grouped.clear();
        self.grouped.resize(total as usize, Stats::default());
        for stats in self.stats.iter().filter(large) {
            let slot = &mut next[usize::from(stats.code)];
            self.grouped[*slot as usize] = *stats;
            *slot += 1;
        }
    }

    fn sort_and_merge(&mut self, colors: &[ColorClass]) {
        self.regions.clear();
        let mut starts = [0u32; MAX_COLORS + 1];
        for (c, start) in starts.iter_mut().enumerate().take(MAX_COLORS) {
            *start = self.regions.len() as u32;
            let range = self.color_starts[c] as usize..self.color_starts[c + 1] as usize;
            let Some(group) = self.grouped.get_mut(range) else {
                continue;
            };
            sort_by_area(group);
            let threshold = colors.get(c).map_or(0.0, |class| class.merge_density);
            let kept = if threshold > 0.0 {
                density_merge(group, threshold)
            } else {
                group.len()
            };
            self.regions
                .extend(group.iter().take(kept).map(Stats::region));
        }
        starts[MAX_COLORS] = self.regions.len() as u32;
        self.color_starts = starts;
    }
}

fn sort_by_area(group: &mut [Stats]) {
    group.sort_unstable_by_key(|s| (Reverse(s.area), s.order));
}

/// Merges regions of one colour (sorted by area) while some pair's density exceeds
/// `threshold`; returns how many are left at the front of `group`, sorted by area.
fn density_merge(group: &mut [Stats], threshold: f64) -> usize {
    let n = group.len().min(MERGE_LIMIT);
    loop {
        let mut merged = false;
        for i in 0..n {
            if group[i].area == 0 {
                continue;
            }
            for j in i + 1..n {
                if group[j].area != 0 && group[i].merged_density(&group[j]) > threshold {
                    let absorbed = group[j];
                    group[i].absorb(&absorbed);
                    group[j].area = 0;
                    merged = true;
                }
            }
        }
        if !merged {
            break;
        }
    }
    let mut kept = 0;
    for i in 0..group.len() {
        if group[i].area != 0 {
            group[kept] = group[i];
            kept += 1;
        }
    }
    sort_by_area(&mut group[..kept]);
    kept
}

/// Unions the runs of two adjacent rows that overlap in a column and share a colour.
fn connect(runs: &[Run], parent: &mut [u32], above: Range<usize>, below: Range<usize>) {
    let (mut i, mut j) = (above.start, below.start);
    while i < above.end && j < below.end {
        let (a, b) = (runs[i], runs[j]);
        if a.code == b.code && a.start <= b.end && b.start <= a.end {
            union(parent, i, j);
        }
        if a.end < b.end {
            i += 1;
        } else if b.end < a.end {
            j += 1;
        } else {
            i += 1;
            j += 1;
        }
    }
}

/// Root of `i`, halving the path on the way.
fn find(parent: &mut [u32], mut i: usize) -> usize {
    while parent[i] as usize != i {
        let grandparent = parent[parent[i] as usize];
        parent[i] = grandparent;
        i = grandparent as usize;
    }
    i
}

/// Joins the sets of `a` and `b`, linking the larger root below the smaller.
fn union(parent: &mut [u32], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        let (low, high) = if ra < rb { (ra, rb) } else { (rb, ra) };
        parent[high] = low as u32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(area: u32, left: u32, top: u32, right: u32, bottom: u32, order: u32) -> Stats {
        Stats {
            code: 1,
            area,
            left,
            top,
            right,
            bottom,
            sum_x: 0,
            sum_y: 0,
            order,
        }
    }

    #[test]
    fn two_halves_of_a_dense_box_merge_and_a_far_region_does_not() {
        let mut group = vec![
            stats(50, 0, 0, 9, 4, 0),
            stats(40, 0, 6, 9, 9, 1),
            stats(30, 100, 100, 105, 104, 2),
        ];
        let kept = density_merge(&mut group, 0.8);
        assert_eq!(kept, 2);
        assert_eq!((group[0].area, group[0].bottom), (90, 9));
        assert_eq!(group[1].area, 30);
    }

    #[test]
    fn a_sparse_union_box_does_not_merge() {
        let mut group = vec![stats(50, 0, 0, 9, 4, 0), stats(40, 0, 20, 9, 23, 1)];
        assert_eq!(density_merge(&mut group, 0.5), 2);
    }
}
