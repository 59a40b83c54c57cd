//! The heap budget of a bake (`--memory`) and how it is shared between the stages, decided
//! here and nowhere else, and reported with the bake's stats.
//!
//! The stages run one after the other, so each may use the whole budget minus what the
//! stages before it leave alive. What lives through the whole bake is small next to the mesh:
//! the tiling's per-triangle maps are on the heap only when the tiling ran in core (which it
//! does only when its peak, far larger, fits the budget) and memory-mapped otherwise; the
//! visibility rows take one bit per view and patch. The mesh itself is memory-mapped and not
//! counted: the page cache holds it, which is why the default budget is half the available
//! memory and not all of it.
//!
//! | stage | share | how it keeps to it |
//! |---|---|---|
//! | input conversion | whole | text meshes are converted streaming, in runs of that size |
//! | tiling | whole | in core when its peak fits, else out of core within it |
//! | sampling | whole; the patch-ordered mesh copy ¼ | the copy is memory-mapped past ¼ |
//! | GPU upload | ¼, at most 256 MiB | host staging of one vertex and index buffer pair |
//! | `--dilate` patch graph | whole | refused with a clear error when it cannot fit |
//! | `--conservative` solids | ½ (beside the mesh copy) | refused with a clear error when they cannot fit |
//! | encoding | whole | the rows, a few counts and the file (kilobytes to megabytes) |
//! | eval | whole | per-triangle maps bounded by a check, pixels per worker |
//!
//! **The minimum.** Some needs do not shrink with the budget: the sampler's per-worker ID
//! buffers (and the probe pass's shrunk occluders beside them), the batch of the
//! patch-ordered mesh it builds, the visibility rows, and the out-of-core tiling's merge
//! buffers and small patch graph. [`MemoryBudget::minimum`] adds
//! them up for one bake (constants measured with `--stats` on the bunny and a 400K-triangle
//! mesh, with margin), and the bake refuses a budget below it before any work, naming the
//! minimum, so that every budget it accepts is honoured.

/// Smallest default budget: below this the machine is too small to bake anything large
/// anyway, and a tiny budget would only make conversion slow.
const MIN_DEFAULT: u64 = 256 << 20;

/// The budget where the available memory cannot be read (not Linux).
const FALLBACK: u64 = 512 << 20;

/// Largest host staging buffer of the GPU upload.
const MAX_GPU_STAGING: u64 = 256 << 20;

/// Bytes the `--dilate` patch graph takes while it is built, per triangle: three sorted
/// edge entries of 16 bytes (the neighbour lists after them are smaller).
pub const PATCH_GRAPH_BYTES_PER_TRIANGLE: u64 = 48;

/// Bytes `--conservative`'s solids (`sampler/solid.rs`) take while they are built, per
/// triangle: three directed edges of 16 bytes sorted, the union-find, the weld and the
/// per-triangle component and orientation that stay; the boundary is kept in the edges'
/// place, and sheets keep no caps. Measured as the sampling stage's peak heap over the
/// default bake's (`--stats`): 24 (bunny), 39 (a 400,000-triangle truss), 41 (cards of two
/// triangles), 49 (lone triangles) and 50 (open tubes with 256-vertex loops).
pub const SOLIDS_BYTES_PER_TRIANGLE: u64 = 60;

/// The largest mesh whose solids fit the solids' share of the smallest default budget: the
/// default bake's probe pass runs on meshes up to this many triangles (2,236,962), on every
/// machine alike (`bake::Plan::for_mesh`).
pub const DEFAULT_PROBE_MAX_TRIANGLES: u32 = (MIN_DEFAULT / 2 / SOLIDS_BYTES_PER_TRIANGLE) as u32;

/// Heap of the sampler per triangle of the batch of its patch-ordered mesh being built
/// (whole patches, at most `MAPPED_BATCH_TRIANGLES`, 2^19 triangles, when the copy is
/// mapped): measured 18 (400K triangles) to 34 (bunny, 100 triangles a patch) bytes.
pub const SAMPLING_BUILD_BYTES_PER_TRIANGLE: u64 = 36;

/// Triangles of the sampler's mesh batch (`sampler::patch_mesh`'s `MAPPED_BATCH_TRIANGLES`).
const SAMPLING_BATCH_TRIANGLES: u64 = 1 << 19;

/// Heap of each sampling worker per ID-buffer pixel: an 8-byte depth/patch key, the tiles,
/// and the back faces put off until the tiles exist: measured 8 to 12 bytes on the bunny at
/// 128 to 1024 pixels.
pub const SAMPLING_BYTES_PER_PIXEL: u64 = 12;

