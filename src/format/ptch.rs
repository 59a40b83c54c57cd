//! Writing the patch table (spec § PTCH): the full `f32` layout of versions 1–3 and the
//! compact, quantised layout of version 4.
//!
//! The compact table quantises each patch *conservatively*: the decoded bounding sphere
//! contains the true one (the radius absorbs the centre's rounding) and the decoded normal
//! cone contains the true one (the half-angle absorbs the axis's rounding), so the
//! back-facing and frustum tests a renderer runs on decoded records stay conservative. Widths
//! are chosen per file: the centre grid is fine enough that the median patch's sphere grows by
//! at most a quarter of its radius, the radius and count fields are as wide as the largest
//! value needs, and the cone fields are fixed (measured in spec § Rationale). Cost: one pass
//! over the patches, a few trial axes each.

use crate::runtime::consts::*;
use crate::runtime::{PatchInfo, Quantisation, Record, unit_axis};
use crate::tiling::Patch;

/// Bits per octahedral coordinate of the cone axis: ±63 steps, at most about 1.3° off.
const AXIS_BITS: u32 = 7;

/// Bits of the cone's cosine: steps of 1/63.
const COS_BITS: u32 = 6;

/// The centre grid is chosen so that its step is at most this fraction of the median patch
/// radius: rounding a centre moves it by at most `step · √3 / 2`, so the median sphere grows
/// by at most ~22% of its radius.
const STEP_PER_MEDIAN_RADIUS: f64 = 0.25;

/// Margin added to a cone's half-angle for the binary32 rounding of the decoded axis and of
/// the renderer's test, in radians.
const CONE_MARGIN: f64 = 1e-5;

/// § PTCH, full layout: the header, then 40-byte records.
pub(super) fn full(triangle_count: u64, patches: &[Patch]) -> Vec<u8> {
    let len = PTCH_HEADER_LEN + PATCH_RECORD_LEN * patches.len() as u64;
    let mut out = Vec::with_capacity(len as usize);
    header(&mut out, triangle_count, patches.len());
    for patch in patches {
        out.extend_from_slice(&patch.first.to_le_bytes());
        out.extend_from_slice(&patch.count.to_le_bytes());
        for v in patch.center {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&patch.radius.to_le_bytes());
        for v in patch.cone_axis {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&patch.cone_cos.to_le_bytes());
    }
    out
}

/// The fixed part both layouts share: `patch_count`, reserved, `triangle_count`.
fn header(out: &mut Vec<u8>, triangle_count: u64, patches: usize) {
    // A count past u32 is caught by the reader's MAX_PATCHES check on the saturated value.
    let count = u32::try_from(patches).unwrap_or(u32::MAX);
    out.extend_from_slice(&count.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&triangle_count.to_le_bytes());
}

/// A compact table: its bytes and the cone axes the facing feature sees (the integer axes,
/// exactly as a reader decodes them).
pub(super) struct Compact {
    /// The PTCH section body.
    pub bytes: Vec<u8>,
    /// Per patch, the integer cone axis as `f32` (§ Features, `front`).
    pub facing_axes: Vec<[f32; 3]>,
}

