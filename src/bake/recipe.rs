//! The recipe a bake follows, stage by stage: tile → sample (supersample and fold) → number
//! the patches → encode, then write the outputs. [`Recipe::run`] is `patchvis bake`;
//! `eval --sweep` runs the same stages, sampling once per patch count and cutting every level
//! it evaluates from those rows ([`SampledRows::stored`]).

use super::frame::Frame;
use super::settings::{BakeSettings, PatchOrder, Supersample};
use super::{Backend, BakeError, SampledRows, Shard, Stages};
use crate::format::{self, BakeContents};
use crate::memory::{FixedNeeds, MemoryBudget};
use crate::meshout::{self, MeshFormat};
use crate::ooc::attributes::Attributes;
use crate::ooc::{Mesh, MeshError, MeshErrorKind, OpenOptions, default_cache_dir};
use crate::output::{AtomicFile, NamedPath};
use crate::progress::Progress;
use crate::runtime::Pvis;
use crate::sampler::SamplingOptions;
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
    /// Checkpoint of the stored level's plain pass when the fold has a threshold.
    pub coarse_checkpoint: Option<PathBuf>,
    /// Checkpoint of the main (supersampled) pass.
    pub fine_checkpoint: Option<PathBuf>,
}

/// The result of [`Recipe::run`]: the file's bytes and what they were made of.
#[derive(Debug)]
pub struct Baked {
    /// Where the sampling cameras were (the stored level).
    pub params: SamplingParams,
    /// The tiling, in the file's patch numbering.
    pub tiling: Tiling,
    /// The stored rows, in the file's patch numbering.
    pub visibility: VisibilityMatrix,
    /// Whether the patches were renumbered by co-visibility.
    pub renumbered: bool,
    /// Views rendered, every pass counted.
    pub sampled_views: u32,
    /// The `.pvis` file.
    pub bytes: Vec<u8>,
    /// Bytes of its VISB payload.
    pub visibility_bytes: u64,
}

