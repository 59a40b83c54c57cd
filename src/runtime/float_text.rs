//! The digits of an `f32` as `Display` prints them, in a few hundred bytes of code instead of
//! `core`'s float formatting; [`super::Message::f32`] lays them out without an exponent.
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
//! against `Display` on every exponent and on random bit patterns (`message.rs`).

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
pub(crate) fn shortest(v: f32) -> (u64, i32) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits_and_exponents_of_a_few_values() {
        assert_eq!(shortest(1.0), (1, 0));
        assert_eq!(shortest(1.5), (15, -1));
        assert_eq!(shortest(0.1), (1, -1));
        assert_eq!(shortest(100.0), (1, 2));
        assert_eq!(shortest(f32::MAX), (34_028_235, 31));
        assert_eq!(shortest(f32::from_bits(1)), (1, -45));
    }
}
