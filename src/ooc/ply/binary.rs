//! Binary PLY bodies: a cursor that reads scalars of either byte order and skips records.
//!
//! Every read is bounds-checked; running out of bytes is a `Truncated` fault naming the byte
//! offset where the data ran out and how many bytes were expected. Cost: a few instructions
//! per value; skipping a fixed-size element is O(1), a variable-size one walks its lists.

use super::super::error::{Fault, MeshErrorKind};
use super::header::{Element, PropertyType, ScalarType};

/// A position in a binary body.
pub(crate) struct BinaryCursor<'a> {
    bytes: &'a [u8],
    pub(crate) offset: usize,
    big_endian: bool,
}

impl<'a> BinaryCursor<'a> {
    pub(crate) fn new(bytes: &'a [u8], offset: usize, big_endian: bool) -> BinaryCursor<'a> {
        BinaryCursor {
            bytes,
            offset,
            big_endian,
        }
    }

    /// Bytes left after the cursor.
    pub(crate) fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.offset)
    }

    /// Takes the next `n` bytes, or says where the data ran out.
    pub(crate) fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], Fault> {
        match self
            .offset
            .checked_add(n)
            .and_then(|end| self.bytes.get(self.offset..end))
        {
            Some(s) => {
                self.offset += n;
                Ok(s)
            }
            None => Err(Fault::at_byte(
                MeshErrorKind::Truncated,
                self.offset,
                format!(
                    "the file ends here, expected {n} more bytes ({what}) but only {} remain",
                    self.remaining()
                ),
            )),
        }
    }

    /// Reads one scalar; every PLY scalar is exact in an `f64`.
    pub(crate) fn scalar(&mut self, ty: ScalarType) -> Result<f64, Fault> {
        let s = self.take(ty.size(), ty.name())?;
        let be = self.big_endian;
        macro_rules! int {
            ($t:ty, $n:literal) => {{
                let mut a = [0u8; $n];
                a.copy_from_slice(s);
                f64::from(if be {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                })
            }};
        }
        Ok(match ty {
            ScalarType::I8 => int!(i8, 1),
            ScalarType::U8 => int!(u8, 1),
            ScalarType::I16 => int!(i16, 2),
            ScalarType::U16 => int!(u16, 2),
            ScalarType::I32 => int!(i32, 4),
            ScalarType::U32 => int!(u32, 4),
            ScalarType::F32 => int!(f32, 4),
            ScalarType::F64 => int!(f64, 8),
        })
    }

    /// Reads a list count: a non-negative integer.
    pub(crate) fn list_count(&mut self, ty: ScalarType) -> Result<u64, Fault> {
        let at = self.offset;
        let count = self.scalar(ty)?;
        if count < 0.0 {
            return Err(Fault::at_byte(
                MeshErrorKind::BadValue,
                at,
                format!("list count {count}, expected a non-negative count"),
            ));
        }
        // Integer types only (checked in the header), so the value is integral.
        Ok(count as u64)
    }

    /// Skips `count` items of `ty` in one step.
    pub(crate) fn skip(&mut self, count: u64, ty: ScalarType) -> Result<(), Fault> {
        let n = usize::try_from(count)
            .ok()
            .and_then(|c| c.checked_mul(ty.size()))
            .unwrap_or(usize::MAX);
        self.take(n, ty.name()).map(|_| ())
    }

    /// Skips every record of `element`: one step when its records have a fixed size.
    pub(crate) fn skip_element(&mut self, element: &Element) -> Result<(), Fault> {
        if let Some(size) = element.fixed_size() {
            let n = usize::try_from(element.count)
                .ok()
                .and_then(|c| c.checked_mul(size));
            let Some(n) = n.filter(|&n| n <= self.remaining()) else {
                return Err(self.element_truncated(element, size));
            };
            self.offset += n;
            return Ok(());
        }
        for _ in 0..element.count {
            for p in &element.properties {
                match p.ty {
                    PropertyType::Scalar(s) => self.skip(1, s)?,
                    PropertyType::List { count, item } => {
                        let n = self.list_count(count)?;
                        self.skip(n, item)?;
                    }
                }
            }
        }
        Ok(())
    }

    /// The fault for a fixed-size element that does not fit in the rest of the file.
    pub(crate) fn element_truncated(&self, element: &Element, record_size: usize) -> Fault {
        Fault::at_byte(
            MeshErrorKind::Truncated,
            self.offset,
            format!(
                "element '{}' needs {} records of {record_size} bytes ({} bytes), \
                 but the file ends after {} bytes",
                element.name,
                element.count,
                u128::from(element.count) * record_size as u128,
                self.remaining()
            ),
        )
    }
}
