//! What both sampling backends add to a view's point-sampled row: `--dilate`'s edge
//! neighbours of the seen patches that may face the eye, then the `--always-visible`
//! patches. One implementation, so that the CPU and GPU backends mark the same bits.
//!
//! Cost: building the patch graph is O(n log n) for n triangles (`patch_graph.rs`); per view,
//! one pass over the seen patches' neighbours plus one OR per row word.

use super::SamplingOptions;
use super::patch_graph::{PatchGraph, may_face};
use crate::ooc::Mesh;
use crate::runtime::Patches;
use crate::tiling::{PatchId, Tiling};

/// The marks of one sampling run: the patch graph when dilating (or opening the probe's
/// apertures), the always-visible row.
pub(crate) struct Marks {
    graph: Option<PatchGraph>,
    dilate: bool,
    always: Vec<u64>,
}

impl Marks {
    /// The marks `options` ask for over the patches of `tiling` (a tiling of `mesh`).
    ///
    /// Panics (caller contract) if an always-visible id is not a patch of `tiling`.
    pub(crate) fn new(mesh: &Mesh, tiling: &Tiling, options: &SamplingOptions) -> Marks {
        let patch_count = tiling.patches.len() as u32;
        let mut always = vec![0u64; (patch_count as usize).div_ceil(64)];
        for &p in &options.always_visible {
            assert!(
                p < patch_count,
                "always-visible patch {p} is not below {patch_count}"
            );
            always[p as usize / 64] |= 1 << (p % 64);
        }
        Marks {
            // The probe's apertures tell a gap from a fold by it too.
            graph: (options.dilate || (options.probe.is_some() && options.apertures > 0))
                .then(|| PatchGraph::new(mesh, &tiling.patch_of, patch_count)),
            dilate: options.dilate,
            always,
        }
    }

    /// The patch graph, if built.
    pub(crate) fn graph(&self) -> Option<&PatchGraph> {
        self.graph.as_ref()
    }

    /// The always-visible patches as a row.
    pub(crate) fn always(&self) -> &[u64] {
        &self.always
    }

    /// Sets in `row` (which holds `seen` or more) the marks of a view from `eye` that saw
    /// the patches in `seen`.
    pub(crate) fn apply(&self, tiling: &Tiling, eye: [f64; 3], seen: &[u64], row: &mut [u64]) {
        if let Some(graph) = self.graph.as_ref().filter(|_| self.dilate) {
            for p in Patches::of_bits(seen) {
                for &q in graph.neighbours(p as PatchId) {
                    let (w, bit) = (q as usize / 64, 1u64 << (q % 64));
                    if row[w] & bit == 0 && may_face(&tiling.patches[q as usize], eye) {
                        row[w] |= bit;
                    }
                }
            }
        }
        for (r, a) in row.iter_mut().zip(&self.always) {
            *r |= a;
        }
    }
}
