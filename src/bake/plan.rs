//! The bake plan: what the settings resolve to, and the list of spheres of views a bake
//! samples, each with its level, supersampling, probe, distance and band.
//!
//! Defaults that depend on the preset or on other settings are resolved here and nowhere
//! else ([`Plan::new`]): the stored level, the view supersampling (one finer level unless the
//! level is the finest), whether a thresholded fold needs a plain pass of its own, the fold,
//! the probe pass and its cells, the finer views' layout, and the shells' level. The one
//! decision that needs the mesh and the backend is [`Plan::for_mesh`]: it turns the default's
//! probe pass off where it cannot run, which is the plan of the same settings with
//! `--probe off`.
//!
//! With the mesh's sampling sphere, [`Plan::spheres`] lists the spheres of views in sampling
//! order: the sampling sphere, then each sampling shell (`shells.rs`), each with the
//! checkpoints of its passes. `Recipe` runs them in one loop, and the merge of a sharded bake
//! builds the same plan from the parts' [`RowSettings`].

use super::settings::{
    CONSERVATIVE_FOLD_CORNERS, CONSERVATIVE_LEVEL, CONSERVATIVE_PROBE_PIXELS,
    DEFAULT_FOLD_MIN_PIXELS, DEFAULT_LEVEL, DEFAULT_PROBE_PIXELS, DEFAULT_VIEW_SUPERSAMPLE,
    PROBE_FOLD_CORNERS, Preset, Probe, Research, RowSettings, SettingsError, UNPROBED_FOLD_CORNERS,
};
use super::shells;
use crate::memory::MemoryBudget;
use crate::ooc::Mesh;
use crate::sampler::{FinerViews, FoldCorners, MAX_VIEW_SUPERSAMPLE, PassViews, probe_reach};
use crate::sphere::{MAX_LEVEL, view_count};
use crate::visibility::SamplingParams;
use std::path::{Path, PathBuf};

/// How the stored views of one sphere are supersampled, resolved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Supersample {
    /// Extra sphere levels sampled (0: none).
    pub extra_levels: u32,
    /// Finer views fold only patches of at least this many pixels; 0 when no separate
    /// thresholded pass is needed (no supersampling, or a threshold at or below the stored
    /// views' own `min_pixels`).
    pub fold_min_pixels: u32,
    /// Which stored views receive a finer view's patches.
    pub fold_corners: FoldCorners,
    /// Where the finer views lie.
    pub finer: FinerViews,
}

impl Supersample {
    /// The sphere levels of one sphere's sampling passes at stored level `level`, in order:
    /// the stored level plainly and the finer one thresholded, or the finer one alone (whose
    /// prefix is the stored level). The finer level is capped at the finest.
    /// With the split fold, the finer pass's seen rows come as a second pass of the same
    /// level.
    pub fn pass_levels(&self, level: u32) -> Vec<u32> {
        let fine = (level + self.extra_levels).min(MAX_LEVEL);
        if self.fold_min_pixels > 0 {
            vec![level, fine]
        } else if self.splits(level) {
            vec![fine, fine]
        } else {
            vec![fine]
        }
    }

    /// The layout of the views of a sampling pass at `pass_level` of a sphere whose stored level
    /// is `stored`: `--finer-views`' for the finer pass, the sphere's vertices for a pass at
    /// the stored level (or a coarser one cut from the same rows, `eval --sweep`), whose
    /// views are all vertices.
    pub fn finer_views(&self, stored: u32, pass_level: u32) -> FinerViews {
        if pass_level > stored {
            self.finer
        } else {
            FinerViews::Midpoints
        }
    }

    /// Whether the passes at stored level `level` fold with [`FoldCorners::Split`]: there is
    /// a finer level to fold from, so the finer pass keeps its seen rows too
    /// (`sampler::sample_tiled_split`).
    pub fn splits(&self, level: u32) -> bool {
        self.fold_corners == FoldCorners::Split
            && (level + self.extra_levels).min(MAX_LEVEL) > level
    }
}

