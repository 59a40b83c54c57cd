//! The patch table (spec § PTCH) in both layouts: 40-byte `f32` records (versions 1–3) and
//! the compact layout of version 4, fixed-width bit-packed records quantised relative to a
//! frame stored once.
//!
//! A compact record holds `triangle_count − 1`, the bounding-sphere centre as three grid
//! coordinates, the radius in grid steps, the normal-cone axis as two octahedral coordinates
//! and the cone's cosine in `1 / (2^cos_bits − 1)` steps; triangle ranges follow from the
//! counts, with the first triangle of every 64th patch stored so that a range is found in at
//! most 63 additions. Everything is decoded with the exact arithmetic the spec states, so
//! every reader sees the same spheres and cones; the writer quantises conservatively (a
//! decoded sphere contains the true one, a decoded cone the true normals). Cost: validation is
//! one pass over the records; a record is a few shifts and masks.

use super::consts::*;
use super::exact::dot_positive;
use super::fields::{POSITIVE, Section, at, finite3, float, read, reserved};
use super::stream::Stream;
use super::{Error, PatchInfo, Rule};

/// How version-4 records are quantised (spec § PTCH, compact layout): the header's frame and
/// field widths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantisation {
    /// Grid origin: centre coordinate `i` is `origin[i] + q · step`.
    pub origin: [f32; 3],
    /// Grid step of the centres, and the unit of the radii.
    pub step: f32,
    /// Bits of `triangle_count − 1`.
    pub count_bits: u32,
    /// Bits of each centre coordinate.
    pub center_bits: u32,
    /// Bits of the radius.
    pub radius_bits: u32,
    /// Bits of each octahedral coordinate of the cone axis.
    pub axis_bits: u32,
    /// Bits of the cone's cosine.
    pub cos_bits: u32,
}

impl Quantisation {
    /// Bits in one record.
    pub const fn record_bits(&self) -> u32 {
        self.count_bits
            + 3 * self.center_bits
            + self.radius_bits
            + 2 * self.axis_bits
            + self.cos_bits
    }

    /// The octahedral coordinates' bound `M = 2^(axis_bits − 1) − 1`: a stored coordinate is
    /// `u + M` with `u` in `−M..=M`.
    pub const fn axis_max(&self) -> i32 {
        (1 << (self.axis_bits - 1)) - 1
    }

    /// The cosine's denominator `2^cos_bits − 1`.
    pub const fn cos_max(&self) -> u32 {
        (1 << self.cos_bits) - 1
    }

    /// Centre coordinate `i` of grid coordinate `q` (binary32: one product, one sum).
    #[inline]
    pub fn center(&self, i: usize, q: u32) -> f32 {
        self.origin[i] + q as f32 * self.step
    }

    /// The radius of `q` steps (binary32).
    #[inline]
    pub fn radius(&self, q: u32) -> f32 {
        q as f32 * self.step
    }

    /// The cone's cosine of `q`; `q = 0` stands for no bound (reported as −1, every direction).
    #[inline]
    pub fn cos(&self, q: u32) -> f32 {
        if q == 0 {
            -1.0
        } else {
            q as f32 / self.cos_max() as f32
        }
    }

    /// The integer cone axis of the stored octahedral coordinates `(su, sv)` (spec § PTCH):
    /// `u = su − M`, `v = sv − M`, `z = M − |u| − |v|`; where `z < 0` the lower half folds
    /// back, `(x, y) = (sgn u · (M − |v|), sgn v · (M − |u|))` with `sgn 0 = +1`. The result
    /// has `|x| + |y| + |z| = M`.
    #[inline]
    pub fn axis(&self, su: u32, sv: u32) -> [i32; 3] {
        let m = self.axis_max();
        let (u, v) = (su as i32 - m, sv as i32 - m);
        let z = m - u.abs() - v.abs();
        if z >= 0 {
            [u, v, z]
        } else {
            let sgn = |a: i32| if a < 0 { -1 } else { 1 };
            [sgn(u) * (m - v.abs()), sgn(v) * (m - u.abs()), z]
        }
    }
}

impl Quantisation {
    /// The patch record `r` stands for, its range starting at triangle `first`.
    pub fn decode(&self, r: &Record, first: u32) -> PatchInfo {
        PatchInfo {
            first_triangle: first,
            triangle_count: r.count as u32,
            center: core::array::from_fn(|i| self.center(i, r.center[i])),
            radius: self.radius(r.radius),
            cone_axis: unit_axis(self.axis(r.axis[0], r.axis[1])),
            cone_cos: self.cos(r.cos),
        }
    }
}

