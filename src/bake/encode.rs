//! The file a bake writes from its stored rows: the patch numbering (by co-visibility from
//! the sampling sphere's rows, every shell following it) and the encoding. `Recipe::run` and
//! the merge of a sharded bake (`merge.rs`) both go through here, so that they write the same
//! bytes.

use super::BakeError;
use super::settings::PatchOrder;
use crate::format::{self, BakeContents, ShellRows, VisibilityEncoding};
use crate::tiling::{Patch, PatchId, Tiling};
use crate::visibility::{SamplingParams, VisibilityMatrix};

/// The file's patch numbering of the tiling's `patches` and their stored rows `visibility`
/// (file id `i` is tiling patch `order[i]`), or `None` to keep the tiling's. Patches the file
/// cannot tell apart stay in tiling order among themselves
/// ([`format::keep_equal_records_in_order`]).
pub(crate) fn file_patch_order(
    order: PatchOrder,
    patches: &[Patch],
    visibility: &VisibilityMatrix,
) -> Option<Vec<PatchId>> {
    match order {
        PatchOrder::Spatial => None,
        PatchOrder::Covisibility => {
            let mut order = format::covisibility_order(visibility)?;
            format::keep_equal_records_in_order(patches, &mut order);
            Some(order)
        }
    }
}

/// The tiling and the rows in the file's numbering ([`file_patch_order`], from the sampling
/// sphere's rows `visibility` alone; every shell's rows in `shells` follow it), and whether
/// the patches were renumbered.
pub(crate) fn number(
    order: PatchOrder,
    tiling: Tiling,
    visibility: VisibilityMatrix,
    shells: Vec<VisibilityMatrix>,
) -> Result<(Tiling, VisibilityMatrix, Vec<VisibilityMatrix>, bool), BakeError> {
    match file_patch_order(order, &tiling.patches, &visibility) {
        Some(order) => {
            let tiling = tiling.renumbered(&order).map_err(BakeError::TempFile)?;
            let shells = shells.iter().map(|m| m.with_patch_order(&order)).collect();
            Ok((tiling, visibility.with_patch_order(&order), shells, true))
        }
        None => Ok((tiling, visibility, shells, false)),
    }
}

/// The `.pvis` bytes of the patch records `patches` and the stored rows, in the file's
/// numbering: the sampling sphere's `visibility` and the shells' `shells`, outermost first,
/// with SHEL's `reach` (0 for none, `Plan::sampling_reach`).
pub(crate) fn encode(
    encoding: VisibilityEncoding,
    params: &SamplingParams,
    triangle_count: u32,
    patches: &[Patch],
    visibility: &VisibilityMatrix,
    shells: &[ShellRows],
    reach: f32,
) -> Vec<u8> {
    try_encode(
        encoding,
        params,
        triangle_count,
        patches,
        visibility,
        shells,
        reach,
    )
    .unwrap_or_else(|e| panic!("the bake's own records break the format: {e}"))
}

/// [`encode`] of records read from parts: the reader's error where they break the format.
pub(crate) fn try_encode(
    encoding: VisibilityEncoding,
    params: &SamplingParams,
    triangle_count: u32,
    patches: &[Patch],
    visibility: &VisibilityMatrix,
    shells: &[ShellRows],
    reach: f32,
) -> Result<Vec<u8>, crate::runtime::Error> {
    format::try_encode_with(
        &BakeContents {
            sampling: params,
            triangle_count: u64::from(triangle_count),
            patches,
            visibility,
            shells,
            reach,
        },
        encoding,
    )
}
