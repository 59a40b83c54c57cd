//! The merge of a sharded bake (`patchvis merge PARTS… -o OUT.pvis`): the parts' rows put
//! back together (the sampling sphere's and every shell's) and run through the rest of
//! `Recipe::run` (fold, numbering, encoding), so that the file is byte for byte the one a
//! single bake writes.
//!
//! Before anything is merged every part must be whole (`part.rs`'s checks), of the same mesh,
//! settings and tiling as the others (their hashes), with the same camera and patch records
//! (bit for bit), of the same shard count, hold exactly
//! the views its shard owns, and every shard must be there once. A part that differs from the
//! others is named by its path; when the parts disagree, the value most of them share is
//! taken as the bake's (the first part's on a tie). The merge needs no mesh: the parts carry
//! the file's camera and patch records. Cost: the fold, the numbering and the encoding of a
//! bake, and the parts in memory (together, the sampled rows once).

use super::part::{HEAD_BYTES, Part};
use super::plan::{Plan, SphereSampling};
use super::rows::SphereRows;
use super::wire::{PATCH_BYTES, Put};
use super::{BakeError, encode};
use crate::format::ShellRows;
use crate::mapped::{Backing, FileBytes, open_regular};
use crate::runtime::Pvis;
use crate::sphere::view_count;
use crate::tiling::renumbered_patches;
use crate::visibility::{SamplingParams, VisibilityMatrix};
use std::io::Read as _;
use std::path::{Path, PathBuf};
use xxhash_rust::xxh64::xxh64;

/// A part and the path it was read from (which errors name).
#[derive(Clone, Debug)]
pub struct LoadedPart {
    /// Where it was read from.
    pub path: PathBuf,
    /// The part.
    pub part: Part,
}

/// Why a merge was refused: a part (named) or the set of parts.
#[derive(Debug, thiserror::Error)]
#[error("{}{reason}", part.as_ref().map(|p| format!("{}: ", p.display())).unwrap_or_default())]
pub struct MergeError {
    /// The part at fault, if one is.
    pub part: Option<PathBuf>,
    /// What is wrong and what to do.
    pub reason: String,
}

impl MergeError {
    fn part(path: &Path, reason: String) -> MergeError {
        MergeError {
            part: Some(path.to_path_buf()),
            reason,
        }
    }
}

/// What [`merge`] made.
#[derive(Debug)]
pub struct Merged {
    /// The `.pvis` file.
    pub bytes: Vec<u8>,
    /// Bytes of its VISB payload.
    pub visibility_bytes: u64,
    /// Stored views.
    pub views: u32,
    /// Patches.
    pub patches: u32,
    /// Shards merged.
    pub shards: u32,
    /// The sampling shells, outermost first: each one's distance and stored rows, in the
    /// file's patch numbering.
    pub shells: Vec<(f32, VisibilityMatrix)>,
}

/// Reads the part file at `path`.
///
/// The magic and the version are read and checked first ([`Part::check_head`]), so a file
/// of another kind is refused whatever its size; then the file is mapped, not read.
pub fn read_part(path: &Path) -> Result<LoadedPart, MergeError> {
    let cannot = |e: std::io::Error| MergeError::part(path, format!("cannot read: {e}"));
    let refused = |reason: String| MergeError::part(path, reason);
    let (file, metadata) = open_regular(path).map_err(cannot)?;
    let mut head = Vec::with_capacity(HEAD_BYTES);
    std::io::Read::read_to_end(&mut (&file).take(HEAD_BYTES as u64), &mut head).map_err(cannot)?;
    Part::check_head(&head, metadata.len()).map_err(refused)?;
    let bytes = FileBytes::open(&file, metadata.len(), Backing::Input(path)).map_err(cannot)?;
    let part = Part::decode(&bytes).map_err(refused)?;
    Ok(LoadedPart {
        path: path.to_path_buf(),
        part,
    })
}

/// XXH64 of a part's camera (every field, bit for bit) and triangle count.
fn camera_hash(part: &Part) -> u64 {
    let p = &part.params;
    let mut bytes = Vec::with_capacity(32);
    for word in [
        p.level,
        p.resolution,
        p.fov_deg.to_bits(),
        p.radius.to_bits(),
    ]
    .into_iter()
    .chain(p.center.map(f32::to_bits))
    .chain([part.triangle_count])
    {
        bytes.put_u32(word);
    }
    xxh64(&bytes, 0)
}

/// XXH64 of a part's patch records, bit for bit.
fn records_hash(part: &Part) -> u64 {
    let mut bytes = Vec::with_capacity(part.patches.len() * PATCH_BYTES);
    for patch in &part.patches {
        bytes.put_patch(patch);
    }
    xxh64(&bytes, 0)
}

