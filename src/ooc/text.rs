//! Line scanning, tokenising and number parsing for the text formats (OBJ, ASCII STL, ASCII PLY).
//!
//! Works on the mapped bytes: a line is a slice, a token a sub-slice, nothing is copied and
//! nothing is checked for UTF-8 (numbers are ASCII; anything else fails to parse and is quoted
//! lossily in the error). Lines are found with `memchr` (SIMD), tokens with a one-compare fast
//! path for the common printable byte. Floats go through `fast-float2` (Eisel–Lemire with an
//! exact big-decimal fallback, the algorithm the standard library uses, without its `&str`
//! detour): any decimal a C `strtod` accepts is read to the nearest `f32`/`f64`, and `inf` /
//! `nan` spellings parse as the standard library's do (then fail the finiteness check).
//! Integers are parsed here, digit by digit with overflow checks.
//! Cost: about 4 ns per input byte in release (BENCHMARKS.md, "Mesh input"), number parsing
//! first.

use super::error::{Fault, MeshErrorKind, snippet};

/// True for the bytes `u8::is_ascii_whitespace` accepts (space, tab, LF, FF, CR), with one
/// compare for the common case: every byte above the space is a token byte.
#[inline(always)]
pub(crate) fn is_blank(b: u8) -> bool {
    b <= b' ' && b.is_ascii_whitespace()
}

/// Lines of a text body with 1-based numbers; `\r\n` and `\n` endings.
pub(crate) struct Lines<'a> {
    bytes: &'a [u8],
    at: usize,
    number: u64,
}

impl<'a> Lines<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Lines<'a> {
        Lines {
            bytes,
            at: 0,
            number: 0,
        }
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = (u64, &'a [u8]);
    #[inline]
    fn next(&mut self) -> Option<(u64, &'a [u8])> {
        let rest = self.bytes.get(self.at..).filter(|r| !r.is_empty())?;
        let end = memchr::memchr(b'\n', rest).unwrap_or(rest.len());
        self.at += end + 1;
        self.number += 1;
        let line = &rest[..end];
        Some((self.number, line.strip_suffix(b"\r").unwrap_or(line)))
    }
}

/// Whitespace-separated tokens of one line (see [`tokens`]).
pub(crate) struct Tokens<'a> {
    rest: &'a [u8],
}

impl<'a> Iterator for Tokens<'a> {
    type Item = &'a [u8];
    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let start = self.rest.iter().position(|&b| !is_blank(b))?;
        let rest = &self.rest[start..];
        let len = rest.iter().position(|&b| is_blank(b)).unwrap_or(rest.len());
        self.rest = &rest[len..];
        Some(&rest[..len])
    }
}

/// Whitespace-separated tokens of one line.
#[inline]
pub(crate) fn tokens(line: &[u8]) -> Tokens<'_> {
    Tokens { rest: line }
}

/// The `f32` nearest to the decimal `token` (the whole token), or `None`.
#[inline]
pub(crate) fn parse_f32(token: &[u8]) -> Option<f32> {
    fast_float2::parse(token).ok()
}

/// The `f64` nearest to the decimal `token` (the whole token), or `None`.
#[inline]
pub(crate) fn parse_f64(token: &[u8]) -> Option<f64> {
    fast_float2::parse(token).ok()
}

/// A finite `f32` from `token`, or a positioned error saying what was expected.
#[inline]
pub(crate) fn finite_f32(token: Option<&[u8]>, line: u64, what: &str) -> Result<f32, Fault> {
    let Some(token) = token else {
        return Err(Fault::at_line(
            MeshErrorKind::BadValue,
            line,
            format!("the line ends here, expected {what}"),
        ));
    };
    match parse_f32(token) {
        Some(v) if v.is_finite() => Ok(v),
        Some(v) => Err(Fault::at_line(
            MeshErrorKind::NonFinite,
            line,
            format!("{what} is {v}, expected a finite coordinate"),
        )),
        None => Err(Fault::at_line(
            MeshErrorKind::BadValue,
            line,
            format!("expected {what} (a number), found '{}'", snippet(token)),
        )),
    }
}

