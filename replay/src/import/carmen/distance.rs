//! The Distance reading of a RangeFinder reading, over a span of bearings.

use lewis_interfaces::msg::{Distance, RangeFinder};
use lewis_services::sim::{SectorLayout, distance_from_range_finder};

/// A span of bearings in the robot frame, counter-clockwise from `from_rad` to `to_rad`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SectorSpan {
    /// Where the first sector starts, in rad.
    pub from_rad: f64,
    /// Where the last sector ends, in rad.
    pub to_rad: f64,
}

/// `sectors` equal sectors over `span`, each holding the nearest reading of `scan` in it
/// (the simulator's and the drivers' computation, so the imported Distance means the same).
#[must_use]
pub fn distance_over(scan: &RangeFinder, span: SectorSpan, sectors: usize) -> Distance {
    distance_from_range_finder(
        scan,
        SectorLayout::spanning(span.from_rad, span.to_rad, sectors),
    )
}
