//! The project's random numbers: xoshiro256++ seeded by SplitMix64, and
//! normal deviates by the Box-Muller transform. The simulator draws from
//! it, and tests that need reproducible random inputs should too.
//!
//! Our own few lines rather than `rand`, on purpose: a simulated dataset is a
//! pure function of its seed, byte for byte, and must stay so across
//! dependency upgrades (`rand` does not promise value stability across
//! versions). Each ball draws from its own stream `(seed, ball)`, so that
//! the result does not depend on the order or the thread that simulates it.

/// One random stream.
pub struct Rng {
    state: [u64; 4],
}

/// SplitMix64 step: advances `x` and returns a well-mixed 64-bit value.
fn splitmix64(x: &mut u64) -> u64 {
    *x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *x;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Rng {
    /// The stream `stream` of seed `seed`.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut x = seed ^ splitmix64(&mut stream.wrapping_mul(0xD1B5_4A32_D192_ED03));
        Self {
            state: std::array::from_fn(|_| splitmix64(&mut x)),
        }
    }

    /// The next 64 random bits (xoshiro256++).
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

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `0..n` (`n` > 0): the high 64 bits of the 128-bit
    /// product of 64 random bits and `n` (Lemire 2019), biased by less than
    /// `n / 2^64`.
    pub fn below(&mut self, n: u64) -> u64 {
        ((u128::from(self.next_u64()) * u128::from(n)) >> 64) as u64
    }

    /// Uniform in `[low, high)`.
    pub fn uniform(&mut self, low: f64, high: f64) -> f64 {
        low + (high - low) * self.unit()
    }

    /// Normal deviate with mean 0 and standard deviation `sigma`
    /// (Box-Muller, one deviate per pair of uniforms).
    pub fn normal(&mut self, sigma: f64) -> f64 {
        let radius = (-2.0 * (1.0 - self.unit()).ln()).sqrt();
        sigma * radius * (std::f64::consts::TAU * self.unit()).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::Rng;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let draw = |seed, stream| {
            let mut rng = Rng::new(seed, stream);
            (0..4).map(|_| rng.unit()).collect::<Vec<_>>()
        };
        assert_eq!(draw(1, 0), draw(1, 0));
        assert_ne!(draw(1, 0), draw(1, 1));
        assert_ne!(draw(1, 0), draw(2, 0));
    }

    #[test]
    fn normal_deviates_have_the_requested_moments() {
        let mut rng = Rng::new(5, 0);
        let n = 200_000;
        let draws: Vec<f64> = (0..n).map(|_| rng.normal(2.0)).collect();
        let mean = draws.iter().sum::<f64>() / n as f64;
        let variance = draws.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        // Standard errors: 2/sqrt(n) = 0.0045 for the mean, ~0.0126 for the variance.
        assert!(mean.abs() < 0.02, "mean {mean}");
        assert!((variance - 4.0).abs() < 0.06, "variance {variance}");
    }

    #[test]
    fn below_is_uniform_over_its_range() {
        let mut rng = Rng::new(9, 0);
        let n = 70_000;
        let mut counts = [0u32; 7];
        for _ in 0..n {
            counts[rng.below(7) as usize] += 1;
        }
        // Each count is binomial(70000, 1/7): mean 10000, sd 92.6.
        for (i, &c) in counts.iter().enumerate() {
            assert!((f64::from(c) - 10_000.0).abs() < 5.0 * 92.6, "{i}: {c}");
        }
        assert_eq!(rng.below(1), 0);
    }
}
