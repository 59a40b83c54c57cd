//! The recipe a bake follows, stage by stage: tile → sample (each sphere of the plan,
//! `sample.rs`) → number the patches → encode (`encode.rs`), then write the outputs.
//! [`Recipe::run`] is `patchvis bake`; `eval --sweep` runs the same stages, sampling once per
//! patch count and cutting every level it evaluates from those rows ([`SampledRows::stored`]).

use super::frame::Frame;
use super::{
    Backend, BakeError, BakeSettings, Plan, SampledRows, SampledSphere, Shard, Stages, encode,
};
use crate::format::ShellRows;
use crate::memory::MemoryBudget;
use crate::ooc::{Mesh, OpenOptions, default_cache_dir};
use crate::progress::Progress;
use crate::runtime::Pvis;
use crate::sampler::Scene;
use crate::tiling::{self, Tiling, TilingOptions};
use crate::visibility::{SamplingParams, VisibilityMatrix};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Checked settings and their plan ([`BakeSettings::check`]): what a bake does.
#[derive(Clone, Debug, PartialEq)]
pub struct Recipe {
    /// The settings as given.
    pub settings: BakeSettings,
    /// What the settings' rows resolve to ([`Recipe::for_mesh`] may turn the default's probe
    /// off for a mesh).
    pub plan: Plan,
}

/// The result of [`Recipe::run`]: the file's bytes and what they were made of.
#[derive(Debug)]
pub struct Baked {
    /// Where the sampling cameras were (the stored level).
    pub params: SamplingParams,
    /// The plan it ran (the recipe's, for the mesh: [`Recipe::for_mesh`]).
    pub plan: Plan,
    /// The tiling, in the file's patch numbering.
    pub tiling: Tiling,
    /// The stored rows, in the file's patch numbering.
    pub visibility: VisibilityMatrix,
    /// Whether the patches were renumbered by co-visibility.
    pub renumbered: bool,
    /// Views rendered for the sampling sphere, every pass counted (the shells' are in
    /// `shells`).
    pub sampled_views: u32,
    /// The sampling shells in the file's order: the far band's, then those inside the
    /// sampling sphere, each outermost first (empty without shells).
    pub shells: Vec<BakedShell>,
    /// The `.pvis` file.
    pub bytes: Vec<u8>,
    /// Bytes of its VISB payload.
    pub visibility_bytes: u64,
}

/// One sampling shell of a [`Baked`].
#[derive(Debug)]
pub struct BakedShell {
    /// The views' distance from the centre, as the file stores it.
    pub distance: f32,
    /// The sphere level of its views.
    pub level: u32,
    /// The stored rows, in the file's patch numbering.
    pub visibility: VisibilityMatrix,
    /// Views rendered for the shell, every pass counted.
    pub sampled_views: u32,
    /// Seconds its sampling took.
    pub seconds: f64,
}

impl Baked {
    /// The fraction of the patches a query answers, averaged over the leaf faces of the
    /// sampling sphere (each answers the OR of its corners' rows). Not the rows' own
    /// fraction: folded and saturated rows hold patches no single view showed.
    pub fn visible_fraction(&self) -> f64 {
        let rows = &self.visibility;
        let faces = crate::sphere::leaf_faces(self.params.level);
        let pairs = faces.len() as f64 * f64::from(rows.patches());
        if pairs == 0.0 {
            return 0.0;
        }
        let answered: u64 = faces
            .iter()
            .flat_map(|f| rows.or_rows(&f.views))
            .map(|w| u64::from(w.count_ones()))
            .sum();
        answered as f64 / pairs
    }
}

impl Recipe {
    /// The ID-buffer side sampled (`--resolution`).
    pub fn resolution(&self) -> u32 {
        self.plan.rows.resolution
    }

    /// The stored level of the sampling sphere.
    pub fn level(&self) -> u32 {
        self.plan.level()
    }

    /// This recipe for a mesh of `triangles` triangles sampled on the CPU backend (`cpu`) or
    /// not, and why it differs, when it does ([`Plan::for_mesh`]). The checkpoints keep their
    /// names (their hash tells the rows apart).
    pub fn for_mesh(&self, triangles: u32, cpu: bool) -> Option<(Recipe, String)> {
        let (plan, why) = self.plan.for_mesh(triangles, cpu, self.memory())?;
        Some((
            Recipe {
                settings: self.settings.clone(),
                plan,
            },
            why,
        ))
    }

