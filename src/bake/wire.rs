//! The little-endian fields of the files a sharded bake passes around (the tiling file and
//! the part files): one way to write them, one bounds-checked way to read them back, and the
//! 48-byte patch record both files hold.

use crate::tiling::Patch;

/// Bytes of one patch record: `first`, `count` (`u32`), `area` (`f64`), centre (3 × `f32`),
/// radius (`f32`), cone axis (3 × `f32`), cone cosine (`f32`).
pub(crate) const PATCH_BYTES: usize = 48;

/// Appends little-endian fields to a byte vector.
pub(crate) trait Put {
    fn put_u8(&mut self, v: u8);
    fn put_u32(&mut self, v: u32);
    fn put_u64(&mut self, v: u64);
    fn put_f32(&mut self, v: f32) {
        self.put_u32(v.to_bits());
    }
    fn put_patch(&mut self, p: &Patch) {
        self.put_u32(p.first);
        self.put_u32(p.count);
        self.put_u64(p.area.to_bits());
        for c in p.center {
            self.put_f32(c);
        }
        self.put_f32(p.radius);
        for c in p.cone_axis {
            self.put_f32(c);
        }
        self.put_f32(p.cone_cos);
    }
}

impl Put for Vec<u8> {
    fn put_u8(&mut self, v: u8) {
        self.push(v);
    }
    fn put_u32(&mut self, v: u32) {
        self.extend_from_slice(&v.to_le_bytes());
    }
    fn put_u64(&mut self, v: u64) {
        self.extend_from_slice(&v.to_le_bytes());
    }
}

/// Reads fields from the front of a byte slice; every read is `None` past the end.
pub(crate) struct Fields<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Fields<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Fields<'a> {
        Fields { bytes, at: 0 }
    }

    /// Bytes read so far.
    pub(crate) fn offset(&self) -> usize {
        self.at
    }

    pub(crate) fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.at.checked_add(n)?;
        let out = self.bytes.get(self.at..end)?;
        self.at = end;
        Some(out)
    }

    pub(crate) fn u8(&mut self) -> Option<u8> {
        Some(self.take(1)?[0])
    }

    pub(crate) fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }

    pub(crate) fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }

    pub(crate) fn f32(&mut self) -> Option<f32> {
        self.u32().map(f32::from_bits)
    }

    pub(crate) fn patch(&mut self) -> Option<Patch> {
        Some(Patch {
            first: self.u32()?,
            count: self.u32()?,
            area: f64::from_bits(self.u64()?),
            center: [self.f32()?, self.f32()?, self.f32()?],
            radius: self.f32()?,
            cone_axis: [self.f32()?, self.f32()?, self.f32()?],
            cone_cos: self.f32()?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_patch_record_reads_back_and_is_48_bytes() {
        let p = Patch {
            first: 7,
            count: 9,
            area: 0.125,
            center: [1.0, -2.0, 3.5],
            radius: 0.75,
            cone_axis: [0.0, 1.0, 0.0],
            cone_cos: -1.0,
        };
        let mut bytes = Vec::new();
        bytes.put_patch(&p);
        assert_eq!(bytes.len(), PATCH_BYTES);
        let mut fields = Fields::new(&bytes);
        assert_eq!(fields.patch(), Some(p));
        assert_eq!(fields.u8(), None);
    }
}
