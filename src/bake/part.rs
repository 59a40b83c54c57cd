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
//! | settings block length, then the block ([`PartSettings`]) | `u32` + n |
//! | the file's camera: level, resolution, fov, centre, radius | `u32` × 2, `f32` × 5 |
//! | patches, then their records in the tiling's numbering (`wire.rs`) | `u32` + 48 each |
//! | passes ([`PartSettings::pass_levels`]: the sampling sphere's 1, or 2 with a fold threshold, then as many for each sampling shell), each: level, views, the view ids (ascending), then each view's row (`⌈patches / 64⌉` `u64` words) | … |
//! | CRC-32C of every byte before it | `u32` |
//!
//! The settings block holds what decides the rows and the encoding: level, sampled resolution,
//! fov bits, `min_pixels`, `dilate`, `conservative_raster`, extra levels, fold threshold,
//! fold corners, patch order, encoding, the probe pass (0, or its radius + 1), the
//! always-visible ids, and the sampling shells (count, `--shell-min` as binary64 bits, level,
//! extra levels, fold threshold, `--far-views`, then their probe pass and fold corners), and
//! `--sampled-rows`. The shells' distances follow from the camera and those
//! (`shells.rs`), so the merge computes them as the bake does. The camera and patch
//! records are the original mesh's (a mesh baked in a working frame gets them as
//! `Recipe::run` computes them). As the sampler's checkpoint does (`sampler/checkpoint.rs`),
//! the version is bumped whenever the rows change for the same inputs, and the CRC-32C
//! catches damage that would otherwise merge into a file that verifies but differs.

use super::settings::{PatchOrder, Supersample};
use super::shard::Shard;
use super::shells::MAX_SHELLS;
use super::wire::{Fields, PATCH_BYTES, Put};
use crate::format::VisibilityEncoding;
use crate::runtime::crc32c::crc32c;
use crate::sampler::{FinerViews, FoldCorners};
use crate::sphere::{MAX_LEVEL, view_count};
use crate::tiling::Patch;
use crate::visibility::SamplingParams;
use xxhash_rust::xxh64::xxh64;

const MAGIC: &[u8; 8] = b"PVISPART";
/// The layout's version; bumped with the sampler checkpoint's whenever the rows change, and
/// whenever the layout does: 3 since parts carry the sampling shells' passes, 4 since they
/// record `--far-views` (and a conservative part carries its split fold's second passes), 5
/// since they record the shells' probe and fold apart from the sampling sphere's, 6 since they
/// record `--sampled-rows`.
const VERSION: u32 = 7;

/// A fold's code in the settings block.
fn fold_code(corners: FoldCorners) -> u8 {
    match corners {
        FoldCorners::All => 0,
        FoldCorners::One => 1,
        FoldCorners::Split => 2,
        FoldCorners::Cover => 3,
    }
}

/// [`fold_code`]'s fold, or `None` for no fold's code.
fn fold_of(code: u8) -> Option<FoldCorners> {
    Some(match code {
        0 => FoldCorners::All,
        1 => FoldCorners::One,
        2 => FoldCorners::Split,
        3 => FoldCorners::Cover,
        _ => return None,
    })
}
const CRC_BYTES: usize = 4;
/// What a refused part's message tells the user to do.
const BAKE_AGAIN: &str = "bake this shard again";

/// The settings that decide a part's rows and the merged file's encoding.
#[derive(Clone, Debug, PartialEq)]
pub struct PartSettings {
    /// Stored sphere level.
    pub level: u32,
    /// Sampled ID-buffer side (`--conservative` already applied).
    pub resolution: u32,
    /// Field of view, degrees.
    pub fov_deg: f32,
    /// `--min-pixels`.
    pub min_pixels: u32,
    /// `--dilate`.
    pub dilate: bool,
    /// `--conservative-raster`.
    pub conservative_raster: bool,
    /// The probe pass's occluder shrink, or `None`.
    pub probe: Option<u32>,
    /// The shells' (`Recipe::shell_probe`).
    pub shell_probe: Option<u32>,
    /// Always-visible patches (the tiling's numbering).
    pub always_visible: Vec<u32>,
    /// Extra levels sampled and folded.
    pub extra_levels: u32,
    /// Fold threshold of the finer pass (0: no separate pass).
    pub fold_min_pixels: u32,
    /// Which stored views receive a finer view's patches.
    pub fold_corners: FoldCorners,
    /// The file's patch numbering.
    pub patch_order: PatchOrder,
    /// The VISB encoding.
    pub encoding: VisibilityEncoding,
    /// Sampling shells (`--shells`).
    pub shells: u32,
    /// The innermost shell's radius over the bounding radius (`--shell-min`).
    pub shell_min: f64,
    /// The shells' stored level.
    pub shell_level: u32,
    /// Extra levels the shells sample and fold.
    pub shell_extra_levels: u32,
    /// Fold threshold of the shells' finer passes (0: no separate pass).
    pub shell_fold_min_pixels: u32,
    /// `--far-views`.
    pub far_views: bool,
    /// Which stored shell views receive a finer view's patches.
    pub shell_fold_corners: FoldCorners,
    /// `--sampled-rows`: the merged file keeps the rows as sampled, unsaturated.
    pub sampled_rows: bool,
    /// Where the sampling sphere's finer views lie (`--finer-views`).
    pub finer_views: FinerViews,
}