/// § PTCH, compact layout (version 4), or `None` when the patches lie too far out for the
/// grid: the largest centre or radius it can express must be a finite `f32` (spec), which
/// fails only for coordinates near `f32::MAX` (about 1e37 and beyond).
///
/// # Panics
/// If the ranges are not contiguous from triangle 0 (a broken caller contract: the compact
/// table stores counts only, so it could not say where such a range starts).
pub(super) fn compact(triangle_count: u64, patches: &[Patch]) -> Option<Compact> {
    let mut next = 0u64;
    for (i, p) in patches.iter().enumerate() {
        assert!(
            u64::from(p.first) == next && p.count > 0,
            "encode: the bake contents break the .pvis format: patch {i} covers triangles \
             {}+{}, expected a non-empty range starting at {next}",
            p.first,
            p.count
        );
        next += u64::from(p.count);
    }
    let (q, records) = writer_records(patches)?;
    let mut out = Vec::new();
    header(&mut out, triangle_count, patches.len());
    for v in q.origin {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&q.step.to_le_bytes());
    for w in [
        q.count_bits,
        q.center_bits,
        q.radius_bits,
        q.axis_bits,
        q.cos_bits,
    ] {
        out.push(w as u8);
    }
    out.extend_from_slice(&[0; 3]);
    debug_assert_eq!(out.len() as u64, PTCH_COMPACT_HEADER_LEN);
    let mut first = 0u64;
    for (i, r) in records.iter().enumerate() {
        if (i as u32).is_multiple_of(PTCH_START_INTERVAL) {
            out.extend_from_slice(&(first as u32).to_le_bytes());
        }
        first += r.count;
    }
    let mut bits = BitWriter::default();
    for r in &records {
        bits.put((r.count - 1) as u32, q.count_bits);
        for c in r.center {
            bits.put(c, q.center_bits);
        }
        bits.put(r.radius, q.radius_bits);
        bits.put(r.axis[0], q.axis_bits);
        bits.put(r.axis[1], q.axis_bits);
        bits.put(r.cos, q.cos_bits);
    }
    out.extend_from_slice(&bits.finish());
    let facing_axes = records
        .iter()
        .map(|r| q.axis(r.axis[0], r.axis[1]).map(|a| a as f32))
        .collect();
    Some(Compact {
        bytes: out,
        facing_axes,
    })
}

/// The compact table's frame and every patch's record, as [`compact`] writes them, or `None`
/// when the patches lie too far out for the grid.
fn writer_records(patches: &[Patch]) -> Option<(Quantisation, Vec<Record>)> {
    let (q, records) = quantise_all(
        grid(patches, STEP_PER_MEDIAN_RADIUS, AXIS_BITS, COS_BITS),
        patches,
    );
    let top = |bits: u32| ((1u64 << bits) - 1) as u32;
    let representable = (0..3).all(|i| q.center(i, top(q.center_bits)).is_finite())
        && q.radius(top(q.radius_bits)).is_finite();
    representable.then_some((q, records))
}

/// What identifies a patch record, bit for bit, once read: its triangle count, bounding
/// sphere and normal cone (not where its range starts).
pub type RecordKey = (u32, [u32; 3], u32, [u32; 3], u32);

/// The key of a record as a reader decodes it.
pub fn record_key(r: &PatchInfo) -> RecordKey {
    (
        r.triangle_count,
        r.center.map(f32::to_bits),
        r.radius.to_bits(),
        r.cone_axis.map(f32::to_bits),
        r.cone_cos.to_bits(),
    )
}

/// Per patch, the key of the record a reader decodes from the compact table the writer
/// would write for `patches` (in any numbering: the frame depends on the set alone), or of
/// the patch's own values where that table cannot hold them (the writer then writes the
/// full one). Patches of equal values have equal compact keys, so a numbering that keeps
/// each group of equal compact keys in order keeps those of the full table in order too.
pub(super) fn writer_keys(patches: &[Patch]) -> Vec<RecordKey> {
    match writer_records(patches) {
        Some((q, records)) => records
            .iter()
            .zip(patches)
            .map(|(r, p)| record_key(&q.decode(r, p.first)))
            .collect(),
        None => patches
            .iter()
            .map(|p| record_key(&stored_record(None, p)))
            .collect(),
    }
}

/// Least-significant-bit-first packing.
#[derive(Default)]
struct BitWriter {
    bytes: Vec<u8>,
    acc: u64,
    used: u32,
}

impl BitWriter {
    fn put(&mut self, value: u32, bits: u32) {
        debug_assert!(bits == 32 || value >> bits == 0);
        self.acc |= u64::from(value) << self.used;
        self.used += bits;
        while self.used >= 8 {
            self.bytes.push(self.acc as u8);
            self.acc >>= 8;
            self.used -= 8;
        }
    }

    fn finish(mut self) -> Vec<u8> {
        if self.used > 0 {
            self.bytes.push(self.acc as u8);
        }
        self.bytes
    }
}

