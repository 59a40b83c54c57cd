//! Sharded bakes on the command line: `patchvis tile` (the tiling every shard reads),
//! `patchvis bake --shard I/N|auto` (one shard's part file) and `patchvis merge` (the parts
//! into the `.pvis`). Glue over `patchvis::bake`'s `tile_framed`, `run_shard` and `merge`.

use super::UsageError;
use super::args::{BakeArgs, MergeArgs, TileArgs, memory_budget};
use super::bake_common::{check_paths, report};
use super::out::outln;
use super::progress::Bars;
use anyhow::{Result, anyhow};
use patchvis::bake::{
    Backend, BackendChoice, BakeSettings, LoadedPart, Outputs, Recipe, RowSettings, Shard, Stages,
    merge as merge_parts, mesh_hash, read_part, read_tiling_file, write_tiling_file,
};
use patchvis::output::NamedPath;
use std::time::Instant;

/// `patchvis bake --shard`: checks, then bakes `shard` (`I/N` or `auto`) of `args` into
/// the part file `-o`.
pub fn bake(args: &BakeArgs, shard: &str, recipe: &Recipe) -> Result<()> {
    let shard = if shard == "auto" {
        Shard::from_env(|name| std::env::var(name).ok())
    } else {
        Shard::parse(shard)
    }
    .map_err(|e| UsageError(e.0))?;
    let outputs = Outputs {
        pvis: args.output.clone(),
        mesh: None,
    };
    // Held until the part is written; the tiling file is among the inputs checked.
    let _lock = check_paths(args, recipe, &outputs)?;
    if args.backend != super::args::BackendArg::Cpu {
        return Err(UsageError(
            "--shard: sharded bakes sample on the CPU backend (bit-exact, so that the merge \
             equals one bake); use --backend cpu"
                .into(),
        )
        .into());
    }
    let (backend, _) =
        Backend::open(BackendChoice::Cpu, &recipe.settings).map_err(|e| report(&args.input, e))?;
    let bars = Bars::new(!args.quiet);
    let start = Instant::now();
    let mut stages = Stages::new();
    let tiling = match &args.tiling_file {
        Some(path) => {
            let file = stages
                .run("tiling", || read_tiling_file(path))
                .map_err(|e| anyhow!("{}: {e}", path.display()))?;
            Some((path.as_path(), file))
        }
        None => None,
    };
    let mesh = stages
        .run("input", || {
            bars.spin("reading", || recipe.open(&args.input))
        })
        .map_err(|e| report(&args.input, e))?;
    let baked = recipe
        .run_shard(&mesh, tiling, shard, &backend, &bars, &mut stages)
        .map_err(|e| report(&args.input, e))?;
    let bytes = baked.part.encode();
    stages
        .run("write", || recipe.write_part(&bytes, &args.output))
        .map_err(|e| report(&args.input, e))?;
    let seconds = start.elapsed().as_secs_f64();
    if let Some(path) = &args.stats {
        let json = serde_json::json!({
            "input": args.input.display().to_string(),
            "output": args.output.display().to_string(),
            "shard": {"index": shard.index, "count": shard.count},
            "triangles": mesh.triangle_count(),
            "patches": baked.part.patches.len(),
            "owned_views": baked.owned_views,
            "rendered_views": baked.rendered_views,
            "bytes": bytes.len(),
            "seconds": seconds,
            "peak_heap_bytes": stages.peak_heap_bytes(),
            "stages": stages.records().iter().map(|r| serde_json::json!({
                "name": r.name, "seconds": r.seconds, "peak_heap_bytes": r.peak_heap_bytes,
            })).collect::<Vec<_>>(),
        });
        let text = serde_json::to_string_pretty(&json)? + "\n";
        patchvis::format::write_atomic(path, text.as_bytes())
            .map_err(|e| anyhow!("{}: cannot write: {e}", path.display()))?;
    }
    if !args.quiet {
        outln!(
            "{}: {} triangles; shard {shard}: {} patches ({}), sampled {} views for the {} it \
             owns ({:.2} s)",
            args.input.display(),
            mesh.triangle_count(),
            baked.part.patches.len(),
            match &args.tiling_file {
                Some(path) => format!("tiling from {}", path.display()),
                None => format!("tiled in {:.2} s", stages.seconds("tiling")),
            },
            baked.rendered_views,
            baked.owned_views,
            stages.seconds("sampling"),
        )?;
        outln!(
            "wrote {}: {} bytes ({seconds:.2} s total); merge every shard with patchvis merge",
            args.output.display(),
            bytes.len()
        )?;
    }
    Ok(())
}

