//! Checkpoints of a level-by-level bake, so that an interrupted bake resumes at the first
//! level it had not finished (`patchvis bake --resume`).
//!
//! After each sphere level the rows done so far are written atomically to the checkpoint path
//! ([`crate::output::write_atomic`]: a temporary file `.NAME.patchvis-tmp` beside it, then a
//! rename; a killed run's temporary file is removed by the next run). A checkpoint records a
//! hash of everything that decides those rows (mesh positions and triangles, the tiling,
//! sampling parameters and options); one whose hash differs is refused rather than mixed into
//! a different bake. A CRC-32C over the whole file catches damage: rows with a flipped bit
//! would otherwise be resumed into a `.pvis` that passes `verify` but differs from the bake.
//!
//! Layout, little-endian: magic `PVISCKPT`, `u32` version, `u32` levels done, `u64` input
//! hash, `u32` rows, `u32` patches, the rows' `u64` words, then the `u32` CRC-32C of every
//! byte before it. Cost: one hash pass over the mesh per bake; writing a level is one file of
//! `views × ⌈patches / 64⌉ × 8` bytes, checksummed once when written and once when read.

use super::{SamplingError, SamplingOptions, SamplingParams, VisibilityMatrix};
use crate::ooc::Mesh;
use crate::runtime::crc32c::crc32c;
use crate::tiling::Tiling;
use std::path::Path;

const MAGIC: &[u8; 8] = b"PVISCKPT";
/// Bumped whenever the sampler's rows change for the same inputs, so that a checkpoint an
/// older build wrote is refused instead of mixed with rows of this one: 2 since vertices
/// snap through the binary32 transform (`raster::snap32`), 3 since a depth tie goes to the
/// smaller patch id instead of the smaller input triangle, 4 since the file ends in a
/// CRC-32C, 5 since it hashes the probe pass, 6 since it hashes a near pass's shell and the
/// band its probe spans, 7 since a pass may hold its seen rows too (`sample_tiled_split`)
/// and (until 10) render far views, 8 since a finer view's probe may leave
/// out what its parents hold (`SamplingOptions::folds_into`), 9 since a pass's finer views
/// may be face centroids (`SamplingOptions::finer`), 10 since the far views went (the far band
/// is shells beyond the sampling sphere), 11 since the probe may open apertures
/// (`SamplingOptions::apertures`).
const VERSION: u32 = 11;
const HEADER_BYTES: usize = 8 + 4 + 4 + 8 + 4 + 4;
const CRC_BYTES: usize = 4;
/// What a refused checkpoint's message tells the user to do.
const DELETE_IT: &str = "delete it to bake from the start";

/// A 64-bit FNV-1a-style hash fed whole words: enough to tell one bake's inputs from
/// another's, not a defence against deliberate collisions.
struct InputHash(u64);

impl InputHash {
    fn word(&mut self, w: u64) {
        self.0 = (self.0 ^ w).wrapping_mul(0x0000_0100_0000_01B3);
    }
}

/// The hash of everything that decides the visibility rows of a bake.
pub(crate) fn input_hash(
    mesh: &Mesh,
    tiling: &Tiling,
    params: &SamplingParams,
    options: &SamplingOptions,
    split: bool,
) -> u64 {
    let mut h = InputHash(0xCBF2_9CE4_8422_2325);
    h.word(u64::from(VERSION));
    h.word(u64::from(split));
    h.word(u64::from(params.level));
    h.word(u64::from(params.resolution));
    h.word(u64::from(params.fov_deg.to_bits()));
    for c in params.center {
        h.word(u64::from(c.to_bits()));
    }
    h.word(u64::from(params.radius.to_bits()));
    // Every option, destructured whole: a field added to `SamplingOptions` does not compile
    // here until it is hashed or said not to change the rows.
    let SamplingOptions {
        min_pixels,
        dilate,
        ref always_visible,
        conservative_raster,
        checkpoint: _,
        resume: _,
        memory: _,
        ref views,
        probe,
        apertures,
        shell,
        band,
        folds_into,
        finer,
    } = *options;
    h.word(u64::from(min_pixels));
    h.word(u64::from(dilate) | u64::from(conservative_raster) << 1);
    h.word(always_visible.len() as u64);
    for &p in always_visible {
        h.word(u64::from(p));
    }
    h.word(probe.map_or(0, |r| u64::from(r) + 1));
    h.word(u64::from(apertures));
    // A tag per option, so that a shell and a band of the same bits hash apart.
    h.word(shell.map_or(0, |r| u64::from(r.to_bits()) | 1 << 32));
    h.word(band.map_or(0, |[near, far]| {
        u64::from(near.to_bits()) | u64::from(far.to_bits()) << 32
    }));
    h.word(u64::from(band.is_some()));
    h.word(folds_into.map_or(0, |l| u64::from(l) + 1));
    h.word(match finer {
        crate::sampler::FinerViews::Midpoints => 0,
        crate::sampler::FinerViews::Centroids => 1,
    });
    if let Some(views) = views {
        h.word(views.len() as u64 | 1 << 63);
        for &v in views {
            h.word(u64::from(v));
        }
    }
    h.word(u64::from(mesh.vertex_count()));
    h.word(u64::from(mesh.triangle_count()));
    for v in 0..mesh.vertex_count() {
        let [x, y, z] = mesh.position(v).map(f32::to_bits);
        h.word(u64::from(x) | u64::from(y) << 32);
        h.word(u64::from(z));
    }
    for t in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(t);
        h.word(u64::from(a) | u64::from(b) << 32);
        h.word(u64::from(c));
    }
    h.word(tiling.patches.len() as u64);
    for (&p, &o) in tiling.patch_of.iter().zip(&tiling.order) {
        h.word(u64::from(p) | u64::from(o) << 32);
    }
    h.0
}

