//! Reading a field and checking its rule, for the validation in `parse.rs` and `ptch.rs`:
//! each read reports where the file ended or which rule the value broke (spec § Header …
//! § VISB), so every error names a field and its byte offset. Also where a section lies.

use super::stream::{FromData, Stream};
use super::{Error, Rule};

/// Where a section lies.
#[derive(Clone, Copy)]
pub(crate) struct Section {
    /// Offset of its body.
    pub offset: u64,
    /// Length of its body.
    pub length: u64,
}

/// Converts an in-file offset to `usize`. Every offset checked against `data.len()` fits.
pub(crate) fn at(offset: u64) -> usize {
    usize::try_from(offset).unwrap_or(usize::MAX)
}

/// Reads a `T` or reports how many bytes were missing.
pub(crate) fn read<T: FromData>(s: &mut Stream<'_>, have: usize) -> Result<T, Error> {
    let needed = s.offset() as u64 + T::SIZE as u64;
    s.read::<T>().ok_or(Error::Truncated {
        needed,
        have: have as u64,
    })
}

/// Reads a `u32` that must be zero (reserved fields).
pub(crate) fn reserved(s: &mut Stream<'_>, have: usize, what: Rule) -> Result<(), Error> {
    let offset = s.offset() as u64;
    match read::<u32>(s, have)? {
        0 => Ok(()),
        value => Err(Error::Invalid {
            what,
            offset,
            value: value as u64,
        }),
    }
}

/// Reads an `f32` that must lie in `[low, high]` (which excludes NaN, and the infinities where
/// `low` and `high` are finite). One function for every float rule, rather than one copy per
/// rule.
pub(crate) fn float(
    s: &mut Stream<'_>,
    have: usize,
    what: Rule,
    [low, high]: [f32; 2],
) -> Result<f32, Error> {
    let offset = s.offset() as u64;
    let value = read::<f32>(s, have)?;
    if low <= value && value <= high {
        Ok(value)
    } else {
        Err(Error::InvalidFloat {
            what,
            offset,
            bits: value.to_bits(),
        })
    }
}

/// Every finite `f32`, as the bounds of [`float`].
pub(crate) const FINITE: [f32; 2] = [f32::MIN, f32::MAX];

/// Every finite `f32` above zero (subnormals included), as the bounds of [`float`].
pub(crate) const POSITIVE: [f32; 2] = [0f32.next_up(), f32::MAX];

/// Reads three finite `f32`s.
pub(crate) fn finite3(s: &mut Stream<'_>, have: usize, what: Rule) -> Result<[f32; 3], Error> {
    let mut out = [0.0; 3];
    for v in &mut out {
        *v = float(s, have, what, FINITE)?;
    }
    Ok(out)
}