/// Heap of each sampling worker per ID-buffer pixel for the probe pass (the default bake's
/// and `--conservative`'s), at most, counted from its buffers rather than measured: its
/// shrunk occluders, a 4-byte depth (`sampler::key_buffer`'s `DepthBuffer`); the pixels where
/// one boundary loop's cap lies in front of them, up to 4 bytes each when the cap fills the
/// image; the openings' distance grids, a quarter of a byte; the tiles and a ring of a few
/// rows.
pub const PROBE_BYTES_PER_PIXEL: u64 = 9;
/// Heap per worker and pixel of `--apertures` (`sampler/tiled/aperture.rs`): each pixel's
/// revealed depth, and three `f32` images of scratch (the depths, then the spread's wedges).
pub const APERTURE_BYTES_PER_PIXEL: u64 = 16;

/// Heap a bake takes whatever its budget: the out-of-core tiling's merge buffers and patch
/// graph (3.0 to 4.0 MB measured on the bunny and a 400K-triangle mesh at budgets of 1 to
/// 8 MiB), per-patch records and the allocator's slack.
pub const MIN_FIXED_BYTES: u64 = 4 << 20;

/// Slack on top of the sampler's measured needs (per-patch scratch, allocator rounding).
const SAMPLING_SLACK_BYTES: u64 = 1 << 20;

/// What one bake needs from the heap whatever its budget ([`MemoryBudget::minimum`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FixedNeeds {
    /// Triangles of the mesh.
    pub triangles: u32,
    /// Side of the sampled ID buffers, in pixels.
    pub resolution: u32,
    /// Sampling workers (threads), each with its own ID buffer.
    pub workers: usize,
    /// Bytes of the visibility rows sampled (one bit per view and patch).
    pub row_bytes: u64,
    /// Whether some pass runs the probe pass ([`PROBE_BYTES_PER_PIXEL`] more per worker).
    pub probe: bool,
    /// Whether its probe opens apertures ([`APERTURE_BYTES_PER_PIXEL`] more per worker).
    pub apertures: bool,
}

impl FixedNeeds {
    /// The sampler's heap besides the patch-ordered mesh copy (which is mapped when the rest
    /// of the budget cannot hold it).
    pub fn sampling(&self) -> u64 {
        let batch = u64::from(self.triangles).min(SAMPLING_BATCH_TRIANGLES);
        let pixels = u64::from(self.resolution).pow(2);
        let per_pixel = SAMPLING_BYTES_PER_PIXEL
            + if self.probe { PROBE_BYTES_PER_PIXEL } else { 0 }
            + if self.probe && self.apertures {
                APERTURE_BYTES_PER_PIXEL
            } else {
                0
            };
        SAMPLING_SLACK_BYTES
            .saturating_add(batch.saturating_mul(SAMPLING_BUILD_BYTES_PER_TRIANGLE))
            .saturating_add((self.workers as u64).saturating_mul(pixels.saturating_mul(per_pixel)))
            .saturating_add(self.row_bytes.saturating_mul(2))
    }
}

/// A heap budget in bytes and its split between the stages (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryBudget {
    total: u64,
}

/// The sampler's share of a budget ([`StageBudgets::sampling`]), in bytes, as the sampler
/// takes it (`sampler::SamplingOptions::memory`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SamplingShare {
    /// Per-worker buffers, the rows and the patch-ordered mesh copy together.
    pub total: u64,
    /// Above this, the sampler's patch-ordered mesh copy lives in a mapped temporary file.
    pub mesh_copy: u64,
    /// Host staging of the GPU upload (one vertex and index buffer pair at a time).
    pub gpu_staging: u64,
}

/// The shares of [`MemoryBudget::split`], in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StageBudgets {
    /// Text-to-binary mesh conversion.
    pub input: u64,
    /// Tiling (in core or out of core).
    pub tiling: u64,
    /// Sampling: per-worker buffers, the rows, the mesh copy and the GPU upload.
    pub sampling: SamplingShare,
    /// The `--dilate` patch graph.
    pub patch_graph: u64,
    /// `--conservative`'s solids, built before sampling and kept through it.
    pub solids: u64,
    /// Numbering and encoding.
    pub encoding: u64,
    /// `patchvis eval`.
    pub eval: u64,
}

impl MemoryBudget {
    /// A budget of `bytes`.
    pub fn new(bytes: u64) -> MemoryBudget {
        MemoryBudget { total: bytes }
    }

