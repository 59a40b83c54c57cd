//! Every knob of a bake, with the defaults of `patchvis bake`, and the check that turns them
//! into a [`Recipe`] whose values are all usable as they are.
//!
//! Defaults that depend on other settings are resolved here and nowhere else: view
//! supersampling (one finer level unless the level is the finest), whether a thresholded
//! fold needs a plain pass of its own, the probe pass of `--conservative`, the sampling
//! shells' level and supersampling, and the checkpoint files of each sampling pass.

use crate::format::VisibilityEncoding;
use crate::sampler::{FinerViews, FoldCorners, MAX_RESOLUTION, MAX_VIEW_SUPERSAMPLE};
use crate::sphere::{MAX_LEVEL, view_count};
use crate::tiling::{PatchId, TilingMode};
use std::path::PathBuf;

use super::shells::{DEFAULT_SHELL_MIN, DEFAULT_SHELLS, MAX_SHELLS};
use super::{MemoryBudget, Recipe};

/// `--level` unless given: 1,026 stored views.
pub const DEFAULT_LEVEL: u32 = 4;
/// `--level` unless given, with `--conservative` ([`BakeSettings::conservative`]): sphere faces
/// half as wide as [`DEFAULT_LEVEL`]'s. A conservative level-4 file culls 12–14 points below
/// the ideal on the model zoo, and even the rows of 45 views a face, folded into its corners,
/// leave no room for a probe within 10 points; at level 5 with centroid finer views
/// `--conservative` culls within 7.6–9.8 points (BENCHMARKS.md, "Quality on the model zoo").
pub const CONSERVATIVE_LEVEL: u32 = 5;

/// `--view-supersample` unless given: one level finer, which removes most misses between the
/// stored views for ~4× the sampling time (BENCHMARKS.md, "Quality").
pub const DEFAULT_VIEW_SUPERSAMPLE: u32 = 1;
/// `--fold-min-pixels` unless given: finer views fold every patch they show. A threshold of 4
/// bought ~3 points of culling on the bunny but missed 1.6–22× more pixels on the model zoo
/// (BENCHMARKS.md, "Quality on the model zoo").
pub const DEFAULT_FOLD_MIN_PIXELS: u32 = 0;
/// `--fold-corners` unless given: every stored view around a finer view (the corners the
/// faces holding it share), so that a query anywhere in a face sees every finer sample of it
/// from each corner's side, not one.
pub const DEFAULT_FOLD_CORNERS: FoldCorners = FoldCorners::All;
/// `--fold-corners` unless given, with `--conservative`: the probe's additions go to one
/// corner, what the views showed to all of them. 2.3–3.3 points more culling on the model
/// zoo than [`FoldCorners::All`], every model still ≥ 99 % identical (BENCHMARKS.md,
/// "Quality on the model zoo").
pub const CONSERVATIVE_FOLD_CORNERS: FoldCorners = FoldCorners::Split;
/// `--fold-corners` unless given, with `--probe`: one stored view per face holding the finer
/// view, chosen over the whole sphere. At `--probe 1`, 1.7 points more culling on the bunny
/// than [`FoldCorners::Split`] (44.4 against 42.7 %) for misses of at most 0.4 pixels a view
/// on the zoo (BENCHMARKS.md, "The probe with the cover fold").
pub const PROBE_FOLD_CORNERS: FoldCorners = FoldCorners::Cover;
/// `--conservative`'s probe pass shrinks each view's occluders by this many pixels
/// (`sampler/tiled/probe.rs`). 0 catches sub-pixel parts only; more also the parts about to
/// come out from behind an edge. With [`CONSERVATIVE_LEVEL`]'s centroid finer views every zoo
/// model keeps ≥ 99 % of its views identical at 1 pixel; at level 4, with the edge midpoints
/// for finer views, the exposed engine needed 2 (97.3 % identical at 0, 98.7 % at 1 and
/// 99.3 % at 2; BENCHMARKS.md, "Quality on the model zoo").
pub const CONSERVATIVE_PROBE_PIXELS: u32 = 1;
/// The default bake's probe pass shrinks occluders by this many pixels. With the cover fold,
/// every zoo model misses at most 0.4 pixels a view on average at 1× and 2× the resolution
/// (p99 ≤ 2), the bunny culls 45.3 % (45.4 % without the probe), and the bunny's bake takes
/// 0.99× the filing-day default's time with `--shells 0`; at 0 pixels the exposed engine
/// misses 2.1 pixels a view at 2× (BENCHMARKS.md, "The probe with the cover fold").
pub const DEFAULT_PROBE_PIXELS: u32 = 1;