/// How every sphere of one kind (the sampling sphere, or each shell) is sampled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SphereSampling {
    /// The stored sphere level.
    pub level: u32,
    /// Supersampling and folding.
    pub supersample: Supersample,
    /// The probe pass's occluder shrink in pixels, or `None`.
    pub probe: Option<u32>,
    /// The widest gap the probe opens as an aperture, in pixels (`SamplingOptions::apertures`);
    /// 0: none.
    pub apertures: u32,
}

/// Which sphere of views a [`Sphere`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SphereKind {
    /// The sampling sphere, at the sampling distance.
    Sampling,
    /// Sampling shell `s` (1 is the outermost), nearer the model (`shells.rs`).
    Shell(u32),
    /// Shell `j` of the far band (1 is the innermost), beyond the sampling sphere
    /// (`shells.rs`).
    Far(u32),
}

/// One sphere of views of a bake on a mesh, as [`Plan::spheres`] lists them.
#[derive(Clone, Debug, PartialEq)]
pub struct Sphere {
    /// Which one it is.
    pub kind: SphereKind,
    /// The cameras at its stored level: the sampling sphere's centre, radius and field of
    /// view.
    pub params: SamplingParams,
    /// How it is sampled.
    pub sampling: SphereSampling,
    /// A shell's camera distance, nearer or farther (`SamplingOptions::shell`); `None`: the
    /// sampling distance.
    pub shell: Option<f32>,
    /// The camera distances the probe's cells span (`SamplingOptions::band`); `None`: each
    /// view's own distance.
    pub probe_band: Option<[f32; 2]>,
    /// Its passes' checkpoints.
    pub checkpoints: PassCheckpoints,
}

/// The checkpoint files of one sphere's sampling passes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PassCheckpoints {
    /// Of the stored level's plain pass, when the fold has a threshold.
    pub coarse: Option<PathBuf>,
    /// Of the main (supersampled) pass.
    pub fine: Option<PathBuf>,
}

impl PassCheckpoints {
    /// Both, the ones there are.
    pub fn paths(&self) -> impl Iterator<Item = &PathBuf> {
        [&self.fine, &self.coarse].into_iter().flatten()
    }
}

/// What a bake's [`RowSettings`] resolve to (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// The settings planned.
    pub rows: RowSettings,
    /// The sampling sphere.
    pub main: SphereSampling,
    /// Each sampling shell, near or far. The far band's are sampled as the near ones: without
    /// the finer level or the probe, a camera between a far shell's views misses what a gap
    /// shows (the exposed engine at 2×D: 94.3 % of views identical without the finer level).
    pub shell: SphereSampling,
    /// Whether the probe is the default bake's, which [`Plan::for_mesh`] turns off where it
    /// cannot run, and whose cells lie at each view's own distance.
    pub default_probe: bool,
}

