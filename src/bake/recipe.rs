//! The recipe a bake follows, stage by stage: tile → sample (supersample and fold; the
//! sampling sphere, then each sampling shell, `shells.rs`) → number the patches → encode, then
//! write the outputs. [`Recipe::run`] is `patchvis bake`; `eval --sweep` runs the same stages,
//! sampling once per patch count and cutting every level it evaluates from those rows
//! ([`SampledRows::stored`]).

use super::frame::Frame;
use super::rows::SphereRows;
use super::settings::{BakeSettings, PassCheckpoints, PatchOrder, Supersample};
use super::{Backend, BakeError, SampledRows, Shard, Stages, shells};
use crate::format::{self, BakeContents, ShellRows};
use crate::memory::{FixedNeeds, MemoryBudget};
use crate::meshout::{self, MeshFormat};
use crate::ooc::attributes::Attributes;
use crate::ooc::{Mesh, MeshError, MeshErrorKind, OpenOptions, default_cache_dir};
use crate::output::{AtomicFile, NamedPath};
use crate::progress::Progress;
use crate::runtime::Pvis;
use crate::sampler::SamplingOptions;
use crate::sampler::{FinerViews, FoldCorners};
use crate::tiling::{self, Patch, PatchId, Tiling, TilingOptions};
use crate::visibility::{SamplingParams, VisibilityMatrix};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Checked settings with every default resolved ([`BakeSettings::check`]): what a bake does.
#[derive(Clone, Debug, PartialEq)]
pub struct Recipe {
    /// The settings as given.
    pub settings: BakeSettings,
    /// Supersampling and folding.
    pub supersample: Supersample,
    /// The shells' supersampling and folding: the stored level's, capped at the finest level.
    pub shell_supersample: Supersample,
    /// Checkpoint of the stored level's plain pass when the fold has a threshold.
    pub coarse_checkpoint: Option<PathBuf>,
    /// Checkpoint of the main (supersampled) pass.
    pub fine_checkpoint: Option<PathBuf>,
    /// Checkpoints of each shell's passes, outermost first (`OUT.pvis.shellS….ckpt`).
    pub shell_checkpoints: Vec<PassCheckpoints>,
    /// The probe pass's occluder shrink in pixels, or `None` ([`Recipe::probe`]).
    pub(super) probe: Option<u32>,
    /// The shells' ([`Recipe::shell_probe`]).
    pub(super) shell_probe: Option<u32>,
    /// Whether `probe` is the default bake's, which [`Recipe::for_mesh`] turns off where it
    /// cannot run.
    pub(super) default_probe: bool,
}

/// The result of [`Recipe::run`]: the file's bytes and what they were made of.
#[derive(Debug)]
pub struct Baked {
    /// Where the sampling cameras were (the stored level).
    pub params: SamplingParams,
    /// The probe pass it ran ([`Recipe::probe`] after [`Recipe::for_mesh`]).
    pub probe: Option<u32>,
    /// The fold it folded with.
    pub fold_corners: crate::sampler::FoldCorners,
    /// The tiling, in the file's patch numbering.
    pub tiling: Tiling,
    /// The stored rows, in the file's patch numbering.
    pub visibility: VisibilityMatrix,
    /// Whether the patches were renumbered by co-visibility.
    pub renumbered: bool,
    /// Views rendered for the sampling sphere, every pass counted (the shells' are in
    /// `shells`).
    pub sampled_views: u32,
    /// The sampling shells, outermost first (empty without shells).
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

/// Where [`Recipe::write`] puts a bake.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Outputs {
    /// The `.pvis` file.
    pub pvis: PathBuf,
    /// The mesh reordered by patch (`--mesh-out`): glTF for `.glb` / `.gltf`, else PLY
    /// ([`MeshFormat::of`]).
    pub mesh: Option<PathBuf>,
}