/// The value of `key` most parts share (the earliest part's on a tie).
fn consensus(parts: &[LoadedPart], key: impl Fn(&Part) -> u64) -> u64 {
    let keys: Vec<u64> = parts.iter().map(|p| key(&p.part)).collect();
    let mut counts = std::collections::HashMap::new();
    for &k in &keys {
        *counts.entry(k).or_insert(0usize) += 1;
    }
    let most = counts.values().copied().max().unwrap_or(0);
    keys.into_iter()
        .find(|k| counts[k] == most)
        .expect("at least one part")
}

/// Merges `parts` (in any order) into the `.pvis` a single bake with their settings writes.
pub fn merge(parts: &[LoadedPart]) -> Result<Merged, MergeError> {
    if parts.is_empty() {
        return Err(whole("no parts to merge".into()));
    }
    let count = check_set(parts)?;
    let first = &parts[0].part;
    // The part's decoding checked that its settings plan.
    let plan = Plan::new(first.settings.clone()).map_err(|e| {
        MergeError::part(
            &parts[0].path,
            format!("its settings do not check: {e}; bake this shard again"),
        )
    })?;
    let matrices = gather_passes(parts, &plan)?;
    encode_passes(&parts[0], &plan, matrices, count)
}

/// A fault of the whole set of parts.
fn whole(reason: String) -> MergeError {
    MergeError { part: None, reason }
}

/// Checks that `parts` are one bake's, of the same mesh, settings, tiling and shard count,
/// each shard once and none missing; returns the shard count.
fn check_set(parts: &[LoadedPart]) -> Result<u32, MergeError> {
    let mesh = consensus(parts, |p| p.mesh_hash);
    let settings = consensus(parts, |p| p.settings.hash());
    let tiling = consensus(parts, |p| p.tiling_hash);
    let camera = consensus(parts, camera_hash);
    let records = consensus(parts, records_hash);
    let count = consensus(parts, |p| u64::from(p.shard.count)) as u32;
    for LoadedPart { path, part } in parts {
        let differs = |what: &str, found: u64, expected: u64| {
            MergeError::part(
                path,
                format!(
                    "{what} (hash {found:016x}; the other parts' is {expected:016x}); bake \
                     this shard again with the others' input and flags"
                ),
            )
        };
        if part.mesh_hash != mesh {
            return Err(differs("from another mesh", part.mesh_hash, mesh));
        }
        if part.settings.hash() != settings {
            return Err(differs(
                "baked with other settings",
                part.settings.hash(),
                settings,
            ));
        }
        if part.tiling_hash != tiling {
            return Err(differs(
                "sampled another tiling (another tiling file, --patches, --tiling or --memory)",
                part.tiling_hash,
                tiling,
            ));
        }
        // Parts of one tiling carry one camera and one set of records: the merge writes
        // the first part's, so each must be the same.
        if camera_hash(part) != camera {
            return Err(differs(
                "has another camera or triangle count than the other parts",
                camera_hash(part),
                camera,
            ));
        }
        if records_hash(part) != records {
            return Err(differs(
                "has other patch records than the other parts",
                records_hash(part),
                records,
            ));
        }
        if part.shard.count != count {
            return Err(MergeError::part(
                path,
                format!(
                    "shard {} of a bake in {} shards; the other parts are of {count} shards",
                    part.shard, part.shard.count
                ),
            ));
        }
    }
    let mut holder: Vec<Option<&Path>> = vec![None; count as usize];
    for LoadedPart { path, part } in parts {
        if let Some(other) = holder[part.shard.index as usize] {
            return Err(MergeError::part(
                path,
                format!(
                    "shard {} is given twice (also {}); give each shard's part once",
                    part.shard,
                    other.display()
                ),
            ));
        }
        holder[part.shard.index as usize] = Some(path);
    }
    if let Some(missing) = holder.iter().position(Option::is_none) {
        let n = holder.iter().filter(|h| h.is_none()).count();
        return Err(whole(format!(
            "shard {missing}/{count} is missing ({n} of {count} shards have no part among the \
             {} given); bake it with --shard {missing}/{count} and merge all {count}",
            parts.len()
        )));
    }
    Ok(count)
}