    /// Every checkpoint file of this bake: the sampling sphere's, then each shell's.
    pub fn checkpoints(&self) -> Vec<PathBuf> {
        self.plan
            .checkpoints(self.settings.checkpoint.as_deref())
            .iter()
            .flat_map(|c| c.paths().cloned().collect::<Vec<_>>())
            .collect()
    }

    /// The heap budget.
    pub fn memory(&self) -> MemoryBudget {
        self.settings.memory
    }

    /// How to open the input mesh: the user's conversion cache, within the input's share.
    pub fn open_options(&self) -> OpenOptions {
        OpenOptions {
            cache_dir: Some(default_cache_dir()),
            memory_budget: self.memory().split().input,
        }
    }

    /// Tiling options: the algorithm asked for, within the tiling's share.
    pub fn tiling_options(&self) -> TilingOptions {
        TilingOptions {
            mode: self.settings.tiling,
            memory_budget: self.memory().split().tiling,
        }
    }

    /// Where the cameras of the stored level are, for `mesh`.
    pub fn sampling_params(&self, mesh: &Mesh) -> SamplingParams {
        SamplingParams::for_mesh(
            mesh,
            self.level(),
            self.resolution(),
            self.plan.rows.fov_deg,
        )
    }

    /// Opens `path` with [`Recipe::open_options`].
    pub fn open(&self, path: &Path) -> Result<Mesh, BakeError> {
        Ok(Mesh::open_with(path, &self.open_options())?)
    }

    /// Checks what depends on the mesh before any work (`checks.rs`): the `--dilate` patch
    /// graph and the probe's solids against the budget, that some triangle has an area, and
    /// that the budget is at least what the stages need whatever it is
    /// ([`MemoryBudget::minimum`]).
    pub fn check_mesh(&self, mesh: &Mesh) -> Result<(), BakeError> {
        super::checks::check_mesh(&self.plan, &self.settings, mesh)
    }

    /// The warning for ID buffers coarse enough to miss many patches (below
    /// [`WARN_RESOLUTION`](super::settings::WARN_RESOLUTION) pixels), or `None`.
    pub fn resolution_warning(&self) -> Option<String> {
        (self.resolution() < super::settings::WARN_RESOLUTION).then(|| {
            format!(
                "--resolution {}: ID buffers this coarse miss many patches (the bunny's views \
                 see 7 % of its patches at 16 px, 22 % at 32, 44 % at 256); use {} px or more",
                self.resolution(),
                super::settings::WARN_RESOLUTION
            )
        })
    }

    /// Tiles `mesh` after [`Recipe::check_mesh`], and checks the always-visible ids against
    /// the patch count.
    pub fn tile(&self, mesh: &Mesh) -> Result<Tiling, BakeError> {
        self.check_mesh(mesh)?;
        self.tile_checked(mesh)
    }

    /// [`Recipe::tile`] once `mesh` is checked.
    pub(super) fn tile_checked(&self, mesh: &Mesh) -> Result<Tiling, BakeError> {
        let tiling = tiling::tile_with(mesh, self.settings.patches, &self.tiling_options())?;
        let patch_count = tiling.patches.len() as u32;
        if let Some(&bad) = self
            .plan
            .rows
            .always_visible
            .iter()
            .find(|&&p| p >= patch_count)
        {
            return Err(BakeError::Settings(format!(
                "--always-visible {bad}: the bake has patches 0 to {}",
                patch_count - 1
            )));
        }
        Ok(tiling)
    }

    /// Samples every sphere of the plan with `backend` (see [`SampledRows`]).
    pub fn sample(
        &self,
        mesh: &Mesh,
        tiling: &Tiling,
        backend: &Backend,
        progress: &dyn Progress,
    ) -> Result<SampledRows, BakeError> {
        self.sample_share(mesh, tiling, backend, None, progress)
    }

