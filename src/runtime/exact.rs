//! The two binary64 steps of the spec (§ Query step 3, `inside_sphere`; § Features, `front`
//! of a full-layout patch) in integer arithmetic, with the same results bit for bit.
//!
//! Both sum three exact products of binary32 values, `(p₀ + p₁) + p₂`, rounding each
//! addition to binary64, and then compare. A target without binary64 hardware (a Cortex-M4F)
//! would otherwise link the compiler's soft-float addition, multiplication, conversions and
//! comparisons (about 2 KB of flash) for these few lines. Here every product is held exactly
//! as a sign, a 64-bit significand normalised to `[2^63, 2^64)` and a power of two; an
//! addition aligns the two in 64 bits, keeping a sticky bit, and rounds to 53 significant
//! bits to nearest, ties to even — what binary64 does. No step can overflow or underflow binary64:
//! the magnitudes lie between `2^−298` and `2^258`. Tested against the `f64` evaluation on
//! random values, on ties and on cancellations. Most calls never reach the integers: the same
//! sums in binary32, with a margin far above both formats' rounding, settle every case that
//! is not close to the threshold.
//!
//! WebAssembly has binary64 arithmetic in its instruction set, so there the two steps are
//! evaluated as the spec writes them ([`NATIVE_BINARY64`]): a few instructions instead of
//! about 2 KB of integer code in the `.wasm`.

/// Whether the target computes binary64 in hardware (WebAssembly's `f64` instructions), so
/// that the spec's binary64 expressions are cheaper than their integer form. Elsewhere (a
/// Cortex-M4F has only a binary32 FPU; the host keeps the measured fast path) the integer
/// form is used.
const NATIVE_BINARY64: bool = cfg!(target_arch = "wasm32");

/// `(−1)^neg · mant · 2^exp` exactly; zero has `mant = 0` and the lowest `exp`, so that
/// `(exp, mant)` orders magnitudes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Exact {
    neg: bool,
    mant: u64,
    exp: i32,
}

const ZERO: Exact = Exact {
    neg: false,
    mant: 0,
    exp: i32::MIN,
};

impl Exact {
    /// `(−1)^neg · m · 2^e`, normalised.
    fn new(neg: bool, m: u64, e: i32) -> Exact {
        if m == 0 {
            return ZERO;
        }
        let shift = m.leading_zeros();
        Exact {
            neg,
            mant: m << shift,
            exp: e - shift as i32,
        }
    }

    /// The finite `x · k` (`|k| < 2^32`), exactly.
    fn product(x: f32, k: i64) -> Exact {
        let bits = x.to_bits();
        let (biased, fraction) = ((bits >> 23 & 0xFF) as i32, u64::from(bits & 0x7F_FFFF));
        let (m, e) = if biased == 0 {
            (fraction, -149)
        } else {
            (fraction | 1 << 23, biased - 150)
        };
        Exact::new((bits >> 31 == 1) != (k < 0), m * k.unsigned_abs(), e)
    }

    /// The magnitude as `(exp, mant)`, ordered like the magnitudes.
    fn magnitude(self) -> (i32, u64) {
        (self.exp, self.mant)
    }

    /// `self + other` rounded to binary64 (to nearest, ties to even), as soft-float adders do
    /// it: the smaller operand shifted right with the bits it loses *jammed* into bit 0, the
    /// sum or difference in 64 bits, then rounding at bit 11. Both operands have at most 53
    /// significant bits (products, or sums rounded here), so a shift of up to 11 bits loses
    /// nothing, and a longer one leaves a difference that needs at most one bit of
    /// renormalisation; a jammed result is odd and lies within one unit of bit 0 of the exact
    /// value, so it rounds as the exact value does.
    fn add(self, other: Exact) -> Exact {
        let (hi, lo) = if self.magnitude() >= other.magnitude() {
            (self, other)
        } else {
            (other, self)
        };
        if lo.mant == 0 {
            return hi;
        }
        let d = (hi.exp - lo.exp) as u32;
        let low = match d {
            0 => lo.mant,
            1..=63 => lo.mant >> d | u64::from(lo.mant << (64 - d) != 0),
            _ => 1,
        };
        let (mut m, mut e) = (hi.mant, hi.exp);
        if hi.neg == lo.neg {
            let (sum, carry) = m.overflowing_add(low);
            m = sum;
            if carry {
                m = m >> 1 | (m & 1) | 1 << 63;
                e += 1;
            }
        } else {
            m -= low;
            if m == 0 {
                return ZERO;
            }
            let shift = m.leading_zeros();
            m <<= shift;
            e -= shift as i32;
        }
        let (rest, half) = (m & 0x7FF, 0x400);
        m >>= 11;
        if rest > half || (rest == half && m & 1 == 1) {
            m += 1;
        }
        Exact::new(hi.neg, m, e + 11)
    }
}

