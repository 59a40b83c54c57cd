//! The part file of a sharded bake: the rows one shard sampled (`patchvis bake --shard I/N`),
//! with everything the merge needs to write the `.pvis` without the mesh, and what it needs
//! to refuse parts of different bakes.
//!
//! Layout, little-endian:
//!
//! | field | bytes |
//! | --- | --- |
//! | magic `PVISPART` | 8 |
//! | version | `u32` |
//! | mesh hash ([`super::fingerprint::mesh_hash`]) | `u64` |
//! | tiling hash ([`super::fingerprint::tiling_hash`]) | `u64` |
//! | settings hash (XXH64 of the settings block) | `u64` |
//! | shard index, shard count | `u32` × 2 |
//! | triangles | `u32` |
//! | settings block length, then the block ([`RowSettings::encode`]) | `u32` + n |
//! | the file's camera: level, resolution, fov, centre, radius | `u32` × 2, `f32` × 5 |
//! | patches, then their records in the tiling's numbering (`wire.rs`) | `u32` + 48 each |
//! | passes ([`Plan::pass_levels`] of the settings: the sampling sphere's 1, or 2 with a fold threshold or the split fold, then as many for each sampling shell and each far shell), each: level, views, the view ids (ascending), then each view's row (`⌈patches / 64⌉` `u64` words) | … |
//! | CRC-32C of every byte before it | `u32` |
//!
//! The settings block is the bake's [`RowSettings`] as its shard planned them for the mesh
//! (the default's probe turned off where it could not run, `Plan::for_mesh`), in their one
//! codec: the merge plans them again to fold, number and encode, and a part is read only if
//! its camera, passes and views are exactly what that plan and its shard say. The shells'
//! distances follow from the camera and the settings
//! (`shells.rs`), so the merge computes them as the bake does. The camera and patch
//! records are checked as the reader checks a `.pvis`'s (`Part::decode`), so that a part
//! crafted under a recomputed checksum is refused, never merged into a file the format
//! forbids. They are the original mesh's (a mesh baked in a working frame gets them as
//! `Recipe::run` computes them). As the sampler's checkpoint does (`sampler/checkpoint.rs`),
//! the version is bumped whenever the rows change for the same inputs, and the CRC-32C
//! catches damage that would otherwise merge into a file that verifies but differs.

use super::plan::Plan;
use super::settings::RowSettings;
use super::shard::Shard;
use super::wire::{Fields, PATCH_BYTES, Put};
use crate::runtime::consts::MAX_PATCHES;
use crate::runtime::crc32c::crc32c;
use crate::sphere::view_count;
use crate::tiling::Patch;
use crate::visibility::SamplingParams;
use xxhash_rust::xxh64::xxh64;

const MAGIC: &[u8; 8] = b"PVISPART";
/// The layout's version; bumped with the sampler checkpoint's whenever the rows change for
/// the same settings, and whenever the layout or the settings' codec does.
const VERSION: u32 = 10;
const CRC_BYTES: usize = 4;
/// Bytes of the magic and the version, which [`Part::check_head`] checks.
pub const HEAD_BYTES: usize = 12;
/// Byte offset of the triangle count.
const TRIANGLES_AT: usize = 44;
/// What a refused part's message tells the user to do.
const BAKE_AGAIN: &str = "bake this shard again";

/// The rows of one sampling pass that a part holds.
#[derive(Clone, Debug, PartialEq)]
pub struct PassRows {
    /// The pass's sphere level.
    pub level: u32,
    /// The views held, ascending.
    pub views: Vec<u32>,
    /// Their rows, one after the other, `⌈patches / 64⌉` words each.
    pub words: Vec<u64>,
}

/// One shard's part of a sharded bake (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    /// Content hash of the mesh.
    pub mesh_hash: u64,
    /// Hash of the tiling sampled.
    pub tiling_hash: u64,
    /// Which shard this is.
    pub shard: Shard,
    /// Triangles of the mesh.
    pub triangle_count: u32,
    /// What decides the rows and the encoding, as the shard's bake planned it for the mesh
    /// (`Plan::for_mesh`).
    pub settings: RowSettings,
    /// The file's camera (the stored level's, the original mesh's bounding sphere).
    pub params: SamplingParams,
    /// The patch records in the tiling's numbering, of the original mesh.
    pub patches: Vec<Patch>,
    /// The rows of each pass ([`Plan::pass_levels`]).
    pub passes: Vec<PassRows>,
}