/// Every pass's rows of the bake `plan` describes, put together from the views each part
/// holds; refuses a part with other passes, patches or views than its shard's, a view held
/// twice, and a view no part holds.
fn gather_passes(parts: &[LoadedPart], plan: &Plan) -> Result<Vec<VisibilityMatrix>, MergeError> {
    let first = &parts[0].part;
    let patch_count = first.patches.len() as u32;
    let levels = plan.pass_levels();
    let mut matrices: Vec<VisibilityMatrix> = levels
        .iter()
        .map(|&l| VisibilityMatrix::new(view_count(l), patch_count))
        .collect();
    let mut seen: Vec<Vec<bool>> = levels
        .iter()
        .map(|&l| vec![false; view_count(l) as usize])
        .collect();
    for LoadedPart { path, part } in parts {
        let wrong = |what: String| {
            MergeError::part(
                path,
                format!("{what} (written by another patchvis build?); bake this shard again"),
            )
        };
        if part.passes.len() != levels.len() || part.patches.len() as u32 != patch_count {
            return Err(wrong(
                "holds other passes or patches than its settings say".into(),
            ));
        }
        for (pass, ((&level, matrix), seen)) in part
            .passes
            .iter()
            .zip(levels.iter().zip(&mut matrices).zip(&mut seen))
        {
            if pass.level != level || pass.views != part.shard.views(level) {
                return Err(wrong(format!(
                    "holds other views than shard {} owns at level {level}",
                    part.shard
                )));
            }
            let words = matrix.words_per_row();
            for (i, &v) in pass.views.iter().enumerate() {
                if std::mem::replace(&mut seen[v as usize], true) {
                    return Err(wrong(format!("holds view {v} of level {level} again")));
                }
                matrix
                    .row_mut(v)
                    .copy_from_slice(&pass.words[i * words..][..words]);
            }
        }
    }
    if let Some((level, view)) = levels
        .iter()
        .zip(&seen)
        .find_map(|(&l, s)| s.iter().position(|&b| !b).map(|v| (l, v)))
    {
        return Err(whole(format!(
            "no part holds view {view} of level {level}; bake every shard with one patchvis build"
        )));
    }
    Ok(matrices)
}

/// What `Recipe::run` does after sampling, on the part's records instead of the tiling: each
/// sphere's passes `matrices` folded into its stored rows, the patches numbered and the file
/// encoded (of a bake in `shards` shards).
fn encode_passes(
    first: &LoadedPart,
    plan: &Plan,
    matrices: Vec<VisibilityMatrix>,
    shards: u32,
) -> Result<Merged, MergeError> {
    let (path, first) = (&first.path, &first.part);
    let patch_count = first.patches.len() as u32;
    // Back into one sphere's rows per sphere: the sampling sphere's passes, then each shell's,
    // then each far shell's (`Plan::pass_levels`).
    let params = first.params;
    let mut matrices = matrices.into_iter();
    let mut stored = |sampling: SphereSampling| {
        let passes = sampling.supersample.pass_levels(sampling.level).len();
        let plain = matrices.next().expect("the passes of pass_levels");
        SphereRows {
            plain,
            fine: if passes == 2 { matrices.next() } else { None },
            params: SamplingParams {
                level: sampling.level,
                ..params
            },
            supersample: sampling.supersample,
            saturate: !plan.rows.research.sampled_rows,
        }
        .stored(sampling.level)
    };
    let visibility = stored(plan.main);
    let inner: Vec<VisibilityMatrix> = (0..plan.rows.shells).map(|_| stored(plan.shell)).collect();
    let far: Vec<VisibilityMatrix> = (0..plan.rows.far_shells.len())
        .map(|_| stored(plan.shell))
        .collect();
    // In the file's order: the far band outermost first, then the shells inside.
    // The parts carry the file's camera: the shells are where the single bake puts them (the
    // far band left out, as it does, where binary32 cannot hold it around the model).
    let (distances, dropped, _) = plan
        .file_shells_in_world(&params)
        .map_err(|e| MergeError::part(path, format!("{e}; bake this shard again")))?;
    let shells: Vec<VisibilityMatrix> = far.into_iter().rev().chain(inner).skip(dropped).collect();
    let order = encode::file_patch_order(plan.rows.patch_order, &first.patches, &visibility);
    let (patches, visibility, shells) = match order {
        Some(order) => (
            renumbered_patches(&first.patches, &order),
            visibility.with_patch_order(&order),
            shells.iter().map(|m| m.with_patch_order(&order)).collect(),
        ),
        None => (first.patches.clone(), visibility, shells),
    };
    let shell_rows: Vec<ShellRows> = distances
        .iter()
        .zip(&shells)
        .map(|(&distance, visibility)| ShellRows {
            distance,
            visibility,
        })
        .collect();
    let bytes = encode::try_encode(
        plan.rows.encoding,
        &params,
        first.triangle_count,
        &patches,
        &visibility,
        &shell_rows,
        plan.sampling_reach(params.distance(), &distances),
    )
    .map_err(|e| {
        MergeError::part(
            path,
            format!(
                "its camera and patch records break the .pvis format: {e}; bake this shard again"
            ),
        )
    })?;
    let visibility_bytes = Pvis::parse(&bytes)
        .map(|p| p.visibility_bytes())
        .map_err(|e| {
            whole(format!(
                "internal error: the merged file does not parse: {e}"
            ))
        })?;
    Ok(Merged {
        bytes,
        visibility_bytes,
        views: visibility.views(),
        patches: patch_count,
        shards,
        shells: distances.into_iter().zip(shells).collect(),
    })
}

