//! Writes an `f32` the way `Display` does, shortest round-trip digits without an exponent, in
//! a few hundred bytes of code instead of `core`'s float formatting (about 13 KB of
//! WebAssembly, most of the reader's error path).
//!
//! The reader's error messages name the offending float (`found inf at byte 172`), and the
//! conformance vectors hold those messages, so every build must print a float exactly as
//! `Display` does. The digits are the fewest that read back to the same `f32`, the closest
//! to it among those (a tie goes up): for 1 to 9 significant digits, the multiples of the digit unit just
//! below and just above the value are tested against the interval of reals that round to it
//! (half the gap to each neighbour; the lower gap is half as wide at a power of two; the
//! bounds are inside when the significand is even). Exact, in fixed-size integers of 512
//! bits scaled by `2^151 · 10^t`: no allocation. Tested against `Display` on every exponent
//! and on random bit patterns.

use core::fmt;

/// Limbs of [`Big`]: 512 bits, room for a significand below `2^24` times `2^(104 + 151)` or
/// times `10^54 · 2^2` (the largest and smallest scaled values).
const LIMBS: usize = 16;

/// An unsigned integer of `LIMBS` 32-bit limbs, least significant first.
#[derive(Clone, Copy, PartialEq, Eq)]
struct Big([u32; LIMBS]);

impl Big {
    fn from_u64(x: u64) -> Big {
        let mut b = [0; LIMBS];
        b[0] = x as u32;
        b[1] = (x >> 32) as u32;
        Big(b)
    }

    /// `self · k`.
    fn mul_small(mut self, k: u32) -> Big {
        let mut carry = 0u64;
        for limb in &mut self.0 {
            let t = u64::from(*limb) * u64::from(k) + carry;
            *limb = t as u32;
            carry = t >> 32;
        }
        self
    }

    /// `self · 10^p`.
    fn mul_pow10(mut self, p: u32) -> Big {
        for _ in 0..p {
            self = self.mul_small(10);
        }
        self
    }

    /// `self · 2^s`.
    fn shl(self, s: u32) -> Big {
        let (words, bits) = ((s / 32) as usize, s % 32);
        let mut out = [0; LIMBS];
        for i in (words..LIMBS).rev() {
            let lo = self.0[i - words];
            let below = if bits > 0 && i > words {
                self.0[i - words - 1] >> (32 - bits)
            } else {
                0
            };
            out[i] = (lo << bits) | below;
        }
        Big(out)
    }

    /// `floor(self / 2^s)`.
    fn shr(self, s: u32) -> Big {
        let (words, bits) = ((s / 32) as usize, s % 32);
        let mut out = [0; LIMBS];
        for (i, slot) in out.iter_mut().enumerate().take(LIMBS - words) {
            let lo = self.0[i + words];
            let above = if bits > 0 && i + words + 1 < LIMBS {
                self.0[i + words + 1] << (32 - bits)
            } else {
                0
            };
            *slot = (lo >> bits) | above;
        }
        Big(out)
    }

    /// `floor(self / 10)`.
    fn div10(mut self) -> Big {
        let mut rem = 0u64;
        for limb in self.0.iter_mut().rev() {
            let t = (rem << 32) | u64::from(*limb);
            *limb = (t / 10) as u32;
            rem = t % 10;
        }
        self
    }

    /// The low 64 bits.
    fn low64(&self) -> u64 {
        u64::from(self.0[0]) | u64::from(self.0[1]) << 32
    }

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
    fn sub(mut self, other: &Big) -> Big {
        let mut borrow = 0i64;
        for (a, b) in self.0.iter_mut().zip(other.0) {
            let t = i64::from(*a) - i64::from(b) - borrow;
            *a = t as u32;
            borrow = i64::from(t < 0);
        }
        self
    }
}

