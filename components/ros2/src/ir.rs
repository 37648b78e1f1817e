//! The Create 3's IR proximity sensors: raw intensity to distance.
//!
//! The Create 3 reports, for each of its seven IR sensors behind the bumper, a raw
//! reflected intensity (`irobot_create_msgs/msg/IrIntensity.value`, higher is nearer), not a
//! distance. Reflected light from a diffuse surface falls with a power of the distance, so
//! the model is an **inverse power law**
//!
//! ```text
//! intensity = k / d^p        so        d = (k / intensity)^(1/p)
//! ```
//!
//! clamped to `[min_range, max_range]`; an intensity at or below the `floor` (the sensor's
//! noise with nothing in front) is "nothing seen": `max_range`. `k` and `p` depend on the
//! surface's colour and the robot's own sensors, so they are parameters, fitted from a few
//! readings at known distances by [`IrModel::fit`] (a least-squares line through
//! `ln intensity = ln k - p ln d`).
//!
//! The defaults (`p = 2`, the inverse square of a point source on a diffuse wall, and `k`
//! such that a white wall 5 cm away reads 400) are a starting point, not a calibration: the
//! guide's chapter says how to fit your robot's. The fallback is a short-range ring (about
//! 20 cm with the defaults), as the B21r's sonar was to its laser: it keeps the avoider from
//! driving into what is right ahead, no more.

use serde::Deserialize;

/// Intensity to distance: `d = (k / intensity)^(1/p)`, clamped. Its numbers are checked
/// ([`IrModel::check`]) when the robot file is loaded.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default, try_from = "IrModelFields")]
pub struct IrModel {
    /// The law's scale: the intensity at 1 m (in raw units times m^p).
    pub k: f64,
    /// The law's exponent.
    pub p: f64,
    /// Intensities at or below this are nothing seen.
    pub floor: f64,
    /// The nearest distance reported, in m.
    pub min_range_m: f64,
    /// The farthest, and what "nothing seen" reports, in m.
    pub max_range_m: f64,
}

impl Default for IrModel {
    fn default() -> Self {
        // 400 at 5 cm: k = 400 * 0.05^2 = 1.0.
        Self {
            k: 1.0,
            p: 2.0,
            floor: 20.0,
            min_range_m: 0.01,
            max_range_m: 0.2,
        }
    }
}

/// [`IrModel`] as written, before its check.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct IrModelFields {
    k: f64,
    p: f64,
    floor: f64,
    min_range_m: f64,
    max_range_m: f64,
}

impl Default for IrModelFields {
    fn default() -> Self {
        let d = IrModel::default();
        Self {
            k: d.k,
            p: d.p,
            floor: d.floor,
            min_range_m: d.min_range_m,
            max_range_m: d.max_range_m,
        }
    }
}

impl TryFrom<IrModelFields> for IrModel {
    type Error = String;

    fn try_from(f: IrModelFields) -> Result<Self, String> {
        let model = Self {
            k: f.k,
            p: f.p,
            floor: f.floor,
            min_range_m: f.min_range_m,
            max_range_m: f.max_range_m,
        };
        model.check()?;
        Ok(model)
    }
}

impl IrModel {
    /// What is wrong with the model's numbers, if anything.
    ///
    /// # Errors
    /// A number that is not positive and finite, or limits out of order.
    pub fn check(&self) -> Result<(), String> {
        for (name, x) in [
            ("k", self.k),
            ("p", self.p),
            ("min_range_m", self.min_range_m),
            ("max_range_m", self.max_range_m),
        ] {
            if !(x.is_finite() && x > 0.0) {
                return Err(format!("ir model `{name}` is {x}: give a positive number"));
            }
        }
        if !(self.floor.is_finite() && self.floor >= 0.0) {
            return Err(format!(
                "ir model `floor` is {}: give 0 or more",
                self.floor
            ));
        }
        if self.min_range_m >= self.max_range_m {
            return Err(format!(
                "ir model: min_range_m {} is not below max_range_m {}",
                self.min_range_m, self.max_range_m
            ));
        }
        Ok(())
    }