/// Bits needed to store every value up to `max`.
fn bits_for(max: u64) -> u32 {
    64 - max.leading_zeros()
}

/// The frame and widths for `patches` with a centre grid step of at most
/// `step_per_median_radius` times the median patch radius and the given cone widths
/// (`axis_bits` in `2..=16`, `cos_bits` in `1..=16`). For measurements: the writer uses a
/// quarter of the median radius, 7 and 6 bits.
pub fn choose_with(
    patches: &[Patch],
    step_per_median_radius: f64,
    axis_bits: u32,
    cos_bits: u32,
) -> Quantisation {
    quantise_all(
        grid(patches, step_per_median_radius, axis_bits, cos_bits),
        patches,
    )
    .0
}

/// The frame and widths of [`choose_with`] but `radius_bits`, which [`quantise_all`] sets.
fn grid(
    patches: &[Patch],
    step_per_median_radius: f64,
    axis_bits: u32,
    cos_bits: u32,
) -> Quantisation {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in patches {
        for i in 0..3 {
            lo[i] = lo[i].min(p.center[i]);
            hi[i] = hi[i].max(p.center[i]);
        }
    }
    let extent = (0..3)
        .map(|i| f64::from(hi[i]) - f64::from(lo[i]))
        .fold(0.0, f64::max);
    let mut radii: Vec<f32> = patches.iter().map(|p| p.radius).collect();
    radii.sort_unstable_by(f32::total_cmp);
    let median = f64::from(radii.get(radii.len() / 2).copied().unwrap_or(0.0));
    let max_radius = f64::from(radii.last().copied().unwrap_or(0.0));
    // The coarsest grid whose step is at most a quarter of the median radius, but no finer
    // than keeps every radius below 2^23 steps (the radius field's 24 bits, and integers
    // that binary32 holds exactly).
    let floor = max_radius / f64::from(1u32 << 22);
    let target = (median * step_per_median_radius).max(floor);
    let mut center_bits = 0;
    while center_bits < 24 && extent / (((1u64 << center_bits) - 1).max(1) as f64) > target {
        center_bits += 1;
    }
    let cells = ((1u64 << center_bits) - 1).max(1) as f64;
    // A positive step that covers the extent once rounded to binary32 (infinite only for
    // coordinates near f32::MAX, which `compact` then leaves to the full table).
    let mut step = if center_bits == 0 {
        target as f32
    } else {
        (extent / cells).max(floor) as f32
    };
    if step.is_nan() || step <= 0.0 {
        step = f32::MIN_POSITIVE;
    }
    while step.is_finite() && (f64::from(step) * cells) < extent {
        step = step.next_up();
    }
    let max_count = patches.iter().map(|p| p.count).max().unwrap_or(1);
    Quantisation {
        origin: lo.map(|v| if v.is_finite() { v } else { 0.0 }),
        step,
        count_bits: bits_for(u64::from(max_count.saturating_sub(1))),
        center_bits,
        // Set by `quantise_all` from the records; the widest allowed until then.
        radius_bits: 24,
        axis_bits,
        cos_bits,
    }
}

/// Every patch's record under `q` (whose `radius_bits` does not change them), and `q` with
/// `radius_bits` just wide enough for the largest radius.
fn quantise_all(mut q: Quantisation, patches: &[Patch]) -> (Quantisation, Vec<Record>) {
    let records: Vec<Record> = patches.iter().map(|p| quantise(&q, p)).collect();
    let max_radius = records.iter().map(|r| r.radius).max().unwrap_or(0);
    q.radius_bits = bits_for(u64::from(max_radius));
    (q, records)
}

/// The record a reader decodes for `patch` from a file whose patch table is quantised by
/// `quantisation` (`Pvis::quantisation`): the patch's own values in a full table, their
/// conservative quantised form in a compact one.
pub fn stored_record(quantisation: Option<Quantisation>, patch: &Patch) -> PatchInfo {
    match quantisation {
        Some(q) => q.decode(&quantise(&q, patch), patch.first),
        None => PatchInfo {
            first_triangle: patch.first,
            triangle_count: patch.count,
            center: patch.center,
            radius: patch.radius,
            cone_axis: patch.cone_axis,
            cone_cos: patch.cone_cos,
        },
    }
}

