//! `patchvis info` and `patchvis query`: read a `.pvis` through the runtime reader.

use super::args::{InfoArgs, QueryArgs};
use anyhow::{Context, Result, anyhow};
use patchvis::runtime::Pvis;
use serde_json::json;
use std::path::Path;

fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))
}

fn parse<'a>(path: &Path, bytes: &'a [u8]) -> Result<Pvis<'a>> {
    Pvis::parse(bytes).map_err(|e| anyhow!("{}: {e}", path.display()))
}

/// Runs `patchvis info`.
pub fn info(args: &InfoArgs) -> Result<()> {
    let bytes = read(&args.file)?;
    let pvis = parse(&args.file, &bytes)?;
    let s = pvis.sampling();
    if args.json {
        let report = json!({
            "version": pvis.version(),
            "patches": pvis.patch_count(),
            "triangles": pvis.triangle_count(),
            "level": s.level,
            "views": s.views,
            "camera": {
                "center": s.center,
                "radius": s.radius,
                "distance": s.distance,
                "fov_deg": s.fov_deg,
                "resolution": s.resolution,
            },
            "bytes": {"total": pvis.total_bytes(), "visibility": pvis.visibility_bytes()},
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{}: patchvis file version {}",
            args.file.display(),
            pvis.version()
        );
        println!(
            "  {} patches over {} triangles",
            pvis.patch_count(),
            pvis.triangle_count()
        );
        println!(
            "  {} views (sphere level {}), {}x{} px, fov {}°",
            s.views, s.level, s.resolution, s.resolution, s.fov_deg
        );
        println!(
            "  centre [{}, {}, {}], radius {}, camera distance {}",
            s.center[0], s.center[1], s.center[2], s.radius, s.distance
        );
        println!(
            "  {} bytes, of which visibility {}",
            pvis.total_bytes(),
            pvis.visibility_bytes()
        );
    }
    Ok(())
}

/// Runs `patchvis query`.
pub fn query(args: &QueryArgs) -> Result<()> {
    let bytes = read(&args.file)?;
    let pvis = parse(&args.file, &bytes)?;
    let mut scratch = vec![0u64; pvis.scratch_words()];
    let visible = pvis.query(args.from, &mut scratch);
    let patches: Vec<u32> = visible.patches().collect();
    // Patches are contiguous triangle ranges in patch order: merge neighbours into one draw.
    let mut ranges: Vec<[u64; 2]> = Vec::new();
    for &p in &patches {
        let info = pvis.patch(p);
        let (first, count) = (
            u64::from(info.first_triangle),
            u64::from(info.triangle_count),
        );
        match ranges.last_mut() {
            Some(last) if last[0] + last[1] == first => last[1] += count,
            _ => ranges.push([first, count]),
        }
    }
    let triangles: u64 = ranges.iter().map(|r| r[1]).sum();
    if args.json {
        let report = json!({
            "patches": patches,
            "ranges": ranges,
            "inside_sphere": visible.inside_sphere,
            "triangles": triangles,
            "views": visible.leaf,
        });
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!(
            "{} of {} patches visible, {} of {} triangles in {} ranges (views {:?})",
            patches.len(),
            pvis.patch_count(),
            triangles,
            pvis.triangle_count(),
            ranges.len(),
            visible.leaf
        );
        if visible.inside_sphere {
            println!("the camera is inside the sampling sphere: draw everything");
        }
    }
    Ok(())
}
