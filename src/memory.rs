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
//! | encoding | whole | the rows, a few counts and the file (kilobytes to megabytes) |
//! | eval | whole | per-triangle maps bounded by a check, pixels per worker |

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

/// A heap budget in bytes and its split between the stages (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryBudget {
    total: u64,
}

/// The shares of [`MemoryBudget::split`], in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StageBudgets {
    /// Text-to-binary mesh conversion.
    pub input: u64,
    /// Tiling (in core or out of core).
    pub tiling: u64,
    /// Sampling: per-worker buffers and the rows.
    pub sampling: u64,
    /// Above this, the sampler's patch-ordered mesh copy lives in a mapped temporary file.
    pub sampling_mesh: u64,
    /// Host staging of the GPU upload (one vertex and index buffer pair at a time).
    pub gpu_staging: u64,
    /// The `--dilate` patch graph.
    pub patch_graph: u64,
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
            sampling: self.total,
            sampling_mesh: quarter,
            gpu_staging: quarter.min(MAX_GPU_STAGING),
            patch_graph: self.total,
            encoding: self.total,
            eval: self.total,
        }
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
                s.sampling,
                s.sampling_mesh,
                s.gpu_staging,
                s.patch_graph,
                s.encoding,
                s.eval,
            ] {
                assert!(share <= total, "{share} of {total}");
            }
            assert!(s.gpu_staging <= MAX_GPU_STAGING);
        }
        assert!(MemoryBudget::from_available_memory().total() >= MIN_DEFAULT.min(FALLBACK));
    }
}
