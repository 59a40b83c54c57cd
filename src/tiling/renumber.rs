//! Renumbering a finished tiling's patches (e.g. by co-visibility, `format::patch_order`).
//!
//! The tiling numbers patches along a Z-order curve (`reorder.rs`), which depends on the mesh
//! and patch count alone. A writer that knows the visibility can number them better for its
//! coder; this moves every per-patch and per-triangle record to the new numbering so that the
//! tiling stays self-consistent: patch `i` of the result is patch `order[i]` of the input,
//! its triangles one contiguous range of the new `order`, ranges adjacent in patch order.
//!
//! Cost: O(n + p) time; the two per-triangle maps are rebuilt where the old ones lived (heap,
//! or mapped temporary files for out-of-core tilings), so the heap stays bounded.

use std::io;

use super::{Patch, PatchId, Tiling, TriangleMap};

impl Tiling {
    /// This tiling with its patches renumbered: patch `i` of the result is patch `order[i]`
    /// of `self`. Patch records, triangle order and triangle → patch map all follow; the
    /// statistics are unchanged. Fails only if a mapped map cannot be created.
    ///
    /// Panics (caller contract) if `order` is not a permutation of the patch ids.
    pub fn renumbered(&self, order: &[PatchId]) -> io::Result<Tiling> {
        let count = self.patches.len();
        assert_eq!(order.len(), count, "the order must name every patch once");
        let mut new_id = vec![PatchId::MAX; count];
        for (i, &old) in order.iter().enumerate() {
            let slot = &mut new_id[old as usize];
            assert_eq!(
                *slot,
                PatchId::MAX,
                "patch {old} appears twice in the order"
            );
            *slot = i as PatchId;
        }
        let triangles = self.order.len();
        let fresh = |mapped: bool| {
            if mapped {
                TriangleMap::mapped_zeroed(triangles)
            } else {
                Ok(TriangleMap::from_vec(vec![0; triangles]))
            }
        };
        let patches = renumbered_patches(&self.patches, order);
        let mut reordered = fresh(self.order.is_mapped())?;
        for (&old, new) in order.iter().zip(&patches) {
            let patch = &self.patches[old as usize];
            let range = patch.first as usize..(patch.first + patch.count) as usize;
            let to = new.first as usize..new.first as usize + range.len();
            reordered[to].copy_from_slice(&self.order[range]);
        }
        let mut patch_of = fresh(self.patch_of.is_mapped())?;
        for (new, &old) in patch_of.iter_mut().zip(self.patch_of.iter()) {
            *new = new_id[old as usize];
        }
        Ok(Tiling {
            patch_of,
            order: reordered,
            patches,
            stats: self.stats,
            quality: self.quality,
        })
    }
}

/// The patch records of [`Tiling::renumbered`] alone: record `i` is `patches[order[i]]`, its
/// range moved so that the ranges are adjacent in the new order from 0. What a merge of a
/// sharded bake, which has the records but no per-triangle maps, renumbers with.
///
/// Panics (caller contract) if an id in `order` is not below `patches.len()`.
pub fn renumbered_patches(patches: &[Patch], order: &[PatchId]) -> Vec<Patch> {
    let mut first = 0u32;
    order
        .iter()
        .map(|&old| {
            let patch = patches[old as usize];
            let moved = Patch { first, ..patch };
            first += patch.count;
            moved
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use crate::test_kit::meshes::grid;
    use crate::test_kit::rng::Rng;
    use crate::tiling::tile;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]

        /// Whatever the permutation, each patch keeps its triangles and record, ranges stay
        /// contiguous from 0, and the triangle → patch map agrees with the ranges.
        #[test]
        fn renumbering_moves_every_record(seed in any::<u64>(), patches in 1u32..40) {
            let mesh = grid(9, 7, 0.2, seed, |_, _| false).mesh();
            let tiling = tile(&mesh, patches).unwrap();
            let count = tiling.patches.len();
            // A seeded permutation (Fisher–Yates).
            let mut order: Vec<u32> = (0..count as u32).collect();
            let mut rng = Rng::new(seed);
            for i in (1..count).rev() {
                order.swap(i, (rng.next_u64() >> 33) as usize % (i + 1));
            }
            let renumbered = tiling.renumbered(&order).unwrap();
            let mut next = 0;
            for (i, &old) in order.iter().enumerate() {
                let (a, b) = (&tiling.patches[old as usize], &renumbered.patches[i]);
                prop_assert_eq!(b.first, next);
                next += b.count;
                prop_assert_eq!((a.count, a.center, a.radius), (b.count, b.center, b.radius));
                let mut before = tiling.order[a.first as usize..][..a.count as usize].to_vec();
                let after = &renumbered.order[b.first as usize..][..b.count as usize];
                prop_assert_eq!(&before[..], after);
                before.sort_unstable();
                for &t in after {
                    prop_assert_eq!(renumbered.patch_of[t as usize], i as u32);
                    prop_assert_eq!(tiling.patch_of[t as usize], old);
                }
            }
            prop_assert_eq!(next as usize, mesh.triangle_count() as usize);
        }
    }

    #[test]
    #[should_panic(expected = "appears twice")]
    fn a_repeated_id_is_a_caller_error() {
        let tiling = tile(&grid(4, 4, 0.0, 1, |_, _| false).mesh(), 3).unwrap();
        assert_eq!(tiling.patches.len(), 3);
        let _ = tiling.renumbered(&[0, 0, 1]);
    }
}