impl PartialOrd for Big {
    fn partial_cmp(&self, other: &Big) -> Option<core::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Big {
    fn cmp(&self, other: &Big) -> core::cmp::Ordering {
        self.0.iter().rev().cmp(other.0.iter().rev())
    }
}

/// The shortest digits of a finite `v > 0`: `(d, j)` with `v` reading back from `d · 10^j`,
/// `d` without trailing zeros.
fn shortest(v: f32) -> (u64, i32) {
    let bits = v.to_bits();
    let (biased, fraction) = ((bits >> 23) & 0xFF, bits & 0x7F_FFFF);
    let (m, e) = if biased == 0 {
        (fraction, -149)
    } else {
        (fraction | 1 << 23, biased as i32 - 150)
    };
    let even = m % 2 == 0;
    // Scaled by 2^151, the value and the half gaps to the neighbours are integers.
    let value = |t: u32| {
        Big::from_u64(u64::from(m))
            .shl((e + 151) as u32)
            .mul_pow10(t)
    };
    let up = |t: u32| Big::from_u64(1).shl((e + 150) as u32).mul_pow10(t);
    let lower_closer = fraction == 0 && biased > 1;
    let down = |t: u32| {
        let shift = if lower_closer { e + 149 } else { e + 150 };
        Big::from_u64(1).shl(shift as u32).mul_pow10(t)
    };
    // 10^j scaled by 2^151 and 10^t (j + t ≥ 0).
    let unit = |j: i32, t: u32| Big::from_u64(1).mul_pow10((j + t as i32) as u32).shl(151);
    // The decimal exponent k: 10^k ≤ v < 10^(k+1), from an estimate made exact.
    // floor(log10(2^e2)) for v in [2^e2, 2^(e2+1)): 78913 / 2^18 is log10(2) to 6 digits,
    // enough for |e2| ≤ 1650.
    let e2 = e + 31 - m.leading_zeros() as i32;
    let mut k = (e2 * 78_913) >> 18;
    let below = |k: i32| {
        let t = (-k).max(0) as u32;
        value(t) < unit(k, t)
    };
    while below(k) {
        k -= 1;
    }
    while !below(k + 1) {
        k += 1;
    }
    for n in 1..=9 {
        let j = k - n + 1;
        let t = (-j).max(0) as u32;
        let (x, u) = (value(t), unit(j, t));
        let mut q = x.shr(151);
        for _ in 0..(j + t as i32) {
            q = q.div10();
        }
        let q = q.low64();
        let lo = Big::from_u64(q).mul_pow10((j + t as i32) as u32).shl(151);
        let hi = lo.add(&u);
        let (d_lo, d_hi) = (x.sub(&lo), hi.sub(&x));
        let (h_down, h_up) = (down(t), up(t));
        let lo_ok = d_lo < h_down || (even && d_lo == h_down);
        let hi_ok = d_hi < h_up || (even && d_hi == h_up);
        let pick = match (lo_ok, hi_ok) {
            // A tie goes up, as `core`'s formatting does.
            (true, true) if d_lo < d_hi => Some(q),
            (true, true) | (false, true) => Some(q + 1),
            (true, false) => Some(q),
            (false, false) => None,
        };
        if let Some(mut d) = pick {
            let mut j = j;
            while d % 10 == 0 && d != 0 {
                d /= 10;
                j += 1;
            }
            return (d, j);
        }
    }
    // Nine digits always read back (unreachable for a finite f32).
    (0, 0)
}

/// ASCII digits as text.
fn text(digits: &[u8]) -> &str {
    core::str::from_utf8(digits).unwrap_or("")
}

/// `v` as `Display` writes it: `NaN`, `inf`, `-inf`, `0`, `-0`, or the shortest round-trip
/// digits in positional notation.
pub(crate) struct FloatText(pub f32);

impl fmt::Display for FloatText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v.is_nan() {
            return f.write_str("NaN");
        }
        if v.is_sign_negative() {
            f.write_str("-")?;
        }
        let v = v.abs();
        if v.is_infinite() {
            return f.write_str("inf");
        }
        if v == 0.0 {
            return f.write_str("0");
        }
        let (d, j) = shortest(v);
        let mut digits = [0u8; 20];
        let mut len = 0;
        let mut rest = d;
        while rest > 0 {
            digits[len] = b'0' + (rest % 10) as u8;
            rest /= 10;
            len += 1;
        }
        digits[..len].reverse();
        let digits = &digits[..len];
        let zeros = |f: &mut fmt::Formatter<'_>, n: i32| (0..n).try_for_each(|_| f.write_str("0"));
        if j >= 0 {
            f.write_str(text(digits))?;
            zeros(f, j)
        } else if len as i32 + j > 0 {
            let point = (len as i32 + j) as usize;
            f.write_str(text(&digits[..point]))?;
            f.write_str(".")?;
            f.write_str(text(&digits[point..]))
        } else {
            f.write_str("0.")?;
            zeros(f, -j - len as i32)?;
            f.write_str(text(digits))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::format;

    fn same(v: f32) {
        assert_eq!(
            format!("{}", FloatText(v)),
            format!("{v}"),
            "bits {:#010x}",
            v.to_bits()
        );
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