/// The unit vector along an integer axis: each component divided by the length in binary64
/// (exact squares and sum, correctly rounded square root and division), then rounded to
/// binary32.
pub fn unit_axis(a: [i32; 3]) -> [f32; 3] {
    let [x, y, z] = a.map(f64::from);
    let len = libm::sqrt(x * x + y * y + z * z);
    if len == 0.0 {
        return [0.0; 3];
    }
    [(x / len) as f32, (y / len) as f32, (z / len) as f32]
}

/// One compact record's stored integers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Record {
    /// Triangles in the patch (at least 1).
    pub count: u64,
    /// Grid coordinates of the centre.
    pub center: [u32; 3],
    /// Radius in grid steps.
    pub radius: u32,
    /// Stored octahedral coordinates of the cone axis (`u + M`, `v + M`).
    pub axis: [u32; 2],
    /// The cone's cosine in `1 / (2^cos_bits − 1)` steps; 0 = no bound.
    pub cos: u32,
}

/// Reads `n ≤ 32` bits at bit offset `bit` of `bytes`, least significant first (0 past the end).
#[inline(always)]
pub(crate) fn bits(bytes: &[u8], bit: u64, n: u32) -> u32 {
    let start = (bit / 8) as usize;
    // One unaligned 8-byte load where the bytes are there (`bit % 8 + n ≤ 39` bits fit);
    // byte by byte at the end of the records.
    let word = match bytes.get(start..start.wrapping_add(8)) {
        Some(b) => u64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]),
        None => tail_word(bytes, start),
    };
    ((word >> (bit % 8)) & ((1u64 << n) - 1)) as u32
}

/// The 5 bytes at `start` as a little-endian word, 0 past the end: [`bits`] near the end of
/// the records. Out of line, so that the many inlined copies of `bits` share it.
#[cold]
#[inline(never)]
fn tail_word(bytes: &[u8], start: usize) -> u64 {
    (0..5).fold(0, |w, i| {
        w | u64::from(bytes.get(start.wrapping_add(i)).copied().unwrap_or(0)) << (8 * i)
    })
}

/// Reads compact record `p`. The fields are read in one loop over their widths rather than
/// one inlined bit read each: a record is read at parse and by [`PatchTable::info`], never
/// in a query's inner loop, so the smaller code wins (a few hundred bytes of WebAssembly).
#[inline]
pub(crate) fn read_record(q: &Quantisation, records: &[u8], p: u32) -> Record {
    let widths = [
        q.count_bits,
        q.center_bits,
        q.center_bits,
        q.center_bits,
        q.radius_bits,
        q.axis_bits,
        q.axis_bits,
        q.cos_bits,
    ];
    let mut bit = u64::from(p) * u64::from(q.record_bits());
    let mut f = [0u32; 8];
    for (v, &n) in f.iter_mut().zip(&widths) {
        *v = bits(records, bit, n);
        bit += u64::from(n);
    }
    Record {
        count: u64::from(f[0]) + 1,
        center: [f[1], f[2], f[3]],
        radius: f[4],
        axis: [f[5], f[6]],
        cos: f[7],
    }
}

/// A patch's cone axis as the `front` feature reads it (§ Features): the `f32` axis of a
/// full-layout record, or the integer axis of a compact one.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Axis {
    /// Versions 1–3.
    Float([f32; 3]),
    /// Version 4: `|x| + |y| + |z| = 2^(axis_bits − 1) − 1 < 2^15`.
    Int([i32; 3]),
}

impl Axis {
    /// The model's [`facing`](super::model::facing) of this axis from lattice point `v`
    /// (`|v.x| + |v.y| + |v.z| ≤ 2^7`). An integer axis needs no rounding at all: every
    /// product and sum is an integer below `2^22`, exact in binary64 as in `i32`. A float axis
    /// takes the binary64 steps in integers (`exact.rs`), so targets without binary64 hardware
    /// need no soft-float code.
    #[inline(always)]
    pub fn front(self, v: [i32; 3]) -> u32 {
        match self {
            Axis::Int(a) => u32::from(a[0] * v[0] + a[1] * v[1] + a[2] * v[2] > 0),
            Axis::Float(a) => u32::from(dot_positive(a, v)),
        }
    }
}