/// Writes the first `rows` rows of `matrix` as the checkpoint after `levels_done` levels.
pub(crate) fn save(
    path: &Path,
    hash: u64,
    levels_done: u32,
    rows: u32,
    matrix: &VisibilityMatrix,
) -> Result<(), SamplingError> {
    let bytes = encode(hash, levels_done, rows, matrix);
    crate::output::write_atomic(path, &bytes).map_err(|source| SamplingError::Io {
        path: path.to_path_buf(),
        action: "write",
        source,
    })
}

/// The checkpoint file holding the first `rows` rows of `matrix` after `levels_done` levels
/// of a bake whose inputs hash to `hash`.
///
/// Panics (caller contract) if `matrix` has fewer than `rows` rows.
pub fn encode(hash: u64, levels_done: u32, rows: u32, matrix: &VisibilityMatrix) -> Vec<u8> {
    assert!(
        rows <= matrix.views(),
        "{rows} rows of a {}-row matrix",
        matrix.views()
    );
    let words = &matrix.words()[..rows as usize * matrix.words_per_row()];
    let mut bytes = Vec::with_capacity(HEADER_BYTES + words.len() * 8 + CRC_BYTES);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&VERSION.to_le_bytes());
    bytes.extend_from_slice(&levels_done.to_le_bytes());
    bytes.extend_from_slice(&hash.to_le_bytes());
    bytes.extend_from_slice(&rows.to_le_bytes());
    bytes.extend_from_slice(&matrix.patches().to_le_bytes());
    for w in words {
        bytes.extend_from_slice(&w.to_le_bytes());
    }
    let crc = crc32c(&bytes);
    bytes.extend_from_slice(&crc.to_le_bytes());
    bytes
}

/// Reads the checkpoint at `path` into the first rows of `matrix` and returns how many
/// levels it holds; `Ok(None)` if there is no file. A damaged checkpoint, one of other
/// inputs (`hash`) or one of another shape is an error that says what to do.
pub(crate) fn load(
    path: &Path,
    hash: u64,
    matrix: &mut VisibilityMatrix,
) -> Result<Option<u32>, SamplingError> {
    // The largest checkpoint of this matrix: every row.
    let limit = (HEADER_BYTES + CRC_BYTES) as u64 + 8 * matrix.words().len() as u64;
    let bytes = match crate::mapped::read_regular(path, limit, "a checkpoint of this bake") {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        // Larger than any checkpoint of this bake: another bake's (a split pass's, say).
        Err(e) if e.kind() == std::io::ErrorKind::FileTooLarge => {
            return Err(SamplingError::Checkpoint {
                path: path.to_path_buf(),
                reason: format!("{e}; {DELETE_IT}"),
            });
        }
        Err(source) => {
            return Err(SamplingError::Io {
                path: path.to_path_buf(),
                action: "read",
                source,
            });
        }
    };
    decode(&bytes, hash, matrix)
        .map(Some)
        .map_err(|reason| SamplingError::Checkpoint {
            path: path.to_path_buf(),
            reason,
        })
}