impl Plan {
    /// Checks `rows` and resolves every default: the one place the presets are expanded.
    pub fn new(rows: RowSettings) -> Result<Plan, SettingsError> {
        rows.check_ranges()?;
        let fail = |message: String| Err(SettingsError(message));
        let conservative = rows.preset == Preset::Conservative;
        let r: &Research = &rows.research;
        let level = rows.level.unwrap_or(match rows.preset {
            Preset::Default => DEFAULT_LEVEL,
            Preset::Conservative => CONSERVATIVE_LEVEL,
        });
        // The level was checked, so the subtraction cannot underflow.
        let extra_levels = r
            .view_supersample
            .unwrap_or(DEFAULT_VIEW_SUPERSAMPLE.min(MAX_LEVEL - level));
        if extra_levels > MAX_VIEW_SUPERSAMPLE || level + extra_levels > MAX_LEVEL {
            return fail(format!(
                "--view-supersample {extra_levels}: expected 0 to {MAX_VIEW_SUPERSAMPLE} with --level + K at most {MAX_LEVEL} (--level is {level})"
            ));
        }
        if conservative && r.probe != Probe::Default {
            return fail(
                "--probe with --conservative: expected one of them (--conservative is the probe \
                 pass at 1 pixel with the split fold and centroid finer views)"
                    .into(),
            );
        }
        let apertures = r.apertures.unwrap_or(0);
        let probe = match r.probe {
            Probe::Off => None,
            Probe::Pixels(pixels) => Some(pixels),
            Probe::Default if conservative => Some(CONSERVATIVE_PROBE_PIXELS),
            Probe::Default => Some(DEFAULT_PROBE_PIXELS),
        };
        if apertures > 0 && probe.is_none() {
            return fail(format!(
                "--apertures {apertures} with --probe off: expected the probe pass, which opens \
                 the apertures (the default's, --probe or --conservative)"
            ));
        }
        if r.min_pixels > 1 && probe.is_some() {
            // The probe adds back what the threshold drops: the file would be the same.
            let which = match r.probe {
                _ if conservative => "--conservative's probe pass".to_owned(),
                Probe::Pixels(pixels) => format!("the probe pass (--probe {pixels})"),
                _ => "the default's probe pass".to_owned(),
            };
            return fail(format!(
                "--min-pixels {}: {which} draws every patch a view did not show again and adds \
                 it back where a camera near the view may see it, so a pixel threshold would \
                 change nothing; add --probe off (without --conservative) to use one",
                r.min_pixels
            ));
        }
        let fold_min_pixels = r.fold_min_pixels.unwrap_or(DEFAULT_FOLD_MIN_PIXELS);
        // A threshold at or below the stored views' own changes nothing.
        let threshold = fold_min_pixels > r.min_pixels.max(1);
        let fold_corners = r.fold_corners.unwrap_or(if conservative && !threshold {
            CONSERVATIVE_FOLD_CORNERS
        } else if probe.is_some() {
            PROBE_FOLD_CORNERS
        } else {
            UNPROBED_FOLD_CORNERS
        });
        if fold_corners == FoldCorners::Split {
            if probe.is_none() {
                return fail(
                    "--fold-corners split: expected --conservative or --probe (it folds the \
                     probe pass's additions apart from what the views showed)"
                        .into(),
                );
            }
            if threshold {
                return fail(format!(
                    "--fold-corners split with --fold-min-pixels {fold_min_pixels}: expected no \
                     fold threshold (the split fold folds every pixel)"
                ));
            }
        }
        let finer = r
            .finer_views
            .unwrap_or(if conservative && extra_levels == 1 {
                FinerViews::Centroids
            } else {
                FinerViews::Midpoints
            });
        if finer == FinerViews::Centroids && extra_levels != 1 {
            return fail(format!(
                "--finer-views centroids with --view-supersample {extra_levels}: expected one \
                 finer level (the centroids of the stored faces)"
            ));
        }
        let supersample = |extra_levels: u32| Supersample {
            extra_levels,
            // Without finer views, no extra plain pass.
            fold_min_pixels: if extra_levels > 0 && threshold {
                fold_min_pixels
            } else {
                0
            },
            fold_corners,
            finer: FinerViews::Midpoints,
        };
        // Each near view renders several frustums, and the shells' figures were measured at
        // the default level: `--conservative`'s shells stay there.
        let shell_level = rows.shell_level.unwrap_or(if conservative {
            level.min(DEFAULT_LEVEL)
        } else {
            level
        });
        Ok(Plan {
            main: SphereSampling {
                level,
                supersample: Supersample {
                    finer,
                    ..supersample(extra_levels)
                },
                probe,
                apertures,
            },
            // The shells probe and fold as the sampling sphere does, their supersampling
            // capped at the finest level; their finer views are the vertices.
            shell: SphereSampling {
                level: shell_level,
                supersample: supersample(extra_levels.min(MAX_LEVEL - shell_level)),
                probe,
                apertures,
            },
            // Split needs the probe's rows: asking for it makes the probe a must.
            default_probe: r.probe == Probe::Default
                && !conservative
                && fold_corners != FoldCorners::Split,
            rows,
        })
    }