/// A validated patch table.
#[derive(Clone, Copy, Debug)]
pub(crate) enum PatchTable<'a> {
    /// Versions 1–3: `patch_count × PATCH_RECORD_LEN` bytes of records.
    Full(&'a [u8]),
    /// Version 4.
    Compact {
        /// The frame and widths.
        quantisation: Quantisation,
        /// `ceil(patch_count / 64)` little-endian `u32` first triangles of every 64th patch.
        starts: &'a [u8],
        /// The bit-packed records.
        records: &'a [u8],
    },
}

impl PatchTable<'_> {
    /// The triangle range `(first, count)` of patch `p`.
    pub fn range(&self, p: u32) -> (u32, u32) {
        match *self {
            PatchTable::Full(records) => {
                let mut s = Stream::new_at(records, p as usize * PATCH_RECORD_LEN as usize);
                (s.read().unwrap_or(0), s.read().unwrap_or(0))
            }
            PatchTable::Compact {
                quantisation: q,
                starts,
                records,
            } => {
                let block = p / PTCH_START_INTERVAL;
                let mut first = Stream::new_at(starts, block as usize * 4)
                    .read::<u32>()
                    .unwrap_or(0);
                for i in block * PTCH_START_INTERVAL..p {
                    first = first.wrapping_add(count_at(&q, records, i));
                }
                (first, count_at(&q, records, p))
            }
        }
    }

    /// The triangle range of patch `p`, given the range `(q, first, count)` of an earlier
    /// patch `q < p` when there is one: a compact table then adds the counts from `q` on when
    /// that is shorter than from `p`'s block start, so walking the patches in order costs one
    /// addition a patch.
    pub fn range_after(&self, known: Option<(u32, u32, u32)>, p: u32) -> (u32, u32) {
        match (*self, known) {
            (
                PatchTable::Compact {
                    quantisation: q,
                    records,
                    ..
                },
                Some((k, first, count)),
            ) if k < p && p - k <= p % PTCH_START_INTERVAL => {
                let mut at = first.wrapping_add(count);
                for i in k + 1..p {
                    at = at.wrapping_add(count_at(&q, records, i));
                }
                (at, count_at(&q, records, p))
            }
            _ => self.range(p),
        }
    }

    /// The record of patch `p`, decoded.
    pub fn info(&self, p: u32) -> PatchInfo {
        match *self {
            PatchTable::Full(records) => {
                let mut s = Stream::new_at(records, p as usize * PATCH_RECORD_LEN as usize);
                PatchInfo {
                    first_triangle: s.read().unwrap_or(0),
                    triangle_count: s.read().unwrap_or(0),
                    center: s.read().unwrap_or([0.0; 3]),
                    radius: s.read().unwrap_or(0.0),
                    cone_axis: s.read().unwrap_or([0.0; 3]),
                    cone_cos: s.read().unwrap_or(-1.0),
                }
            }
            PatchTable::Compact {
                quantisation: q,
                records,
                ..
            } => q.decode(&read_record(&q, records, p), self.range(p).0),
        }
    }

    /// The cone axis the facing feature of VISB encoding 2 uses (§ Features, `front`): the
    /// stored `f32` axis of a full record, the integer axis of a compact one (exact in `f32`).
    #[inline(always)]
    pub(crate) fn facing_axis(&self, p: u32) -> Axis {
        match *self {
            PatchTable::Full(records) => {
                let at = p as usize * PATCH_RECORD_LEN as usize + 24;
                match records.get(at..at + 12) {
                    Some(b) => Axis::Float(core::array::from_fn(|i| {
                        f32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]])
                    })),
                    None => Axis::Int([0; 3]),
                }
            }
            PatchTable::Compact {
                quantisation: q,
                records,
                ..
            } => {
                let at = u64::from(p) * u64::from(q.record_bits())
                    + u64::from(q.count_bits + 3 * q.center_bits + q.radius_bits);
                // Both coordinates in one read: 2 · axis_bits ≤ 32.
                let both = bits(records, at, 2 * q.axis_bits);
                let mask = (1 << q.axis_bits) - 1;
                Axis::Int(q.axis(both & mask, both >> q.axis_bits))
            }
        }
    }
}