/// The record that stores `patch` conservatively under `q`.
pub fn quantise(q: &Quantisation, patch: &Patch) -> Record {
    let top = ((1u64 << q.center_bits) - 1) as f64;
    let center: [u32; 3] = core::array::from_fn(|i| {
        let t = (f64::from(patch.center[i]) - f64::from(q.origin[i])) / f64::from(q.step);
        t.round().clamp(0.0, top) as u32
    });
    // How far rounding moved the centre, in binary64 on the decoded binary32 values.
    let moved = (0..3)
        .map(|i| {
            let d = f64::from(q.center(i, center[i])) - f64::from(patch.center[i]);
            d * d
        })
        .sum::<f64>()
        .sqrt();
    let needed = f64::from(patch.radius) + moved;
    let mut radius = (needed / f64::from(q.step))
        .ceil()
        .clamp(0.0, f64::from(u32::MAX)) as u32;
    // The ceiling is enough but for binary32 rounding of the product; a step or two more at
    // most (radii stay below 2^23 steps, exact in binary32).
    for _ in 0..4 {
        if f64::from(q.radius(radius)) >= needed {
            break;
        }
        radius = radius.saturating_add(1);
    }
    let (axis, cos) = cone(q, patch.cone_axis, patch.cone_cos);
    Record {
        count: u64::from(patch.count),
        center,
        radius,
        axis,
        cos,
    }
}

/// The stored octahedral coordinates nearest `axis` and the cone cosine that covers the true
/// cone around the decoded axis.
fn cone(q: &Quantisation, axis: [f32; 3], cos: f32) -> ([u32; 2], u32) {
    let n = axis.map(f64::from);
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let m = q.axis_max();
    if len == 0.0 || !len.is_finite() {
        return ([m as u32, m as u32], 0);
    }
    let n = n.map(|c| c / len);
    let l1 = n[0].abs() + n[1].abs() + n[2].abs();
    let (mut x, mut y) = (n[0] / l1, n[1] / l1);
    if n[2] < 0.0 {
        let sgn = |a: f64| if a < 0.0 { -1.0 } else { 1.0 };
        (x, y) = ((1.0 - y.abs()) * sgn(x), (1.0 - x.abs()) * sgn(y));
    }
    let (fx, fy) = (x * f64::from(m), y * f64::from(m));
    // The best of the four grid points around the exact position.
    let mut best = ([m as u32, m as u32], f64::INFINITY);
    for u in [fx.floor(), fx.ceil()] {
        for v in [fy.floor(), fy.ceil()] {
            let (u, v) = (
                u.clamp(-f64::from(m), f64::from(m)),
                v.clamp(-f64::from(m), f64::from(m)),
            );
            let stored = [(u as i32 + m) as u32, (v as i32 + m) as u32];
            // The axis a reader decodes (binary32), and its angle to the true one by atan2:
            // `acos` of a dot product near 1 would turn the axis's rounding into an error of
            // 1e-4 radians at small angles.
            let d = unit_axis(q.axis(stored[0], stored[1])).map(f64::from);
            let cross = [
                d[1] * n[2] - d[2] * n[1],
                d[2] * n[0] - d[0] * n[2],
                d[0] * n[1] - d[1] * n[0],
            ];
            let sin = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
            let angle = sin.atan2(d[0] * n[0] + d[1] * n[1] + d[2] * n[2]);
            if angle < best.1 {
                best = (stored, angle);
            }
        }
    }
    let (stored, moved) = best;
    if cos <= 0.0 {
        return (stored, 0);
    }
    let half_angle = f64::from(cos.min(1.0)).acos() + moved + CONE_MARGIN;
    if half_angle >= core::f64::consts::FRAC_PI_2 {
        return (stored, 0);
    }
    let bound = half_angle.cos();
    let mut c = (bound * f64::from(q.cos_max())).floor() as u32;
    while c > 0 && f64::from(q.cos(c)) > bound {
        c -= 1;
    }
    (stored, c)
}
