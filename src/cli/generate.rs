//! `patchvis gen`: write a huge, real-looking test mesh as binary PLY, streaming.
//!
//! The models live in [`patchvis::generate`]; this file resolves the flags, reads the source
//! mesh through [`Mesh`], and writes through a temporary file that is renamed into place only
//! when complete, so an interrupted run leaves no half-written mesh behind.

use super::UsageError;
use super::args::{GenArgs, GenKind};
use anyhow::{Context, Result};
use patchvis::generate::engine::Engine;
use patchvis::generate::exposed::ExposedEngine;
use patchvis::generate::grid::BunnyGrid;
use patchvis::generate::subdivide::SubdividedMesh;
use patchvis::generate::truss::Truss;
use patchvis::generate::{Model, write_ply};
use patchvis::ooc::Mesh;
use std::path::Path;
use std::time::Instant;

/// Runs `patchvis gen`.
pub fn run(args: &GenArgs) -> Result<()> {
    if args.triangles == 0 {
        return Err(UsageError("--triangles 0: expected at least 1 triangle".into()).into());
    }
    let start = Instant::now();
    let source;
    let model: Box<dyn Model + '_> = match args.kind {
        GenKind::SubdividedBunny | GenKind::BunnyGrid => {
            source = Mesh::open(&args.source)?;
            if args.kind == GenKind::SubdividedBunny {
                let k = SubdividedMesh::factor_for(&source, args.triangles);
                Box::new(SubdividedMesh::new(&source, k))
            } else {
                let copies = BunnyGrid::copies_for(&source, args.triangles);
                Box::new(BunnyGrid::new(&source, copies))
            }
        }
        GenKind::Engine => Box::new(Engine::new(args.triangles)),
        GenKind::ExposedEngine => Box::new(ExposedEngine::new(args.triangles)),
        GenKind::Truss => Box::new(Truss::new(args.triangles)),
    };
    let dir = match args.output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let cannot_write = || format!("{}: cannot write", args.output.display());
    let mut tmp = tempfile::NamedTempFile::new_in(dir).with_context(cannot_write)?;
    let comment = format!(
        "patchvis gen --kind {} --triangles {}",
        args.kind.name(),
        args.triangles
    );
    write_ply(tmp.as_file_mut(), model.as_ref(), &comment).with_context(cannot_write)?;
    tmp.persist(&args.output).with_context(cannot_write)?;
    if !args.quiet {
        println!(
            "wrote {}: {} triangles, {} vertices ({} kind) in {:.2} s",
            args.output.display(),
            model.triangle_count(),
            model.vertex_count(),
            args.kind.name(),
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
