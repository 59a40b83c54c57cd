//! How much culling the fold into stored corners costs, against rows of whole sphere faces.
//!
//! `cargo run --release --example fold_bound -- FINE.pvis LEVEL [FINE_LEVEL]`
//!
//! `FINE.pvis` is a plain bake at a fine level with its rows as sampled (`patchvis bake M -o
//! FINE.pvis --level 7 --view-supersample 0 --probe off --shells 0 --sampled-rows`): each
//! view's row is what that view shows.
//! For 300 random directions (seed 1, as `eval`) it prints the culling, averaged, of three
//! answers for the sphere face of `LEVEL` holding the direction, from the views of
//! `FINE_LEVEL` (the file's level unless given) that lie in the closed face:
//!
//! - the face's own row: the OR of those views' rows, which a file with one row per face
//!   would store (the most any fold into corners can cull);
//! - the OR of the face's corner rows folded with `--fold-corners all`;
//! - the same with the cover fold (`sampler::cover_fold`).
//!
//! Why: the fold of the stored corners decides how much of the face's own culling is kept,
//! apart from how the rows were sampled (BENCHMARKS.md, "The probe with the cover fold").

use anyhow::{Context, Result, bail};
use patchvis::eval::views::random_directions;
use patchvis::runtime::Pvis;
use patchvis::sampler::{FoldCorners, VisibilityMatrix, fold_into_with, fold_targets};
use patchvis::sphere::{Face, leaf_faces, locate, view_count};
use std::collections::HashMap;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if !(2..=3).contains(&args.len()) {
        bail!("usage: fold_bound FINE.pvis LEVEL [FINE_LEVEL]");
    }
    let bytes = std::fs::read(&args[0]).with_context(|| format!("reading {}", args[0]))?;
    let pvis = Pvis::parse(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", args[0]))?;
    let level: u32 = args[1].parse().context("LEVEL")?;
    let fine_level = match args.get(2) {
        Some(l) => l.parse().context("FINE_LEVEL")?,
        None => pvis.sampling().level,
    };
    if !(level < fine_level && fine_level <= pvis.sampling().level) {
        bail!(
            "expected LEVEL < FINE_LEVEL <= the file's level {}",
            pvis.sampling().level
        );
    }
    let patches = pvis.patch_count();
    let mut fine = VisibilityMatrix::new(view_count(fine_level), patches);
    for v in 0..fine.views() {
        pvis.view_row(v, fine.row_mut(v));
    }
    let own = fine.prefix(view_count(level));

    // Each face's own row: its corners' rows and those of the finer views lying in it.
    let faces: Vec<Face> = leaf_faces(level);
    let index: HashMap<[u32; 3], usize> = faces
        .iter()
        .enumerate()
        .map(|(i, f)| (sorted(f.views), i))
        .collect();
    let words = fine.words_per_row();
    let mut face_rows: Vec<u64> = faces.iter().flat_map(|f| own.or_rows(&f.views)).collect();
    for u in view_count(level)..fine.views() {
        let targets = fold_targets(u, level);
        for (i, face) in faces.iter().enumerate() {
            if targets.views().iter().all(|t| face.views.contains(t)) {
                or_into(&mut face_rows[i * words..][..words], fine.row(u));
            }
        }
    }

    let all = fold_into_with(own.clone(), &fine, fine_level, level, FoldCorners::All);
    let cover = fold_into_with(own, &fine, fine_level, level, FoldCorners::Cover);
    let triangles: Vec<u64> = (0..patches)
        .map(|p| u64::from(pvis.patch(p).triangle_count))
        .collect();
    let total = pvis.triangle_count() as f64;
    let culling = |row: &[u64]| {
        let drawn: u64 = (0..patches as usize)
            .filter(|&p| row[p / 64] >> (p % 64) & 1 == 1)
            .map(|p| triangles[p])
            .sum();
        1.0 - drawn as f64 / total
    };
    let corners = |rows: &VisibilityMatrix, face: &Face| rows.or_rows(&face.views);
    let directions = random_directions(300, 1);
    let (mut face_sum, mut all_sum, mut cover_sum) = (0.0, 0.0, 0.0);
    for &d in &directions {
        let face = locate(d, level);
        let i = index[&sorted(face.views)];
        face_sum += culling(&face_rows[i * words..][..words]);
        all_sum += culling(&corners(&all, &face));
        cover_sum += culling(&corners(&cover, &face));
    }
    let n = directions.len() as f64;
    println!(
        "level {level} faces from level {fine_level} views, culling over {} directions: \
         the face's own row {:.1} %, --fold-corners all {:.1} %, cover {:.1} %",
        directions.len(),
        100.0 * face_sum / n,
        100.0 * all_sum / n,
        100.0 * cover_sum / n
    );
    Ok(())
}

fn sorted(mut views: [u32; 3]) -> [u32; 3] {
    views.sort_unstable();
    views
}

fn or_into(dst: &mut [u64], src: &[u64]) {
    for (d, &s) in dst.iter_mut().zip(src) {
        *d |= s;
    }
}
