//! Recovery: finds the guide in the red cap and follows them back to a safe place.
//!
//! It stops, then turns in 45 degree steps until a blob of the followed colour is in view
//! (it gives up, 4, after two full turns). It follows: a goal 1.5 m short of the cap
//! (placed by Blobs3D; by the Blobs bearing alone when no range covers it), renewed twice a
//! second, and a stop whenever anything is nearer than 0.8 m ahead. Once it has followed
//! and the cap has been out of sight for 3 s, it stops and finishes (0).

use std::f64::consts::FRAC_PI_4;

use lewis_geometry::Vec2;
use lewis_interfaces::msg::{Blob, Blobs, Blobs3D, Distance};
use lewis_service::{Context, Input};

use crate::common::driver::{Driver, moving_service};
use crate::common::exit;
use crate::common::mover::Motion;
use crate::common::watch::DEFAULT_STALE_NS;

/// What Recovery asks the broker for.
pub const REQUIRES: &[&str] = &["Blobs", "Blobs3D", "Distance", "Egomotion", "Mover"];

/// The goal stays this far short of the cap, in m.
const SHORT_M: f64 = 1.5;
/// The goal is renewed this often, in ns.
const RENEW_NS: i64 = 500_000_000;
/// Nothing may be nearer than this ahead, in m.
const MIN_AHEAD_M: f64 = 0.8;
/// "Ahead": within this of the heading, in rad.
const AHEAD_RAD: f64 = 0.5;
/// Lost once unseen this long, in ns.
const LOST_NS: i64 = 3_000_000_000;
/// Turns of 45 degrees before giving up: two full turns.
const SEARCH_TURNS: u32 = 16;
/// Blobs smaller than this are noise, in px.
const MIN_AREA_PX: i32 = 30;

/// Recovery's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct RecoveryConfig {
    /// The colour class followed, as the blob finder names it (`Red`).
    pub colour: String,
    /// The camera's horizontal field of view, in rad (for a bearing from Blobs alone).
    pub horizontal_fov_rad: f64,
    /// How long an input may be silent, in ns.
    pub stale_ns: i64,
}

impl Default for RecoveryConfig {
    fn default() -> Self {
        Self {
            colour: "Red".to_owned(),
            horizontal_fov_rad: 48.8_f64.to_radians(),
            stale_ns: DEFAULT_STALE_NS,
        }
    }
}

impl RecoveryConfig {
    /// The colour of `--follow "red cap"`: its first word, as a colour class (`Red`).
    #[must_use]
    pub fn colour_of(follow: &str) -> String {
        let word = follow.split_whitespace().next().unwrap_or("red");
        let mut chars = word.chars();
        chars.next().map_or_else(String::new, |c| {
            c.to_uppercase().collect::<String>() + &chars.as_str().to_lowercase()
        })
    }
}

/// The bearing of a blob from the camera, in rad (left positive), from its place in the
/// image and the camera's field of view.
#[must_use]
pub fn blob_bearing(blob: &Blob, image_width_px: i32, horizontal_fov_rad: f64) -> f64 {
    let half = f64::from(image_width_px.max(1)) * 0.5;
    let focal = half / (horizontal_fov_rad * 0.5).tan();
    -((blob.centroid_x - half) / focal).atan()
}

/// Where the program is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Turning until the cap is in view.
    Search { turns: u32 },
    /// After it.
    Follow,
}

/// The Recovery program.
#[derive(Debug)]
pub struct Recovery {
    config: RecoveryConfig,
    driver: Driver,
    phase: Phase,
    /// When the cap was last seen, in ns.
    seen_ns: Option<i64>,
    /// The cap's latest place (odometry), when a range covered it.
    cap: Option<Vec2>,
    /// The cap's latest bearing in the image.
    bearing: Option<f64>,
    renewed_ns: Option<i64>,
    ahead_clear: bool,
}

impl Recovery {
    /// The program with its settings.
    #[must_use]
    pub fn new(config: RecoveryConfig) -> Self {
        Self {
            driver: Driver::new(&["Blobs", "Egomotion", "Distance"], config.stale_ns),
            config,
            phase: Phase::Search { turns: 0 },
            seen_ns: None,
            cap: None,
            bearing: None,
            renewed_ns: None,
            ahead_clear: true,
        }
    }

    fn is_followed(&self, blob: &Blob) -> bool {
        blob.area >= MIN_AREA_PX && blob.colour_name.eq_ignore_ascii_case(&self.config.colour)
    }

    fn on_blobs(&mut self, ctx: &mut Context<'_>, blobs: &Blobs) {
        let best = blobs
            .blobs
            .iter()
            .filter(|b| self.is_followed(b))
            .max_by_key(|b| b.area);
        if let Some(blob) = best {
            self.seen_ns = Some(ctx.now());
            self.bearing = Some(blob_bearing(
                blob,
                blobs.image_width,
                self.config.horizontal_fov_rad,
            ));
        }
    }