/// Whether `(a.x·b.x + a.y·b.y) + a.z·b.z > 0` in binary64, each product exact: the `front`
/// feature of a full-layout patch (§ Features) with `a` its `cone_axis` and `b` the view's
/// lattice point.
pub(crate) fn dot_positive(a: [f32; 3], b: [i32; 3]) -> bool {
    if NATIVE_BINARY64 {
        let p = |i: usize| f64::from(a[i]) * f64::from(b[i]);
        return (p(0) + p(1)) + p(2) > 0.0;
    }
    dot_sign_f32(a, b).unwrap_or_else(|| dot_positive_exact(a, b))
}

/// [`dot_positive`] in integers alone. Out of line, so that the shortcut's callers stay
/// small.
#[cold]
#[inline(never)]
fn dot_positive_exact(a: [f32; 3], b: [i32; 3]) -> bool {
    let p = |i: usize| Exact::product(a[i], i64::from(b[i]));
    // Rounding to nearest keeps the sign, and no nonzero sum underflows: the sign of the last
    // addition is the sign of its exact sum.
    let (s, z) = (p(0).add(p(1)), p(2));
    if s.neg == z.neg {
        !s.neg && (s.mant | z.mant) != 0
    } else {
        let (pos, neg) = if s.neg { (z, s) } else { (s, z) };
        pos.magnitude() > neg.magnitude()
    }
}

/// Whether `(d.x·d.x + d.y·d.y) + d.z·d.z < r·r` in binary64, each product exact: § Query
/// step 3, `inside_sphere`, for finite `d` and `r`.
pub(crate) fn norm_below(d: [f32; 3], r: f32) -> bool {
    if NATIVE_BINARY64 {
        let square = |x: f32| f64::from(x) * f64::from(x);
        return (square(d[0]) + square(d[1])) + square(d[2]) < square(r);
    }
    norm_below_f32(d, r).unwrap_or_else(|| norm_below_exact(d, r))
}

/// [`norm_below`] in integers alone. Out of line, so that the shortcut's callers stay small.
#[cold]
#[inline(never)]
fn norm_below_exact(d: [f32; 3], r: f32) -> bool {
    let square = |x: f32| {
        // At most 24 significant bits, at the top: the square of the top half is exact.
        let e = Exact::product(x, 1);
        if e.mant == 0 {
            return ZERO;
        }
        let m = e.mant >> 32;
        Exact::new(false, m * m, 2 * (e.exp + 32))
    };
    let sum = square(d[0]).add(square(d[1])).add(square(d[2]));
    sum.magnitude() < square(r).magnitude()
}

/// Margin of the binary32 shortcuts: `2^−20`, sixteen times the worst relative error of
/// three binary32 products and two sums of like-signed terms (under `5 · 2^−24`), which is
/// far above binary64's.
const MARGIN: f32 = 1.0 / (1 << 20) as f32;

/// Smallest scale the shortcuts trust: terms that underflow binary32 (below `2^−126`) lose at
/// most `2^−150` each, nothing next to `MARGIN` times this.
const TINY: f32 = 1.0 / (1u128 << 100) as f32;

/// [`dot_positive`] from binary32 arithmetic, where the sum is clearly away from zero:
/// `None` when it is within `MARGIN` of the magnitudes, or something overflowed. Nearly
/// every call (unit axes, small lattice points) ends here.
#[inline(always)]
fn dot_sign_f32(a: [f32; 3], b: [i32; 3]) -> Option<bool> {
    let p = [0, 1, 2].map(|i| a[i] * b[i] as f32);
    let dot = (p[0] + p[1]) + p[2];
    let scale = (p[0].abs() + p[1].abs()) + p[2].abs();
    if scale == 0.0 {
        return Some(false);
    }
    let margin = scale * MARGIN;
    (scale.is_finite() && margin >= TINY && dot.abs() > margin).then_some(dot > 0.0)
}