/// Triangles in compact record `p`.
#[inline]
fn count_at(q: &Quantisation, records: &[u8], p: u32) -> u32 {
    let bit = u64::from(p) * u64::from(q.record_bits());
    bits(records, bit, q.count_bits).wrapping_add(1)
}

/// § PTCH: validates the section of a file of `version` and returns the table with
/// `(patch_count, triangle_count)`.
pub(crate) fn parse(
    data: &[u8],
    section: Section,
    version: u32,
) -> Result<(PatchTable<'_>, u32, u64), Error> {
    if section.length < PTCH_HEADER_LEN {
        return Err(Error::BadSection { tag: TAG_PTCH });
    }
    let have = data.len();
    let mut s = Stream::new_at(data, at(section.offset));
    let count_offset = s.offset() as u64;
    let patch_count = read::<u32>(&mut s, have)?;
    if patch_count == 0 {
        return Err(Error::Invalid {
            what: Rule::PatchCount,
            offset: count_offset,
            value: 0,
        });
    }
    if patch_count > MAX_PATCHES {
        return Err(Error::LimitExceeded {
            what: Rule::PatchCountLimit,
            value: patch_count as u64,
            limit: MAX_PATCHES as u64,
        });
    }
    reserved(&mut s, have, Rule::PtchReserved)?;
    let triangle_count = read::<u64>(&mut s, have)?;
    if triangle_count > u32::MAX as u64 {
        return Err(Error::LimitExceeded {
            what: Rule::TriangleCount,
            value: triangle_count,
            limit: u32::MAX as u64,
        });
    }
    let table = if version >= COMPACT_PTCH_VERSION {
        parse_compact(data, section, s, patch_count, triangle_count)?
    } else {
        parse_full(data, section, s, patch_count, triangle_count)?
    };
    Ok((table, patch_count, triangle_count))
}

/// § PTCH, full layout (versions 1–3).
fn parse_full<'a>(
    data: &'a [u8],
    section: Section,
    mut s: Stream<'a>,
    patch_count: u32,
    triangle_count: u64,
) -> Result<PatchTable<'a>, Error> {
    let have = data.len();
    // Cannot overflow: patch_count ≤ 2^20.
    let expected = PTCH_HEADER_LEN + PATCH_RECORD_LEN * patch_count as u64;
    if section.length != expected {
        return Err(Error::SectionLength {
            tag: TAG_PTCH,
            length: section.length,
            expected,
        });
    }
    let mut next_first = 0u64;
    for patch in 0..patch_count {
        let first = read::<u32>(&mut s, have)?;
        let count = read::<u32>(&mut s, have)?;
        if first as u64 != next_first || count == 0 {
            return Err(Error::PatchRange {
                patch,
                first,
                count,
                expected_first: next_first,
            });
        }
        next_first += count as u64;
        finite3(&mut s, have, Rule::PatchCenter)?;
        float(&mut s, have, Rule::PatchRadius, [0.0, f32::MAX])?;
        finite3(&mut s, have, Rule::PatchConeAxis)?;
        float(&mut s, have, Rule::PatchConeCos, [-1.0, 1.0])?;
    }
    if next_first != triangle_count {
        return Err(Error::TriangleCountMismatch {
            header: triangle_count,
            sum: next_first,
        });
    }
    let start = section.offset + PTCH_HEADER_LEN;
    Ok(PatchTable::Full(
        &data[at(start)..at(section.offset + section.length)],
    ))
}

