//! One shard of a sharded bake: the recipe's tile and sample stages for the views the shard
//! owns (`shard.rs`), packed into a [`Part`] for the merge (`merge.rs`). Also the tiling step
//! every shard can share (`patchvis tile`, `tiling_file.rs`).
//!
//! A shard works as `Recipe::run` does up to the sampled rows, in the same frame, on the
//! same tiling (read from the tiling file, or tiled again), with each pass (the sampling
//! sphere's and every shell's) restricted to the shard's views and the ancestors that seed
//! them; it stops before the fold, the numbering
//! and the encoding, which need every view and are the merge's. Cost: the mesh hash (one
//! pass), the tiling unless given, and the sampling of about `1/N` of the views plus the
//! ancestors across the shard's border.

use super::fingerprint::{mesh_hash, tiling_hash};
use super::frame::Frame;
use super::part::PassRows;
use super::tiling_file::TilingFile;
use super::{Backend, BakeError, Part, Recipe, Shard, Stages};
use crate::ooc::Mesh;
use crate::progress::Progress;
use crate::sampler::PassViews;
use crate::tiling::Tiling;
use crate::visibility::VisibilityMatrix;
use std::path::Path;

/// What [`Recipe::run_shard`] made: the part, and what its summary reports.
#[derive(Debug)]
pub struct ShardBaked {
    /// The part, to write with [`Part::encode`].
    pub part: Part,
    /// The tiling sampled (in the tiling's numbering).
    pub tiling: Tiling,
    /// Views the shard owns, over every pass.
    pub owned_views: u32,
    /// Views it rendered: those and their ancestors, over every pass.
    pub rendered_views: u32,
}

impl Recipe {
    /// Tiles `mesh` as [`Recipe::run`] does, in the frame it samples in: the tiling a tiling
    /// file holds (`patchvis tile`). Checks only what a tiling needs (the shards check their
    /// sampling).
    pub fn tile_framed(&self, mesh: &Mesh) -> Result<Tiling, BakeError> {
        super::checks::check_tiling(&self.settings, mesh)?;
        match Frame::choose(mesh, self.plan.rows.fov_deg)? {
            Some(frame) => self.tile_checked(&frame.apply(mesh)?),
            None => self.tile_checked(mesh),
        }
    }

    /// Bakes shard `shard` of `mesh`: the rows of the views it owns in every sampling pass,
    /// with the file's camera and patch records. `tiling` is a tiling file read back and its
    /// path, refused if it tiles another mesh or another `--patches`; `None` tiles here.
    pub fn run_shard(
        &self,
        mesh: &Mesh,
        tiling: Option<(&Path, TilingFile)>,
        shard: Shard,
        backend: &Backend,
        progress: &dyn Progress,
        stages: &mut Stages,
    ) -> Result<ShardBaked, BakeError> {
        if !backend.is_cpu() {
            return Err(BakeError::Settings(format!(
                "--shard: sharded bakes sample on the CPU backend (bit-exact, so that the \
                 merge equals one bake); use --backend cpu, not {}",
                backend.describe()
            )));
        }
        if let Some((recipe, why)) = self.for_mesh(mesh.triangle_count(), true) {
            // A usage error first, alone.
            self.check_mesh(mesh)?;
            progress.warn(&why);
            return recipe.run_shard(mesh, tiling, shard, backend, progress, stages);
        }
        let frame = self.prepare(mesh, progress)?;
        let mesh_hash = stages.run("hash", || mesh_hash(mesh));
        let local = match &frame {
            Some(frame) => Some(stages.run("frame", || frame.apply(mesh))?),
            None => None,
        };
        let work = local.as_ref().unwrap_or(mesh);
        let tiling = match tiling {
            Some((path, file)) => self.check_tiling_file(path, file, mesh_hash)?,
            None => stages.run("tiling", || self.tile(work))?,
        };
        let rows = stages.run("sampling", || {
            self.sample_share(work, &tiling, backend, Some(shard), progress)
        })?;
        let mut params = rows.params(self.level());
        let patches = match frame {
            Some(_) => {
                params = Frame::world_params(mesh, params);
                Frame::world_patches(mesh, &tiling)
            }
            None => tiling.patches.clone(),
        };
        let (mut owned_views, mut rendered_views) = (0, 0);
        let passes: Vec<PassRows> = self
            .plan
            .pass_levels()
            .into_iter()
            .zip(self.plan.pass_finer_views())
            .zip(rows.passes())
            .map(|((level, finer), matrix)| {
                let views = shard.views(level);
                owned_views += views.len() as u32;
                let pass = PassViews::pass(level, finer);
                debug_assert_eq!(pass.slots(), matrix.views());
                rendered_views += crate::sampler::rendered_view_count(&pass, &views);
                PassRows {
                    level,
                    words: owned_rows(matrix, &views),
                    views,
                }
            })
            .collect();
        Ok(ShardBaked {
            part: Part {
                mesh_hash,
                tiling_hash: tiling_hash(&tiling),
                shard,
                triangle_count: mesh.triangle_count(),
                settings: self.plan.rows.clone(),
                params,
                patches,
                passes,
            },
            tiling,
            owned_views,
            rendered_views,
        })
    }

    /// Writes a part's `bytes` to `path` atomically, then removes the shard's checkpoints,
    /// which have served their purpose.
    pub fn write_part(&self, bytes: &[u8], path: &Path) -> Result<(), BakeError> {
        crate::output::write_atomic(path, bytes).map_err(|source| BakeError::Write {
            path: path.to_path_buf(),
            source,
        })?;
        self.remove_checkpoints()
    }

    /// The tiling of a tiling file, if it tiles the mesh hashing to `mesh_hash` into
    /// `--patches` patches and the always-visible ids are among them.
    fn check_tiling_file(
        &self,
        path: &Path,
        file: TilingFile,
        mesh_hash: u64,
    ) -> Result<Tiling, BakeError> {
        let fail = |what: String| BakeError::Sharded(format!("{}: {what}", path.display()));
        if file.mesh_hash != mesh_hash {
            return Err(fail(format!(
                "tiles another mesh (content hash {:016x}, the input's is {mesh_hash:016x}); \
                 run patchvis tile on this input",
                file.mesh_hash
            )));
        }
        if file.patches_asked != self.settings.patches {
            return Err(fail(format!(
                "tiled with --patches {}, this bake asks for {}; give the same --patches to \
                 both",
                file.patches_asked, self.settings.patches
            )));
        }
        let count = file.tiling.patches.len() as u32;
        if let Some(&bad) = self.plan.rows.always_visible.iter().find(|&&p| p >= count) {
            return Err(BakeError::Settings(format!(
                "--always-visible {bad}: the bake has patches 0 to {}",
                count - 1
            )));
        }
        Ok(file.tiling)
    }
}

/// The rows of `views` in `matrix`, one after the other.
fn owned_rows(matrix: &VisibilityMatrix, views: &[u32]) -> Vec<u64> {
    let mut words = Vec::with_capacity(views.len() * matrix.words_per_row());
    for &v in views {
        words.extend_from_slice(matrix.row(v));
    }
    words
}