impl Outputs {
    /// Every file a bake with `recipe` writes to these outputs, named as the user knows them:
    /// the `.pvis` (`-o`), the mesh (`--mesh-out`) and the checkpoints beside the `.pvis`.
    /// Check them with [`crate::output::check_outputs`] before the bake reads its input.
    pub fn paths(&self, recipe: &Recipe) -> Vec<NamedPath> {
        let mut paths = vec![NamedPath::flag("-o", &self.pvis)];
        if let Some(mesh) = &self.mesh {
            paths.push(NamedPath::flag("--mesh-out", mesh));
        }
        for checkpoint in recipe.checkpoints() {
            paths.push(NamedPath::new("the checkpoint of -o", "-o", checkpoint));
        }
        paths
    }
}

impl Recipe {
    /// The ID-buffer side sampled (`--resolution`).
    pub fn resolution(&self) -> u32 {
        self.settings.resolution
    }

    /// The probe pass's occluder shrink in pixels, or `None`: [`BakeSettings::probe`], as
    /// [`Recipe::for_mesh`] leaves it.
    pub fn probe(&self) -> Option<u32> {
        self.probe
    }

    /// The sampling shells' probe pass: the same as the sampling sphere's. It is kept apart
    /// because part files record it apart: parts written before the default probed the shells
    /// have none there.
    pub fn shell_probe(&self) -> Option<u32> {
        self.shell_probe
    }

    /// This recipe for a mesh of `triangles` triangles sampled on the CPU backend (`cpu`) or
    /// not, and why it differs, when it does: the default bake's probe pass, and with it the
    /// cover fold unless `--fold-corners` was given, is off past
    /// [`crate::memory::DEFAULT_PROBE_MAX_TRIANGLES`] (so that a mesh gets the same file on
    /// every machine whatever the memory it defaults to), where its solids do not fit
    /// `--memory`, and on the GPU backend, which has no probe pass. `--probe PX` and
    /// `--conservative` are never turned off: they fail with the budget or the backend
    /// instead. The checkpoints keep their names (their hash tells the rows apart).
    pub fn for_mesh(&self, triangles: u32, cpu: bool) -> Option<(Recipe, String)> {
        if !self.default_probe {
            return None;
        }
        let why = if triangles > crate::memory::DEFAULT_PROBE_MAX_TRIANGLES {
            format!(
                "{triangles} triangles, past the {} it runs on whatever the memory \
                 (--probe {} asks for it within --memory)",
                crate::memory::DEFAULT_PROBE_MAX_TRIANGLES,
                super::settings::DEFAULT_PROBE_PIXELS
            )
        } else if !self.memory().fits_solids(triangles) {
            format!(
                "the solids of {triangles} triangles take more than half of --memory {} MiB",
                self.memory().total() >> 20
            )
        } else if !cpu {
            "the GPU backend has none".to_string()
        } else {
            return None;
        };
        let mut recipe = self.clone();
        recipe.probe = None;
        recipe.shell_probe = None;
        recipe.default_probe = false;
        if self.settings.fold_corners.is_none() {
            recipe.supersample.fold_corners = super::settings::DEFAULT_FOLD_CORNERS;
            recipe.shell_supersample.fold_corners = super::settings::DEFAULT_FOLD_CORNERS;
        }
        Some((
            recipe,
            format!(
                "the default's probe pass is off: {why}; --probe off asks for this without a note"
            ),
        ))
    }

    /// Every checkpoint file of this bake: the sampling sphere's, then each shell's.
    pub fn checkpoints(&self) -> impl Iterator<Item = &PathBuf> {
        [&self.fine_checkpoint, &self.coarse_checkpoint]
            .into_iter()
            .flatten()
            .chain(
                self.shell_checkpoints
                    .iter()
                    .flat_map(PassCheckpoints::paths),
            )
    }

    /// The sphere level of each sampling pass, in order: the sampling sphere's passes, then
    /// each shell's ([`Supersample::pass_levels`]).
    pub fn pass_levels(&self) -> Vec<u32> {
        let shell = self.shell_supersample.pass_levels(self.shell_level());
        let mut levels = self.supersample.pass_levels(self.settings.level);
        for _ in 0..self.settings.shells {
            levels.extend_from_slice(&shell);
        }
        levels
    }