    /// [`Recipe::sample`] of the views `shard` owns in each pass (every view with `None`);
    /// the other rows are empty. Each view is seeded and rendered as in the whole bake, so its
    /// row is the same bit for bit.
    pub fn sample_share(
        &self,
        mesh: &Mesh,
        tiling: &Tiling,
        backend: &Backend,
        shard: Option<Shard>,
        progress: &dyn Progress,
    ) -> Result<SampledRows, BakeError> {
        if let Some((recipe, why)) = self.for_mesh(mesh.triangle_count(), backend.is_cpu()) {
            progress.warn(&why);
            return recipe.sample_share(mesh, tiling, backend, shard, progress);
        }
        let params = self.sampling_params(mesh);
        let spheres = self
            .plan
            .spheres(&params, self.settings.checkpoint.as_deref())?;
        let run = super::sample::Run {
            plan: &self.plan,
            settings: &self.settings,
        };
        // One scene for every sphere: the CPU sampler's set-up is built once.
        let scene = Scene::new(mesh, tiling);
        let mut sampled = Vec::with_capacity(spheres.len());
        for sphere in &spheres {
            let start = Instant::now();
            let rows = run.sphere(&scene, backend, progress, sphere, shard)?;
            sampled.push(SampledSphere {
                kind: sphere.kind,
                shell: sphere.shell,
                rows,
                seconds: start.elapsed().as_secs_f64(),
            });
        }
        Ok(SampledRows { spheres: sampled })
    }

    /// The file's patch numbering: by co-visibility (patches seen from the same views get
    /// neighbouring ids), which moves the tiling with the rows, or the tiling's own. Returns
    /// whether the patches were renumbered.
    pub fn number(
        &self,
        tiling: Tiling,
        visibility: VisibilityMatrix,
    ) -> Result<(Tiling, VisibilityMatrix, bool), BakeError> {
        let (tiling, visibility, _, renumbered) =
            encode::number(self.plan.rows.patch_order, tiling, visibility, Vec::new())?;
        Ok((tiling, visibility, renumbered))
    }

    /// The `.pvis` bytes of a bake with the sampling shells `shells` (outermost first, in the
    /// file's patch numbering; none for a file without shells), and SHEL's reach where they
    /// include a far band ([`Plan::sampling_reach`]).
    pub fn encode(
        &self,
        params: &SamplingParams,
        triangle_count: u32,
        tiling: &Tiling,
        visibility: &VisibilityMatrix,
        shells: &[ShellRows],
    ) -> Vec<u8> {
        let distances: Vec<f32> = shells.iter().map(|s| s.distance).collect();
        encode::encode(
            self.plan.rows.encoding,
            params,
            triangle_count,
            &tiling.patches,
            visibility,
            shells,
            self.plan.sampling_reach(params.distance(), &distances),
        )
    }

    /// Bytes each shell of `baked` adds to the file, outermost first: the file encoded with
    /// the shells up to it, less the file with those before it (one encoding per shell; for
    /// `--stats`).
    pub fn shell_bytes(&self, baked: &Baked, triangle_count: u32) -> Vec<u64> {
        let rows = shell_rows(&baked.shells);
        let encoded = |k: usize| {
            self.encode(
                &baked.params,
                triangle_count,
                &baked.tiling,
                &baked.visibility,
                &rows[..k],
            )
            .len() as u64
        };
        let mut before = encoded(0);
        (1..=rows.len())
            .map(|k| {
                let bytes = if k == rows.len() {
                    baked.bytes.len() as u64
                } else {
                    encoded(k)
                };
                bytes - std::mem::replace(&mut before, bytes)
            })
            .collect()
    }