    /// The stored level of the sampling sphere.
    pub fn level(&self) -> u32 {
        self.main.level
    }

    /// This plan for a mesh of `triangles` triangles sampled on the CPU backend (`cpu`) or
    /// not, within `memory`, and why it differs, when it does: the default bake's probe pass
    /// is off past [`crate::memory::DEFAULT_PROBE_MAX_TRIANGLES`] (so that a mesh gets the
    /// same file on every machine whatever the memory it defaults to), where its solids do not
    /// fit `memory`, and on the GPU backend, which has no probe pass. The plan is then the one
    /// of the same settings with `--probe off` (the fold without the probe, unless
    /// `--fold-corners` was given). `--probe PX` and `--conservative` are never turned off:
    /// they fail with the budget or the backend instead.
    pub fn for_mesh(
        &self,
        triangles: u32,
        cpu: bool,
        memory: MemoryBudget,
    ) -> Option<(Plan, String)> {
        if !self.default_probe {
            return None;
        }
        let why = if triangles > crate::memory::DEFAULT_PROBE_MAX_TRIANGLES {
            format!(
                "{triangles} triangles, past the {} it runs on whatever the memory \
                 (--probe {DEFAULT_PROBE_PIXELS} asks for it within --memory)",
                crate::memory::DEFAULT_PROBE_MAX_TRIANGLES,
            )
        } else if !memory.fits_solids(triangles) {
            format!(
                "the solids of {triangles} triangles take more than half of --memory {} MiB",
                memory.total() >> 20
            )
        } else if !cpu {
            "the GPU backend has none".to_string()
        } else {
            return None;
        };
        let mut rows = self.rows.clone();
        rows.research.probe = Probe::Off;
        let plan = Plan::new(rows).expect("the default's settings check with --probe off");
        Some((
            plan,
            format!(
                "the default's probe pass is off: {why}; --probe off asks for this without a note"
            ),
        ))
    }

    /// Whether the bake runs the probe pass (the shells probe as the sampling sphere does).
    pub fn probes(&self) -> bool {
        self.main.probe.is_some()
    }

    /// SHEL's `reach` for a file whose sampling sphere is at `distance` and whose SHEL
    /// records are at `shells`: `distance` times how far out the probe cells of the sampling
    /// sphere's finest pass hold every camera whose query uses its rows
    /// ([`crate::sampler::probe_reach`]), rounded down to binary32, so that the sampling
    /// sphere alone answers every eye out to there (spec § Query) and culls as it did before
    /// the far band. 0 without the probe or without a far shell.
    pub fn sampling_reach(&self, distance: f32, shells: &[f32]) -> f32 {
        if !self.probes() || !shells.iter().any(|&s| s > distance) {
            return 0.0;
        }
        // The finest pass: the last of the sampling sphere's.
        let main = &self.main;
        let levels = main.supersample.pass_levels(main.level);
        let fine = levels.last().copied().unwrap_or(main.level);
        let pass = PassViews::pass(fine, main.supersample.finer_views(main.level, fine));
        let exact = f64::from(distance) * probe_reach(&pass);
        let reach = exact as f32;
        let reach = if f64::from(reach) > exact {
            reach.next_down()
        } else {
            reach
        };
        if reach > distance && reach <= f32::MAX {
            reach
        } else {
            0.0
        }
    }

    /// The sphere level of each sampling pass, in order: the sampling sphere's passes, then
    /// each shell's, then each far shell's ([`Supersample::pass_levels`]).
    pub fn pass_levels(&self) -> Vec<u32> {
        let shell = self.shell.supersample.pass_levels(self.shell.level);
        let mut levels = self.main.supersample.pass_levels(self.main.level);
        for _ in 0..self.rows.shells as usize + self.rows.far_shells.len() {
            levels.extend_from_slice(&shell);
        }
        levels
    }

