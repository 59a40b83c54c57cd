//! The correctly rounded binary32 square root the spec's normalisations and the reader's cone
//! test need, in the smallest code each target allows.
//!
//! Where `libm` takes the square root with a hardware instruction (x86 with SSE2, AArch64)
//! [`sqrtf`] is `libm::sqrtf`: fast and small. Elsewhere (Cortex-M, WebAssembly without the
//! unstable intrinsics) `libm` falls back to a table-driven Goldschmidt iteration of about
//! 500 bytes of code and table; there [`sqrtf`] is [`sqrtf_digits`], a digit-by-digit integer
//! square root of ~100 bytes. Both are correctly rounded (round to nearest even), so every
//! target gets bit-identical answers; the tests compare them.

/// `sqrt(x)` in binary32, correctly rounded: `libm::sqrtf` where it is a hardware instruction,
/// [`sqrtf_digits`] elsewhere.
#[inline]
pub fn sqrtf(x: f32) -> f32 {
    let hardware = cfg!(any(
        target_feature = "sse2",
        all(target_arch = "aarch64", target_feature = "neon")
    ));
    if hardware {
        libm::sqrtf(x)
    } else {
        sqrtf_digits(x)
    }
}

/// `sqrt(x)` in binary32, correctly rounded, from the integer square root of the significand:
/// `x = m · 2^p` with `p` odd and `m < 2^25`; the floor of `sqrt(m · 2^25)` has 25 bits, the
/// result's 24 and a rounding bit. A tie cannot occur (an exact square root of a binary32 has
/// at most 24 significant bits), so rounding up on the rounding bit is round-to-nearest.
/// NaN and negative inputs give NaN, `±0` and `+∞` themselves.
pub fn sqrtf_digits(x: f32) -> f32 {
    if x.is_nan() || x < 0.0 {
        return f32::NAN;
    }
    if x == 0.0 || x == f32::INFINITY {
        return x;
    }
    let bits = x.to_bits();
    let mut m = bits & 0x007F_FFFF;
    let mut e = (bits >> 23) as i32;
    if e == 0 {
        // Subnormal: shift the leading one to bit 23.
        let shift = m.leading_zeros() as i32 - 8;
        m <<= shift;
        e = 1 - shift;
    } else {
        m |= 0x0080_0000;
    }
    // x = m · 2^p, made p odd so that sqrt(m · 2^25) · 2^((p − 25) / 2) splits evenly.
    let mut p = e - 150;
    if p & 1 == 0 {
        m <<= 1;
        p -= 1;
    }
    // Floor of the square root of m · 2^25 (in [2^48, 2^50)), one bit a step.
    let mut rem = u64::from(m) << 25;
    let mut root = 0u64;
    let mut bit = 1u64 << 48;
    while bit != 0 {
        if rem >= root + bit {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    // root ∈ [2^24, 2^25): the significand (with its leading one) and the rounding bit. A carry
    // out of the significand moves into the exponent field, as it should.
    let q = ((root + 1) >> 1) as u32;
    let biased = ((p - 23) / 2 + 150) as u32;
    f32::from_bits(((biased - 1) << 23) + q)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Checks `x` against `libm::sqrtf` bit for bit.
    fn check(x: f32) {
        let (want, got) = (libm::sqrtf(x), sqrtf_digits(x));
        assert!(
            want.to_bits() == got.to_bits() || (want.is_nan() && got.is_nan()),
            "sqrt({x:e} = {:#x}): {want:e} expected, {got:e} computed",
            x.to_bits()
        );
    }

    #[test]
    fn special_values() {
        for x in [
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -1.0,
            -f32::MIN_POSITIVE,
        ] {
            check(x);
        }
        assert_eq!(sqrtf_digits(-0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(sqrtf_digits(4.0), 2.0);
        assert_eq!(sqrtf_digits(f32::MAX), libm::sqrtf(f32::MAX));
    }

    #[test]
    fn subnormals_and_extremes() {
        for bits in (1..0x0100_0000u32)
            .step_by(97)
            .chain(0x7F00_0000..0x7F80_0000)
        {
            check(f32::from_bits(bits));
        }
    }

    #[test]
    fn every_significand_of_two_binades() {
        // [1, 4): both exponent parities, every significand.
        for bits in 0x3F80_0000u32..0x4080_0000 {
            check(f32::from_bits(bits));
        }
    }

    #[test]
    fn spread_over_all_positive_floats() {
        for bits in (1..0x7F80_0000u32).step_by(9973) {
            check(f32::from_bits(bits));
        }
    }
}