    fn on_blobs3d(&mut self, ctx: &mut Context<'_>, blobs: &Blobs3D) {
        let best = blobs
            .blobs
            .iter()
            .filter(|b| b.range_valid && self.is_followed(&b.blob))
            .max_by_key(|b| b.blob.area);
        if let Some(b) = best
            && let Some(at) = self
                .driver
                .odometry
                .to_odom(Vec2::new(b.position.x, b.position.y))
        {
            self.seen_ns = Some(ctx.now());
            self.cap = Some(at);
        }
    }

    /// It stops first (see the module documentation).
    fn stop_first(&mut self, ctx: &mut Context<'_>) {
        self.driver.mover.stop(ctx);
    }

    fn other_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        let _ = match input.interface {
            "Blobs" => input
                .decode()
                .map(|blobs: Blobs| self.on_blobs(ctx, &blobs)),
            "Blobs3D" => input
                .decode()
                .map(|blobs: Blobs3D| self.on_blobs3d(ctx, &blobs)),
            "Distance" => input
                .decode()
                .map(|d: Distance| self.ahead_clear = ahead_clear(&d)),
            _ => Ok(()),
        };
    }

    fn step(&mut self, ctx: &mut Context<'_>) {
        let now = ctx.now();
        if let Some(lost) = self.driver.watch.lost(now) {
            self.driver
                .finish(ctx, exit::INPUT_LOST, &format!("no {lost} for too long"));
            return;
        }
        self.driver.mover.tick(ctx);
        let Some(pose) = self.driver.odometry.pose() else {
            return;
        };
        let seen_lately = self.seen_ns.is_some_and(|at| now - at < LOST_NS);
        match self.phase {
            Phase::Search { turns } => {
                if self.seen_ns.is_some() {
                    ctx.info("the cap is in view: following");
                    self.phase = Phase::Follow;
                    self.driver.mover.stop(ctx);
                    return;
                }
                let idle = match self.driver.mover.wanted() {
                    None => true,
                    Some(Motion::Stop) => self.driver.mover.state().is_some(),
                    Some(_) => self.driver.mover.arrived(),
                };
                if idle {
                    if turns >= SEARCH_TURNS {
                        self.driver
                            .finish(ctx, exit::GAVE_UP, "no cap in sight all around");
                        return;
                    }
                    self.driver.mover.rotate(ctx, FRAC_PI_4);
                    self.phase = Phase::Search { turns: turns + 1 };
                }
            }
            Phase::Follow => {
                if !seen_lately {
                    self.driver.finish(
                        ctx,
                        exit::SUCCESS,
                        "the guide went out of sight: here is safe",
                    );
                    return;
                }
                if !self.ahead_clear {
                    self.driver.mover.stop(ctx);
                    return;
                }
                if self.renewed_ns.is_some_and(|at| now - at < RENEW_NS) {
                    return;
                }
                self.renewed_ns = Some(now);
                let here = pose.position();
                if let Some(cap) = self.cap {
                    let gap = cap.distance(here);
                    if gap > SHORT_M + 0.2 {
                        self.driver
                            .mover
                            .goto(ctx, cap + (here - cap) * (SHORT_M / gap));
                    } else {
                        self.driver.mover.stop(ctx);
                    }
                } else if let Some(bearing) = self.bearing
                    && bearing.abs() > 0.15
                {
                    self.driver.mover.rotate(ctx, bearing);
                }
            }
        }
    }
}

moving_service!(Recovery, then stop_first);

/// Whether nothing is nearer than 0.8 m in the sectors ahead.
#[must_use]
pub fn ahead_clear(distance: &Distance) -> bool {
    distance.sector_distances.iter().enumerate().all(|(i, d)| {
        let bearing = lewis_geometry::wrap_angle(
            distance.first_sector_angle + i as f64 * distance.sector_width,
        );
        bearing.abs() > AHEAD_RAD + distance.sector_width * 0.5 || *d >= MIN_AHEAD_M
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn follow_red_cap_is_the_colour_class_red() {
        assert_eq!(RecoveryConfig::colour_of("red cap"), "Red");
        assert_eq!(RecoveryConfig::colour_of("YELLOW"), "Yellow");
    }

    #[test]
    fn a_blob_right_of_the_image_centre_is_to_the_right() {
        let blob = |x: f64| Blob {
            centroid_x: x,
            ..Blob::default()
        };
        let fov = 48.8_f64.to_radians();
        assert!(blob_bearing(&blob(320.0), 640, fov).abs() < 1e-12);
        let right = blob_bearing(&blob(640.0), 640, fov);
        assert!((right + fov / 2.0).abs() < 1e-9, "{right}");
        assert!(blob_bearing(&blob(100.0), 640, fov) > 0.0);
    }

    #[test]
    fn only_the_sectors_ahead_must_be_clear() {
        let sectors = |near: usize| Distance {
            sector_count: 8,
            sector_distances: (0..8).map(|i| if i == near { 0.5 } else { 5.0 }).collect(),
            first_sector_angle: 0.0,
            sector_width: FRAC_PI_4,
            ..Distance::default()
        };
        assert!(!ahead_clear(&sectors(0)));
        assert!(ahead_clear(&sectors(4)), "behind");
        assert!(ahead_clear(&sectors(2)), "to the left");
    }
}
