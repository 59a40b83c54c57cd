//! The one way the reader reads a value: a cursor over `&[u8]` with `read::<T>()`.
//!
//! Follows ttf-parser's `Stream`: every read is bounds-checked and returns `Option`, values are
//! little-endian, and the cursor is an absolute file offset so errors can say where they are.
//! Cost: one bounds check per read.

/// A value with a fixed little-endian encoding.
pub(crate) trait FromData: Sized {
    /// Encoded size in bytes.
    const SIZE: usize;
    /// Decodes from exactly `SIZE` bytes.
    fn parse(data: &[u8]) -> Option<Self>;
}

impl FromData for u32 {
    const SIZE: usize = 4;
    fn parse(data: &[u8]) -> Option<Self> {
        data.try_into().ok().map(u32::from_le_bytes)
    }
}

impl FromData for u64 {
    const SIZE: usize = 8;
    fn parse(data: &[u8]) -> Option<Self> {
        data.try_into().ok().map(u64::from_le_bytes)
    }
}

impl FromData for f32 {
    const SIZE: usize = 4;
    fn parse(data: &[u8]) -> Option<Self> {
        u32::parse(data).map(f32::from_bits)
    }
}

impl FromData for [u8; 4] {
    const SIZE: usize = 4;
    fn parse(data: &[u8]) -> Option<Self> {
        data.try_into().ok()
    }
}

impl FromData for [f32; 3] {
    const SIZE: usize = 12;
    fn parse(data: &[u8]) -> Option<Self> {
        Some([
            f32::parse(data.get(0..4)?)?,
            f32::parse(data.get(4..8)?)?,
            f32::parse(data.get(8..12)?)?,
        ])
    }
}

/// A read cursor over a whole file; `offset` is absolute.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Stream<'a> {
    data: &'a [u8],
    offset: usize,
}

impl<'a> Stream<'a> {
    /// A cursor at `offset` (which may be past the end; reads then fail).
    pub(crate) fn new_at(data: &'a [u8], offset: usize) -> Self {
        Stream { data, offset }
    }

    /// Absolute offset of the next read.
    pub(crate) fn offset(&self) -> usize {
        self.offset
    }

    /// Reads one `T` and advances past it.
    pub(crate) fn read<T: FromData>(&mut self) -> Option<T> {
        let bytes = self.read_bytes(T::SIZE)?;
        T::parse(bytes)
    }

    /// Reads `len` raw bytes and advances past them.
    pub(crate) fn read_bytes(&mut self, len: usize) -> Option<&'a [u8]> {
        let end = self.offset.checked_add(len)?;
        let bytes = self.data.get(self.offset..end)?;
        self.offset = end;
        Some(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_little_endian_and_stops_at_the_end() {
        let data = [1, 0, 0, 0, 0, 0, 0x80, 0x3f, 9];
        let mut s = Stream::new_at(&data, 0);
        assert_eq!(s.read::<u32>(), Some(1));
        assert_eq!(s.read::<f32>(), Some(1.0));
        assert_eq!(s.offset(), 8);
        assert_eq!(s.read::<u32>(), None);
        assert_eq!(s.offset(), 8, "a failed read does not advance");
        assert_eq!(Stream::new_at(&data, usize::MAX).read_bytes(2), None);
    }
}