impl Part {
    /// The part file's bytes.
    pub fn encode(&self) -> Vec<u8> {
        let block = self.settings.encode();
        let mut b = Vec::new();
        b.extend_from_slice(MAGIC);
        b.put_u32(VERSION);
        b.put_u64(self.mesh_hash);
        b.put_u64(self.tiling_hash);
        b.put_u64(xxh64(&block, 0));
        b.put_u32(self.shard.index);
        b.put_u32(self.shard.count);
        b.put_u32(self.triangle_count);
        b.put_u32(block.len() as u32);
        b.extend_from_slice(&block);
        let p = &self.params;
        b.put_u32(p.level);
        b.put_u32(p.resolution);
        b.put_f32(p.fov_deg);
        for c in p.center {
            b.put_f32(c);
        }
        b.put_f32(p.radius);
        b.put_u32(self.patches.len() as u32);
        b.reserve(self.patches.len() * PATCH_BYTES);
        for patch in &self.patches {
            b.put_patch(patch);
        }
        b.put_u32(self.passes.len() as u32);
        for pass in &self.passes {
            b.put_u32(pass.level);
            b.put_u32(pass.views.len() as u32);
            for &v in &pass.views {
                b.put_u32(v);
            }
            b.reserve(pass.words.len() * 8);
            for &w in &pass.words {
                b.put_u64(w);
            }
        }
        let crc = crc32c(&b);
        b.put_u32(crc);
        b
    }

    /// Reads a part file's `bytes`; the error says what is wrong and what to do. Checks, in
    /// order: the magic, the version, the checksum, then that every field is in range (the
    /// settings hash, the levels, ascending views, rows of the right length with zero
    /// padding). Never panics.
    pub fn decode(bytes: &[u8]) -> Result<Part, String> {
        Part::check_head(bytes, bytes.len() as u64)?;
        let body = bytes.len() - CRC_BYTES;
        let stored = u32::from_le_bytes([
            bytes[body],
            bytes[body + 1],
            bytes[body + 2],
            bytes[body + 3],
        ]);
        if crc32c(&bytes[..body]) != stored {
            return Err(format!(
                "part file is damaged or cut short (checksum mismatch over its {} bytes); \
                 {BAKE_AGAIN}",
                bytes.len()
            ));
        }
        let (part, camera_at) = Part::fields(&bytes[12..body]).ok_or_else(|| {
            format!(
                "part file's fields are out of range though its checksum holds (written by a \
                 faulty build?); {BAKE_AGAIN}"
            )
        })?;
        part.check(12 + camera_at).map_err(|e| {
            format!("{e} (its checksum holds: written by a faulty build?); {BAKE_AGAIN}")
        })?;
        Ok(part)
    }

