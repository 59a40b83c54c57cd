//! Writes an `f32` the way `Display` does, shortest round-trip digits without an exponent, in
//! a few hundred bytes of code instead of `core`'s float formatting.
//!
//! The reader's error messages name the offending float (`found inf at byte 172`), and the
//! conformance vectors hold those messages, so every build must print a float exactly as
//! `Display` does: the fewest digits that read back to the same `f32`, the closest to it
//! among those, a tie going up. The digits come from Steele & White's free-format algorithm
//! as Burger & Dybvig state it ("Printing floating-point numbers quickly and accurately",
//! 1996): the value and the half gaps to its neighbours as exact fractions `r / s`,
//! `m⁺ / s`, `m⁻ / s` (the lower gap half as wide at a power of two; the bounds belong to the
//! interval when the significand is even), scaled by a power of ten, then one digit per step
//! until one of the two candidates at that digit is inside the interval. Exact, in
//! fixed-size integers of 256 bits (an `f32` needs at most 180): no allocation. Tested
//! against `Display` on every exponent and on random bit patterns.

use super::message::Message;

/// Limbs of [`Big`]: 256 bits. The largest value is `r · 10 < 2^180` (the smallest
/// subnormal, scaled by `2^151 · 10^45`).
const LIMBS: usize = 8;

/// An unsigned integer of `LIMBS` 32-bit limbs, least significant first.
#[derive(Clone, Copy, PartialEq, Eq)]
struct Big([u32; LIMBS]);

impl Big {
    #[inline(never)]
    fn from_u32(x: u32) -> Big {
        let mut b = [0; LIMBS];
        b[0] = x;
        Big(b)
    }

    /// `self · k`.
    #[inline(never)]
    fn mul_small(&mut self, k: u32) {
        let mut carry = 0u64;
        for limb in &mut self.0 {
            let t = u64::from(*limb) * u64::from(k) + carry;
            *limb = t as u32;
            carry = t >> 32;
        }
    }

    /// `self · 2^n`.
    #[inline(never)]
    fn shl(mut self, n: u32) -> Big {
        for _ in 0..n {
            self.mul_small(2);
        }
        self
    }

    /// `self · 10^n`.
    #[inline(never)]
    fn mul_pow10(&mut self, n: u32) {
        for _ in 0..n {
            self.mul_small(10);
        }
    }

    /// `self + other`.
    #[inline(never)]
    fn add(mut self, other: &Big) -> Big {
        let mut carry = 0u64;
        for (a, b) in self.0.iter_mut().zip(other.0) {
            let t = u64::from(*a) + u64::from(b) + carry;
            *a = t as u32;
            carry = t >> 32;
        }
        self
    }

    /// `self − other`, which must not be negative.
    #[inline(never)]
    fn sub(&mut self, other: &Big) {
        let mut borrow = 0u64;
        for (a, b) in self.0.iter_mut().zip(other.0) {
            let t = u64::from(*a)
                .wrapping_sub(u64::from(b))
                .wrapping_sub(borrow);
            *a = t as u32;
            borrow = t >> 63;
        }
    }

    /// `self ≥ other` (or `>` when `!or_equal`).
    #[inline(never)]
    fn above(&self, other: &Big, or_equal: bool) -> bool {
        for (a, b) in self.0.iter().zip(other.0).rev() {
            if *a != b {
                return *a > b;
            }
        }
        or_equal
    }
}