/// § PTCH, compact layout (version 4).
fn parse_compact<'a>(
    data: &'a [u8],
    section: Section,
    mut s: Stream<'a>,
    patch_count: u32,
    triangle_count: u64,
) -> Result<PatchTable<'a>, Error> {
    let have = data.len();
    if section.length < PTCH_COMPACT_HEADER_LEN {
        return Err(Error::SectionLength {
            tag: TAG_PTCH,
            length: section.length,
            expected: PTCH_COMPACT_HEADER_LEN,
        });
    }
    let origin = finite3(&mut s, have, Rule::Origin)?;
    let step = float(&mut s, have, Rule::Step, POSITIVE)?;
    let widths_at = s.offset() as u64;
    let widths = read::<[u8; 4]>(&mut s, have)?;
    let cos_at = s.offset() as u64;
    let tail = read::<[u8; 4]>(&mut s, have)?;
    let width = |i: u64, value: u8, range: core::ops::RangeInclusive<u8>, what| {
        if range.contains(&value) {
            Ok(u32::from(value))
        } else {
            Err(Error::Invalid {
                what,
                offset: widths_at + i,
                value: value as u64,
            })
        }
    };
    let quantisation = Quantisation {
        origin,
        step,
        count_bits: width(0, widths[0], 0..=32, Rule::CountBits)?,
        center_bits: width(1, widths[1], 0..=24, Rule::CenterBits)?,
        radius_bits: width(2, widths[2], 0..=24, Rule::RadiusBits)?,
        axis_bits: width(3, widths[3], 2..=16, Rule::AxisBits)?,
        cos_bits: width(4, tail[0], 1..=16, Rule::CosBits)?,
    };
    if let Some(i) = tail[1..].iter().position(|&b| b != 0) {
        return Err(Error::Invalid {
            what: Rule::PtchReservedBytes,
            offset: cos_at + 1 + i as u64,
            value: tail[1 + i] as u64,
        });
    }
    // The largest centre and radius the widths can express must be finite, so that no
    // decoded value is.
    let top = |bits: u32| ((1u64 << bits) - 1) as u32;
    let step_at = section.offset + PTCH_HEADER_LEN + 12;
    let far = top(quantisation.center_bits);
    if !(0..3).all(|i| quantisation.center(i, far).is_finite()) {
        return Err(Error::InvalidFloat {
            what: Rule::StepCenterRange,
            offset: step_at,
            bits: step.to_bits(),
        });
    }
    if !quantisation
        .radius(top(quantisation.radius_bits))
        .is_finite()
    {
        return Err(Error::InvalidFloat {
            what: Rule::StepRadiusRange,
            offset: step_at,
            bits: step.to_bits(),
        });
    }
    let blocks = patch_count.div_ceil(PTCH_START_INTERVAL) as u64;
    let record_bits = u64::from(quantisation.record_bits());
    let starts_at = section.offset + PTCH_COMPACT_HEADER_LEN;
    let records_at = starts_at + 4 * blocks;
    let record_bytes = (patch_count as u64 * record_bits).div_ceil(8);
    let expected = PTCH_COMPACT_HEADER_LEN + 4 * blocks + record_bytes;
    if section.length != expected {
        return Err(Error::SectionLength {
            tag: TAG_PTCH,
            length: section.length,
            expected,
        });
    }
    let starts = &data[at(starts_at)..at(records_at)];
    let records = &data[at(records_at)..at(records_at + record_bytes)];
    let m = quantisation.axis_max() as u32;
    let mut next_first = 0u64;
    for patch in 0..patch_count {
        if patch.is_multiple_of(PTCH_START_INTERVAL) {
            let offset = starts_at + 4 * u64::from(patch / PTCH_START_INTERVAL);
            let start = read::<u32>(&mut Stream::new_at(data, at(offset)), have)?;
            if u64::from(start) != next_first {
                return Err(Error::Invalid {
                    what: Rule::BlockStart,
                    offset,
                    value: start as u64,
                });
            }
        }
        let r = read_record(&quantisation, records, patch);
        next_first += r.count;
        if next_first > triangle_count {
            break;
        }
        if let Some(i) = r.axis.iter().position(|&a| a > 2 * m) {
            let bit = u64::from(patch) * record_bits
                + u64::from(
                    quantisation.count_bits
                        + 3 * quantisation.center_bits
                        + quantisation.radius_bits,
                )
                + i as u64 * u64::from(quantisation.axis_bits);
            return Err(Error::Invalid {
                what: Rule::RecordAxis,
                offset: records_at + bit / 8,
                value: r.axis[i] as u64,
            });
        }
    }
    if next_first != triangle_count {
        return Err(Error::TriangleCountMismatch {
            header: triangle_count,
            sum: next_first,
        });
    }
    let used = patch_count as u64 * record_bits;
    if !used.is_multiple_of(8) {
        let last = records.last().copied().unwrap_or(0);
        if last >> (used % 8) != 0 {
            return Err(Error::Invalid {
                what: Rule::RecordPadding,
                offset: records_at + record_bytes - 1,
                value: last as u64,
            });
        }
    }
    Ok(PatchTable::Compact {
        quantisation,
        starts,
        records,
    })
}
