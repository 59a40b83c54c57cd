//! Every knob of a bake as the user gives it, with the defaults of `patchvis bake`.
//!
//! [`RowSettings`] is the one type for everything that decides a file's rows and its encoding:
//! the preset and each option as given (`None` where the preset or another option decides).
//! It has one codec ([`RowSettings::encode`]), which part files carry and the merge compares,
//! so that a new row option is one field here, one flag, one codec entry and its test. What the
//! values resolve to (levels, folds, probe, passes) is the bake plan's (`plan.rs`).
//! [`BakeSettings`] adds what changes how a bake runs but not what it writes: the patch
//! count asked for, the tiling algorithm, the memory budget and the checkpoints.

use super::shells::{
    DEFAULT_FAR_SHELLS, DEFAULT_SHELL_MIN, DEFAULT_SHELLS, MAX_FAR_SHELL, MAX_SHELLS,
};
use super::wire::{Fields, Put};
use super::{MemoryBudget, Plan, Recipe};
use crate::format::VisibilityEncoding;
use crate::sampler::{FinerViews, FoldCorners, MAX_RESOLUTION};
use crate::sphere::{MAX_LEVEL, view_count};
use crate::tiling::{PatchId, TilingMode};
use std::path::PathBuf;
use xxhash_rust::xxh64::xxh64;

/// `--level` unless given: 1,026 stored views.
pub const DEFAULT_LEVEL: u32 = 4;
/// `--level` unless given, with `--conservative` ([`Preset::Conservative`]): sphere faces
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
/// `--fold-corners` unless given, without a probe pass (`--probe off`, or the default's
/// probe turned off for a mesh): every stored view around a finer view (the corners the faces
/// holding it share), so that a query anywhere in a face sees every finer sample of it from
/// each corner's side, not one.
pub const UNPROBED_FOLD_CORNERS: FoldCorners = FoldCorners::All;
/// `--fold-corners` unless given, with `--conservative`: the probe's additions go to one
/// corner, what the views showed to all of them. 2.3–3.3 points more culling on the model
/// zoo than [`FoldCorners::All`], every model still ≥ 99 % identical (BENCHMARKS.md,
/// "Quality on the model zoo").
pub const CONSERVATIVE_FOLD_CORNERS: FoldCorners = FoldCorners::Split;
/// `--fold-corners` unless given, with a probe pass (the default's, or `--probe`): one stored
/// view per face holding the finer view, chosen over the whole sphere. At `--probe 1`, 1.7
/// points more culling on the bunny than [`FoldCorners::Split`] (44.4 against 42.7 %) for
/// misses of at most 0.4 pixels a view on the zoo (BENCHMARKS.md, "The probe with the cover
/// fold").
pub const PROBE_FOLD_CORNERS: FoldCorners = FoldCorners::Cover;
/// `--conservative`'s probe pass shrinks each view's occluders by this many pixels
/// (`sampler/tiled/probe.rs`). 0 catches sub-pixel parts only; more also the parts about to
/// come out from behind an edge. With [`CONSERVATIVE_LEVEL`]'s centroid finer views every zoo
/// model keeps ≥ 99 % of its views identical at 1 pixel; at level 4, with the edge midpoints
/// for finer views, the exposed engine needed 2 (97.3 % identical at 0, 98.7 % at 1 and
/// 99.3 % at 2; BENCHMARKS.md, "Quality on the model zoo").
pub const CONSERVATIVE_PROBE_PIXELS: u32 = 1;
/// The largest `--apertures PX`: past it nearly every rim of an assembly is a gap (at 2 the
/// cycloidal drive already culls 13–25 points less with `--conservative`,
/// docs/benchmarks/far-cameras.md, "Apertures").
pub const MAX_APERTURE_PIXELS: u32 = 16;
/// The default bake's probe pass shrinks occluders by this many pixels. With the cover fold,
/// every zoo model misses at most 0.4 pixels a view on average at 1× and 2× the resolution
/// (p99 ≤ 2), the bunny culls 45.3 % (45.4 % without the probe); at 0 pixels the exposed
/// engine misses 2.1 pixels a view at 2× (BENCHMARKS.md, "The probe with the cover fold").
pub const DEFAULT_PROBE_PIXELS: u32 = 1;

/// The largest `--probe PX`: occluders shrunk further than this hide nothing near an edge
/// (the default and `--conservative` shrink by 1). The command line and the Python package
/// refuse larger values.
pub const MAX_PROBE_PIXELS: u32 = 16;