    /// Runs the whole recipe on `mesh`: tile → sample → fold → number → encode, each stage
    /// recorded in `stages` and reported to `progress`.
    pub fn run(
        &self,
        mesh: &Mesh,
        backend: &Backend,
        progress: &dyn Progress,
        stages: &mut Stages,
    ) -> Result<Baked, BakeError> {
        if let Some((recipe, why)) = self.for_mesh(mesh.triangle_count(), backend.is_cpu()) {
            // A usage error first, alone.
            self.check_mesh(mesh)?;
            progress.warn(&why);
            return recipe.run(mesh, backend, progress, stages);
        }
        let frame = self.prepare(mesh, progress)?;
        let local = match &frame {
            Some(frame) => Some(stages.run("frame", || frame.apply(mesh))?),
            None => None,
        };
        let work = local.as_ref().unwrap_or(mesh);
        let tiling = stages.run("tiling", || spin(progress, "tiling", || self.tile(work)))?;
        let rows = stages.run("sampling", || self.sample(work, &tiling, backend, progress))?;
        let visibility = rows.stored(self.level());
        let shell_matrices: Vec<VisibilityMatrix> =
            rows.shells().map(|s| s.stored(s.level())).collect();
        let (mut params, sampled_views) = (rows.params(self.level()), rows.sampled_views());
        let shell_sampling: Vec<(u32, u32, f64)> = rows
            .shells()
            .map(|s| (s.level(), s.sampled_views(), s.seconds))
            .collect();
        drop(rows);
        let (mut tiling, visibility, shell_matrices, renumbered) =
            stages.run("patch-order", || {
                encode::number(
                    self.plan.rows.patch_order,
                    tiling,
                    visibility,
                    shell_matrices,
                )
            })?;
        if frame.is_some() {
            params = Frame::world_params(mesh, params);
            tiling = Frame::world_tiling(mesh, tiling);
        }
        // The file's shells are where a bake of the original in its own frame puts them: the
        // same rule on the file's camera.
        let (distances, dropped, why) = self.plan.file_shells_in_world(&params)?;
        if let Some(why) = why {
            progress.warn(&why);
        }
        let shells: Vec<BakedShell> = distances
            .into_iter()
            .zip(shell_matrices.into_iter().skip(dropped))
            .zip(shell_sampling.into_iter().skip(dropped))
            .map(
                |((distance, visibility), (level, sampled_views, seconds))| BakedShell {
                    distance,
                    level,
                    visibility,
                    sampled_views,
                    seconds,
                },
            )
            .collect();
        let bytes = stages.run("encoding", || {
            spin(progress, "encoding", || {
                self.encode(
                    &params,
                    mesh.triangle_count(),
                    &tiling,
                    &visibility,
                    &shell_rows(&shells),
                )
            })
        });
        let visibility_bytes = Pvis::parse(&bytes)
            .map(|p| p.visibility_bytes())
            .map_err(|e| BakeError::Internal(format!("the written file does not parse: {e}")))?;
        Ok(Baked {
            params,
            plan: self.plan.clone(),
            tiling,
            visibility,
            renumbered,
            sampled_views,
            shells,
            bytes,
            visibility_bytes,
        })
    }

    /// What every bake (whole or one shard) does first: reports the mesh's and the
    /// settings' warnings, checks the mesh and the shells' radii, and chooses the working
    /// frame. Coordinates
    /// binary32 cameras cannot handle are tiled and sampled in a frame of their own
    /// (`frame.rs`); the file gets the original's camera and patch records.
    pub(crate) fn prepare(
        &self,
        mesh: &Mesh,
        progress: &dyn Progress,
    ) -> Result<Option<Frame>, BakeError> {
        for warning in mesh
            .warnings()
            .iter()
            .cloned()
            .chain(self.resolution_warning())
        {
            progress.warn(&warning);
        }
        self.check_mesh(mesh)?;
        let frame = Frame::choose(mesh, self.plan.rows.fov_deg)?;
        if frame.is_none() {
            // Before the tiling: shells binary32 cannot tell apart are a usage error. (In a
            // working frame of its own, the mesh's shells are checked where they are sampled.)
            self.plan
                .file_shell_distances(&self.sampling_params(mesh))?;
        }
        Ok(frame)
    }
}

/// The shells of a bake as the writer takes them.
pub(super) fn shell_rows(shells: &[BakedShell]) -> Vec<ShellRows<'_>> {
    shells
        .iter()
        .map(|s| ShellRows {
            distance: s.distance,
            visibility: &s.visibility,
        })
        .collect()
}

/// Runs `f` as an indeterminate progress step (a spinner with elapsed time in the binary).
fn spin<T>(progress: &dyn Progress, what: &str, f: impl FnOnce() -> T) -> T {
    progress.start(what, 0);
    let out = f();
    progress.finish();
    out
}

#[cfg(test)]
mod tests;