    /// The layout of each pass's views, in [`Plan::pass_levels`]' order: the sampling
    /// sphere's finer pass has `--finer-views`' (`sampler::PassViews::pass`), every other pass
    /// the sphere's vertices.
    pub fn pass_finer_views(&self) -> Vec<FinerViews> {
        let main = &self.main;
        let main_passes = main.supersample.pass_levels(main.level).len();
        self.pass_levels()
            .iter()
            .enumerate()
            .map(|(i, &level)| {
                if i < main_passes {
                    main.supersample.finer_views(main.level, level)
                } else {
                    FinerViews::Midpoints
                }
            })
            .collect()
    }

    /// Where the cameras of the stored level are, for `mesh`.
    pub fn sampling_params(&self, mesh: &Mesh) -> SamplingParams {
        SamplingParams::for_mesh(mesh, self.level(), self.rows.resolution, self.rows.fov_deg)
    }

    /// Views every pass together renders.
    pub fn sampled_view_count(&self) -> u64 {
        self.pass_levels()
            .into_iter()
            .map(|l| u64::from(view_count(l)))
            .sum()
    }

    /// The camera distances of the shells inside the sampling sphere `params`, outermost
    /// first (`shells.rs`); a usage error naming the flags if they cannot be used.
    pub fn shell_distances(&self, params: &SamplingParams) -> Result<Vec<f32>, SettingsError> {
        shells::shell_distances(params, self.rows.shells, self.rows.shell_min)
            .map_err(SettingsError)
    }

    /// The camera distances of the far band's shells around the sampling sphere `params`,
    /// innermost first (`shells.rs`).
    pub fn far_distances(&self, params: &SamplingParams) -> Result<Vec<f32>, SettingsError> {
        shells::far_distances(params, &self.rows.far_shells).map_err(SettingsError)
    }

    /// Every SHEL record's camera distance, in the file's order (decreasing): the far band's
    /// outermost first, then the shells inside the sampling sphere.
    pub fn file_shell_distances(&self, params: &SamplingParams) -> Result<Vec<f32>, SettingsError> {
        let mut all = self.far_distances(params)?;
        all.reverse();
        all.extend(self.shell_distances(params)?);
        Ok(all)
    }

    /// [`Plan::file_shell_distances`] for a file whose rows were sampled in a working frame of
    /// their own (a model far from unit scale, `frame.rs`), and how many far shells lead the
    /// rows but are left out of the file: all of them, with the reason, where binary32 cannot
    /// hold the far band's distances around the model (near `f32::MAX`); then the sampling
    /// sphere's rows answer every camera beyond it.
    pub fn file_shells_in_world(
        &self,
        params: &SamplingParams,
    ) -> Result<(Vec<f32>, usize, Option<String>), SettingsError> {
        let far = self.rows.far_shells.len();
        match self.far_distances(params) {
            Ok(_) => Ok((self.file_shell_distances(params)?, 0, None)),
            Err(why) if far > 0 => Ok((
                self.shell_distances(params)?,
                far,
                Some(format!("the far band is left out: {}", why.0)),
            )),
            Err(why) => Err(why),
        }
    }