/// A decimal integer with an optional sign, exactly as `str::parse::<i64>` reads it (any
/// number of digits, leading zeros included), or `None` (not an integer, or out of range).
#[inline]
pub(crate) fn integer(token: &[u8]) -> Option<i64> {
    let (negative, digits) = match token.first() {
        Some(b'-') => (true, &token[1..]),
        Some(b'+') => (false, &token[1..]),
        _ => (false, token),
    };
    if digits.is_empty() {
        return None;
    }
    // Accumulated negatively so that i64::MIN is reachable.
    let mut value: i64 = 0;
    for &d in digits {
        let digit = d.wrapping_sub(b'0');
        if digit > 9 {
            return None;
        }
        value = value.checked_mul(10)?.checked_sub(i64::from(digit))?;
    }
    if negative {
        Some(value)
    } else {
        value.checked_neg()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Spellings the text formats meet, and ones they must refuse, parse exactly as the
    /// standard library parses them (the readers used `str::parse` before `fast-float2`).
    #[test]
    fn floats_parse_as_the_standard_library_does() {
        let cases: &[&str] = &[
            "0",
            "-0",
            "+1",
            "1.",
            ".5",
            "-.5",
            "1e5",
            "1E+5",
            "1e-5",
            "3.4028235e38",
            "3.4028236e38",
            "1e39",
            "-1e39",
            "1.17549435e-38",
            "1e-46",
            "0.1",
            "0.30000001192",
            "123456789012345678901234567890",
            "inf",
            "-inf",
            "+inf",
            "Infinity",
            "INF",
            "nan",
            "NaN",
            "-nan",
            "",
            "+",
            "-",
            ".",
            "e5",
            "1e",
            "1e+",
            "1.2.3",
            "1,5",
            "0x10",
            "1f",
            " 1",
            "1 ",
            "--1",
            "+-1",
            "١",
            "1_0",
            "4.9406564584124654e-324",
            "2.2250738585072014e-308",
            "1.7976931348623157e308",
            "1.8e308",
        ];
        for case in cases {
            let std32 = case.parse::<f32>().ok().map(f32::to_bits);
            let std64 = case.parse::<f64>().ok().map(f64::to_bits);
            assert_eq!(
                parse_f32(case.as_bytes()).map(f32::to_bits),
                std32,
                "{case:?} as f32"
            );
            assert_eq!(
                parse_f64(case.as_bytes()).map(f64::to_bits),
                std64,
                "{case:?} as f64"
            );
        }
    }

    #[test]
    fn integers_parse_as_the_standard_library_does() {
        let cases: &[&str] = &[
            "0",
            "-0",
            "+0",
            "7",
            "-7",
            "+7",
            "0000000000000000000000042",
            "9223372036854775807",
            "9223372036854775808",
            "-9223372036854775808",
            "-9223372036854775809",
            "",
            "+",
            "-",
            "1.0",
            "1e3",
            " 1",
            "1 ",
            "--1",
            "+-1",
            "12a",
            "99999999999999999999",
        ];
        for case in cases {
            assert_eq!(
                integer(case.as_bytes()),
                case.parse::<i64>().ok(),
                "{case:?}"
            );
        }
    }

    #[test]
    fn tokens_and_lines_split_like_the_standard_library() {
        let text = b"v 1 2\t3\r\n\n  f\x0b 1//2 \x0c x\rend";
        let lines: Vec<_> = Lines::new(text).collect();
        assert_eq!(
            lines,
            vec![
                (1, &b"v 1 2\t3"[..]),
                (2, &b""[..]),
                (3, &b"  f\x0b 1//2 \x0c x\rend"[..])
            ]
        );
        for (_, line) in lines {
            let expected: Vec<&[u8]> = line
                .split(|b| b.is_ascii_whitespace())
                .filter(|t| !t.is_empty())
                .collect();
            assert_eq!(tokens(line).collect::<Vec<_>>(), expected);
        }
        assert_eq!(Lines::new(b"").count(), 0);
        assert_eq!(Lines::new(b"a\n").count(), 1);
    }
}