/// [`norm_below`] from binary32 arithmetic, where the comparison is clear: `None` within
/// `MARGIN` of the threshold, or when a square overflowed or the threshold is tiny. Nearly
/// every query ends here.
#[inline(always)]
fn norm_below_f32(d: [f32; 3], r: f32) -> Option<bool> {
    let norm = (d[0] * d[0] + d[1] * d[1]) + d[2] * d[2];
    let limit = r * r;
    let slack = limit * MARGIN;
    // An infinite limit makes `limit − slack` NaN, so neither branch below takes it; an
    // overflowed `norm` is above any finite limit.
    if slack.is_nan() || slack < TINY {
        None
    } else if norm < limit - slack {
        Some(true)
    } else if norm > limit + slack && limit < f32::INFINITY {
        Some(false)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_kit::rng::Rng;

    fn dot_f64(a: [f32; 3], b: [i32; 3]) -> bool {
        let [x, y, z] = b.map(f64::from);
        (f64::from(a[0]) * x + f64::from(a[1]) * y) + f64::from(a[2]) * z > 0.0
    }

    fn norm_f64(d: [f32; 3], r: f32) -> bool {
        let sq = |x: f32| f64::from(x) * f64::from(x);
        (sq(d[0]) + sq(d[1])) + sq(d[2]) < sq(r)
    }

    /// A float with a random sign, a random significand and an exponent in `lo..hi` binades
    /// (subnormals and zero included at the bottom).
    fn float(rng: &mut Rng, lo: u32, hi: u32) -> f32 {
        let biased = lo + (rng.next_u64() % u64::from(hi - lo)) as u32;
        let bits = (rng.next_u64() as u32 & 0x807F_FFFF) | biased << 23;
        f32::from_bits(bits)
    }

    #[test]
    fn dot_signs_agree_with_binary64() {
        let mut rng = Rng::new(23);
        for i in 0..400_000 {
            // Narrow exponent windows make cancellations and roundings of the first sum
            // common; wide ones test the alignment limits.
            let (lo, hi) = match i % 3 {
                0 => (100, 130),
                1 => (0, 255),
                _ => (120, 124),
            };
            let a = [0; 3].map(|_| float(&mut rng, lo, hi));
            let b = [0; 3].map(|_| (rng.next_u64() % 257) as i32 - 128);
            assert_eq!(dot_positive(a, b), dot_f64(a, b), "{a:?} · {b:?}");
            assert_eq!(dot_positive_exact(a, b), dot_f64(a, b), "{a:?} · {b:?}");
        }
    }

    #[test]
    fn dot_signs_agree_where_the_first_sum_rounds() {
        // p₀ + p₁ loses p₁ (or a tie) to rounding, and p₂ cancels p₀ exactly: the binary64
        // sign is the rounded one, not the exact one.
        let big = 1.0f32;
        for small in [
            2f32.powi(-53),
            2f32.powi(-54),
            2f32.powi(-60),
            3.0 * 2f32.powi(-54),
        ] {
            for (s1, s2) in [(1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
                let a = [big, small * s1, big * s2];
                let b = [1, 1, 1];
                assert_eq!(dot_positive(a, b), dot_f64(a, b), "{a:?}");
                let b = [3, 128, 3];
                assert_eq!(dot_positive(a, b), dot_f64(a, b), "{a:?} · {b:?}");
                assert_eq!(dot_positive_exact(a, b), dot_f64(a, b), "{a:?} · {b:?}");
            }
        }
        assert!(!dot_positive([0.0, -0.0, 0.0], [1, 2, 3]));
        assert!(!dot_positive([1.0, 0.0, 0.0], [0, 5, 5]));
        assert!(dot_positive([f32::MAX, f32::MAX, -f32::MAX], [128, 1, 128]));
    }

    #[test]
    fn norms_agree_with_binary64() {
        let mut rng = Rng::new(5);
        for i in 0..400_000 {
            let (lo, hi) = match i % 3 {
                0 => (100, 160),
                1 => (0, 255),
                _ => (126, 128),
            };
            let d = [0; 3].map(|_| float(&mut rng, lo, hi));
            let r = float(&mut rng, lo, hi).abs();
            assert_eq!(norm_below(d, r), norm_f64(d, r), "{d:?} {r}");
            assert_eq!(norm_below_exact(d, r), norm_f64(d, r), "{d:?} {r}");
            // On the sphere: r taken from the binary64 norm, rounded either way.
            let n = norm_f64_value(d).sqrt() as f32;
            if !n.is_finite() || n.to_bits() >= f32::MAX.to_bits() {
                continue;
            }
            for r in [
                n,
                f32::from_bits(n.to_bits() + 1),
                f32::from_bits(n.to_bits().max(1) - 1),
            ] {
                assert_eq!(norm_below(d, r), norm_f64(d, r), "{d:?} {r}");
                assert_eq!(norm_below_exact(d, r), norm_f64(d, r), "{d:?} {r}");
            }
        }
        assert!(!norm_below([0.0; 3], 0.0));
        assert!(norm_below([0.0; 3], f32::from_bits(1)));
        assert!(!norm_below([3.0, 4.0, 0.0], 5.0));
    }

    fn norm_f64_value(d: [f32; 3]) -> f64 {
        let sq = |x: f32| f64::from(x) * f64::from(x);
        (sq(d[0]) + sq(d[1])) + sq(d[2])
    }
}