/// Smallest `--resolution`: coarser ID buffers miss nearly every patch. Measured on the
/// bunny in 1,000 patches at level 2: a view sees 43.8 % of the patches at 256 px, 40.9 % at
/// 128, 34.8 % at 64, 21.9 % at 32, 7.1 % at 16, 1.8 % at 8 and 0.1 % at 1 px. 16 px is the
/// smallest the test suite's quickest bakes use.
pub const MIN_RESOLUTION: u32 = 16;

/// Below this sampled resolution a bake warns ([`Recipe::resolution_warning`]): it keeps less
/// than half of the visible patches on the bunny (see [`MIN_RESOLUTION`]).
pub const WARN_RESOLUTION: u32 = 32;

/// A named set of defaults for the options left unset (`plan.rs` expands it, in one place).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Preset {
    /// `patchvis bake`: level [`DEFAULT_LEVEL`], one finer level folded with the cover fold,
    /// the probe pass at [`DEFAULT_PROBE_PIXELS`] where the mesh allows it.
    #[default]
    Default,
    /// `patchvis bake --conservative`: level [`CONSERVATIVE_LEVEL`], the stored faces'
    /// centroids for finer views, the probe pass at [`CONSERVATIVE_PROBE_PIXELS`] with the
    /// split fold, shells at most at [`DEFAULT_LEVEL`]. Never turned off for a mesh.
    Conservative,
}

/// The probe pass of a bake (`--probe`, `sampler/tiled/probe.rs`): after each view, the patches
/// it did not show are drawn again, conservatively, against its occluders shrunk by some
/// pixels, and added where they may show to a camera near the view.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Probe {
    /// The preset's: [`DEFAULT_PROBE_PIXELS`] over every sphere of views, each view's cell at
    /// its own sphere's distance, with the cover fold, on the CPU backend for meshes of up to
    /// [`crate::memory::DEFAULT_PROBE_MAX_TRIANGLES`] triangles whose solids fit the budget,
    /// else off ([`Plan::for_mesh`]); [`CONSERVATIVE_PROBE_PIXELS`] with `--conservative`.
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

/// Everything that decides a file's rows and its encoding, as given (module documentation).
/// `Default` is the command's default bake.
#[derive(Clone, Debug, PartialEq)]
pub struct RowSettings {
    /// The defaults of the options left `None` (`--conservative`).
    pub preset: Preset,
    /// Sphere level of the stored views (`--level`); `None`: the preset's.
    pub level: Option<u32>,
    /// ID-buffer side in pixels (`--resolution`).
    pub resolution: u32,
    /// Field of view in degrees (`--fov`).
    pub fov_deg: f32,
    /// Sampling shells of near views inside the sampling sphere (`--shells`, `shells.rs`);
    /// 0: none, a version-4 file.
    pub shells: u32,
    /// The innermost shell's radius over the bounding radius (`--shell-min`), above 1 and
    /// below the sampling distance's.
    pub shell_min: f64,
    /// Sphere level of the shells' views (`--shell-level`); `None`: the preset's.
    pub shell_level: Option<u32>,
    /// ID-buffer side of the shells' views (`--shell-resolution`), at most `resolution`;
    /// `None`: `resolution`.
    pub shell_resolution: Option<u32>,
    /// The far band's shells beyond the sampling sphere (`--far-shells`, `shells.rs`), as
    /// multiples of the sampling distance, increasing; empty: none.
    pub far_shells: Vec<f64>,
    /// Patches never culled, in the tiling's spatial numbering (`--always-visible`).
    pub always_visible: Vec<PatchId>,
    /// Patch numbering (`--patch-order`).
    pub patch_order: PatchOrder,
    /// VISB encoding (`--encoding`).
    pub encoding: VisibilityEncoding,
    /// The options for studying the sampling (`docs/sampling-options.md`).
    pub research: Research,
}