    /// Views every pass together renders.
    fn sampled_view_count(&self) -> u64 {
        self.pass_levels()
            .into_iter()
            .map(|l| u64::from(crate::sphere::view_count(l)))
            .sum()
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
            self.settings.level,
            self.resolution(),
            self.settings.fov_deg,
        )
    }

    /// Opens `path` with [`Recipe::open_options`].
    pub fn open(&self, path: &Path) -> Result<Mesh, BakeError> {
        Ok(Mesh::open_with(path, &self.open_options())?)
    }

    /// Checks what depends on the mesh before any work: the `--dilate` patch graph and the
    /// `--conservative` solids against the budget, that some triangle has an area, and that the budget is at least what the
    /// stages need whatever it is ([`MemoryBudget::minimum`]).
    pub fn check_mesh(&self, mesh: &Mesh) -> Result<(), BakeError> {
        let settings = &self.settings;
        if settings.dilate && !self.memory().fits_patch_graph(mesh.triangle_count()) {
            return Err(BakeError::Budget(format!(
                "--dilate builds a patch graph of about {} MiB for {} triangles, more than --memory {} MiB",
                (u64::from(mesh.triangle_count()) * crate::memory::PATCH_GRAPH_BYTES_PER_TRIANGLE)
                    >> 20,
                mesh.triangle_count(),
                self.memory().total() >> 20
            )));
        }
        // The default's probe is turned off instead (`for_mesh`).
        if (self.probe.is_some() || self.shell_probe.is_some())
            && !self.default_probe
            && !self.memory().fits_solids(mesh.triangle_count())
        {
            return Err(BakeError::Budget(format!(
                "the probe pass (--conservative, --probe) finds the mesh's solids in about {} MiB for {} triangles, \
                 more than half of --memory {} MiB; raise --memory",
                (u64::from(mesh.triangle_count()) * crate::memory::SOLIDS_BYTES_PER_TRIANGLE) >> 20,
                mesh.triangle_count(),
                self.memory().total() >> 20
            )));
        }
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
        let patches = u64::from(settings.patches.min(mesh.triangle_count()));
        // Every pass's rows live until the encoding: the sampling sphere's and each shell's.
        let views = self.sampled_view_count();
        let needs = FixedNeeds {
            triangles: mesh.triangle_count(),
            resolution: self.resolution(),
            workers: rayon::current_num_threads(),
            row_bytes: views * patches.div_ceil(64) * 8,
            probe: self.probe.is_some() || self.shell_probe.is_some(),
        };
        let minimum = MemoryBudget::minimum(&needs);
        if self.memory().total() < minimum {
            return Err(BakeError::Settings(format!(
                "--memory {}: below the {} MiB this bake needs whatever its budget ({} \
                 triangles, {} px ID buffers on {} threads, {} views × {} patches); use at \
                 least {} MiB",
                size_text(self.memory().total()),
                minimum >> 20,
                mesh.triangle_count(),
                self.resolution(),
                needs.workers,
                views,
                patches,
                minimum >> 20
            )));
        }
        Ok(())
    }

    /// The warning for ID buffers coarse enough to miss many patches (below
    /// [`WARN_RESOLUTION`](super::settings::WARN_RESOLUTION) pixels), or `None`.
    pub fn resolution_warning(&self) -> Option<String> {
        (self.resolution() < super::settings::WARN_RESOLUTION).then(|| {
            format!(
                "--resolution {}: ID buffers this coarse miss many patches (the bunny's views \
                 see 7 % of its patches at 16 px, 22 % at 32, 44 % at 256); use {} px or more",
                self.settings.resolution,
                super::settings::WARN_RESOLUTION
            )
        })
    }

    /// Tiles `mesh` after [`Recipe::check_mesh`], and checks the always-visible ids against
    /// the patch count.
    pub fn tile(&self, mesh: &Mesh) -> Result<Tiling, BakeError> {
        let settings = &self.settings;
        self.check_mesh(mesh)?;
        let tiling = tiling::tile_with(mesh, settings.patches, &self.tiling_options())?;
        let patch_count = tiling.patches.len() as u32;
        if let Some(&bad) = settings.always_visible.iter().find(|&&p| p >= patch_count) {
            return Err(BakeError::Settings(format!(
                "--always-visible {bad}: the bake has patches 0 to {}",
                patch_count - 1
            )));
        }
        Ok(tiling)
    }

    /// Sampling options of one pass: `min_pixels`, `checkpoint`, `views` and where the pass's
    /// views are (`shell`, `band`, see [`SphereSampling`]), the rest from the settings.
    fn sampling_options(
        &self,
        min_pixels: u32,
        checkpoint: Option<PathBuf>,
        views: Option<Vec<u32>>,
        sphere: &SphereSampling,
    ) -> SamplingOptions {
        let s = &self.settings;
        SamplingOptions {
            min_pixels,
            dilate: s.dilate,
            always_visible: s.always_visible.clone(),
            conservative: s.conservative_raster,
            checkpoint,
            resume: s.resume,
            memory_budget: Some(self.memory().split().sampling),
            views,
            probe: match sphere.shell {
                Some(_) => self.shell_probe,
                None => self.probe,
            },
            shell: sphere.shell,
            // The default's probe covers the cameras at the pass's own distance: those between
            // two spheres of views are answered by both (spec § Query), and a cell spanning
            // the band cost the bunny 3.5 points of culling at the sampling distance.
            band: if self.default_probe {
                None
            } else {
                sphere.band
            },
            far_view: s.far_views && sphere.shell.is_none(),
            folds_into: None,
            finer: FinerViews::Midpoints,
        }
    }

    /// Samples the views the stored level needs with `backend`: the stored views with every
    /// pixel, and the finer views of the supersampling, thresholded when the fold has a
    /// threshold (see [`SampledRows`]); then each sampling shell's the same way.
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
    /// row is the same bit for bit. The passes run one after the other, each within the
    /// sampling share of the budget (the rows of those before it are counted in
    /// [`Recipe::check_mesh`]'s minimum).
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
        let distances = self.shell_distances(&params)?;
        let bands = shells::bands(params.distance(), &distances);
        let main = self.sample_sphere(
            mesh,
            tiling,
            backend,
            progress,
            &SphereSampling {
                params,
                supersample: self.supersample,
                checkpoints: PassCheckpoints {
                    coarse: self.coarse_checkpoint.clone(),
                    fine: self.fine_checkpoint.clone(),
                },
                shard,
                shell: None,
                band: bands[0],
            },
        )?;
        let shells = self.sample_shells(mesh, tiling, backend, progress, &params, shard)?;
        Ok(SampledRows { main, shells })
    }

    /// Samples one sphere of views (the sampling sphere or a shell): its stored level plainly
    /// and its finer level thresholded, or the finer level alone.
    pub(super) fn sample_sphere(
        &self,
        mesh: &Mesh,
        tiling: &Tiling,
        backend: &Backend,
        progress: &dyn Progress,
        sphere: &SphereSampling,
    ) -> Result<SphereRows, BakeError> {
        let SphereSampling {
            params,
            supersample,
            ref checkpoints,
            shard,
            ..
        } = *sphere;
        let views = |level: u32| shard.map(|s| s.views(level));
        // The finer pass differs from the stored level in `level` only (same centre, radius,
        // camera distance), so its views are the stored ones plus the finer ones.
        let fine = SamplingParams {
            // Capped for `eval --sweep`, whose recipe may sample at the finest level (a checked
            // bake has `level + extra_levels` within it already).
            level: (params.level + supersample.extra_levels).min(crate::sphere::MAX_LEVEL),
            ..params
        };
        let min_pixels = self.settings.min_pixels;
        // Where the finer pass's views lie (at the finest level it is the stored level).
        let finer = supersample.finer_views(params.level, fine.level);
        let (plain, fine) = if supersample.fold_min_pixels > 0 {
            let coarse_options = self.sampling_options(
                min_pixels,
                checkpoints.coarse.clone(),
                views(params.level),
                sphere,
            );
            let plain = backend.sample(mesh, tiling, &params, &coarse_options, progress)?;
            let fine_options = SamplingOptions {
                finer,
                ..self.sampling_options(
                    supersample.fold_min_pixels,
                    checkpoints.fine.clone(),
                    views(fine.level),
                    sphere,
                )
            };
            let rows = backend.sample(mesh, tiling, &fine, &fine_options, progress)?;
            (plain, Some(rows))
        } else {
            let mut options = SamplingOptions {
                finer,
                ..self.sampling_options(
                    min_pixels,
                    checkpoints.fine.clone(),
                    views(fine.level),
                    sphere,
                )
            };
            // These folds drop what a finer view's fold targets (its parents) hold, so its
            // probe need not look for it.
            if fine.level == params.level + 1
                && matches!(
                    supersample.fold_corners,
                    FoldCorners::Split | FoldCorners::Cover
                )
            {
                options.folds_into = Some(params.level);
            }
            if supersample.splits(params.level) {
                let (rows, seen) = backend.sample_split(mesh, tiling, &fine, &options, progress)?;
                (rows, Some(seen))
            } else {
                (
                    backend.sample(mesh, tiling, &fine, &options, progress)?,
                    None,
                )
            }
        };
        Ok(SphereRows {
            plain,
            fine,
            params,
            supersample,
            saturate: !self.settings.sampled_rows,
        })
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
            self.number_with_shells(tiling, visibility, Vec::new())?;
        Ok((tiling, visibility, renumbered))
    }

    /// [`Recipe::number`] of a bake with sampling shells: the numbering comes from the
    /// sampling sphere's rows `visibility` alone, and every shell's rows follow it.
    pub fn number_with_shells(
        &self,
        tiling: Tiling,
        visibility: VisibilityMatrix,
        shells: Vec<VisibilityMatrix>,
    ) -> Result<(Tiling, VisibilityMatrix, Vec<VisibilityMatrix>, bool), BakeError> {
        match self.file_patch_order(&tiling.patches, &visibility) {
            Some(order) => {
                let tiling = tiling.renumbered(&order).map_err(BakeError::TempFile)?;
                let shells = shells.iter().map(|m| m.with_patch_order(&order)).collect();
                Ok((tiling, visibility.with_patch_order(&order), shells, true))
            }
            None => Ok((tiling, visibility, shells, false)),
        }
    }

    /// The file's patch numbering of the tiling's `patches` and their stored rows
    /// `visibility` (file id `i` is tiling patch `order[i]`), or `None` to keep the tiling's.
    /// Patches the file cannot tell apart stay in tiling order among themselves
    /// ([`format::keep_equal_records_in_order`]). [`Recipe::number`] and the merge of a
    /// sharded bake (`merge.rs`) both number through here.
    pub(crate) fn file_patch_order(
        &self,
        patches: &[Patch],
        visibility: &VisibilityMatrix,
    ) -> Option<Vec<PatchId>> {
        match self.settings.patch_order {
            PatchOrder::Spatial => None,
            PatchOrder::Covisibility => {
                let mut order = format::covisibility_order(visibility)?;
                format::keep_equal_records_in_order(patches, &mut order);
                Some(order)
            }
        }
    }

    /// The `.pvis` bytes of a bake without sampling shells.
    pub fn encode(
        &self,
        params: &SamplingParams,
        triangle_count: u32,
        tiling: &Tiling,
        visibility: &VisibilityMatrix,
    ) -> Vec<u8> {
        self.encode_patches(params, triangle_count, &tiling.patches, visibility, &[])
    }

    /// The `.pvis` bytes of a bake with the sampling shells `shells` (outermost first, in the
    /// file's patch numbering; none: [`Recipe::encode`]'s bytes).
    pub fn encode_with_shells(
        &self,
        params: &SamplingParams,
        triangle_count: u32,
        tiling: &Tiling,
        visibility: &VisibilityMatrix,
        shells: &[ShellRows],
    ) -> Vec<u8> {
        self.encode_patches(params, triangle_count, &tiling.patches, visibility, shells)
    }

    /// [`Recipe::encode_with_shells`] from the patch records alone, which is all the merge of
    /// a sharded bake has.
    pub(crate) fn encode_patches(
        &self,
        params: &SamplingParams,
        triangle_count: u32,
        patches: &[Patch],
        visibility: &VisibilityMatrix,
        shells: &[ShellRows],
    ) -> Vec<u8> {
        format::encode_with(
            &BakeContents {
                sampling: params,
                triangle_count: u64::from(triangle_count),
                patches,
                visibility,
                shells,
            },
            self.settings.encoding,
        )
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
        let visibility = rows.stored(self.settings.level);
        let shell_matrices: Vec<VisibilityMatrix> = rows
            .shells()
            .iter()
            .map(|s| s.stored(self.shell_level()))
            .collect();
        let (mut params, sampled_views) = (rows.params(self.settings.level), rows.sampled_views());
        let shell_sampling: Vec<(u32, f64)> = rows
            .shells()
            .iter()
            .map(|s| (s.sampled_views(), s.seconds))
            .collect();
        drop(rows);
        let (mut tiling, visibility, shell_matrices, renumbered) = stages
            .run("patch-order", || {
                self.number_with_shells(tiling, visibility, shell_matrices)
            })?;
        if frame.is_some() {
            params = Frame::world_params(mesh, params);
            tiling = Frame::world_tiling(mesh, tiling);
        }
        // The file's shells are where a bake of the original in its own frame puts them: the
        // same rule on the file's camera.
        let shells: Vec<BakedShell> = self
            .shell_distances(&params)?
            .into_iter()
            .zip(shell_matrices)
            .zip(shell_sampling)
            .map(
                |((distance, visibility), (sampled_views, seconds))| BakedShell {
                    distance,
                    visibility,
                    sampled_views,
                    seconds,
                },
            )
            .collect();
        let bytes = stages.run("encoding", || {
            spin(progress, "encoding", || {
                self.encode_with_shells(
                    &params,
                    mesh.triangle_count(),
                    &tiling,
                    &visibility,
                    &shells::shell_rows(&shells),
                )
            })
        });
        let visibility_bytes = Pvis::parse(&bytes)
            .map(|p| p.visibility_bytes())
            .map_err(|e| BakeError::Internal(format!("the written file does not parse: {e}")))?;
        Ok(Baked {
            params,
            probe: self.probe,
            fold_corners: self.supersample.fold_corners,
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
        let frame = Frame::choose(mesh, self.settings.fov_deg)?;
        if frame.is_none() && self.settings.shells > 0 {
            // Before the tiling: shells binary32 cannot tell apart are a usage error. (In a
            // working frame of its own, the mesh's shells are checked where they are sampled.)
            self.shell_distances(&self.sampling_params(mesh))?;
        }
        Ok(frame)
    }

    /// Removes this bake's sampling checkpoints (once its output is complete, they have
    /// served their purpose); a missing one is fine.
    pub(crate) fn remove_checkpoints(&self) -> Result<(), BakeError> {
        for checkpoint in self.checkpoints() {
            match std::fs::remove_file(checkpoint) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(BakeError::Remove {
                        path: checkpoint.clone(),
                        source: e,
                    });
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Writes `baked` (from `mesh`) to `outputs`: the reordered mesh to a temporary file
    /// first, then the `.pvis` atomically, then the mesh renamed into place, so that a failure
    /// anywhere leaves no partial output behind; the finished bake's checkpoints are removed.
    pub fn write(
        &self,
        baked: &Baked,
        mesh: &Mesh,
        outputs: &Outputs,
        stages: &mut Stages,
    ) -> Result<(), BakeError> {
        let mesh_tmp = match &outputs.mesh {
            Some(path) => {
                Some(stages.run("mesh-out", || write_mesh_tmp(path, mesh, &baked.tiling))?)
            }
            None => None,
        };
        format::write_atomic(&outputs.pvis, &baked.bytes).map_err(|source| BakeError::Write {
            path: outputs.pvis.clone(),
            source,
        })?;
        // The output is complete: its checkpoints have served their purpose.
        self.remove_checkpoints()?;
        if let (Some(tmp), Some(path)) = (mesh_tmp, &outputs.mesh) {
            tmp.commit().map_err(|source| BakeError::Write {
                path: path.clone(),
                source,
            })?;
        }
        Ok(())
    }
}

/// How one sphere of views is sampled ([`Recipe::sample_share`]).
pub(super) struct SphereSampling {
    /// The cameras at the sphere's stored level (the sampling sphere's centre, radius and
    /// field of view).
    pub(super) params: SamplingParams,
    pub(super) supersample: Supersample,
    pub(super) checkpoints: PassCheckpoints,
    /// The shard whose views are rendered, or every view.
    pub(super) shard: Option<Shard>,
    /// A shell's camera distance (`SamplingOptions::shell`); `None`: the sampling sphere.
    pub(super) shell: Option<f32>,
    /// The camera distances its rows answer for (`SamplingOptions::band`).
    pub(super) band: Option<[f32; 2]>,
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

/// Runs `f` as an indeterminate progress step (a spinner with elapsed time in the binary).
fn spin<T>(progress: &dyn Progress, what: &str, f: impl FnOnce() -> T) -> T {
    progress.start(what, 0);
    let out = f();
    progress.finish();
    out
}

/// The reordered mesh of `--mesh-out` (with the input's attributes, read again from it) in
/// its temporary file beside `path` (with the permissions of a plain create), to be committed
/// once the `.pvis` is in place.
fn write_mesh_tmp(path: &Path, mesh: &Mesh, tiling: &Tiling) -> Result<AtomicFile, BakeError> {
    let failed = |source| BakeError::Write {
        path: path.to_path_buf(),
        source,
    };
    let format = MeshFormat::of(path);
    let attributes = Attributes::read(mesh, format != MeshFormat::Ply)?;
    let mut tmp = AtomicFile::create(path).map_err(failed)?;
    {
        let mut out = BufWriter::new(tmp.file());
        meshout::write(&mut out, format, mesh, &attributes, tiling)
            .and_then(|()| out.flush())
            .map_err(failed)?;
    }
    Ok(tmp)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::Probe;
    use crate::progress::NoProgress;
    use crate::sphere::view_count;
    use crate::test_kit::bunny::bunny;

    #[test]
    fn the_default_probe_turns_itself_off_where_it_cannot_run() {
        use crate::memory::DEFAULT_PROBE_MAX_TRIANGLES;
        let recipe = |f: fn(&mut BakeSettings)| {
            let mut s = BakeSettings {
                memory: MemoryBudget::new(256 << 20),
                ..BakeSettings::default()
            };
            f(&mut s);
            s.check().unwrap()
        };
        let default = recipe(|_| {});
        assert_eq!((default.probe(), default.shell_probe()), (Some(1), Some(1)));
        assert_eq!(default.supersample.fold_corners, FoldCorners::Cover);
        // Up to the bound on the CPU: as it is, on every machine (256 MiB is the smallest
        // default budget, and the bound's solids fit it).
        assert!(
            default
                .for_mesh(DEFAULT_PROBE_MAX_TRIANGLES, true)
                .is_none()
        );
        for (triangles, cpu, why) in [
            (DEFAULT_PROBE_MAX_TRIANGLES + 1, true, "past the 2236962"),
            (1000, false, "the GPU backend"),
        ] {
            let (off, message) = default.for_mesh(triangles, cpu).unwrap();
            assert!(message.contains(why), "{message}");
            assert_eq!((off.probe(), off.shell_probe()), (None, None));
            assert_eq!(off.supersample.fold_corners, FoldCorners::All);
            assert_eq!(off.shell_supersample.fold_corners, FoldCorners::All);
            assert_eq!(off.checkpoints().count(), default.checkpoints().count());
            assert!(off.for_mesh(triangles, cpu).is_none());
        }
        // A smaller --memory than its solids need.
        let small = recipe(|s| s.memory = MemoryBudget::new(16 << 20));
        let (off, message) = small.for_mesh(1_000_000, true).unwrap();
        assert!(message.contains("--memory 16 MiB"), "{message}");
        assert_eq!(off.probe(), None);
        // An explicit fold stays; what was asked for is never turned off.
        let cover = recipe(|s| s.fold_corners = Some(FoldCorners::Cover));
        let (off, _) = cover.for_mesh(1000, false).unwrap();
        assert_eq!(off.supersample.fold_corners, FoldCorners::Cover);
        for asked in [
            recipe(|s| s.probe = Probe::Pixels(1)),
            recipe(|s| s.conservative = true),
            recipe(|s| s.fold_corners = Some(FoldCorners::Split)),
            recipe(|s| s.probe = Probe::Off),
        ] {
            assert!(
                asked.for_mesh(u32::MAX, false).is_none(),
                "{:?}",
                asked.settings
            );
        }
    }

    /// The default bake's shells lie at the documented radii, are sampled like the
    /// sampling sphere (its supersampling), the same on one thread and two, and follow the
    /// sampling sphere's patch numbering.
    #[test]
    fn shells_lie_at_their_radii_and_follow_the_sampling_spheres_numbering() {
        let mesh = bunny();
        let recipe = |patch_order| {
            BakeSettings {
                patches: 80,
                level: 1,
                resolution: 32,
                patch_order,
                ..BakeSettings::default()
            }
            .check()
            .unwrap()
        };
        let bake = |patch_order, threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                recipe(patch_order)
                    .run(&mesh, &Backend::Cpu, &NoProgress, &mut Stages::new())
                    .unwrap()
            })
        };
        let spatial = bake(PatchOrder::Spatial, 2);
        let (d, r) = (
            f64::from(spatial.params.distance()),
            f64::from(spatial.params.radius),
        );
        assert_eq!(spatial.shells.len(), shells::DEFAULT_SHELLS as usize);
        for (s, shell) in spatial.shells.iter().enumerate() {
            let expected =
                (d * (1.1 * r / d).powf((s + 1) as f64 / f64::from(shells::DEFAULT_SHELLS))) as f32;
            assert!(
                (shell.distance - expected).abs() <= expected * f32::EPSILON,
                "shell {s}: {} vs {expected}",
                shell.distance
            );
            assert_eq!(shell.visibility.views(), view_count(1));
            assert_eq!(shell.sampled_views, view_count(2));
        }
        assert_eq!(spatial.sampled_views, view_count(2));
        let (one, two) = (
            bake(PatchOrder::Covisibility, 1),
            bake(PatchOrder::Covisibility, 2),
        );
        assert_eq!(one.bytes, two.bytes);
        let order = recipe(PatchOrder::Covisibility)
            .file_patch_order(&spatial.tiling.patches, &spatial.visibility)
            .expect("renumbered by co-visibility");
        assert_eq!(one.visibility, spatial.visibility.with_patch_order(&order));
        for ((a, b), s) in one.shells.iter().zip(&two.shells).zip(&spatial.shells) {
            assert_eq!((a.distance, &a.visibility), (b.distance, &b.visibility));
            assert_eq!(a.distance, s.distance);
            assert_eq!(a.visibility, s.visibility.with_patch_order(&order));
        }
    }

    /// Every pass, each shell's included, checkpoints beside the output; a bake resumed
    /// from them (one shell's missing, so sampled again) gives the same bytes and shells.
    #[test]
    fn every_pass_checkpoints_and_a_resumed_bake_gives_the_same_file() {
        let mesh = bunny();
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("b.pvis");
        let recipe = |resume| {
            BakeSettings {
                patches: 60,
                level: 1,
                resolution: 32,
                fold_min_pixels: Some(4),
                probe: Probe::Off,
                shells: 2,
                checkpoint: Some(out.clone()),
                resume,
                ..BakeSettings::default()
            }
            .check()
            .unwrap()
        };
        let first = recipe(false)
            .run(&mesh, &Backend::Cpu, &NoProgress, &mut Stages::new())
            .unwrap();
        let mut names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        assert_eq!(
            names,
            [
                "b.pvis.ckpt",
                "b.pvis.shell1.ckpt",
                "b.pvis.shell1.vs1.m4.ckpt",
                "b.pvis.shell2.ckpt",
                "b.pvis.shell2.vs1.m4.ckpt",
                "b.pvis.vs1.m4.ckpt"
            ]
        );
        std::fs::remove_file(dir.path().join("b.pvis.shell2.vs1.m4.ckpt")).unwrap();
        let resumed = recipe(true)
            .run(&mesh, &Backend::Cpu, &NoProgress, &mut Stages::new())
            .unwrap();
        assert_eq!(resumed.bytes, first.bytes);
        for (a, b) in resumed.shells.iter().zip(&first.shells) {
            assert_eq!((a.distance, &a.visibility), (b.distance, &b.visibility));
        }
        // Written out, the bake removes every checkpoint.
        let outputs = Outputs {
            pvis: out.clone(),
            mesh: None,
        };
        recipe(true)
            .write(&resumed, &mesh, &outputs, &mut Stages::new())
            .unwrap();
        let left: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left, ["b.pvis"]);
    }
}
