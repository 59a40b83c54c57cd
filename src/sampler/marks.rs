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
pub(crate) struct Marks<'g> {
    graph: Option<&'g PatchGraph>,
    dilate: bool,
    always: Vec<u64>,
}

/// Whether a run with `options` needs the patch graph: to dilate, or to tell the probe's
/// apertures from folds.
pub(crate) fn needs_graph(options: &SamplingOptions) -> bool {
    options.dilate || (options.probe.is_some() && options.apertures > 0)
}

/// The patch graph of `mesh` tiled by `tiling`, for [`Marks::new`].
pub(crate) fn patch_graph(mesh: &Mesh, tiling: &Tiling) -> PatchGraph {
    PatchGraph::new(mesh, &tiling.patch_of, tiling.patches.len() as u32)
}

impl<'g> Marks<'g> {
    /// The marks `options` ask for over the patches of `tiling`; `graph` is the tiling's
    /// patch graph ([`patch_graph`]) where [`needs_graph`] says so.
    ///
    /// Panics (caller contract) if an always-visible id is not a patch of `tiling`, or if the
    /// graph is needed but not given.
    pub(crate) fn new(
        tiling: &Tiling,
        options: &SamplingOptions,
        graph: Option<&'g PatchGraph>,
    ) -> Marks<'g> {
        let patch_count = tiling.patches.len() as u32;
        let mut always = vec![0u64; (patch_count as usize).div_ceil(64)];
        for &p in &options.always_visible {
            assert!(
                p < patch_count,
                "always-visible patch {p} is not below {patch_count}"
            );
            always[p as usize / 64] |= 1 << (p % 64);
        }
        assert!(
            graph.is_some() || !needs_graph(options),
            "the marks need the patch graph"
        );
        Marks {
            graph,
            dilate: options.dilate,
            always,
        }
    }

    /// The patch graph, if built.
    pub(crate) fn graph(&self) -> Option<&'g PatchGraph> {
        self.graph
    }

    /// The always-visible patches as a row.
    pub(crate) fn always(&self) -> &[u64] {
        &self.always
    }

    /// Sets in `row` (which holds `seen` or more) the marks of a view from `eye` that saw
    /// the patches in `seen`.
    pub(crate) fn apply(&self, tiling: &Tiling, eye: [f64; 3], seen: &[u64], row: &mut [u64]) {
        if let Some(graph) = self.graph.filter(|_| self.dilate) {
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