/// The sampling's research options: each changes the rows, none is needed for a good bake,
/// and each one's measured effect is in `docs/sampling-options.md`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Research {
    /// A patch counts only where it covers at least this many pixels (`--min-pixels`).
    pub min_pixels: u32,
    /// Also mark facing edge neighbours of seen patches (`--dilate`).
    pub dilate: bool,
    /// The probe pass (`--probe`).
    pub probe: Probe,
    /// The widest gap the probe opens as an aperture, in pixels (`--apertures`); `None`: none.
    pub apertures: Option<u32>,
    /// A triangle marks every pixel it touches (`--conservative-raster`).
    pub conservative_raster: bool,
    /// Extra sphere levels sampled and folded into the stored ones (`--view-supersample`);
    /// `None`: [`DEFAULT_VIEW_SUPERSAMPLE`], capped at the finest level.
    pub view_supersample: Option<u32>,
    /// Pixel threshold of the folded finer views (`--fold-min-pixels`); `None`:
    /// [`DEFAULT_FOLD_MIN_PIXELS`].
    pub fold_min_pixels: Option<u32>,
    /// Which stored views receive a finer view's patches (`--fold-corners`); `None`: the
    /// preset's and the probe's.
    pub fold_corners: Option<FoldCorners>,
    /// Where the sampling sphere's finer views lie (`--finer-views`); `None`: the preset's.
    /// The shells' finer views are always the vertices.
    pub finer_views: Option<FinerViews>,
    /// Store each view's row as sampled and folded (`--sampled-rows`); by default a bake also
    /// sets every bit that no query's answer depends on (`sampler::saturate`).
    pub sampled_rows: bool,
}

impl Default for RowSettings {
    fn default() -> RowSettings {
        RowSettings {
            preset: Preset::Default,
            level: None,
            resolution: 512,
            fov_deg: 45.0,
            shells: DEFAULT_SHELLS,
            shell_min: DEFAULT_SHELL_MIN,
            shell_level: None,
            shell_resolution: None,
            far_shells: DEFAULT_FAR_SHELLS.to_vec(),
            always_visible: Vec::new(),
            patch_order: PatchOrder::default(),
            encoding: VisibilityEncoding::Tree,
            research: Research::default(),
        }
    }
}

/// What to bake and how: every option `patchvis bake` has, as plain values. `Default` is the
/// command's default bake; [`BakeSettings::check`] validates them and plans the bake.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeSettings {
    /// What decides the rows and the encoding.
    pub rows: RowSettings,
    /// Patches to tile into (`--patches`); fewer when the mesh has fewer triangles.
    pub patches: u32,
    /// Tiling algorithm (`--tiling`).
    pub tiling: TilingMode,
    /// Heap budget (`--memory`).
    pub memory: MemoryBudget,
    /// Checkpoints are written next to this path (the output file's), one per sampling pass,
    /// after every sphere level; `None` writes none.
    pub checkpoint: Option<PathBuf>,
    /// Continue from the checkpoints (`--resume`).
    pub resume: bool,
}

impl Default for BakeSettings {
    fn default() -> BakeSettings {
        BakeSettings {
            rows: RowSettings::default(),
            patches: 1000,
            tiling: TilingMode::Auto,
            memory: MemoryBudget::default(),
            checkpoint: None,
            resume: false,
        }
    }
}

/// A setting out of range; the message names the option as `patchvis bake` spells it.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct SettingsError(pub String);

impl BakeSettings {
    /// `--conservative`'s settings: [`BakeSettings::default`] with [`Preset::Conservative`].
    pub fn conservative() -> BakeSettings {
        BakeSettings {
            rows: RowSettings {
                preset: Preset::Conservative,
                ..RowSettings::default()
            },
            ..BakeSettings::default()
        }
    }

    /// Checks every value and plans the bake.
    pub fn check(self) -> Result<Recipe, SettingsError> {
        if self.patches == 0 {
            return Err(SettingsError(
                "--patches 0: expected at least 1 patch".into(),
            ));
        }
        let plan = Plan::new(self.rows.clone())?;
        Ok(Recipe {
            settings: self,
            plan,
        })
    }
}