/// Smallest `--resolution`: coarser ID buffers miss nearly every patch. Measured on the
/// bunny in 1,000 patches at level 2: a view sees 43.8 % of the patches at 256 px, 40.9 % at
/// 128, 34.8 % at 64, 21.9 % at 32, 7.1 % at 16, 1.8 % at 8 and 0.1 % at 1 px. 16 px is the
/// smallest the test suite's quickest bakes use.
pub const MIN_RESOLUTION: u32 = 16;

/// Below this sampled resolution a bake warns ([`Recipe::resolution_warning`]): it keeps less
/// than half of the visible patches on the bunny (see [`MIN_RESOLUTION`]).
pub const WARN_RESOLUTION: u32 = 32;

/// The probe pass of a bake (`--probe`, `sampler/tiled/probe.rs`): after each view, the patches
/// it did not show are drawn again, conservatively, against its occluders shrunk by some
/// pixels, and added where they may show to a camera near the view.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Probe {
    /// [`DEFAULT_PROBE_PIXELS`] over every view, the sampling sphere's and the shells', each
    /// view's cell at its own sphere's distance, with the cover fold, on the CPU backend for
    /// meshes of up to [`crate::memory::DEFAULT_PROBE_MAX_TRIANGLES`] triangles whose solids
    /// fit the budget, else off ([`Recipe::for_mesh`]); [`CONSERVATIVE_PROBE_PIXELS`] with
    /// `--conservative`.
    #[default]
    Default,
    /// No probe pass (`--probe off`): what each view shows, and nothing more.
    Off,
    /// Occluders shrunk by this many pixels (`--probe PX`), on any mesh the budget holds.
    Pixels(u32),
}

/// How the patches of the file are numbered (`--patch-order`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PatchOrder {
    /// Patches seen from the same views get neighbouring ids, which makes the visibility
    /// payload smaller (`format::covisibility_order`).
    #[default]
    Covisibility,
    /// The tiling's Z-order ids, the same for every bake of a mesh at a patch count.
    Spatial,
}

