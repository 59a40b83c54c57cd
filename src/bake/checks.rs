//! What a bake refuses before any work, once the mesh is open: a `--dilate` or `--apertures` patch graph or
//! the probe's solids past the budget, a mesh of zero-area triangles, and a `--memory` below
//! what the stages need whatever the budget ([`MemoryBudget::minimum`]). A tiling alone
//! (`patchvis tile`) needs no sampling: [`check_tiling`] asks only what tiling needs.

use super::{BakeError, BakeSettings, Plan};
use crate::memory::{FixedNeeds, MIN_FIXED_BYTES, MemoryBudget};
use crate::ooc::{Mesh, MeshError, MeshErrorKind};

/// Checks what depends on the mesh before any work: the `--dilate` patch graph and the
/// `--conservative` solids against the budget, that some triangle has an area, and that the budget is at least what the
/// stages need whatever it is ([`MemoryBudget::minimum`]).
pub(super) fn check_mesh(
    plan: &Plan,
    settings: &BakeSettings,
    mesh: &Mesh,
) -> Result<(), BakeError> {
    let memory = settings.memory;
    let apertures = plan.probes() && plan.main.apertures > 0;
    if (plan.rows.research.dilate || apertures) && !memory.fits_patch_graph(mesh.triangle_count()) {
        let flag = if plan.rows.research.dilate {
            "--dilate"
        } else {
            "--apertures"
        };
        return Err(BakeError::Budget(format!(
            "{flag} builds a patch graph of about {} MiB for {} triangles, more than --memory {} MiB",
            (u64::from(mesh.triangle_count()) * crate::memory::PATCH_GRAPH_BYTES_PER_TRIANGLE)
                >> 20,
            mesh.triangle_count(),
            memory.total() >> 20
        )));
    }
    // The default's probe is turned off instead (`for_mesh`).
    if plan.probes() && !plan.default_probe && !memory.fits_solids(mesh.triangle_count()) {
        return Err(BakeError::Budget(format!(
            "the probe pass (--conservative, --probe) finds the mesh's solids in about {} MiB for {} triangles, \
             more than half of --memory {} MiB; raise --memory",
            (u64::from(mesh.triangle_count()) * crate::memory::SOLIDS_BYTES_PER_TRIANGLE) >> 20,
            mesh.triangle_count(),
            memory.total() >> 20
        )));
    }
    check_area(mesh)?;
    let patches = u64::from(settings.patches.min(mesh.triangle_count()));
    // Every pass's rows live until the encoding: the sampling sphere's and each shell's.
    let views = plan.sampled_view_count();
    let needs = FixedNeeds {
        triangles: mesh.triangle_count(),
        resolution: plan.rows.resolution,
        workers: rayon::current_num_threads(),
        row_bytes: views * patches.div_ceil(64) * 8,
        probe: plan.probes(),
        apertures,
    };
    let minimum = MemoryBudget::minimum(&needs);
    if memory.total() < minimum {
        return Err(BakeError::Settings(format!(
            "--memory {}: below the {} MiB this bake needs whatever its budget ({} \
             triangles, {} px ID buffers on {} threads, {} views × {} patches); use at \
             least {} MiB",
            size_text(memory.total()),
            minimum >> 20,
            mesh.triangle_count(),
            plan.rows.resolution,
            needs.workers,
            views,
            patches,
            minimum >> 20
        )));
    }
    Ok(())
}

/// Checks what a tiling alone needs before any work (`patchvis tile`): that some triangle
/// has an area, and that the budget holds the fixed minimum ([`MIN_FIXED_BYTES`]); the
/// sampler's ID buffers, views and rows are for the shards to check.
pub(super) fn check_tiling(settings: &BakeSettings, mesh: &Mesh) -> Result<(), BakeError> {
    check_area(mesh)?;
    let memory = settings.memory;
    if memory.total() < MIN_FIXED_BYTES {
        return Err(BakeError::Settings(format!(
            "--memory {}: below the {} MiB a tiling needs whatever its budget; use at least {} MiB",
            size_text(memory.total()),
            MIN_FIXED_BYTES >> 20,
            MIN_FIXED_BYTES >> 20
        )));
    }
    Ok(())
}

/// Some triangle of `mesh` must have an area.
fn check_area(mesh: &Mesh) -> Result<(), BakeError> {
    if crate::tiling::first_with_area(mesh).is_none() {
        return Err(BakeError::Mesh(MeshError::whole(
            mesh.path(),
            MeshErrorKind::Degenerate,
            format!(
                "all {} triangles are degenerate (zero area); nothing to bake",
                mesh.triangle_count()
            ),
        )));
    }
    Ok(())
}

/// A byte count as `--memory` spells it: whole MiB, KiB or bytes.
fn size_text(bytes: u64) -> String {
    if bytes >= 1 << 20 && bytes.is_multiple_of(1 << 20) {
        format!("{} MiB", bytes >> 20)
    } else if bytes >= 1 << 10 && bytes.is_multiple_of(1 << 10) {
        format!("{} KiB", bytes >> 10)
    } else {
        format!("{bytes} bytes")
    }
}