/// The shortest digits of a finite `v > 0`: `(d, j)` with `v` reading back from `d · 10^j`,
/// `d` without trailing zeros.
#[inline(never)]
fn shortest(v: f32) -> (u64, i32) {
    let bits = v.to_bits();
    let (biased, fraction) = ((bits >> 23) & 0xFF, bits & 0x7F_FFFF);
    let (m, e) = if biased == 0 {
        (fraction, -149)
    } else {
        (fraction | 1 << 23, biased as i32 - 150)
    };
    // Round-to-nearest-even reads the interval's bounds back to `v` when `m` is even.
    let even = m % 2 == 0;
    // At a power of two (not the smallest normal) the gap below is half the gap above.
    let lower_closer = fraction == 0 && biased > 1;
    let extra = u32::from(lower_closer);
    // v = r / s, the half gaps m⁺ / s and m⁻ / s.
    let (mut r, mut s, mut up, mut down) = if e >= 0 {
        let e = e as u32;
        (
            Big::from_u32(m).shl(e + 1 + extra),
            Big::from_u32(2 << extra),
            Big::from_u32(1).shl(e + extra),
            Big::from_u32(1).shl(e),
        )
    } else {
        let e = (-e) as u32;
        (
            Big::from_u32(m << (1 + extra)),
            Big::from_u32(1).shl(e + 1 + extra),
            Big::from_u32(1 << extra),
            Big::from_u32(1),
        )
    };
    // k with 10^(k−1) ≤ v + m⁺/s < 10^k (≤ at the top when the bound is in the interval):
    // floor(log10(2^e2)) + 1 for v in [2^e2, 2^(e2+1)) is k or k − 1. 78913 / 2^18 is
    // log10(2) to 6 digits, enough for |e2| ≤ 1650.
    let e2 = e + 31 - m.leading_zeros() as i32;
    let mut k = ((e2 * 78_913) >> 18) + 1;
    if k >= 0 {
        s.mul_pow10(k as u32);
    } else {
        for x in [&mut r, &mut up, &mut down] {
            x.mul_pow10((-k) as u32);
        }
    }
    if r.add(&up).above(&s, even) {
        s.mul_small(10);
        k += 1;
    }
    // v = 0.d₁d₂… · 10^k: one digit a step, until d or d + 1 is inside the interval.
    let mut d = 0u64;
    let mut n = 0;
    loop {
        r.mul_small(10);
        up.mul_small(10);
        down.mul_small(10);
        let mut digit = 0u64;
        while r.above(&s, true) {
            r.sub(&s);
            digit += 1;
        }
        n += 1;
        let low_ok = down.above(&r, even);
        let high_ok = r.add(&up).above(&s, even);
        // Nine digits always read back; the bound only keeps the loop visibly finite.
        if !(low_ok || high_ok) && n < 12 {
            d = d * 10 + digit;
            continue;
        }
        // Both inside: the closer one, a tie going up, as `core`'s formatting does.
        let round_up = match (low_ok, high_ok) {
            (true, true) => r.add(&r).above(&s, true),
            (low, _) => !low,
        };
        d = d * 10 + digit + u64::from(round_up);
        break;
    }
    let mut j = k - n;
    while d.is_multiple_of(10) && d != 0 {
        d /= 10;
        j += 1;
    }
    (d, j)
}

/// Writes `v` as `Display` does: `NaN`, `inf`, `-inf`, `0`, `-0`, or the shortest round-trip
/// digits in positional notation.
pub(crate) fn write(v: f32, out: &mut Message) {
    if v.is_nan() {
        out.text("NaN");
        return;
    }
    if v.is_sign_negative() {
        out.text("-");
    }
    let v = v.abs();
    if v.is_infinite() {
        out.text("inf");
        return;
    }
    if v == 0.0 {
        out.text("0");
        return;
    }
    let (d, j) = shortest(v);
    let mut buf = [0u8; 20];
    let start = super::message::decimal(d, &mut buf);
    let digits = &buf[start..];
    let len = digits.len() as i32;
    if j >= 0 {
        out.bytes(digits).zeros(j);
    } else if len + j > 0 {
        let point = (len + j) as usize;
        out.bytes(&digits[..point])
            .text(".")
            .bytes(&digits[point..]);
    } else {
        out.text("0.").zeros(-j - len).bytes(digits);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::format;

    fn same(v: f32) {
        let mut m = Message::new();
        write(v, &mut m);
        assert_eq!(m.as_str(), format!("{v}"), "bits {:#010x}", v.to_bits());
    }

    #[test]
    fn special_values_and_every_binade_print_as_display_does() {
        for v in [
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1.0,
            1.5,
            -0.5,
            0.1,
            3.0e38,
            f32::MAX,
            f32::MIN_POSITIVE,
            1e-45,
            f32::from_bits(1),
            f32::from_bits(0x007F_FFFF),
            100.0,
            123_456_790.0,
        ] {
            same(v);
        }
        // Each exponent: the power of two, its neighbours and a few significands.
        for biased in 0..255u32 {
            for fraction in [0, 1, 2, 0x40_0000, 0x7F_FFFE, 0x7F_FFFF, 0x12_3456] {
                same(f32::from_bits(biased << 23 | fraction));
            }
        }
    }

    #[test]
    fn random_bit_patterns_print_as_display_does() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..200_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            same(f32::from_bits((state >> 16) as u32));
        }
    }
}