/// What to bake and how: every option `patchvis bake` has, as plain values. `Default` is the
/// command's default bake; [`BakeSettings::check`] validates and resolves them.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeSettings {
    /// Patches to tile into (`--patches`); fewer when the mesh has fewer triangles.
    pub patches: u32,
    /// Sphere level of the stored views (`--level`).
    pub level: u32,
    /// ID-buffer side in pixels (`--resolution`).
    pub resolution: u32,
    /// Field of view in degrees (`--fov`).
    pub fov_deg: f32,
    /// A patch counts only where it covers at least this many pixels (`--min-pixels`).
    pub min_pixels: u32,
    /// Also mark facing edge neighbours of seen patches (`--dilate`).
    pub dilate: bool,
    /// Patches never culled, in the tiling's spatial numbering (`--always-visible`).
    pub always_visible: Vec<PatchId>,
    /// The probe pass over every sphere of views, with occluders shrunk by
    /// [`CONSERVATIVE_PROBE_PIXELS`], the split fold, the stored faces' centroids for finer
    /// views (unless `finer_views` says otherwise) and shells at most at [`DEFAULT_LEVEL`]
    /// (`--conservative`). Meant for [`CONSERVATIVE_LEVEL`], which
    /// [`BakeSettings::conservative`] sets and `--conservative` defaults to.
    pub conservative: bool,
    /// The probe pass (`--probe`): the default's, off, or with occluders shrunk by a number of
    /// pixels; only the default with `conservative`.
    pub probe: Probe,
    /// A triangle marks every pixel it touches (`--conservative-raster`).
    pub conservative_raster: bool,
    /// Extra sphere levels sampled and folded into the stored ones (`--view-supersample`);
    /// `None`: [`DEFAULT_VIEW_SUPERSAMPLE`], capped at the finest level.
    pub view_supersample: Option<u32>,
    /// Pixel threshold of the folded finer views (`--fold-min-pixels`); `None`:
    /// [`DEFAULT_FOLD_MIN_PIXELS`].
    pub fold_min_pixels: Option<u32>,
    /// Which stored views receive a finer view's patches (`--fold-corners`); `None`:
    /// [`DEFAULT_FOLD_CORNERS`].
    pub fold_corners: Option<FoldCorners>,
    /// Where the sampling sphere's finer views lie (`--finer-views`): the finer level's
    /// vertices, or, with one finer level, the centroids of the stored faces
    /// (`sampler::FinerViews`); `None`: the centroids with `conservative` and one finer level,
    /// else the vertices. The shells' finer views are always the vertices.
    pub finer_views: Option<FinerViews>,
    /// Patch numbering (`--patch-order`).
    pub patch_order: PatchOrder,
    /// VISB encoding (`--encoding`).
    pub encoding: VisibilityEncoding,
    /// Tiling algorithm (`--tiling`).
    pub tiling: TilingMode,
    /// Heap budget (`--memory`).
    pub memory: MemoryBudget,
    /// Checkpoints are written next to this path (the output file's), one per sampling pass,
    /// after every sphere level; `None` writes none.
    pub checkpoint: Option<PathBuf>,
    /// Continue from the checkpoints (`--resume`).
    pub resume: bool,
    /// Sampling shells of near views inside the sampling sphere (`--shells`, `shells.rs`);
    /// 0: none, a version-4 file.
    pub shells: u32,
    /// The innermost shell's radius over the bounding radius (`--shell-min`), above 1 and
    /// below the sampling distance's.
    pub shell_min: f64,
    /// Sphere level of the shells' views (`--shell-level`); `None`: the stored level.
    pub shell_level: Option<u32>,
    /// Each view of the sampling sphere is also rendered from far out, so that its rows hold
    /// what cameras farther than the sampling distance see (`--far-views`,
    /// `sampler::SamplingOptions::far_view`).
    pub far_views: bool,
    /// Store each view's row as sampled and folded (`--sampled-rows`); by default a bake also
    /// sets every bit that no query's answer depends on (`sampler::saturate`).
    pub sampled_rows: bool,
}

impl Default for BakeSettings {
    fn default() -> BakeSettings {
        BakeSettings {
            patches: 1000,
            level: DEFAULT_LEVEL,
            resolution: 512,
            fov_deg: 45.0,
            min_pixels: 0,
            dilate: false,
            always_visible: Vec::new(),
            conservative: false,
            probe: Probe::Default,
            conservative_raster: false,
            view_supersample: None,
            fold_min_pixels: None,
            fold_corners: None,
            finer_views: None,
            patch_order: PatchOrder::default(),
            encoding: VisibilityEncoding::Tree,
            tiling: TilingMode::Auto,
            memory: MemoryBudget::default(),
            checkpoint: None,
            resume: false,
            shells: DEFAULT_SHELLS,
            shell_min: DEFAULT_SHELL_MIN,
            shell_level: None,
            far_views: false,
            sampled_rows: false,
        }
    }
}

/// A setting out of range; the message names the option as `patchvis bake` spells it.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct SettingsError(pub String);

/// The checkpoint files of one sphere's sampling passes (the sampling sphere's or a shell's).
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

/// How the stored views are supersampled, resolved.
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

impl BakeSettings {
    /// `--conservative`'s settings: [`BakeSettings::default`] with `conservative` and
    /// [`CONSERVATIVE_LEVEL`].
    pub fn conservative() -> BakeSettings {
        BakeSettings {
            conservative: true,
            level: CONSERVATIVE_LEVEL,
            ..BakeSettings::default()
        }
    }

