//! The output's triangle sequence: the tiling's patch order, each patch's triangles grouped
//! by material (stably), and the runs of one material that become glTF primitives.
//!
//! Streaming: a patch's triangles are gathered and sorted when it is visited (patches are
//! small); the heap holds one patch and the list of runs.

use crate::ooc::attributes::Attributes;
use crate::tiling::Tiling;

/// A run of consecutive output triangles with one material.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    /// First output triangle.
    pub first: u32,
    /// Number of triangles.
    pub count: u32,
    /// Material index, or `attributes::NO_MATERIAL`.
    pub material: u32,
}

/// The order in which `--mesh-out` writes the triangles.
pub struct Sequence<'a> {
    tiling: &'a Tiling,
    attributes: &'a Attributes,
    runs: Vec<Run>,
}

impl<'a> Sequence<'a> {
    /// The sequence of `tiling` with `attributes`' materials.
    pub fn new(tiling: &'a Tiling, attributes: &'a Attributes) -> Sequence<'a> {
        let mut sequence = Sequence {
            tiling,
            attributes,
            runs: Vec::new(),
        };
        let mut runs: Vec<Run> = Vec::new();
        let mut at = 0u32;
        sequence.for_each(|t| {
            let material = attributes.material(t);
            match runs.last_mut() {
                Some(run) if run.material == material => run.count += 1,
                _ => runs.push(Run {
                    first: at,
                    count: 1,
                    material,
                }),
            }
            at += 1;
        });
        sequence.runs = runs;
        sequence
    }

    /// Calls `f` with every input triangle, in output order.
    pub fn for_each(&self, mut f: impl FnMut(u32)) {
        let order: &[u32] = &self.tiling.order;
        let mut patch: Vec<u32> = Vec::new();
        for p in &self.tiling.patches {
            let range = &order[p.first as usize..(p.first + p.count) as usize];
            patch.clear();
            patch.extend_from_slice(range);
            // Stable: triangles of one material keep the tiling's order.
            patch.sort_by_key(|&t| self.attributes.material(t));
            patch.iter().for_each(|&t| f(t));
        }
    }

    /// The runs of one material, in output order.
    pub fn runs(&self) -> &[Run] {
        &self.runs
    }

    /// Patch `i`'s first output triangle, for every patch and then the triangle count: patch
    /// `i` is `firsts[i]..firsts[i + 1]`, the range the `.pvis` gives it.
    pub fn patch_firsts(&self) -> Vec<u32> {
        let patches = &self.tiling.patches;
        patches
            .iter()
            .map(|p| p.first)
            .chain(patches.last().map(|p| p.first + p.count))
            .collect()
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> u32 {
        self.tiling.order.len() as u32
    }

    /// Patch of input triangle `t`.
    pub fn patch_of(&self, t: u32) -> u32 {
        self.tiling.patch_of[t as usize]
    }
}