/// Reads checkpoint `bytes` of a bake whose inputs hash to `hash` into the first rows of
/// `matrix` (which gives the expected patch count and the most rows) and returns how many
/// levels they hold; or why they were refused, with what the user should do. Checks, in
/// order: the magic, the version, the CRC-32C, the input hash, the shape, the padding bits.
/// Never panics; on error `matrix` may hold some of the refused rows.
pub fn decode(bytes: &[u8], hash: u64, matrix: &mut VisibilityMatrix) -> Result<u32, String> {
    if bytes.len() < HEADER_BYTES + CRC_BYTES || &bytes[..8] != MAGIC {
        return Err(format!(
            "not a patchvis checkpoint ({} bytes, expected the magic PVISCKPT, a {HEADER_BYTES}-byte header and a checksum); {DELETE_IT}",
            bytes.len()
        ));
    }
    let u32_at =
        |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let version = u32_at(8);
    if version != VERSION {
        return Err(format!(
            "checkpoint version {version}, expected {VERSION} (written by another patchvis build); {DELETE_IT}"
        ));
    }
    let body = bytes.len() - CRC_BYTES;
    if crc32c(&bytes[..body]) != u32_at(body) {
        return Err(format!(
            "checkpoint is damaged (checksum mismatch over its {} bytes); {DELETE_IT}",
            bytes.len()
        ));
    }
    let levels_done = u32_at(12);
    let mut h = [0; 8];
    h.copy_from_slice(&bytes[16..24]);
    let found = u64::from_le_bytes(h);
    if found != hash {
        return Err(format!(
            "stale checkpoint: written for other inputs or settings (hash {found:016x}, expected {hash:016x}); delete it or bake without --resume"
        ));
    }
    let (rows, patches) = (u32_at(24), u32_at(28));
    let expected_rows = match levels_done.checked_sub(1) {
        None => 0,
        Some(level) if level <= crate::sphere::MAX_LEVEL => crate::sphere::view_count(level),
        Some(_) => u32::MAX,
    };
    if rows != expected_rows || rows > matrix.views() || patches != matrix.patches() {
        return Err(format!(
            "checkpoint holds {rows} rows of {patches} patches after {levels_done} levels, expected {expected_rows} rows of {} patches; {DELETE_IT}",
            matrix.patches()
        ));
    }
    let words = rows as usize * matrix.words_per_row();
    if body != HEADER_BYTES + words * 8 {
        return Err(format!(
            "checkpoint is {} bytes, expected {}; {DELETE_IT}",
            bytes.len(),
            HEADER_BYTES + words * 8 + CRC_BYTES
        ));
    }
    for (w, chunk) in matrix.words_mut()[..words]
        .iter_mut()
        .zip(bytes[HEADER_BYTES..body].chunks_exact(8))
    {
        let mut b = [0; 8];
        b.copy_from_slice(chunk);
        *w = u64::from_le_bytes(b);
    }
    let tail = matrix.patches() % 64;
    if tail != 0 {
        let padding = !((1u64 << tail) - 1);
        let last = matrix.words_per_row() - 1;
        if let Some(row) = (0..rows).find(|&r| matrix.row(r)[last] & padding != 0) {
            return Err(format!(
                "row {row} has bits set past patch {}, expected zero padding; {DELETE_IT}",
                matrix.patches() - 1
            ));
        }
    }
    Ok(levels_done)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three levels' rows (18 views) of 70 patches, some bits set.
    fn matrix() -> VisibilityMatrix {
        let mut m = VisibilityMatrix::new(crate::sphere::view_count(2), 70);
        for v in 0..m.views() {
            for p in (v % 7..70).step_by(9) {
                m.set(v, p);
            }
        }
        m
    }

    #[test]
    fn a_checkpoint_reads_back() {
        let m = matrix();
        let rows = crate::sphere::view_count(1);
        let bytes = encode(7, 2, rows, &m);
        let mut back = VisibilityMatrix::new(m.views(), m.patches());
        assert_eq!(decode(&bytes, 7, &mut back), Ok(2));
        for v in 0..rows {
            assert_eq!(back.row(v), m.row(v));
        }
        let err = decode(&bytes, 8, &mut back).unwrap_err();
        assert!(err.contains("stale checkpoint"), "{err}");
    }

    #[test]
    fn every_flipped_bit_and_every_truncation_is_refused() {
        let m = matrix();
        let bytes = encode(7, 2, crate::sphere::view_count(1), &m);
        let mut back = VisibilityMatrix::new(m.views(), m.patches());
        for bit in 0..bytes.len() * 8 {
            let mut damaged = bytes.clone();
            damaged[bit / 8] ^= 1 << (bit % 8);
            let err = decode(&damaged, 7, &mut back).unwrap_err();
            assert!(err.ends_with(DELETE_IT), "bit {bit}: {err}");
        }
        for len in 0..bytes.len() {
            assert!(decode(&bytes[..len], 7, &mut back).is_err(), "{len} bytes");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode(&longer, 7, &mut back).is_err());
    }
}
