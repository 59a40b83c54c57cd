//! The unit tests' random numbers: the crate's SplitMix64 (`splitmix.rs`, which `eval`'s views
//! use too), with the ranges tests want, so tests need no RNG dependency and a seed gives the
//! same numbers on every platform.

use crate::splitmix::SplitMix64;

/// A SplitMix64 stream.
#[derive(Clone, Debug)]
pub(crate) struct Rng(SplitMix64);

impl Rng {
    /// A stream started from `seed` (any value, 0 included).
    pub(crate) fn new(seed: u64) -> Rng {
        Rng(SplitMix64::new(seed))
    }

    /// The next 64 random bits.
    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// Uniform in `[-1, 1)`: the top 24 bits, so every value is exact in `f32`.
    pub(crate) fn signed(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 23) as f32 - 1.0
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub(crate) fn unit(&mut self) -> f64 {
        self.0.next_f64()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_stay_in_their_ranges() {
        let mut rng = Rng::new(42);
        for _ in 0..10_000 {
            assert!((-1.0..1.0).contains(&rng.signed()));
            assert!((0.0..1.0).contains(&rng.unit()));
        }
    }
}
