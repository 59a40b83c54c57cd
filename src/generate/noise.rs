//! Smooth deterministic noise for the generator's "scanned" surface relief, and the small
//! integer hash the generators use for their per-part choices.
//!
//! Value noise (Perlin 1985's lattice idea with hashed values instead of gradients): a hash of
//! the integer lattice corner gives a value in [-1, 1], blended with the quintic fade
//! `6t⁵ − 15t⁴ + 10t³` so the surface has no creases at cell faces. A few octaves summed make
//! a fractal relief like the small bumps of a laser scan. Pure `f32` arithmetic without fused
//! operations, so every platform produces the same bits. Cost: 8 hashes per octave.

/// Octaves summed by [`fractal`]: three give bumps at three scales, enough to hide the facets of
/// the source mesh without turning the surface into noise.
const OCTAVES: u32 = 3;

/// A lattice value in [-1, 1] for integer corner `(x, y, z)`: an integer hash (a variant of
/// the "lowbias32" mixer) of the three coordinates.
fn corner(x: i32, y: i32, z: i32) -> f32 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343)
        ^ (y as u32).wrapping_mul(0xd816_3841)
        ^ (z as u32).wrapping_mul(0xcb1a_b31f);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    (h >> 8) as f32 / (1u32 << 23) as f32 - 1.0
}

fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// Value noise at `p`, in [-1, 1], smooth (C²) everywhere.
pub(crate) fn value(p: [f32; 3]) -> f32 {
    let cell = p.map(|c| c.floor());
    let [x, y, z] = cell.map(|c| c as i32);
    let [u, v, w] = [0, 1, 2].map(|i| fade(p[i] - cell[i]));
    let c = |dx, dy, dz| corner(x + dx, y + dy, z + dz);
    let x00 = lerp(c(0, 0, 0), c(1, 0, 0), u);
    let x10 = lerp(c(0, 1, 0), c(1, 1, 0), u);
    let x01 = lerp(c(0, 0, 1), c(1, 0, 1), u);
    let x11 = lerp(c(0, 1, 1), c(1, 1, 1), u);
    lerp(lerp(x00, x10, v), lerp(x01, x11, v), w)
}

/// [`OCTAVES`] octaves of [`value`], each twice the frequency and half the amplitude of the
/// last; in [-1, 1] (normalised by the amplitude sum).
pub(crate) fn fractal(p: [f32; 3]) -> f32 {
    let (mut sum, mut amplitude, mut total, mut frequency) = (0.0, 1.0, 0.0, 1.0);
    for _ in 0..OCTAVES {
        sum += amplitude * value(p.map(|c| c * frequency));
        total += amplitude;
        amplitude *= 0.5;
        frequency *= 2.0;
    }
    sum / total
}

/// A small integer hash for the generators' per-part choices (part kinds, dithers, turns);
/// any well-mixed function would do.
pub(super) fn cell_hash(i: u32) -> u32 {
    let mut h = i.wrapping_mul(0x9e37_79b9) ^ 0x5bd1_e995;
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^ (h >> 13)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_bounded_smooth_and_deterministic() {
        let mut previous = fractal([0.0, 0.0, 0.0]);
        let mut lo = f32::MAX;
        let mut hi = f32::MIN;
        for i in 1..10_000 {
            let t = i as f32 * 1e-3;
            let n = fractal([t, 0.5 * t, -0.25 * t]);
            assert!((-1.0..=1.0).contains(&n), "{n} at {t}");
            // Smooth: a step of 1e-3 moves the value by far less than its range.
            assert!((n - previous).abs() < 0.02, "jump at {t}");
            previous = n;
            lo = lo.min(n);
            hi = hi.max(n);
        }
        // Not constant: it spans a real part of its range.
        assert!(hi - lo > 0.3, "range {lo}..{hi}");
        // Lattice corners hash to their own values.
        assert_eq!(value([3.0, -2.0, 7.0]), corner(3, -2, 7));
    }
}