    /// What the reader checks of a `.pvis`'s camera and patch table (spec § CAMR, § PTCH),
    /// here before the merge writes them: a finite camera whose distance binary32 holds;
    /// at least one and at most `MAX_PATCHES` patches whose triangle ranges are non-empty,
    /// contiguous from triangle 0 and cover the part's triangles; finite bounding spheres of
    /// non-negative radius, finite cone axes, cone cosines in [-1, 1], finite non-negative
    /// areas. `camera_at` is the camera's byte offset in the file, the patch records follow
    /// it; an error names the byte of the first field that breaks a rule.
    fn check(&self, camera_at: usize) -> Result<(), String> {
        let p = &self.params;
        if !(p.center.iter().all(|c| c.is_finite())
            && p.radius.is_finite()
            && p.radius > 0.0
            && p.distance().is_finite())
        {
            return Err(format!(
                "byte {}: the camera's centre {:?} and radius {}, expected finite numbers, a \
                 positive radius and a camera distance binary32 holds",
                camera_at + 12,
                p.center,
                p.radius
            ));
        }
        let count = self.patches.len();
        if count == 0 || count > MAX_PATCHES as usize {
            return Err(format!(
                "byte {}: {count} patches, expected 1 to {MAX_PATCHES}",
                camera_at + 28
            ));
        }
        let records_at = camera_at + 32;
        let mut next = 0u64;
        for (i, patch) in self.patches.iter().enumerate() {
            let at = records_at + i * PATCH_BYTES;
            if u64::from(patch.first) != next || patch.count == 0 {
                return Err(format!(
                    "byte {at}: patch {i} covers triangles {}+{}, expected a non-empty range \
                     starting at {next}",
                    patch.first, patch.count
                ));
            }
            next += u64::from(patch.count);
            let sphere = patch.center.iter().all(|c| c.is_finite())
                && patch.radius.is_finite()
                && patch.radius >= 0.0;
            let cone = patch.cone_axis.iter().all(|c| c.is_finite())
                && (-1.0..=1.0).contains(&patch.cone_cos);
            let area = patch.area.is_finite() && patch.area >= 0.0;
            if !(sphere && cone && area) {
                return Err(format!(
                    "byte {at}: patch {i} has area {}, centre {:?}, radius {}, cone axis {:?} \
                     and cosine {}, expected finite numbers, a non-negative area and radius \
                     and a cosine in [-1, 1]",
                    patch.area, patch.center, patch.radius, patch.cone_axis, patch.cone_cos
                ));
            }
        }
        if next != u64::from(self.triangle_count) {
            return Err(format!(
                "byte {}: the patches cover {next} triangles, expected the {} the part says \
                 (byte {})",
                records_at - 4,
                self.triangle_count,
                TRIANGLES_AT
            ));
        }
        Ok(())
    }

    /// Checks the magic and the version, the first `HEAD_BYTES` (12) of a file of `len` bytes
    /// (`head` may hold more), so that a file of another kind is refused before the rest is
    /// read.
    pub fn check_head(head: &[u8], len: u64) -> Result<(), String> {
        if len < (HEAD_BYTES + CRC_BYTES) as u64
            || head.len() < HEAD_BYTES
            || head[..8] != MAGIC[..]
        {
            return Err(format!(
                "not a patchvis part file ({len} bytes, expected the magic PVISPART); give the \
                 files patchvis bake --shard wrote"
            ));
        }
        let version = u32::from_le_bytes([head[8], head[9], head[10], head[11]]);
        if version != VERSION {
            return Err(format!(
                "part file version {version}, expected {VERSION} (written by another patchvis \
                 build); {BAKE_AGAIN} with this one"
            ));
        }
        Ok(())
    }

