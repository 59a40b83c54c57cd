//! Line scanning and number parsing for the text formats (OBJ, ASCII STL).
//!
//! Works on the mapped bytes: a line is a slice, a token a sub-slice, nothing is copied.
//! Numbers go through the standard library's parsers (Eisel–Lemire for floats, exact and
//! fast), so any decimal a C `strtod` accepts in these files is read to the nearest `f32`.
//! Cost: one scan per byte plus the number parsing, which dominates.

use super::error::{Fault, MeshErrorKind, snippet};

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
    fn next(&mut self) -> Option<(u64, &'a [u8])> {
        if self.at >= self.bytes.len() {
            return None;
        }
        let rest = &self.bytes[self.at..];
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        self.at += end + 1;
        self.number += 1;
        let line = &rest[..end];
        Some((self.number, line.strip_suffix(b"\r").unwrap_or(line)))
    }
}

/// Whitespace-separated tokens of one line.
pub(crate) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

/// A finite `f32` from `token`, or a positioned error saying what was expected.
pub(crate) fn finite_f32(token: Option<&[u8]>, line: u64, what: &str) -> Result<f32, Fault> {
    let Some(token) = token else {
        return Err(Fault::at_line(
            MeshErrorKind::BadValue,
            line,
            format!("the line ends here, expected {what}"),
        ));
    };
    let value = std::str::from_utf8(token)
        .ok()
        .and_then(|t| t.parse::<f32>().ok());
    match value {
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

/// A decimal integer (optional sign), or `None`.
pub(crate) fn integer(token: &[u8]) -> Option<i64> {
    let (negative, digits) = match token.first() {
        Some(b'-') => (true, &token[1..]),
        Some(b'+') => (false, &token[1..]),
        _ => (false, token),
    };
    if digits.is_empty() || digits.len() > 18 {
        return None;
    }
    let mut value: i64 = 0;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        value = value * 10 + i64::from(d - b'0');
    }
    Some(if negative { -value } else { value })
}
