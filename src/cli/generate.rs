//! `patchvis gen`: write a huge, real-looking test mesh as binary PLY, streaming.
//!
//! The models live in [`patchvis::generate`]; this file resolves the flags, reads the source
//! mesh through [`Mesh`], and writes through a temporary file that is renamed into place only
//! when complete ([`AtomicFile`]), so an interrupted run leaves no half-written mesh behind.
//! The kinds that start from a mesh need `--source`; there is no default, so that the command
//! does not depend on the working directory. The output is checked before any work, and
//! locked: not the source (whatever the kind), a regular file or a new one, in a writable
//! directory. Sizes past [`MAX_TRIANGLES`] are refused.

use super::UsageError;
use super::args::{GenArgs, GenKind};
use super::out::outln;
use anyhow::{Context, Result};
use patchvis::generate::engine::Engine;
use patchvis::generate::exposed::ExposedEngine;
use patchvis::generate::grid::BunnyGrid;
use patchvis::generate::subdivide::SubdividedMesh;
use patchvis::generate::truss::Truss;
use patchvis::generate::{MAX_TRIANGLES, Model, write_ply};
use patchvis::ooc::Mesh;
use patchvis::output::{AtomicFile, NamedPath};
use std::time::Instant;

/// Runs `patchvis gen`.
pub fn run(args: &GenArgs) -> Result<()> {
    if args.triangles == 0 {
        return Err(UsageError("--triangles 0: expected at least 1 triangle".into()).into());
    }
    if args.triangles > MAX_TRIANGLES {
        return Err(UsageError(format!(
            "--triangles {}: expected at most {MAX_TRIANGLES} (about {} GB of PLY); patchvis gen refuses larger meshes",
            args.triangles,
            MAX_TRIANGLES * 25 / 1_000_000_000
        ))
        .into());
    }
    let reads_source = matches!(args.kind, GenKind::SubdividedBunny | GenKind::BunnyGrid);
    if reads_source && args.source.is_none() {
        return Err(no_source(args.kind));
    }
    // The source is an input whatever the kind: a kind that does not read it still must not
    // replace the file the user named as one.
    let inputs: Vec<NamedPath> = args
        .source
        .iter()
        .map(|path| NamedPath::new("the --source mesh", "--source", path))
        .collect();
    let _lock = super::claim_outputs(&inputs, &[NamedPath::flag("-o", &args.output)])?;
    let start = Instant::now();
    let source;
    let model: Box<dyn Model + '_> = match args.kind {
        GenKind::SubdividedBunny | GenKind::BunnyGrid => {
            let Some(path) = &args.source else {
                return Err(no_source(args.kind));
            };
            source = Mesh::open(path)?;
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
    let cannot_write = || format!("{}: cannot write", args.output.display());
    let mut tmp = AtomicFile::create(&args.output).with_context(cannot_write)?;
    let comment = format!(
        "patchvis gen --kind {} --triangles {}",
        args.kind.name(),
        args.triangles
    );
    write_ply(tmp.file(), model.as_ref(), &comment).with_context(cannot_write)?;
    tmp.commit().with_context(cannot_write)?;
    if !args.quiet {
        outln!(
            "wrote {}: {} triangles, {} vertices ({} kind) in {:.2} s",
            args.output.display(),
            model.triangle_count(),
            model.vertex_count(),
            args.kind.name(),
            start.elapsed().as_secs_f64()
        )?;
    }
    Ok(())
}

/// The usage error of a kind that starts from a mesh, run without `--source`.
fn no_source(kind: GenKind) -> anyhow::Error {
    UsageError(format!(
        "--kind {} needs --source MESH.ply, the mesh it starts from (such as assets/bunny.ply \
         in the patchvis repository)",
        kind.name()
    ))
    .into()
}