    /// The spheres of views to sample around the sampling sphere `params` (at the stored
    /// level), in sampling order (the sampling sphere, the shells inside it outermost first,
    /// the far band innermost first), with their checkpoints beside `checkpoint` (none
    /// without).
    pub fn spheres(
        &self,
        params: &SamplingParams,
        checkpoint: Option<&Path>,
    ) -> Result<Vec<Sphere>, SettingsError> {
        let distances = self.shell_distances(params)?;
        let far = self.far_distances(params)?;
        let bands = shells::bands(params.distance(), &distances)
            .into_iter()
            .chain(shells::far_bands(params.distance(), &far));
        let checkpoints = self.checkpoints(checkpoint);
        let kinds = std::iter::once((SphereKind::Sampling, None))
            .chain(
                distances
                    .iter()
                    .enumerate()
                    .map(|(s, &d)| (SphereKind::Shell(s as u32 + 1), Some(d))),
            )
            .chain(
                far.iter()
                    .enumerate()
                    .map(|(j, &d)| (SphereKind::Far(j as u32 + 1), Some(d))),
            );
        Ok(kinds
            .zip(bands)
            .zip(checkpoints)
            .map(|(((kind, shell), band), checkpoints)| {
                let sampling = match kind {
                    SphereKind::Sampling => self.main,
                    SphereKind::Shell(_) | SphereKind::Far(_) => self.shell,
                };
                let resolution = match kind {
                    SphereKind::Shell(_) => self.rows.shell_resolution.unwrap_or(params.resolution),
                    SphereKind::Sampling | SphereKind::Far(_) => params.resolution,
                };
                Sphere {
                    kind,
                    params: SamplingParams {
                        level: sampling.level,
                        resolution,
                        ..*params
                    },
                    sampling,
                    shell,
                    // The default's probe covers the cameras at the pass's own distance:
                    // those between two spheres of views are answered by both (spec § Query),
                    // and a cell spanning the band cost the bunny 3.5 points of culling at the
                    // sampling distance, and the exposed engine's far band 15 points at 4×D
                    // for no fewer misses (docs/benchmarks/far-cameras.md).
                    probe_band: if self.default_probe { None } else { band },
                    checkpoints,
                }
            })
            .collect())
    }

    /// The checkpoints of each sphere's passes beside `base` (the output file), in sampling
    /// order: `OUT.pvis` + the shell + what decides the rows + `.ckpt`. The supersampled bake
    /// samples other rows than a plain one: its own checkpoint, so that resuming finds the
    /// right one and a plain bake's checkpoint stays usable. The plain pass of a thresholded
    /// fold samples exactly what a plain bake does: it shares a plain bake's checkpoint. The
    /// default's probe, on or off ([`Plan::for_mesh`]), names none (their hash tells the rows
    /// apart).
    pub fn checkpoints(&self, base: Option<&Path>) -> Vec<PassCheckpoints> {
        let named_probe = if self.default_probe {
            None
        } else {
            self.main.probe
        };
        let sphere = |prefix: &str, supersample: Supersample| {
            let with = |suffix: String| {
                base.map(|base| {
                    let mut path = base.as_os_str().to_owned();
                    path.push(suffix);
                    PathBuf::from(path)
                })
            };
            let plain = format!(
                "{prefix}{}",
                named_probe.map(|r| format!(".p{r}")).unwrap_or_default(),
            );
            let mut suffix = plain.clone();
            if supersample.extra_levels > 0 {
                suffix.push_str(&format!(".vs{}", supersample.extra_levels));
                if supersample.finer == FinerViews::Centroids {
                    suffix.push_str(".centroids");
                }
                if supersample.fold_corners == FoldCorners::Split {
                    // The pass holds its seen rows too.
                    suffix.push_str(".split");
                }
            }
            let thresholded = supersample.fold_min_pixels > 0;
            if thresholded {
                suffix.push_str(&format!(".m{}", supersample.fold_min_pixels));
            }
            PassCheckpoints {
                coarse: thresholded.then(|| with(plain + ".ckpt")).flatten(),
                fine: with(suffix + ".ckpt"),
            }
        };
        std::iter::once(sphere("", self.main.supersample))
            .chain(
                (1..=self.rows.shells)
                    .map(|s| sphere(&format!(".shell{s}"), self.shell.supersample)),
            )
            .chain(
                (1..=self.rows.far_shells.len())
                    .map(|j| sphere(&format!(".far{j}"), self.shell.supersample)),
            )
            .collect()
    }
}

#[cfg(test)]
mod tests;
