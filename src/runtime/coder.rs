//! The binary range decoder of VISB encoding 1 and the bit context it is driven by
//! (spec § Range coder, § Context).
//!
//! A carry-less-decoding binary range coder in the LZMA style (32-bit range, 12-bit
//! probabilities, byte-wise renormalisation), with static probabilities read from the file and
//! bytes past the end of a view's code read as zero — which lets the writer drop trailing zero
//! bytes and keeps the decoder total: any byte string decodes to *some* bits without a check.
//! Cost: one multiply, one compare and at most two byte reads per bit.

use super::consts::{PROB_BITS, RANGE_TOP};

/// The context of a bit (spec § Context): `a·16 + b·8 + x₋₁·4 + a₋₁·2 + b₋₁`, where `a`, `b`
/// are the parents' bits at this patch, `a₋₁`, `b₋₁` theirs at the previous patch and `x₋₁` the
/// view's own previous bit (all 0 before patch 0, and `a = b = 0` for level-0 views).
#[inline(always)]
#[cfg_attr(not(feature = "bake"), allow(dead_code))] // the encoding-1 writer's
pub fn context(a: u64, b: u64, x_prev: u64, a_prev: u64, b_prev: u64) -> usize {
    (a << 4 | b << 3 | x_prev << 2 | a_prev << 1 | b_prev) as usize
}

/// Decoder state over one view's code.
#[derive(Clone, Copy, Debug)]
pub struct RangeDecoder<'a> {
    code: &'a [u8],
    pos: usize,
    range: u32,
    value: u32,
}

impl<'a> RangeDecoder<'a> {
    /// Starts decoding `code`: `value` is its first 4 bytes, big-endian.
    pub fn new(code: &'a [u8]) -> Self {
        let mut d = RangeDecoder {
            code,
            pos: 0,
            range: u32::MAX,
            value: 0,
        };
        for _ in 0..4 {
            d.value = d.value << 8 | d.next_byte();
        }
        d
    }

    /// Byte `pos` of the code, or 0 past its end.
    #[inline(always)]
    fn next_byte(&mut self) -> u32 {
        let byte = self.code.get(self.pos).copied().unwrap_or(0);
        self.pos += 1;
        byte as u32
    }

    /// Decodes one bit whose probability of being 0 is `p0 / 2^PROB_BITS`. `p0` must be in
    /// `1..2^PROB_BITS` (checked at parse), so the range never collapses.
    #[inline(always)]
    pub fn bit(&mut self, p0: u32) -> u64 {
        let bound = (self.range >> PROB_BITS) * p0;
        // Branch-free: a bit near probability ½ would mispredict half the time. On a
        // corrupt-but-checksummed code `value` may exceed `range`; the subtraction still cannot
        // underflow and the output is merely arbitrary bits.
        let bit = u32::from(self.value >= bound);
        let mask = 0u32.wrapping_sub(bit);
        self.value -= bound & mask;
        self.range = bound ^ ((bound ^ (self.range - bound)) & mask);
        let bit = u64::from(bit);
        while self.range < RANGE_TOP {
            self.range <<= 8;
            self.value = self.value << 8 | self.next_byte();
        }
        bit
    }

    /// Bytes the decoder has read so far, counting reads past the end.
    #[cfg(test)]
    pub fn consumed(&self) -> usize {
        self.pos
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn any_bytes_decode_without_panicking() {
        for code in [&[][..], &[0xFF; 9][..], &[0x80, 0, 0, 1][..]] {
            for p0 in [1, 2048, 4095] {
                let mut d = RangeDecoder::new(code);
                for _ in 0..100 {
                    d.bit(p0);
                }
                assert!(d.consumed() <= 4 + 2 * 100);
            }
        }
    }

    #[test]
    fn empty_code_with_a_certain_model_gives_zeros() {
        // Value 0 is always below the bound: an empty code is a row of zeros.
        let mut d = RangeDecoder::new(&[]);
        assert!((0..1000).all(|_| d.bit(4095) == 0));
    }
}
