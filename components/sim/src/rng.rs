//! The simulator's own random numbers: xoshiro256++ seeded through splitmix64.
//!
//! Owned here rather than taken from a crate so that the sequence for a seed can never
//! change under a dependency upgrade: recordings made from a seed stay reproducible.

/// A seeded, deterministic random number generator (xoshiro256++).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SimRng {
    state: [u64; 4],
}

/// One step of splitmix64: spreads a seed over the generator's state.
fn splitmix64(x: &mut u64) -> u64 {
    *x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *x;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl SimRng {
    /// A generator whose whole sequence is fixed by `seed`.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        let mut x = seed;
        Self {
            state: [
                splitmix64(&mut x),
                splitmix64(&mut x),
                splitmix64(&mut x),
                splitmix64(&mut x),
            ],
        }
    }

    /// A generator for one device, independent of the other devices seeded with the same
    /// `seed`: killing one device does not change what the others draw.
    #[must_use]
    pub fn for_device(seed: u64, device: &str) -> Self {
        // FNV-1a of the device name, mixed into the seed.
        let mut hash: u64 = 0xCBF2_9CE4_8422_2325;
        for byte in device.bytes() {
            hash ^= u64::from(byte);
            hash = hash.wrapping_mul(0x0000_0100_0000_01B3);
        }
        Self::new(seed ^ hash.rotate_left(17))
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.state;
        let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform in [0, 1), with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        // 53 bits fit an f64 mantissa exactly
        let mantissa = (self.next_u64() >> 11) as f64;
        mantissa * (1.0 / (1u64 << 53) as f64)
    }

    /// A standard normal sample (Box-Muller; one sample per call, so the sequence does not
    /// depend on how calls interleave with other draws).
    pub fn standard_normal(&mut self) -> f64 {
        // 1 - uniform() is in (0, 1]: its logarithm is finite.
        let radius = (-2.0 * (1.0 - self.uniform()).ln()).sqrt();
        let angle = std::f64::consts::TAU * self.uniform();
        radius * angle.cos()
    }

    /// A normal sample with mean 0 and standard deviation `std_dev` (0 draws nothing, so a
    /// noiseless model leaves the sequence untouched).
    pub fn normal(&mut self, std_dev: f64) -> f64 {
        if std_dev > 0.0 {
            std_dev * self.standard_normal()
        } else {
            0.0
        }
    }

    /// True with probability `p` (0 draws nothing).
    pub fn chance(&mut self, p: f64) -> bool {
        p > 0.0 && self.uniform() < p
    }
}

#[cfg(test)]
mod tests {
    use super::SimRng;

    #[test]
    fn same_seed_gives_the_same_sequence_and_another_seed_does_not() {
        let mut a = SimRng::new(7);
        let mut b = SimRng::new(7);
        let mut c = SimRng::new(8);
        let xs: Vec<u64> = (0..16).map(|_| a.next_u64()).collect();
        let ys: Vec<u64> = (0..16).map(|_| b.next_u64()).collect();
        let zs: Vec<u64> = (0..16).map(|_| c.next_u64()).collect();
        assert_eq!(xs, ys);
        assert_ne!(xs, zs);
    }

    #[test]
    fn normal_samples_have_the_requested_spread() {
        let mut rng = SimRng::new(1);
        let n = 20_000;
        let samples: Vec<f64> = (0..n).map(|_| rng.normal(2.0)).collect();
        let mean = samples.iter().sum::<f64>() / f64::from(n);
        let var = samples.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / f64::from(n);
        assert!(mean.abs() < 0.05, "mean {mean}");
        assert!((var.sqrt() - 2.0).abs() < 0.05, "std {}", var.sqrt());
    }

    #[test]
    fn devices_seeded_alike_draw_different_sequences() {
        let mut laser = SimRng::for_device(3, "laser");
        let mut sonar = SimRng::for_device(3, "sonar");
        assert_ne!(laser.next_u64(), sonar.next_u64());
    }
}
