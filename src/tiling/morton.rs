//! Morton (Z-order) codes of points inside a box, used to give nearby patches nearby ranks.
//!
//! Each coordinate is quantised to [`MORTON_BITS`] bits over the box and the bits are
//! interleaved (x lowest), so sorting by the code walks space along a Z-order curve.
//! Cost: O(1) per point.

use super::aabb::Aabb;

/// Bits per axis: 3 × 21 = 63 bits fit a `u64`, and 2²¹ cells per axis separate patches of
/// any mesh this tool can hold (at most 2³² triangles).
pub(crate) const MORTON_BITS: u32 = 21;

/// The Morton code of `p` quantised over `bounds`; points outside are clamped to it.
pub(crate) fn morton_code(p: [f64; 3], bounds: &Aabb) -> u64 {
    let cells = f64::from((1u32 << MORTON_BITS) - 1);
    let mut code = 0u64;
    for (k, &c) in p.iter().enumerate() {
        let lo = f64::from(bounds.min[k]);
        let extent = f64::from(bounds.max[k]) - lo;
        // A flat axis (extent 0) carries no ordering information; every point maps to 0.
        let t = if extent > 0.0 {
            ((c - lo) / extent).clamp(0.0, 1.0)
        } else {
            0.0
        };
        code |= spread_bits((t * cells).round() as u64) << k;
    }
    code
}

/// Moves bit `i` of the low 21 bits of `x` to bit `3 i`.
fn spread_bits(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spreads_bits_to_every_third_position() {
        assert_eq!(spread_bits(0b1011), 0b1_000_001_001);
        assert_eq!(spread_bits(0x1f_ffff), 0x1249_2492_4924_9249);
    }

    #[test]
    fn corners_of_the_box_give_extreme_codes() {
        let b = Aabb {
            min: [0.0; 3],
            max: [1.0, 2.0, 4.0],
        };
        assert_eq!(morton_code([0.0; 3], &b), 0);
        assert_eq!(morton_code([1.0, 2.0, 4.0], &b), (1u64 << 63) - 1);
        assert_eq!(morton_code([1.0, 0.0, 0.0], &b), 0x1249_2492_4924_9249);
    }
}