/// Runs `patchvis tile`.
pub fn tile(args: &TileArgs) -> Result<()> {
    let recipe = BakeSettings {
        patches: args.patches,
        rows: RowSettings {
            fov_deg: args.fov,
            ..RowSettings::default()
        },
        tiling: args.tiling.into(),
        memory: memory_budget(args.memory),
        ..BakeSettings::default()
    }
    .check()
    .map_err(|e| UsageError(e.0))?;
    let _lock = super::claim_outputs(
        &[NamedPath::new("the input mesh", "INPUT", &args.input)],
        &[NamedPath::flag("-o", &args.output)],
    )?;
    let bars = Bars::new(!args.quiet);
    let start = Instant::now();
    let mesh = bars
        .spin("reading", || recipe.open(&args.input))
        .map_err(|e| report(&args.input, e))?;
    let tiling = bars
        .spin("tiling", || recipe.tile_framed(&mesh))
        .map_err(|e| report(&args.input, e))?;
    write_tiling_file(&args.output, mesh_hash(&mesh), args.patches, &tiling)
        .map_err(|e| anyhow!("{}: cannot write: {e}", args.output.display()))?;
    if !args.quiet {
        let q = tiling.quality;
        outln!(
            "{}: {} triangles in {} patches, {}/{}/{} triangles min/median/max ({})",
            args.input.display(),
            mesh.triangle_count(),
            tiling.patches.len(),
            q.triangles_min,
            q.triangles_median,
            q.triangles_max,
            if tiling.stats.out_of_core {
                "out-of-core"
            } else {
                "in-core"
            }
        )?;
        outln!(
            "wrote {} ({:.2} s); bake each shard with --tiling-file {} --patches {}",
            args.output.display(),
            start.elapsed().as_secs_f64(),
            args.output.display(),
            args.patches
        )?;
    }
    Ok(())
}

/// Runs `patchvis merge`.
pub fn merge(args: &MergeArgs) -> Result<()> {
    let inputs: Vec<NamedPath> = args
        .parts
        .iter()
        .map(|p| NamedPath::new("a part", "PART", p))
        .collect();
    let _lock = super::claim_outputs(&inputs, &[NamedPath::flag("-o", &args.output)])?;
    let start = Instant::now();
    let parts = args
        .parts
        .iter()
        .map(|p| read_part(p))
        .collect::<Result<Vec<LoadedPart>, _>>()?;
    let merged = merge_parts(&parts)?;
    patchvis::format::write_atomic(&args.output, &merged.bytes)
        .map_err(|e| anyhow!("{}: cannot write: {e}", args.output.display()))?;
    if !args.quiet {
        let shells = match merged.shells.len() {
            0 => String::new(),
            k => format!(", {k} sampling shells"),
        };
        outln!(
            "merged {} shards: {} views, {} patches{shells}",
            merged.shards,
            merged.views,
            merged.patches
        )?;
        outln!(
            "wrote {}: {} bytes, visibility {} bytes ({:.2} s total)",
            args.output.display(),
            merged.bytes.len(),
            merged.visibility_bytes,
            start.elapsed().as_secs_f64()
        )?;
    }
    Ok(())
}