impl RowSettings {
    /// `--shell-min` against the sampling distance, which `--fov` sets: the innermost shell
    /// lies between the bounding sphere and the sampling sphere. With the default
    /// `--shell-min`, a `--fov` too wide for it is the flag to blame.
    fn check_shell_min(&self) -> Result<(), SettingsError> {
        let half = f64::from(self.fov_deg).to_radians() * 0.5;
        // D / R of the sampling sphere.
        let outer_ratio = 1.0 / half.sin();
        let min = self.shell_min;
        if min.is_finite() && min > 1.0 && min < outer_ratio {
            return Ok(());
        }
        // Enough digits that the bound shows above 1.
        let digits = ((-(outer_ratio - 1.0).log10()).ceil() + 2.0).clamp(3.0, 9.0) as usize;
        let below = format!("{outer_ratio:.digits$}");
        if min == DEFAULT_SHELL_MIN && min.is_finite() && min > 1.0 {
            // The widest field of view whose sampling sphere lies outside the default's.
            let widest = (2.0 * (1.0 / min).asin().to_degrees() * 10.0).floor() / 10.0;
            return Err(SettingsError(format!(
                "--fov {}: puts the sampling sphere {below} bounding radii from the centre, \
                 inside the innermost sampling shell (the default --shell-min {min}); use a \
                 --fov below {widest}, or --shells 0 (no near views), or a --shell-min above 1 \
                 and below {below}",
                self.fov_deg
            )));
        }
        Err(SettingsError(format!(
            "--shell-min {min}: expected the innermost shell's radius over the bounding radius, \
             above 1 and below {below} (the sampling distance's at --fov {})",
            self.fov_deg
        )))
    }