    /// The distance, in m, of a raw intensity.
    #[must_use]
    pub fn distance_m(&self, intensity: f64) -> f64 {
        if !intensity.is_finite() || intensity <= self.floor || intensity <= 0.0 {
            return self.max_range_m;
        }
        (self.k / intensity)
            .powf(1.0 / self.p)
            .clamp(self.min_range_m, self.max_range_m)
    }

    /// The intensity the model expects at `distance_m` (its inverse, unclamped).
    #[must_use]
    pub fn intensity(&self, distance_m: f64) -> f64 {
        self.k / distance_m.powf(self.p)
    }

    /// `k` and `p` fitted to `(distance in m, intensity)` readings, by least squares on
    /// `ln intensity = ln k - p ln d`; the other numbers are kept. `None` with fewer than
    /// two distinct distances or a reading that is not positive.
    #[must_use]
    pub fn fit(&self, readings: &[(f64, f64)]) -> Option<Self> {
        if readings
            .iter()
            .any(|&(d, i)| !(d.is_finite() && d > 0.0 && i.is_finite() && i > 0.0))
        {
            return None;
        }
        let n = readings.len() as f64;
        let xs: Vec<f64> = readings.iter().map(|&(d, _)| d.ln()).collect();
        let ys: Vec<f64> = readings.iter().map(|&(_, i)| i.ln()).collect();
        let mean_x = xs.iter().sum::<f64>() / n;
        let mean_y = ys.iter().sum::<f64>() / n;
        let sxx: f64 = xs.iter().map(|x| (x - mean_x).powi(2)).sum();
        if sxx.is_nan() || sxx <= 1e-12 {
            return None;
        }
        let sxy: f64 = xs
            .iter()
            .zip(&ys)
            .map(|(x, y)| (x - mean_x) * (y - mean_y))
            .sum();
        let slope = sxy / sxx;
        let p = -slope;
        let k = (mean_y - slope * mean_x).exp();
        (p.is_finite() && p > 0.0 && k.is_finite()).then_some(Self { k, p, ..*self })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn nearer_is_brighter_and_nothing_seen_is_max_range() {
        let model = IrModel::default();
        assert!((model.distance_m(400.0) - 0.05).abs() < 1e-12);
        assert!(model.distance_m(1600.0) < model.distance_m(400.0));
        assert_eq!(model.distance_m(20.0), 0.2);
        assert_eq!(model.distance_m(0.0), 0.2);
        assert_eq!(model.distance_m(-3.0), 0.2);
        assert_eq!(model.distance_m(1e9), 0.01);
        model.check().unwrap();
    }

    #[test]
    fn a_fit_recovers_the_law_of_its_readings() {
        let truth = IrModel {
            k: 2.5,
            p: 1.7,
            ..IrModel::default()
        };
        let readings: Vec<(f64, f64)> = [0.02, 0.04, 0.08, 0.12, 0.16]
            .iter()
            .map(|&d| (d, truth.intensity(d)))
            .collect();
        let fitted = IrModel::default().fit(&readings).unwrap();
        assert!((fitted.k - 2.5).abs() < 1e-9, "{fitted:?}");
        assert!((fitted.p - 1.7).abs() < 1e-9, "{fitted:?}");
        assert_eq!(IrModel::default().fit(&[(0.05, 100.0)]), None);
        assert_eq!(IrModel::default().fit(&[(0.05, 100.0), (0.1, 0.0)]), None);
    }

    #[test]
    fn bad_numbers_are_refused() {
        let bad = IrModel {
            p: 0.0,
            ..IrModel::default()
        };
        assert!(bad.check().is_err());
        let backwards = IrModel {
            min_range_m: 0.5,
            ..IrModel::default()
        };
        assert!(backwards.check().is_err());
    }
}