    /// The shells' stored level: `shell_level`, else the stored level, with `conservative`
    /// at most [`DEFAULT_LEVEL`] (each near view renders several frustums, and the shells'
    /// figures were measured at that level).
    pub fn shell_level_or_default(&self) -> u32 {
        self.shell_level.unwrap_or(if self.conservative {
            self.level.min(DEFAULT_LEVEL)
        } else {
            self.level
        })
    }

    /// The probe pass's occluder shrink in pixels, `None` for none: `--probe`'s,
    /// [`CONSERVATIVE_PROBE_PIXELS`] with `--conservative`, else [`DEFAULT_PROBE_PIXELS`]
    /// (which [`Recipe::for_mesh`] may turn off).
    pub fn probe(&self) -> Option<u32> {
        match self.probe {
            Probe::Off => None,
            Probe::Pixels(pixels) => Some(pixels),
            Probe::Default if self.conservative => Some(CONSERVATIVE_PROBE_PIXELS),
            Probe::Default => Some(DEFAULT_PROBE_PIXELS),
        }
    }

    /// Checks every value and resolves the defaults.
    pub fn check(self) -> Result<Recipe, SettingsError> {
        let fail = |message: String| Err(SettingsError(message));
        if self.patches == 0 {
            return fail("--patches 0: expected at least 1 patch".into());
        }
        if self.level > MAX_LEVEL {
            return fail(format!(
                "--level {}: expected a sphere level from 0 to {MAX_LEVEL} ({} views at most)",
                self.level,
                view_count(MAX_LEVEL)
            ));
        }
        if self.resolution < MIN_RESOLUTION {
            return fail(format!(
                "--resolution {}: below the minimum of {MIN_RESOLUTION} pixels, where ID buffers \
                 miss nearly every patch; use {MIN_RESOLUTION} to {MAX_RESOLUTION}",
                self.resolution
            ));
        }
        if self.resolution > MAX_RESOLUTION {
            return fail(format!(
                "--resolution {}: expected {MIN_RESOLUTION} to {MAX_RESOLUTION} pixels",
                self.resolution
            ));
        }
        if !(self.fov_deg.is_finite() && self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return fail(format!(
                "--fov {}: expected degrees between 0 and 180, exclusive",
                self.fov_deg
            ));
        }
        // The level was checked above, so the subtraction cannot underflow.
        let extra_levels = self
            .view_supersample
            .unwrap_or(DEFAULT_VIEW_SUPERSAMPLE.min(MAX_LEVEL - self.level));
        if extra_levels > MAX_VIEW_SUPERSAMPLE || self.level + extra_levels > MAX_LEVEL {
            return fail(format!(
                "--view-supersample {extra_levels}: expected 0 to {MAX_VIEW_SUPERSAMPLE} with --level + K at most {MAX_LEVEL} (--level is {})",
                self.level
            ));
        }
        if self.conservative && self.probe != Probe::Default {
            return fail(
                "--probe with --conservative: expected one of them (--conservative is the probe \
                 pass at 1 pixel with the split fold and centroid finer views)"
                    .into(),
            );
        }
        let probe = self.probe();
        let fold_min_pixels = self.fold_min_pixels.unwrap_or(DEFAULT_FOLD_MIN_PIXELS);
        // A threshold at or below the stored views' own changes nothing.
        let threshold = fold_min_pixels > self.min_pixels.max(1);
        let fold_corners = self
            .fold_corners
            .unwrap_or(if self.conservative && !threshold {
                CONSERVATIVE_FOLD_CORNERS
            } else if probe.is_some() {
                PROBE_FOLD_CORNERS
            } else {
                DEFAULT_FOLD_CORNERS
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
        let resolve = |extra_levels: u32| {
            // Without one, no extra plain pass.
            let thresholded = extra_levels > 0 && threshold;
            Supersample {
                extra_levels,
                fold_min_pixels: if thresholded { fold_min_pixels } else { 0 },
                fold_corners,
                finer: FinerViews::Midpoints,
            }
        };
        let finer_views = self
            .finer_views
            .unwrap_or(if self.conservative && extra_levels == 1 {
                FinerViews::Centroids
            } else {
                FinerViews::Midpoints
            });
        if finer_views == FinerViews::Centroids && extra_levels != 1 {
            return fail(format!(
                "--finer-views centroids with --view-supersample {extra_levels}: expected one \
                 finer level (the centroids of the stored faces)"
            ));
        }
        let supersample = Supersample {
            finer: finer_views,
            ..resolve(extra_levels)
        };
        if self.shells > MAX_SHELLS {
            return fail(format!(
                "--shells {}: expected 0 (no near views) to {MAX_SHELLS}",
                self.shells
            ));
        }
        // D / R of the sampling sphere; the radii themselves are checked with the mesh
        // (`shells::shell_distances`).
        let outer_ratio = 1.0 / (f64::from(self.fov_deg).to_radians() * 0.5).sin();
        if !(self.shell_min.is_finite() && self.shell_min > 1.0 && self.shell_min < outer_ratio) {
            return fail(format!(
                "--shell-min {}: expected the innermost shell's radius over the bounding \
                 radius, above 1 and below {outer_ratio:.3} (the sampling distance's at --fov {})",
                self.shell_min, self.fov_deg
            ));
        }
        if let Some(level) = self.shell_level.filter(|&l| l > MAX_LEVEL) {
            return fail(format!(
                "--shell-level {level}: expected a sphere level from 0 to {MAX_LEVEL}"
            ));
        }
        // The shells' supersampling is the stored level's, capped at the finest level.
        let shell_level = self.shell_level_or_default();
        // Split needs the probe's rows: asking for it makes the probe a must.
        let default_probe = self.probe == Probe::Default
            && !self.conservative
            && fold_corners != FoldCorners::Split;
        // The shells probe and fold as the sampling sphere does (the default's cells at each
        // pass's own distance: `Recipe::sampling_options`).
        let shell_probe = probe;
        let shell_supersample = Supersample {
            fold_corners,
            ..resolve(extra_levels.min(MAX_LEVEL - shell_level))
        };
        // Checkpoints are named after what was asked for: the default's probe, on or off
        // (`Recipe::for_mesh`), names none (their hash tells the rows apart).
        let named_probe = if default_probe { None } else { probe };
        let main = self.pass_checkpoints("", supersample, named_probe);
        Ok(Recipe {
            probe,
            shell_probe,
            default_probe,
            supersample,
            shell_supersample,
            coarse_checkpoint: main.coarse,
            fine_checkpoint: main.fine,
            shell_checkpoints: (1..=self.shells)
                .map(|s| {
                    self.pass_checkpoints(&format!(".shell{s}"), shell_supersample, named_probe)
                })
                .collect(),
            settings: self,
        })
    }

    /// The checkpoints of one sphere's passes, named `OUT.pvis` + `prefix` (the shell) + what
    /// decides the rows + `.ckpt`. The supersampled bake samples other rows than a plain one:
    /// its own checkpoint, so that resuming finds the right one and a plain bake's checkpoint
    /// stays usable. The plain pass of a thresholded fold samples exactly what a plain bake
    /// does: it shares a plain bake's checkpoint.
    fn pass_checkpoints(
        &self,
        prefix: &str,
        supersample: Supersample,
        probe: Option<u32>,
    ) -> PassCheckpoints {
        let checkpoint_with = |suffix: String| {
            self.checkpoint.as_ref().map(|base| {
                let mut path = base.clone().into_os_string();
                path.push(suffix);
                PathBuf::from(path)
            })
        };
        // Far views render the sampling sphere's views only, not the shells'.
        let far = self.far_views && prefix.is_empty();
        let plain = format!(
            "{prefix}{}{}",
            probe.map(|r| format!(".p{r}")).unwrap_or_default(),
            if far { ".far" } else { "" }
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
            coarse: thresholded
                .then(|| checkpoint_with(plain + ".ckpt"))
                .flatten(),
            fine: checkpoint_with(suffix + ".ckpt"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(f: impl FnOnce(&mut BakeSettings)) -> Result<Recipe, SettingsError> {
        let mut s = BakeSettings {
            checkpoint: Some("out.pvis".into()),
            ..BakeSettings::default()
        };
        f(&mut s);
        s.check()
    }

    #[test]
    fn supersampling_defaults_follow_the_level_and_conservative() {
        let c = check(|_| {}).unwrap();
        assert_eq!(
            (c.supersample, c.resolution()),
            (
                Supersample {
                    extra_levels: DEFAULT_VIEW_SUPERSAMPLE,
                    fold_min_pixels: 0,
                    fold_corners: FoldCorners::Cover,
                    finer: FinerViews::Midpoints,
                },
                512
            )
        );
        // The probe pass at 1 pixel, and the cover fold.
        assert_eq!(c.probe(), Some(DEFAULT_PROBE_PIXELS));
        // One pass: the finer views' rows hold the stored ones as their prefix.
        assert_eq!(c.fine_checkpoint, Some("out.pvis.vs1.ckpt".into()));
        assert_eq!(c.coarse_checkpoint, None);
        // A threshold samples the stored level plainly once more, with a checkpoint of its
        // own, and the finer pass's checkpoint names the threshold.
        let c = check(|s| s.fold_min_pixels = Some(4)).unwrap();
        assert_eq!(c.supersample.fold_min_pixels, 4);
        assert_eq!(c.fine_checkpoint, Some("out.pvis.vs1.m4.ckpt".into()));
        assert_eq!(c.coarse_checkpoint, Some("out.pvis.ckpt".into()));
        // The finest level has nothing finer to sample: the default turns itself off there,
        // while asking for it explicitly is an error.
        let c = check(|s| s.level = 7).unwrap();
        assert_eq!(
            (c.supersample.extra_levels, c.supersample.fold_min_pixels),
            (0, 0)
        );
        assert_eq!(c.fine_checkpoint, Some("out.pvis.ckpt".into()));
        let err = check(|s| {
            s.level = 7;
            s.view_supersample = Some(1)
        })
        .unwrap_err();
        assert!(err.0.contains("--view-supersample 1"), "{}", err.0);
        let c = check(|s| {
            s.conservative = true;
            s.level = CONSERVATIVE_LEVEL
        })
        .unwrap();
        assert_eq!(
            (
                c.supersample.extra_levels,
                c.supersample.fold_min_pixels,
                c.resolution()
            ),
            (DEFAULT_VIEW_SUPERSAMPLE, 0, 512)
        );
        assert_eq!(c.probe(), Some(CONSERVATIVE_PROBE_PIXELS));
        // The centroids of the stored faces for finer views, and the split fold: the finer
        // pass keeps its seen rows, in a checkpoint of its own.
        assert_eq!(c.supersample.finer, FinerViews::Centroids);
        let suffix = format!(".p{CONSERVATIVE_PROBE_PIXELS}.vs1.centroids.split.ckpt");
        assert_eq!(c.fine_checkpoint, Some(format!("out.pvis{suffix}").into()));
        assert!(!c.settings.conservative_raster);
        assert_eq!(c.supersample.fold_corners, FoldCorners::Split);
        assert_eq!(c.pass_levels()[..2], [6, 6]);
        // The shells stay at the default level, with the vertices for finer views.
        assert_eq!(c.shell_level(), DEFAULT_LEVEL);
        assert_eq!(c.shell_supersample.finer, FinerViews::Midpoints);
        assert_eq!(
            c.settings,
            BakeSettings {
                checkpoint: Some("out.pvis".into()),
                ..BakeSettings::conservative()
            }
        );
        // Finer views asked for, and a level with no finer one, keep the vertices.
        let asked = check(|s| {
            s.conservative = true;
            s.finer_views = Some(FinerViews::Midpoints)
        })
        .unwrap();
        assert_eq!(asked.supersample.finer, FinerViews::Midpoints);
        let finest = check(|s| {
            s.conservative = true;
            s.level = MAX_LEVEL
        })
        .unwrap();
        assert_eq!(
            (finest.supersample.extra_levels, finest.supersample.finer),
            (0, FinerViews::Midpoints)
        );
        // Asked for without the probe, or with a fold threshold: refused.
        let err = check(|s| {
            s.probe = Probe::Off;
            s.fold_corners = Some(FoldCorners::Split)
        })
        .unwrap_err();
        assert!(
            err.0.contains("expected --conservative or --probe"),
            "{}",
            err.0
        );
        let err = check(|s| {
            s.conservative = true;
            s.fold_min_pixels = Some(4);
            s.fold_corners = Some(FoldCorners::Split)
        })
        .unwrap_err();
        assert!(err.0.contains("no fold threshold"), "{}", err.0);
        let c = check(|s| s.probe = Probe::Off).unwrap();
        assert_eq!(
            (c.probe(), c.supersample.fold_corners),
            (None, DEFAULT_FOLD_CORNERS)
        );
        // Named as the default's: neither names its probe.
        assert_eq!(c.fine_checkpoint, Some("out.pvis.vs1.ckpt".into()));
        // --probe: the probe pass alone, with the cover fold and one pass; not with
        // --conservative, and the split fold is its own to ask for.
        let c = check(|s| s.probe = Probe::Pixels(1)).unwrap();
        assert_eq!(c.probe(), Some(1));
        assert_eq!(c.supersample.fold_corners, FoldCorners::Cover);
        assert_eq!(c.pass_levels(), check(|_| {}).unwrap().pass_levels());
        assert_eq!(c.fine_checkpoint, Some("out.pvis.p1.vs1.ckpt".into()));
        let err = check(|s| {
            s.probe = Probe::Pixels(1);
            s.conservative = true
        })
        .unwrap_err();
        assert!(err.0.contains("--probe with --conservative"), "{}", err.0);
        let c = check(|s| {
            s.probe = Probe::Pixels(0);
            s.fold_corners = Some(FoldCorners::Split)
        })
        .unwrap();
        assert_eq!(
            (c.probe(), c.pass_levels()[..2].to_vec()),
            (Some(0), vec![5, 5])
        );
        // A threshold at or below --min-pixels changes nothing: no extra plain pass.
        let c = check(|s| {
            s.min_pixels = 4;
            s.fold_min_pixels = Some(4)
        })
        .unwrap();
        assert_eq!(
            (c.supersample.fold_min_pixels, c.coarse_checkpoint),
            (0, None)
        );
        let c = check(|s| {
            s.view_supersample = Some(0);
            s.fold_min_pixels = Some(9)
        })
        .unwrap();
        assert_eq!(
            (c.supersample.extra_levels, c.supersample.fold_min_pixels),
            (0, 0)
        );
    }

    #[test]
    fn out_of_range_values_are_refused_with_the_option_named() {
        for (f, flag) in [
            (
                &(|s: &mut BakeSettings| s.patches = 0) as &dyn Fn(&mut BakeSettings),
                "--patches",
            ),
            (&|s: &mut BakeSettings| s.level = MAX_LEVEL + 1, "--level"),
            (&|s: &mut BakeSettings| s.resolution = 0, "--resolution"),
            (&|s: &mut BakeSettings| s.resolution = 1, "--resolution"),
            (
                &|s: &mut BakeSettings| s.resolution = MIN_RESOLUTION - 1,
                "--resolution",
            ),
            (
                &|s: &mut BakeSettings| s.resolution = MAX_RESOLUTION + 1,
                "--resolution",
            ),
            (&|s: &mut BakeSettings| s.fov_deg = 180.0, "--fov"),
            (&|s: &mut BakeSettings| s.fov_deg = f32::NAN, "--fov"),
            (
                &|s: &mut BakeSettings| s.view_supersample = Some(3),
                "--view-supersample",
            ),
            (
                &|s: &mut BakeSettings| s.shells = MAX_SHELLS + 1,
                "--shells",
            ),
            (&|s: &mut BakeSettings| s.shell_min = 1.0, "--shell-min"),
            (
                &|s: &mut BakeSettings| s.shell_min = f64::NAN,
                "--shell-min",
            ),
            // The sampling distance is 2.61 radii at 45°, 1 at 180°.
            (&|s: &mut BakeSettings| s.shell_min = 2.62, "--shell-min"),
            (
                &|s: &mut BakeSettings| {
                    s.fov_deg = 120.0;
                    s.shell_min = 1.2
                },
                "--shell-min",
            ),
            (
                &|s: &mut BakeSettings| s.shell_level = Some(MAX_LEVEL + 1),
                "--shell-level",
            ),
        ] {
            let err = check(|s| f(s)).unwrap_err();
            assert!(err.0.starts_with(flag), "{flag}: {}", err.0);
        }
    }

    #[test]
    fn centroid_finer_views_need_one_finer_level_and_leave_the_shells_alone() {
        let c = check(|s| {
            s.finer_views = Some(FinerViews::Centroids);
            s.shells = 1
        })
        .unwrap();
        assert_eq!(c.supersample.finer, FinerViews::Centroids);
        assert_eq!(c.shell_supersample.finer, FinerViews::Midpoints);
        assert_eq!(
            c.fine_checkpoint,
            Some("out.pvis.vs1.centroids.ckpt".into())
        );
        for k in [0, 2] {
            let err = check(|s| {
                s.finer_views = Some(FinerViews::Centroids);
                s.view_supersample = Some(k)
            })
            .unwrap_err();
            assert!(
                err.0.contains(&format!(
                    "--finer-views centroids with --view-supersample {k}"
                )),
                "{}",
                err.0
            );
        }
        // At the finest level there is no finer one.
        assert!(
            check(|s| {
                s.finer_views = Some(FinerViews::Centroids);
                s.level = MAX_LEVEL
            })
            .is_err()
        );
    }

    #[test]
    fn every_shell_has_checkpoints_of_its_own_and_the_stored_levels_fold() {
        let c = check(|_| {}).unwrap();
        // The default's probe and cover fold run on the shells too.
        assert_eq!(c.shell_supersample, c.supersample);
        assert_eq!(c.shell_supersample.fold_corners, PROBE_FOLD_CORNERS);
        assert_eq!(
            (c.probe(), c.shell_probe()),
            (Some(DEFAULT_PROBE_PIXELS), Some(DEFAULT_PROBE_PIXELS))
        );
        let asked = check(|s| s.probe = Probe::Pixels(1)).unwrap();
        assert_eq!(asked.shell_supersample, asked.supersample);
        assert_eq!(asked.shell_probe(), Some(1));
        assert_eq!(c.shell_level(), 4);
        assert_eq!(
            c.shell_checkpoints,
            (1..=DEFAULT_SHELLS)
                .map(|s| PassCheckpoints {
                    coarse: None,
                    fine: Some(format!("out.pvis.shell{s}.vs1.ckpt").into()),
                })
                .collect::<Vec<_>>()
        );
        assert_eq!(c.checkpoints().count(), 1 + DEFAULT_SHELLS as usize);
        // A thresholded fold: two passes per shell, each with a checkpoint.
        let c = check(|s| {
            s.fold_min_pixels = Some(4);
            s.conservative = true;
            s.shells = 1
        })
        .unwrap();
        assert_eq!(
            c.shell_checkpoints,
            vec![PassCheckpoints {
                coarse: Some("out.pvis.shell1.p1.ckpt".into()),
                fine: Some("out.pvis.shell1.p1.vs1.m4.ckpt".into()),
            }]
        );
        assert_eq!(c.pass_levels(), vec![4, 5, 4, 5]);
        // The shells' own level, its supersampling capped at the finest level.
        let c = check(|s| s.shell_level = Some(MAX_LEVEL)).unwrap();
        assert_eq!(c.shell_level(), MAX_LEVEL);
        assert_eq!(c.shell_supersample.extra_levels, 0);
        assert_eq!(
            c.shell_checkpoints[0].fine,
            Some("out.pvis.shell1.ckpt".into())
        );
        // The sampling sphere's fold level, then each shell's own.
        let mut levels = vec![5];
        levels.extend([MAX_LEVEL; DEFAULT_SHELLS as usize]);
        assert_eq!(c.pass_levels(), levels);
        // No shells: the sampling sphere's passes alone, as before.
        let c = check(|s| s.shells = 0).unwrap();
        assert!(c.shell_checkpoints.is_empty());
        assert_eq!(c.pass_levels(), vec![5]);
    }
}