impl PartSettings {
    /// The settings block's bytes.
    pub fn encode(&self) -> Vec<u8> {
        let mut b = Vec::new();
        for v in [
            self.level,
            self.resolution,
            self.fov_deg.to_bits(),
            self.min_pixels,
        ] {
            b.put_u32(v);
        }
        b.put_u8(u8::from(self.dilate));
        b.put_u8(u8::from(self.conservative_raster));
        b.put_u32(self.extra_levels);
        b.put_u32(self.fold_min_pixels);
        b.put_u8(fold_code(self.fold_corners));
        b.put_u8(match self.patch_order {
            PatchOrder::Covisibility => 0,
            PatchOrder::Spatial => 1,
        });
        b.put_u8(match self.encoding {
            VisibilityEncoding::Raw => 0,
            VisibilityEncoding::Hierarchical => 1,
            VisibilityEncoding::Tree => 2,
        });
        b.put_u32(self.probe.map_or(0, |r| r + 1));
        b.put_u32(self.always_visible.len() as u32);
        for &p in &self.always_visible {
            b.put_u32(p);
        }
        b.put_u32(self.shells);
        b.put_u64(self.shell_min.to_bits());
        b.put_u32(self.shell_level);
        b.put_u32(self.shell_extra_levels);
        b.put_u32(self.shell_fold_min_pixels);
        b.put_u8(u8::from(self.far_views));
        b.put_u32(self.shell_probe.map_or(0, |r| r + 1));
        b.put_u8(fold_code(self.shell_fold_corners));
        b.put_u8(u8::from(self.sampled_rows));
        b.put_u8(match self.finer_views {
            FinerViews::Midpoints => 0,
            FinerViews::Centroids => 1,
        });
        b
    }

    /// The XXH64 of [`PartSettings::encode`].
    pub fn hash(&self) -> u64 {
        xxh64(&self.encode(), 0)
    }

    fn decode(bytes: &[u8]) -> Option<PartSettings> {
        let mut f = Fields::new(bytes);
        let settings = PartSettings {
            level: f.u32()?,
            resolution: f.u32()?,
            fov_deg: f.f32()?,
            min_pixels: f.u32()?,
            dilate: flag(f.u8()?)?,
            conservative_raster: flag(f.u8()?)?,
            extra_levels: f.u32()?,
            fold_min_pixels: f.u32()?,
            fold_corners: fold_of(f.u8()?)?,
            patch_order: match f.u8()? {
                0 => PatchOrder::Covisibility,
                1 => PatchOrder::Spatial,
                _ => return None,
            },
            encoding: match f.u8()? {
                0 => VisibilityEncoding::Raw,
                1 => VisibilityEncoding::Hierarchical,
                2 => VisibilityEncoding::Tree,
                _ => return None,
            },
            probe: f.u32()?.checked_sub(1),
            always_visible: {
                let n = f.u32()?;
                (0..n).map(|_| f.u32()).collect::<Option<Vec<_>>>()?
            },
            shells: f.u32()?,
            shell_min: f64::from_bits(f.u64()?),
            shell_level: f.u32()?,
            shell_extra_levels: f.u32()?,
            shell_fold_min_pixels: f.u32()?,
            far_views: flag(f.u8()?)?,
            shell_probe: f.u32()?.checked_sub(1),
            shell_fold_corners: fold_of(f.u8()?)?,
            sampled_rows: flag(f.u8()?)?,
            finer_views: match f.u8()? {
                0 => FinerViews::Midpoints,
                1 => FinerViews::Centroids,
                _ => return None,
            },
        };
        let in_range = settings.level <= MAX_LEVEL
            && settings.extra_levels <= MAX_LEVEL
            && settings.shells <= MAX_SHELLS
            && settings.shell_level <= MAX_LEVEL
            && settings.shell_extra_levels <= MAX_LEVEL;
        (f.offset() == bytes.len() && in_range).then_some(settings)
    }

    /// The sphere levels of the sampling passes, in order: the sampling sphere's (the stored
    /// level plainly and the finer one thresholded, or the finer one alone, whose prefix is
    /// the stored level), then each shell's the same way at the shells' level.
    pub fn pass_levels(&self) -> Vec<u32> {
        let (main, shell) = self.sphere_pass_levels();
        let mut levels = main;
        for _ in 0..self.shells {
            levels.extend_from_slice(&shell);
        }
        levels
    }

