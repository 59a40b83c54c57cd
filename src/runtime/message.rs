//! The reader's own small text formatter, for its error messages ([`super::Error::message`]):
//! text, decimal and hexadecimal integers, section tags and `f32`s, appended to a fixed
//! buffer.
//!
//! It writes exactly what `Display` and `{:08X}` write, in a few hundred bytes of code. A
//! build that prints errors through `core::fmt` carries its whole machinery (padding, width,
//! every integer type, UTF-8 checks: about 6 KB of WebAssembly); the C ABI and the
//! WebAssembly reader print through this instead, and `core::fmt` is linked only where a
//! caller uses `Display`. Every message fits [`Message::CAPACITY`] (checked by the tests on
//! the longest ones), so nothing is cut.

use super::float_text;

/// A message being written, and then written: ASCII bytes in a fixed buffer.
#[derive(Clone)]
pub struct Message {
    bytes: [u8; Message::CAPACITY],
    len: usize,
}

impl Message {
    /// Bytes a message may hold. The longest, a section out of bounds with five 20-digit
    /// numbers, has 202; a float message at most about 170.
    pub const CAPACITY: usize = 256;

    /// An empty message.
    pub(crate) fn new() -> Self {
        Message {
            bytes: [0; Message::CAPACITY],
            len: 0,
        }
    }

    /// The message's bytes (ASCII).
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..self.len]
    }

    /// The message as text.
    pub fn as_str(&self) -> &str {
        // Only ASCII is ever written, so this never fails.
        core::str::from_utf8(self.as_bytes()).unwrap_or("")
    }

    /// Appends one byte; past the capacity, nothing (see the module documentation).
    fn byte(&mut self, b: u8) {
        if let Some(slot) = self.bytes.get_mut(self.len) {
            *slot = b;
            self.len += 1;
        }
    }

    /// Appends `s`.
    pub(crate) fn text(&mut self, s: &str) -> &mut Self {
        self.bytes(s.as_bytes())
    }

    /// Appends `bytes` (ASCII: text or digits).
    #[inline(never)]
    pub(crate) fn bytes(&mut self, bytes: &[u8]) -> &mut Self {
        for &b in bytes {
            self.byte(b);
        }
        self
    }

    /// Appends `n` zeros.
    pub(crate) fn zeros(&mut self, n: i32) -> &mut Self {
        for _ in 0..n {
            self.byte(b'0');
        }
        self
    }

    /// Appends `v` in decimal, as `Display` does.
    #[inline(never)]
    pub(crate) fn u64(&mut self, v: u64) -> &mut Self {
        let mut buf = [0u8; 20];
        let start = decimal(v, &mut buf);
        self.bytes(&buf[start..])
    }

    /// Appends `v` as `0x` and eight upper-case hexadecimal digits (`{:#010X}`).
    #[inline(never)]
    pub(crate) fn hex32(&mut self, v: u32) -> &mut Self {
        self.text("0x");
        for i in (0..8).rev() {
            let d = (v >> (4 * i) & 0xF) as u8;
            self.byte(if d < 10 { b'0' + d } else { b'A' + d - 10 });
        }
        self
    }

    /// Appends a section tag: as text when it is printable ASCII, else as its big-endian
    /// `u32` in hexadecimal.
    #[inline(never)]
    pub(crate) fn tag(&mut self, tag: [u8; 4]) -> &mut Self {
        if tag.iter().all(u8::is_ascii_graphic) {
            for b in tag {
                self.byte(b);
            }
            self
        } else {
            self.hex32(u32::from_be_bytes(tag))
        }
    }

    /// Appends `v` as `Display` writes it: `NaN`, `inf`, `-inf`, `0`, `-0`, or the shortest
    /// round-trip digits ([`float_text::shortest`]) in positional notation.
    #[inline(never)]
    pub(crate) fn f32(&mut self, v: f32) -> &mut Self {
        if v.is_nan() {
            return self.text("NaN");
        }
        if v.is_sign_negative() {
            self.text("-");
        }
        let v = v.abs();
        if v.is_infinite() {
            return self.text("inf");
        }
        if v == 0.0 {
            return self.text("0");
        }
        let (d, j) = float_text::shortest(v);
        let mut buf = [0u8; 20];
        let start = decimal(d, &mut buf);
        let digits = &buf[start..];
        let len = digits.len() as i32;
        if j >= 0 {
            self.bytes(digits).zeros(j)
        } else if len + j > 0 {
            let point = (len + j) as usize;
            self.bytes(&digits[..point])
                .text(".")
                .bytes(&digits[point..])
        } else {
            self.text("0.").zeros(-j - len).bytes(digits)
        }
    }
}

impl core::fmt::Debug for Message {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Debug::fmt(self.as_str(), f)
    }
}

/// Writes `v`'s decimal digits at the end of `buf`; returns where they start.
fn decimal(mut v: u64, buf: &mut [u8; 20]) -> usize {
    let mut at = buf.len();
    loop {
        at -= 1;
        buf[at] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            return at;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::format;

    #[test]
    fn integers_print_as_display_does() {
        for v in [
            0,
            1,
            9,
            10,
            99,
            100,
            12_345,
            u32::MAX as u64,
            u64::MAX - 1,
            u64::MAX,
        ] {
            let mut m = Message::new();
            m.u64(v);
            assert_eq!(m.as_str(), format!("{v}"));
        }
        for v in [0, 1, 0xDEAD_BEEF, 0x0123_4567, u32::MAX] {
            let mut m = Message::new();
            m.hex32(v);
            assert_eq!(m.as_str(), format!("0x{v:08X}"));
        }
    }

    #[test]
    fn tags_print_as_text_or_hex() {
        let mut m = Message::new();
        m.tag(*b"PTCH").text(" ").tag([0, b'A', 0xFF, 0x20]);
        assert_eq!(m.as_str(), "PTCH 0x0041FF20");
    }

    #[test]
    fn a_full_message_keeps_its_first_bytes() {
        let mut m = Message::new();
        for _ in 0..100 {
            m.text("abc");
        }
        assert_eq!(m.as_bytes().len(), Message::CAPACITY);
        assert!(m.as_str().starts_with("abcabc"));
    }

    fn same(v: f32) {
        let mut m = Message::new();
        m.f32(v);
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