    /// The fields after the version and the offset of the camera among them, or `None` if
    /// the layout does not hold (a count past the bytes, a pass or a view the settings and
    /// the shard do not give, a padding bit set).
    fn fields(bytes: &[u8]) -> Option<(Part, usize)> {
        let mut f = Fields::new(bytes);
        let mesh_hash = f.u64()?;
        let tiling_hash = f.u64()?;
        let settings_hash = f.u64()?;
        let shard = Shard::new(f.u32()?, f.u32()?).ok()?;
        let triangle_count = f.u32()?;
        let block_len = f.u32()?;
        let block = f.take(block_len as usize)?;
        if xxh64(block, 0) != settings_hash {
            return None;
        }
        let settings = RowSettings::decode(block)?;
        // Settings that plan, and the camera of that plan's sampling sphere.
        let plan = Plan::new(settings.clone()).ok()?;
        let camera_at = f.offset();
        let params = SamplingParams {
            level: f.u32()?,
            resolution: f.u32()?,
            fov_deg: f.f32()?,
            center: [f.f32()?, f.f32()?, f.f32()?],
            radius: f.f32()?,
        };
        let camera = params.level == plan.level()
            && params.resolution == settings.resolution
            && params.fov_deg.to_bits() == settings.fov_deg.to_bits();
        if !camera {
            return None;
        }
        let patch_count = f.u32()?;
        // Bounded by the bytes left before allocating.
        if (patch_count as usize).checked_mul(PATCH_BYTES)? > bytes.len() - f.offset() {
            return None;
        }
        let patches = (0..patch_count)
            .map(|_| f.patch())
            .collect::<Option<Vec<_>>>()?;
        let words_per_row = (patch_count as usize).div_ceil(64);
        let tail = patch_count % 64;
        let padding = if tail == 0 { 0 } else { !((1u64 << tail) - 1) };
        // Exactly the plan's passes, each with exactly the views the shard owns.
        let levels = plan.pass_levels();
        if f.u32()? as usize != levels.len() {
            return None;
        }
        let mut passes = Vec::new();
        for &expected in &levels {
            let level = f.u32()?;
            let n = f.u32()?;
            if level != expected || n > view_count(level) {
                return None;
            }
            let views = (0..n).map(|_| f.u32()).collect::<Option<Vec<_>>>()?;
            if views != shard.views(level) {
                return None;
            }
            let words_len = (n as usize).checked_mul(words_per_row)?;
            let raw = f.take(words_len.checked_mul(8)?)?;
            let words: Vec<u64> = raw
                .chunks_exact(8)
                .map(|c| u64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
                .collect();
            if words_per_row > 0
                && words
                    .chunks_exact(words_per_row)
                    .any(|row| row[words_per_row - 1] & padding != 0)
            {
                return None;
            }
            passes.push(PassRows {
                level,
                views,
                words,
            });
        }
        let part = Part {
            mesh_hash,
            tiling_hash,
            shard,
            triangle_count,
            settings,
            params,
            patches,
            passes,
        };
        (f.offset() == bytes.len()).then_some((part, camera_at))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A small valid part: shard 1 of 3 at level 1, 70 patches, two passes (a fold threshold)
    /// of the sampling sphere and of each of two shells.
    pub(crate) fn sample_part() -> Part {
        let settings = RowSettings {
            level: Some(1),
            resolution: 64,
            always_visible: vec![3],
            shell_level: Some(1),
            research: crate::bake::Research {
                probe: crate::bake::Probe::Off,
                fold_min_pixels: Some(4),
                ..crate::bake::Research::default()
            },
            ..RowSettings::default()
        };
        let shard = Shard { index: 1, count: 3 };
        let patches = (0..70)
            .map(|i| Patch {
                first: i,
                count: 1,
                area: 1.0,
                center: [i as f32, 0.0, 0.0],
                radius: 0.5,
                cone_axis: [0.0, 0.0, 1.0],
                cone_cos: 0.5,
            })
            .collect();
        let passes = Plan::new(settings.clone())
            .unwrap()
            .pass_levels()
            .into_iter()
            .map(|level| {
                let views = shard.views(level);
                let words = (0..views.len() * 2)
                    .map(|i| if i % 2 == 0 { i as u64 * 0x9E37 } else { 0x2F })
                    .collect();
                PassRows {
                    level,
                    views,
                    words,
                }
            })
            .collect();
        Part {
            mesh_hash: 1,
            tiling_hash: 2,
            shard,
            triangle_count: 70,
            settings,
            params: SamplingParams {
                level: 1,
                resolution: 64,
                fov_deg: 45.0,
                center: [0.0; 3],
                radius: 2.0,
            },
            patches,
            passes,
        }
    }

    #[test]
    fn a_part_reads_back() {
        let part = sample_part();
        assert_eq!(Part::decode(&part.encode()), Ok(part));
    }

    #[test]
    fn every_flipped_bit_and_every_truncation_is_refused() {
        let bytes = sample_part().encode();
        for bit in 0..bytes.len() * 8 {
            let mut damaged = bytes.clone();
            damaged[bit / 8] ^= 1 << (bit % 8);
            assert!(Part::decode(&damaged).is_err(), "bit {bit}");
        }
        for len in 0..bytes.len() {
            let err = Part::decode(&bytes[..len]).unwrap_err();
            assert!(!err.is_empty());
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(Part::decode(&longer).is_err());
    }

    #[test]
    fn fields_out_of_range_under_a_good_checksum_are_refused() {
        let mut part = sample_part();
        // A padding bit past patch 69.
        part.passes[0].words[1] |= 1 << 63;
        assert!(
            Part::decode(&part.encode())
                .unwrap_err()
                .contains("out of range")
        );
        let mut part = sample_part();
        part.passes[1].views.swap(0, 1);
        assert!(Part::decode(&part.encode()).is_err());
    }
}