    /// Checks each value's own range (what the values resolve to is checked by
    /// [`Plan::new`]).
    pub(super) fn check_ranges(&self) -> Result<(), SettingsError> {
        let fail = |message: String| Err(SettingsError(message));
        if let Some(level) = self.level.filter(|&l| l > MAX_LEVEL) {
            return fail(format!(
                "--level {level}: expected a sphere level from 0 to {MAX_LEVEL} ({} views at most)",
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
        if let Some(px) = self
            .research
            .apertures
            .filter(|&px| px > MAX_APERTURE_PIXELS)
        {
            return fail(format!(
                "--apertures {px}: expected 0 (none) to {MAX_APERTURE_PIXELS} pixels"
            ));
        }
        if self.shells > MAX_SHELLS {
            return fail(format!(
                "--shells {}: expected 0 (no near views) to {MAX_SHELLS}",
                self.shells
            ));
        }
        // D / R of the sampling sphere; the radii themselves are checked with the mesh
        // (`shells::shell_distances`).
        if self.shells > 0 {
            self.check_shell_min()?;
        }
        let far = &self.far_shells;
        if far
            .iter()
            .any(|f| !(f.is_finite() && *f > 1.0 && *f <= MAX_FAR_SHELL))
            || far.windows(2).any(|w| w[0] >= w[1])
        {
            return fail(format!(
                "--far-shells {}: expected multiples of the sampling distance above 1 and at \
                 most {MAX_FAR_SHELL}, increasing (or none)",
                far.iter()
                    .map(|f| f.to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            ));
        }
        if self.shells as usize + far.len() > MAX_SHELLS as usize {
            return fail(format!(
                "--shells {} with {} --far-shells: expected at most {MAX_SHELLS} together (the \
                 format's limit)",
                self.shells,
                far.len()
            ));
        }
        if let Some(level) = self.shell_level.filter(|&l| l > MAX_LEVEL) {
            return fail(format!(
                "--shell-level {level}: expected a sphere level from 0 to {MAX_LEVEL}"
            ));
        }
        if let Some(px) = self
            .shell_resolution
            .filter(|&px| !(MIN_RESOLUTION..=self.resolution).contains(&px))
        {
            return fail(format!(
                "--shell-resolution {px}: expected {MIN_RESOLUTION} to --resolution ({}) pixels",
                self.resolution
            ));
        }
        Ok(())
    }

    /// The settings' bytes: what part files carry and the merge compares. Every field, in
    /// declaration order; an option `None` is 0 and a value `v` is `v + 1`.
    pub fn encode(&self) -> Vec<u8> {
        // Destructured whole: a field added to the settings does not compile here until it
        // has its entry.
        let RowSettings {
            preset,
            level,
            resolution,
            fov_deg,
            shells,
            shell_min,
            shell_level,
            shell_resolution,
            ref far_shells,
            ref always_visible,
            patch_order,
            encoding,
            research: ref r,
        } = *self;
        let Research {
            min_pixels,
            dilate,
            probe,
            apertures,
            conservative_raster,
            view_supersample,
            fold_min_pixels,
            fold_corners,
            finer_views,
            sampled_rows,
        } = *r;
        let mut b = Vec::new();
        b.put_u8(match preset {
            Preset::Default => 0,
            Preset::Conservative => 1,
        });
        put_option(&mut b, level);
        b.put_u32(resolution);
        b.put_f32(fov_deg);
        b.put_u32(shells);
        b.put_u64(shell_min.to_bits());
        put_option(&mut b, shell_level);
        put_option(&mut b, shell_resolution);
        b.put_u32(far_shells.len() as u32);
        for &f in far_shells {
            b.put_u64(f.to_bits());
        }
        b.put_u32(always_visible.len() as u32);
        for &p in always_visible {
            b.put_u32(p);
        }
        b.put_u8(match patch_order {
            PatchOrder::Covisibility => 0,
            PatchOrder::Spatial => 1,
        });
        b.put_u8(match encoding {
            VisibilityEncoding::Raw => 0,
            VisibilityEncoding::Table => 1,
            VisibilityEncoding::Tree => 2,
        });
        b.put_u32(min_pixels);
        b.put_u8(u8::from(dilate));
        b.put_u64(match probe {
            Probe::Default => 0,
            Probe::Off => 1,
            Probe::Pixels(pixels) => u64::from(pixels) + 2,
        });
        b.put_u8(u8::from(conservative_raster));
        put_option(&mut b, view_supersample);
        put_option(&mut b, fold_min_pixels);
        put_option(&mut b, fold_corners.map(fold_code));
        put_option(
            &mut b,
            finer_views.map(|f| match f {
                FinerViews::Midpoints => 0,
                FinerViews::Centroids => 1,
            }),
        );
        b.put_u8(u8::from(sampled_rows));
        put_option(&mut b, apertures);
        b
    }

    /// [`RowSettings::encode`]'s settings, or `None` where a field is cut short or not one
    /// of its values, or bytes follow. The values' ranges are [`Plan::new`]'s to check.
    pub fn decode(bytes: &[u8]) -> Option<RowSettings> {
        let mut f = Fields::new(bytes);
        let settings = RowSettings {
            preset: match f.u8()? {
                0 => Preset::Default,
                1 => Preset::Conservative,
                _ => return None,
            },
            level: option(&mut f)?,
            resolution: f.u32()?,
            fov_deg: f.f32()?,
            shells: f.u32()?,
            shell_min: f64::from_bits(f.u64()?),
            shell_level: option(&mut f)?,
            shell_resolution: option(&mut f)?,
            far_shells: {
                let n = f.u32()?;
                // Each takes 8 bytes: a count past what is left is refused before any
                // allocation.
                if u64::from(n) * 8 > (bytes.len() - f.offset()) as u64 {
                    return None;
                }
                (0..n)
                    .map(|_| f.u64().map(f64::from_bits))
                    .collect::<Option<Vec<_>>>()?
            },
            always_visible: {
                let n = f.u32()?;
                // Each id takes 4 bytes: a count past what is left is refused before any
                // allocation.
                if u64::from(n) * 4 > (bytes.len() - f.offset()) as u64 {
                    return None;
                }
                (0..n).map(|_| f.u32()).collect::<Option<Vec<_>>>()?
            },
            patch_order: match f.u8()? {
                0 => PatchOrder::Covisibility,
                1 => PatchOrder::Spatial,
                _ => return None,
            },
            encoding: match f.u8()? {
                0 => VisibilityEncoding::Raw,
                1 => VisibilityEncoding::Table,
                2 => VisibilityEncoding::Tree,
                _ => return None,
            },
            research: Research {
                min_pixels: f.u32()?,
                dilate: flag(f.u8()?)?,
                probe: match f.u64()? {
                    0 => Probe::Default,
                    1 => Probe::Off,
                    p => Probe::Pixels(u32::try_from(p - 2).ok()?),
                },
                conservative_raster: flag(f.u8()?)?,
                view_supersample: option(&mut f)?,
                fold_min_pixels: option(&mut f)?,
                fold_corners: match option(&mut f)? {
                    Some(code) => Some(fold_of(code)?),
                    None => None,
                },
                finer_views: match option(&mut f)? {
                    None => None,
                    Some(0) => Some(FinerViews::Midpoints),
                    Some(1) => Some(FinerViews::Centroids),
                    Some(_) => return None,
                },
                sampled_rows: flag(f.u8()?)?,
                apertures: option(&mut f)?,
            },
        };
        (f.offset() == bytes.len()).then_some(settings)
    }

    /// The XXH64 of [`RowSettings::encode`].
    pub fn hash(&self) -> u64 {
        xxh64(&self.encode(), 0)
    }
}

/// A fold's code in the settings' bytes.
fn fold_code(corners: FoldCorners) -> u32 {
    match corners {
        FoldCorners::All => 0,
        FoldCorners::One => 1,
        FoldCorners::Split => 2,
        FoldCorners::Cover => 3,
    }
}

/// [`fold_code`]'s fold, or `None` for no fold's code.
fn fold_of(code: u32) -> Option<FoldCorners> {
    Some(match code {
        0 => FoldCorners::All,
        1 => FoldCorners::One,
        2 => FoldCorners::Split,
        3 => FoldCorners::Cover,
        _ => return None,
    })
}

fn put_option(b: &mut Vec<u8>, value: Option<u32>) {
    b.put_u64(value.map_or(0, |v| u64::from(v) + 1));
}

/// An option [`put_option`] wrote: `Some(None)` for none, `None` when cut short or out of range.
fn option(f: &mut Fields) -> Option<Option<u32>> {
    match f.u64()? {
        0 => Some(None),
        v => u32::try_from(v - 1).ok().map(Some),
    }
}

fn flag(b: u8) -> Option<bool> {
    match b {
        0 => Some(false),
        1 => Some(true),
        _ => None,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A change of one field of the settings.
    pub(crate) type Change = fn(&mut RowSettings);

    /// A change of each field from the default, each a value a small bake takes (the merge's
    /// test bakes each one whole and in shards).
    pub(crate) fn one_change_per_field() -> Vec<(&'static str, Change)> {
        vec![
            ("preset", |s| s.preset = Preset::Conservative),
            ("level", |s| s.level = Some(2)),
            ("resolution", |s| s.resolution = 48),
            ("fov_deg", |s| s.fov_deg = 50.0),
            ("shells", |s| s.shells = 1),
            ("shell_min", |s| s.shell_min = 1.3),
            ("shell_level", |s| s.shell_level = Some(2)),
            ("shell_resolution", |s| s.shell_resolution = Some(24)),
            ("far_shells", |s| s.far_shells = vec![3.0]),
            ("always_visible", |s| s.always_visible = vec![0, 5]),
            ("patch_order", |s| s.patch_order = PatchOrder::Spatial),
            ("encoding", |s| s.encoding = VisibilityEncoding::Table),
            // A threshold needs the probe off (the probe adds back what it drops).
            ("min_pixels", |s| {
                s.research.min_pixels = 2;
                s.research.probe = Probe::Off
            }),
            ("dilate", |s| s.research.dilate = true),
            ("probe", |s| s.research.probe = Probe::Pixels(2)),
            ("conservative_raster", |s| {
                s.research.conservative_raster = true
            }),
            ("view_supersample", |s| {
                s.research.view_supersample = Some(0)
            }),
            ("fold_min_pixels", |s| s.research.fold_min_pixels = Some(4)),
            ("fold_corners", |s| {
                s.research.fold_corners = Some(FoldCorners::One)
            }),
            ("finer_views", |s| {
                s.research.finer_views = Some(FinerViews::Centroids)
            }),
            ("sampled_rows", |s| s.research.sampled_rows = true),
            ("apertures", |s| s.research.apertures = Some(1)),
        ]
    }

    #[test]
    fn every_field_reads_back_and_changes_the_bytes() {
        let default = RowSettings::default().encode();
        assert_eq!(RowSettings::decode(&default), Some(RowSettings::default()));
        let changes = one_change_per_field();
        // Every field of the type has its change (a field added without one fails here).
        let fields = format!("{:?}", RowSettings::default())
            .matches(": ")
            .count();
        // `research` itself holds the research fields.
        assert_eq!(
            changes.len() + 1,
            fields,
            "a field has no change in the list"
        );
        for (name, change) in &changes {
            let mut settings = RowSettings::default();
            change(&mut settings);
            let settings = &settings;
            let bytes = settings.encode();
            assert_ne!(bytes, default, "{name} does not change the bytes");
            assert_eq!(
                RowSettings::decode(&bytes).as_ref(),
                Some(settings),
                "{name}"
            );
            assert!(settings.clone().check_ranges().is_ok(), "{name}");
        }
        for probe in [Probe::Off, Probe::Pixels(0), Probe::Pixels(u32::MAX)] {
            let s = RowSettings {
                research: Research {
                    probe,
                    ..Research::default()
                },
                ..RowSettings::default()
            };
            assert_eq!(RowSettings::decode(&s.encode()), Some(s));
        }
    }

    #[test]
    fn cut_short_or_extended_bytes_are_refused() {
        let bytes = RowSettings {
            always_visible: vec![0, 5],
            ..RowSettings::default()
        }
        .encode();
        for end in 0..bytes.len() {
            assert_eq!(RowSettings::decode(&bytes[..end]), None, "cut at {end}");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert_eq!(RowSettings::decode(&longer), None);
        // Counts of far shells and of always-visible ids past the bytes left, and a flag of 2.
        let far = 1 + 8 + 4 + 4 + 4 + 8 + 8 + 8;
        let ids = far + 4 + 8 * DEFAULT_FAR_SHELLS.len();
        for at in [far, ids] {
            let mut huge = RowSettings::default().encode();
            huge[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
            assert_eq!(RowSettings::decode(&huge), None, "count at {at}");
        }
        let mut flag = RowSettings::default().encode();
        *flag.last_mut().unwrap() = 2;
        assert_eq!(RowSettings::decode(&flag), None);
    }

    #[test]
    fn out_of_range_values_are_refused_with_the_option_named() {
        for (f, flag) in [
            (
                &(|s: &mut BakeSettings| s.patches = 0) as &dyn Fn(&mut BakeSettings),
                "--patches",
            ),
            (
                &|s: &mut BakeSettings| s.rows.level = Some(MAX_LEVEL + 1),
                "--level",
            ),
            (
                &|s: &mut BakeSettings| s.rows.resolution = 0,
                "--resolution",
            ),
            (
                &|s: &mut BakeSettings| s.rows.resolution = 1,
                "--resolution",
            ),
            (
                &|s: &mut BakeSettings| s.rows.resolution = MIN_RESOLUTION - 1,
                "--resolution",
            ),
            (
                &|s: &mut BakeSettings| s.rows.resolution = MAX_RESOLUTION + 1,
                "--resolution",
            ),
            (&|s: &mut BakeSettings| s.rows.fov_deg = 180.0, "--fov"),
            (&|s: &mut BakeSettings| s.rows.fov_deg = f32::NAN, "--fov"),
            (
                &|s: &mut BakeSettings| s.rows.research.view_supersample = Some(3),
                "--view-supersample",
            ),
            (
                &|s: &mut BakeSettings| s.rows.shells = MAX_SHELLS + 1,
                "--shells",
            ),
            (
                &|s: &mut BakeSettings| s.rows.shell_min = 1.0,
                "--shell-min",
            ),
            (
                &|s: &mut BakeSettings| s.rows.far_shells = vec![1.0],
                "--far-shells 1",
            ),
            (
                &|s: &mut BakeSettings| s.rows.far_shells = vec![4.0, 2.0],
                "--far-shells 4,2",
            ),
            (
                &|s: &mut BakeSettings| s.rows.far_shells = vec![2.0, f64::NAN],
                "--far-shells 2,NaN",
            ),
            (
                &|s: &mut BakeSettings| s.rows.far_shells = vec![MAX_FAR_SHELL * 2.0],
                "--far-shells",
            ),
            (
                &|s: &mut BakeSettings| s.rows.shells = MAX_SHELLS,
                "--shells 8 with 2 --far-shells",
            ),
            (
                &|s: &mut BakeSettings| s.rows.shell_min = f64::NAN,
                "--shell-min",
            ),
            // The sampling distance is 2.61 radii at 45°, 1 at 180°.
            (
                &|s: &mut BakeSettings| s.rows.shell_min = 2.62,
                "--shell-min",
            ),
            (
                &|s: &mut BakeSettings| {
                    s.rows.fov_deg = 120.0;
                    s.rows.shell_min = 1.2
                },
                "--shell-min",
            ),
            // Too wide a field of view for the default --shell-min blames the field of view.
            (&|s: &mut BakeSettings| s.rows.fov_deg = 170.0, "--fov 170"),
            (&|s: &mut BakeSettings| s.rows.fov_deg = 179.0, "--fov 179"),
            (
                &|s: &mut BakeSettings| s.rows.shell_level = Some(MAX_LEVEL + 1),
                "--shell-level",
            ),
            (
                &|s: &mut BakeSettings| s.rows.shell_resolution = Some(1024),
                "--shell-resolution",
            ),
        ] {
            let mut s = BakeSettings::default();
            f(&mut s);
            let err = s.check().unwrap_err();
            assert!(err.0.starts_with(flag), "{flag}: {}", err.0);
        }
    }
}
