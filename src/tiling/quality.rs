//! Tiling quality: patch sizes and compactness, for the bake summary and `--stats`.
//!
//! Compactness is the seed paper's extension measure set against what a patch covers: its
//! bounding-box diagonal squared over its area (Meruvia 2002, §3.1). A flat square patch
//! scores 2; long or folded patches score more; a patch of zero area scores infinity.
//! Reported as median and 95th percentile (nearest rank) so that in-core and out-of-core
//! tilings of the same mesh can be compared.
//! Cost: O(p log p) for p patches.

use super::Patch;

/// Summary figures of a tiling.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TilingQuality {
    /// Number of patches.
    pub patches: u32,
    /// Fewest triangles in a patch.
    pub triangles_min: u32,
    /// Median triangles per patch (the upper median for an even count).
    pub triangles_median: u32,
    /// Most triangles in a patch.
    pub triangles_max: u32,
    /// Median of bounding-box diagonal² / area over the patches.
    pub compactness_median: f64,
    /// 95th percentile (nearest rank) of bounding-box diagonal² / area.
    pub compactness_p95: f64,
}

impl TilingQuality {
    /// The figures of `patches`, `diagonal_squared[i]` being patch `i`'s squared box diagonal.
    pub(crate) fn measure(patches: &[Patch], diagonal_squared: &[f64]) -> TilingQuality {
        if patches.is_empty() {
            return TilingQuality::default();
        }
        let mut sizes: Vec<u32> = patches.iter().map(|p| p.count).collect();
        sizes.sort_unstable();
        let mut compactness: Vec<f64> = patches
            .iter()
            .zip(diagonal_squared)
            .map(|(p, &d2)| {
                if p.area > 0.0 {
                    d2 / p.area
                } else {
                    f64::INFINITY
                }
            })
            .collect();
        compactness.sort_by(f64::total_cmp);
        let len = patches.len();
        let p95 = (len * 95).div_ceil(100).max(1) - 1;
        TilingQuality {
            patches: len as u32,
            triangles_min: sizes[0],
            triangles_median: sizes[len / 2],
            triangles_max: sizes[len - 1],
            compactness_median: compactness[len / 2],
            compactness_p95: compactness[p95],
        }
    }
}