impl Baked {
    /// The fraction of (view, patch) pairs marked visible.
    pub fn visible_fraction(&self) -> f64 {
        let pairs = f64::from(self.visibility.views()) * f64::from(self.visibility.patches());
        if pairs == 0.0 {
            0.0
        } else {
            self.visibility.count_ones() as f64 / pairs
        }
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
        for checkpoint in [&recipe.fine_checkpoint, &recipe.coarse_checkpoint]
            .into_iter()
            .flatten()
        {
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

    /// The probe pass's occluder shrink in pixels (`--conservative`), or `None`.
    pub fn probe(&self) -> Option<u32> {
        self.settings
            .conservative
            .then_some(super::settings::CONSERVATIVE_PROBE_PIXELS)
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
        if self.probe().is_some() && !self.memory().fits_solids(mesh.triangle_count()) {
            return Err(BakeError::Budget(format!(
                "--conservative finds the mesh's solids in about {} MiB for {} triangles, \
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
        let level = (settings.level + self.supersample.extra_levels).min(crate::sphere::MAX_LEVEL);
        let patches = u64::from(settings.patches.min(mesh.triangle_count()));
        let needs = FixedNeeds {
            triangles: mesh.triangle_count(),
            resolution: self.resolution(),
            workers: rayon::current_num_threads(),
            row_bytes: u64::from(crate::sphere::view_count(level)) * patches.div_ceil(64) * 8,
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
                crate::sphere::view_count(level),
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

    /// Sampling options with `min_pixels`, `checkpoint` and `views`, the rest from the
    /// settings.
    fn sampling_options(
        &self,
        min_pixels: u32,
        checkpoint: Option<PathBuf>,
        views: Option<Vec<u32>>,
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
            probe: self.probe(),
            shell: None,
            band: None,
        }
    }

    /// Samples the views the stored level needs with `backend`: the stored views with every
    /// pixel, and the finer views of the supersampling, thresholded when the fold has a
    /// threshold (see [`SampledRows`]).
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
        let params = self.sampling_params(mesh);
        let views = |level: u32| shard.map(|s| s.views(level));
        let Supersample {
            extra_levels,
            fold_min_pixels,
            ..
        } = self.supersample;
        // The finer pass differs from the stored level in `level` only (same centre, radius,
        // camera distance), so its views are the stored ones plus the finer ones.
        let fine = SamplingParams {
            // Capped for `eval --sweep`, whose recipe may sample at the finest level (a checked
            // bake has `level + extra_levels` within it already).
            level: (params.level + extra_levels).min(crate::sphere::MAX_LEVEL),
            ..params
        };
        let min_pixels = self.settings.min_pixels;
        let (plain, fine) = if fold_min_pixels > 0 {
            let coarse_options = self.sampling_options(
                min_pixels,
                self.coarse_checkpoint.clone(),
                views(params.level),
            );
            let plain = backend.sample(mesh, tiling, &params, &coarse_options, progress)?;
            let fine_options = self.sampling_options(
                fold_min_pixels,
                self.fine_checkpoint.clone(),
                views(fine.level),
            );
            let rows = backend.sample(mesh, tiling, &fine, &fine_options, progress)?;
            (plain, Some(rows))
        } else {
            let options =
                self.sampling_options(min_pixels, self.fine_checkpoint.clone(), views(fine.level));
            (
                backend.sample(mesh, tiling, &fine, &options, progress)?,
                None,
            )
        };
        Ok(SampledRows {
            plain,
            fine,
            params,
            supersample: self.supersample,
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
        match self.file_patch_order(&visibility) {
            Some(order) => {
                let tiling = tiling.renumbered(&order).map_err(BakeError::TempFile)?;
                Ok((tiling, visibility.with_patch_order(&order), true))
            }
            None => Ok((tiling, visibility, false)),
        }
    }

    /// The file's patch numbering of the stored rows `visibility` (file id `i` is tiling
    /// patch `order[i]`), or `None` to keep the tiling's. [`Recipe::number`] and the merge of
    /// a sharded bake (`merge.rs`) both number through here.
    pub(crate) fn file_patch_order(&self, visibility: &VisibilityMatrix) -> Option<Vec<PatchId>> {
        match self.settings.patch_order {
            PatchOrder::Spatial => None,
            PatchOrder::Covisibility => format::covisibility_order(visibility),
        }
    }

    /// The `.pvis` bytes of a bake.
    pub fn encode(
        &self,
        params: &SamplingParams,
        triangle_count: u32,
        tiling: &Tiling,
        visibility: &VisibilityMatrix,
    ) -> Vec<u8> {
        self.encode_patches(params, triangle_count, &tiling.patches, visibility)
    }

    /// [`Recipe::encode`] from the patch records alone, which is all the merge of a sharded
    /// bake has.
    pub(crate) fn encode_patches(
        &self,
        params: &SamplingParams,
        triangle_count: u32,
        patches: &[Patch],
        visibility: &VisibilityMatrix,
    ) -> Vec<u8> {
        format::encode_with(
            &BakeContents {
                sampling: params,
                triangle_count: u64::from(triangle_count),
                patches,
                visibility,
                shells: &[],
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
        let frame = self.prepare(mesh, progress)?;
        let local = match &frame {
            Some(frame) => Some(stages.run("frame", || frame.apply(mesh))?),
            None => None,
        };
        let work = local.as_ref().unwrap_or(mesh);
        let tiling = stages.run("tiling", || spin(progress, "tiling", || self.tile(work)))?;
        let rows = stages.run("sampling", || self.sample(work, &tiling, backend, progress))?;
        let visibility = rows.stored(self.settings.level);
        let (mut params, sampled_views) = (rows.params(self.settings.level), rows.sampled_views());
        drop(rows);
        let (mut tiling, visibility, renumbered) =
            stages.run("patch-order", || self.number(tiling, visibility))?;
        if frame.is_some() {
            params = Frame::world_params(mesh, params);
            tiling = Frame::world_tiling(mesh, tiling);
        }
        let bytes = stages.run("encoding", || {
            spin(progress, "encoding", || {
                self.encode(&params, mesh.triangle_count(), &tiling, &visibility)
            })
        });
        let visibility_bytes = Pvis::parse(&bytes)
            .map(|p| p.visibility_bytes())
            .map_err(|e| BakeError::Internal(format!("the written file does not parse: {e}")))?;
        Ok(Baked {
            params,
            tiling,
            visibility,
            renumbered,
            sampled_views,
            bytes,
            visibility_bytes,
        })
    }

    /// What every bake (whole or one shard) does first: reports the mesh's and the
    /// settings' warnings, checks the mesh, and chooses the working frame. Coordinates
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
        Frame::choose(mesh, self.settings.fov_deg)
    }

    /// Removes this bake's sampling checkpoints (once its output is complete, they have
    /// served their purpose); a missing one is fine.
    pub(crate) fn remove_checkpoints(&self) -> Result<(), BakeError> {
        for checkpoint in [&self.fine_checkpoint, &self.coarse_checkpoint]
            .into_iter()
            .flatten()
        {
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