    /// The layout of each pass's views, in [`PartSettings::pass_levels`]' order: the sampling
    /// sphere's finer pass has `--finer-views`' (`sampler::FineViews::pass`), every other pass
    /// the sphere's vertices.
    pub fn pass_finer_views(&self) -> Vec<FinerViews> {
        let (main, _) = self.sphere_pass_levels();
        let supersample = Supersample {
            extra_levels: self.extra_levels,
            fold_min_pixels: self.fold_min_pixels,
            fold_corners: self.fold_corners,
            finer: self.finer_views,
        };
        self.pass_levels()
            .iter()
            .enumerate()
            .map(|(i, &level)| {
                if i < main.len() {
                    supersample.finer_views(self.level, level)
                } else {
                    FinerViews::Midpoints
                }
            })
            .collect()
    }

    /// The pass levels of the sampling sphere, and of one shell.
    pub(crate) fn sphere_pass_levels(&self) -> (Vec<u32>, Vec<u32>) {
        let passes = |extra_levels, fold_min_pixels, fold_corners, level| {
            Supersample {
                extra_levels,
                fold_min_pixels,
                fold_corners,
                // The layout of the finer views changes no pass level.
                finer: FinerViews::Midpoints,
            }
            .pass_levels(level)
        };
        (
            passes(
                self.extra_levels,
                self.fold_min_pixels,
                self.fold_corners,
                self.level,
            ),
            passes(
                self.shell_extra_levels,
                self.shell_fold_min_pixels,
                self.shell_fold_corners,
                self.shell_level,
            ),
        )
    }
}

fn flag(b: u8) -> Option<bool> {
    match b {
        0 => Some(false),
        1 => Some(true),
        _ => None,
    }
}

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
    /// What decides the rows and the encoding.
    pub settings: PartSettings,
    /// The file's camera (the stored level's, the original mesh's bounding sphere).
    pub params: SamplingParams,
    /// The patch records in the tiling's numbering, of the original mesh.
    pub patches: Vec<Patch>,
    /// The rows of each pass ([`PartSettings::pass_levels`]).
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
        if bytes.len() < 12 + CRC_BYTES || &bytes[..8] != MAGIC {
            return Err(format!(
                "not a patchvis part file ({} bytes, expected the magic PVISPART); give the \
                 files patchvis bake --shard wrote",
                bytes.len()
            ));
        }
        let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        if version != VERSION {
            return Err(format!(
                "part file version {version}, expected {VERSION} (written by another patchvis \
                 build); {BAKE_AGAIN} with this one"
            ));
        }
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
        Part::fields(&bytes[12..body]).ok_or_else(|| {
            format!(
                "part file's fields are out of range though its checksum holds (written by a \
                 faulty build?); {BAKE_AGAIN}"
            )
        })
    }

    /// The fields after the version, or `None` if any is out of range.
    fn fields(bytes: &[u8]) -> Option<Part> {
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
        let settings = PartSettings::decode(block)?;
        let params = SamplingParams {
            level: f.u32()?,
            resolution: f.u32()?,
            fov_deg: f.f32()?,
            center: [f.f32()?, f.f32()?, f.f32()?],
            radius: f.f32()?,
        };
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
        let pass_count = f.u32()?;
        if pass_count > 2 * (1 + MAX_SHELLS) {
            return None;
        }
        let mut passes = Vec::new();
        for _ in 0..pass_count {
            let level = f.u32()?;
            if level > MAX_LEVEL {
                return None;
            }
            let n = f.u32()?;
            if n > view_count(level) {
                return None;
            }
            let views = (0..n).map(|_| f.u32()).collect::<Option<Vec<_>>>()?;
            let ascending = views.windows(2).all(|w| w[0] < w[1]);
            if !ascending || views.last().is_some_and(|&v| v >= view_count(level)) {
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
        (f.offset() == bytes.len()).then_some(Part {
            mesh_hash,
            tiling_hash,
            shard,
            triangle_count,
            settings,
            params,
            patches,
            passes,
        })
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A small valid part: shard 1 of 3 at level 1, 70 patches, two passes of the sampling
    /// sphere and one of each of two shells.
    pub(crate) fn sample_part() -> Part {
        let settings = PartSettings {
            level: 1,
            resolution: 64,
            fov_deg: 45.0,
            min_pixels: 0,
            dilate: false,
            conservative_raster: false,
            probe: None,
            shell_probe: None,
            always_visible: vec![3],
            extra_levels: 1,
            fold_min_pixels: 4,
            fold_corners: FoldCorners::All,
            patch_order: PatchOrder::Covisibility,
            encoding: VisibilityEncoding::Tree,
            shells: 2,
            shell_min: 1.1,
            shell_level: 1,
            shell_extra_levels: 1,
            shell_fold_min_pixels: 0,
            far_views: false,
            shell_fold_corners: FoldCorners::All,
            sampled_rows: false,
            finer_views: FinerViews::Centroids,
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
        let passes = settings
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