/// [`merge`] as a [`BakeError`], for callers that handle both.
impl From<MergeError> for BakeError {
    fn from(e: MergeError) -> BakeError {
        BakeError::Sharded(e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::{Backend, BakeSettings, Recipe, Research, RowSettings, Stages};
    use crate::ooc::Mesh;
    use crate::progress::NoProgress;
    use crate::test_kit::bunny::bunny;

    /// `recipe`'s parts of `mesh` in `count` shards, each read back from its bytes.
    fn shards(recipe: &Recipe, mesh: &Mesh, count: u32) -> Vec<LoadedPart> {
        (0..count)
            .map(|index| {
                let shard = crate::bake::Shard { index, count };
                let baked = recipe
                    .run_shard(
                        mesh,
                        None,
                        shard,
                        &Backend::Cpu,
                        &NoProgress,
                        &mut Stages::new(),
                    )
                    .unwrap();
                let part = Part::decode(&baked.part.encode()).unwrap();
                assert_eq!(part, baked.part);
                LoadedPart {
                    path: format!("p{index}").into(),
                    part,
                }
            })
            .collect()
    }

    /// Every row option, each changed alone from a small default bake, merges from two
    /// shards into the single bake's bytes.
    #[test]
    fn every_row_option_merges_into_the_single_bake() {
        let mesh = bunny();
        for (name, change) in crate::bake::settings::tests::one_change_per_field() {
            let mut rows = RowSettings {
                level: Some(1),
                resolution: 32,
                ..RowSettings::default()
            };
            change(&mut rows);
            let recipe = BakeSettings {
                patches: 60,
                rows,
                ..BakeSettings::default()
            }
            .check()
            .unwrap();
            let single = recipe
                .run(&mesh, &Backend::Cpu, &NoProgress, &mut Stages::new())
                .unwrap();
            let merged = merge(&shards(&recipe, &mesh, 2)).unwrap();
            assert!(merged.bytes == single.bytes, "{name}: the merge differs");
        }
    }

    /// Shards of the bunny merge into the single bake's bytes and sampling shells, in any
    /// order, for a plain and a thresholded fold; a missing or repeated shard is refused.
    #[test]
    fn shards_merge_into_the_single_bake() {
        // The bunny far from the origin is baked in a working frame (`frame.rs`): the parts
        // must carry the original's camera and patch records as the bake computes them.
        let near = bunny();
        let b = near.bounds();
        let offset = 4096.0 * (b.max[0] - b.min[0]);
        let far = crate::ooc::Mesh::from_memory(
            "far bunny",
            (0..near.vertex_count())
                .map(|v| near.position(v).map(|c| c + offset))
                .collect(),
            (0..near.triangle_count())
                .map(|t| near.triangle(t))
                .collect(),
        )
        .unwrap();
        assert!(
            super::super::frame::Frame::choose(&far, 45.0)
                .unwrap()
                .is_some()
        );
        for (mesh, fold_min_pixels) in [(&near, None), (&near, Some(3)), (&far, None)] {
            let recipe = BakeSettings {
                patches: 120,
                rows: RowSettings {
                    level: Some(2),
                    resolution: 48,
                    research: Research {
                        fold_min_pixels,
                        ..Research::default()
                    },
                    ..RowSettings::default()
                },
                ..BakeSettings::default()
            }
            .check()
            .unwrap();
            let single = recipe
                .run(mesh, &Backend::Cpu, &NoProgress, &mut Stages::new())
                .unwrap();
            let mut parts = shards(&recipe, mesh, 3);
            parts.reverse();
            let merged = merge(&parts).unwrap();
            assert_eq!(merged.bytes, single.bytes);
            // The shells too, whether or not the writer stores them yet.
            let far = crate::bake::DEFAULT_FAR_SHELLS.len();
            assert_eq!(
                merged.shells.len(),
                far + crate::bake::DEFAULT_SHELLS as usize
            );
            for ((distance, rows), shell) in merged.shells.iter().zip(&single.shells) {
                assert_eq!((*distance, rows), (shell.distance, &shell.visibility));
            }
            let missing = merge(&parts[1..]).unwrap_err();
            assert!(missing.reason.contains("is missing"), "{missing}");
            let mut twice = parts.clone();
            twice[0] = parts[1].clone();
            twice[0].path = "again".into();
            let err = merge(&twice).unwrap_err();
            assert_eq!(err.part, Some("p1".into()), "{err}");
            assert!(err.reason.contains("given twice (also again)"), "{err}");
        }
    }
}
