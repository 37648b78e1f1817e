//! Steady-state CMVision processing allocates nothing: a counting global allocator watches.
#![allow(
    clippy::expect_used,
    reason = "test helpers fail loudly on broken fixtures"
)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use lewis_perception::cmvision::{ChannelRange, CmVision, ColorClass, ColorConfig, RgbFrame};

struct CountingAllocator;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards every call to the system allocator unchanged; only counts.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: the caller's contract is passed on.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract is passed on.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: the caller's contract is passed on.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

#[test]
fn processing_the_same_kind_of_frame_again_allocates_nothing() {
    let band = |lo, hi| ColorClass {
        name: String::new(),
        display_rgb: [0; 3],
        merge_density: 0.5,
        expected_regions: 0,
        y: ChannelRange { lo: 0, hi: 255 },
        u: ChannelRange { lo, hi },
        v: ChannelRange { lo: 0, hi: 255 },
    };
    let config = ColorConfig {
        colors: vec![band(0, 100), band(101, 140), band(141, 255)],
        min_area_px: 2,
    };
    let mut cmv = CmVision::new(&config).expect("three colours");
    // A busy frame: many short runs and many regions in every colour.
    let (width, height) = (160u32, 120u32);
    let frames: Vec<Vec<u8>> = (0..3u32)
        .map(|seed| {
            (0..width * height * 3)
                .map(|i| (i.wrapping_mul(2_654_435_761).wrapping_add(seed * 97) >> 13) as u8)
                .collect()
        })
        .collect();
    let mut regions_seen = 0;
    for data in &frames {
        regions_seen += cmv
            .process(RgbFrame::new(width, height, data).expect("valid frame"))
            .len();
    }
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for _ in 0..3 {
        for data in &frames {
            regions_seen += cmv
                .process(RgbFrame::new(width, height, data).expect("valid frame"))
                .len();
        }
    }
    let allocations = ALLOCATIONS.load(Ordering::Relaxed) - before;
    assert!(
        regions_seen > 100,
        "the frames must give regions to be a test: {regions_seen}"
    );
    assert_eq!(
        allocations, 0,
        "allocations while processing frames seen before"
    );
}
