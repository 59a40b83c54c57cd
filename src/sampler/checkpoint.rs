//! Checkpoints of a level-by-level bake, so that an interrupted bake resumes at the first
//! level it had not finished (`patchvis bake --resume`).
//!
//! After each sphere level the rows done so far are written atomically (temporary file in
//! the same directory, then rename) to the checkpoint path. A checkpoint records a hash of
//! everything that decides those rows (mesh positions and triangles, the tiling, sampling
//! parameters and options); one whose hash differs is refused rather than mixed into a
//! different bake. Layout, little-endian: magic `PVISCKPT`, `u32` version, `u32` levels done,
//! `u64` input hash, `u32` rows, `u32` patches, then the rows' `u64` words.
//! Cost: one hash pass over the mesh per bake; writing a level is one file of
//! `views × ⌈patches / 64⌉ × 8` bytes.

use super::{SamplingError, SamplingOptions, SamplingParams, VisibilityMatrix};
use crate::ooc::Mesh;
use crate::tiling::Tiling;
use std::io::Write;
use std::path::Path;

const MAGIC: &[u8; 8] = b"PVISCKPT";
/// Bumped whenever the sampler's rows change for the same inputs, so that a checkpoint an
/// older build wrote is refused instead of mixed with rows of this one: 2 since vertices
/// snap through the binary32 transform (`raster::snap32`), 3 since a depth tie goes to the
/// smaller patch id instead of the smaller input triangle.
const VERSION: u32 = 3;
const HEADER_BYTES: usize = 8 + 4 + 4 + 8 + 4 + 4;

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
) -> u64 {
    let mut h = InputHash(0xCBF2_9CE4_8422_2325);
    h.word(u64::from(VERSION));
    h.word(u64::from(params.level));
    h.word(u64::from(params.resolution));
    h.word(u64::from(params.fov_deg.to_bits()));
    for c in params.center {
        h.word(u64::from(c.to_bits()));
    }
    h.word(u64::from(params.radius.to_bits()));
    h.word(u64::from(options.min_pixels));
    h.word(u64::from(options.dilate) | u64::from(options.conservative) << 1);
    h.word(options.always_visible.len() as u64);
    for &p in &options.always_visible {
        h.word(u64::from(p));
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
    let io = |source| SamplingError::Io {
        path: path.to_path_buf(),
        action: "write",
        source,
    };
    let words = &matrix.words()[..rows as usize * matrix.words_per_row()];
    let mut bytes = Vec::with_capacity(HEADER_BYTES + words.len() * 8);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&VERSION.to_le_bytes());
    bytes.extend_from_slice(&levels_done.to_le_bytes());
    bytes.extend_from_slice(&hash.to_le_bytes());
    bytes.extend_from_slice(&rows.to_le_bytes());
    bytes.extend_from_slice(&matrix.patches().to_le_bytes());
    for w in words {
        bytes.extend_from_slice(&w.to_le_bytes());
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(io)?;
    tmp.write_all(&bytes).map_err(io)?;
    tmp.as_file().sync_all().map_err(io)?;
    tmp.persist(path).map_err(|e| io(e.error))?;
    Ok(())
}

/// Reads the checkpoint at `path` into the first rows of `matrix` and returns how many
/// levels it holds; `Ok(None)` if there is no file. A checkpoint of other inputs (`hash`) or
/// of another shape is an error.
pub(crate) fn load(
    path: &Path,
    hash: u64,
    matrix: &mut VisibilityMatrix,
) -> Result<Option<u32>, SamplingError> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => {
            return Err(SamplingError::Io {
                path: path.to_path_buf(),
                action: "read",
                source,
            });
        }
    };
    let bad = |reason: String| SamplingError::Checkpoint {
        path: path.to_path_buf(),
        reason,
    };
    if bytes.len() < HEADER_BYTES || &bytes[..8] != MAGIC {
        return Err(bad(format!(
            "not a patchvis checkpoint ({} bytes, expected the magic PVISCKPT and a {HEADER_BYTES}-byte header)",
            bytes.len()
        )));
    }
    let u32_at =
        |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let version = u32_at(8);
    if version != VERSION {
        return Err(bad(format!(
            "checkpoint version {version}, expected {VERSION}"
        )));
    }
    let levels_done = u32_at(12);
    let mut h = [0; 8];
    h.copy_from_slice(&bytes[16..24]);
    let found = u64::from_le_bytes(h);
    if found != hash {
        return Err(bad(format!(
            "stale checkpoint: written for other inputs or settings (hash {found:016x}, expected {hash:016x}); delete it or bake without --resume"
        )));
    }
    let (rows, patches) = (u32_at(24), u32_at(28));
    let expected_rows = if levels_done == 0 {
        0
    } else {
        crate::sphere::view_count(levels_done - 1)
    };
    if rows != expected_rows || rows > matrix.views() || patches != matrix.patches() {
        return Err(bad(format!(
            "checkpoint holds {rows} rows of {patches} patches after {levels_done} levels, expected {expected_rows} rows of {} patches",
            matrix.patches()
        )));
    }
    let words = rows as usize * matrix.words_per_row();
    if bytes.len() != HEADER_BYTES + words * 8 {
        return Err(bad(format!(
            "checkpoint is {} bytes, expected {}",
            bytes.len(),
            HEADER_BYTES + words * 8
        )));
    }
    for (w, chunk) in matrix.words_mut()[..words]
        .iter_mut()
        .zip(bytes[HEADER_BYTES..].chunks_exact(8))
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
            return Err(bad(format!(
                "row {row} has bits set past patch {}, expected zero padding",
                matrix.patches() - 1
            )));
        }
    }
    Ok(Some(levels_done))
}