    /// Half of `MemAvailable` from `/proc/meminfo` (the other half left to the page cache that
    /// serves the mapped mesh), at least 256 MiB; 512 MiB where that file is missing.
    pub fn from_available_memory() -> MemoryBudget {
        let available_kib = std::fs::read_to_string("/proc/meminfo")
            .ok()
            .and_then(|text| {
                text.lines()
                    .find_map(|l| l.strip_prefix("MemAvailable:"))
                    .and_then(|rest| {
                        rest.trim()
                            .trim_end_matches("kB")
                            .trim()
                            .parse::<u64>()
                            .ok()
                    })
            });
        MemoryBudget::new(match available_kib {
            Some(kib) => (kib * 1024 / 2).max(MIN_DEFAULT),
            None => FALLBACK,
        })
    }

    /// The whole budget in bytes.
    pub fn total(&self) -> u64 {
        self.total
    }

    /// Each stage's share.
    pub fn split(&self) -> StageBudgets {
        let quarter = self.total / 4;
        StageBudgets {
            input: self.total,
            tiling: self.total,
            sampling: SamplingShare {
                total: self.total,
                mesh_copy: quarter,
                gpu_staging: quarter.min(MAX_GPU_STAGING),
            },
            patch_graph: self.total,
            solids: self.total / 2,
            encoding: self.total,
            eval: self.total,
        }
    }

    /// The smallest budget a bake with `needs` keeps to, in bytes, rounded up to a MiB:
    /// the larger of [`MIN_FIXED_BYTES`] and the sampler's needs ([`FixedNeeds::sampling`]).
    pub fn minimum(needs: &FixedNeeds) -> u64 {
        let bytes = needs.sampling().max(MIN_FIXED_BYTES);
        bytes.div_ceil(1 << 20).saturating_mul(1 << 20)
    }

    /// Whether `--conservative`'s solids of `triangles` triangles fit.
    pub fn fits_solids(&self, triangles: u32) -> bool {
        u64::from(triangles) * SOLIDS_BYTES_PER_TRIANGLE <= self.split().solids
    }

    /// Whether the `--dilate` patch graph of `triangles` triangles fits.
    pub fn fits_patch_graph(&self, triangles: u32) -> bool {
        u64::from(triangles) * PATCH_GRAPH_BYTES_PER_TRIANGLE <= self.split().patch_graph
    }
}

impl Default for MemoryBudget {
    /// [`MemoryBudget::from_available_memory`].
    fn default() -> MemoryBudget {
        MemoryBudget::from_available_memory()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shares_never_exceed_the_budget() {
        for total in [0, 1, 3 << 20, 256 << 20, 5 << 30, u64::MAX] {
            let s = MemoryBudget::new(total).split();
            for share in [
                s.input,
                s.tiling,
                s.sampling.total,
                s.sampling.mesh_copy,
                s.sampling.gpu_staging,
                s.patch_graph,
                s.encoding,
                s.eval,
            ] {
                assert!(share <= total, "{share} of {total}");
            }
            assert!(s.sampling.gpu_staging <= MAX_GPU_STAGING);
        }
        assert!(MemoryBudget::from_available_memory().total() >= MIN_DEFAULT.min(FALLBACK));
    }

    #[test]
    fn the_minimum_grows_with_the_fixed_needs_and_is_whole_mebibytes() {
        let bunny = FixedNeeds {
            triangles: 99_785,
            resolution: 128,
            workers: 2,
            row_bytes: 66 * 1000 / 8,
            probe: false,
            apertures: false,
        };
        let m = MemoryBudget::minimum(&bunny);
        assert_eq!(m % (1 << 20), 0);
        // The bunny's measured sampling peak at 1 MiB was 3.78 MB: the minimum covers it.
        assert!((3_780_000..8 << 20).contains(&m), "{m}");
        let finer = MemoryBudget::minimum(&FixedNeeds {
            resolution: 1024,
            ..bunny
        });
        assert!(finer > m + (20 << 20), "{finer}");
        // The probe pass: 9 bytes a pixel on each of the 2 workers.
        let probed = MemoryBudget::minimum(&FixedNeeds {
            probe: true,
            ..FixedNeeds {
                resolution: 1024,
                ..bunny
            }
        });
        assert!(
            probed >= finer + (18 << 20) - (1 << 20),
            "{probed} against {finer}"
        );
        let tiny = FixedNeeds {
            triangles: 1,
            resolution: 32,
            workers: 1,
            row_bytes: 1,
            probe: false,
            apertures: false,
        };
        assert_eq!(MemoryBudget::minimum(&tiny), MIN_FIXED_BYTES);
        let huge = FixedNeeds {
            row_bytes: u64::MAX,
            ..tiny
        };
        assert_eq!(MemoryBudget::minimum(&huge), u64::MAX);
    }
}
