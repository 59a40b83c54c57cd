//! The outputs of a bake, written so that they appear whole or not at all, and as a set: the
//! reordered mesh of `--mesh-out` and the `.pvis` each to a temporary file, both synced; then
//! the old `.pvis` removed, the mesh renamed into place and the `.pvis` last. The `.pvis` is
//! never in place before its mesh, and a crash between the renames leaves the new mesh with
//! no `.pvis` (the checkpoints are still there for `--resume`), never a `.pvis` beside a mesh
//! of another bake, whose triangle ranges it would misread. Then the finished bake's
//! checkpoints are removed.

use super::{BakeError, Baked, Recipe, Stages};
use crate::meshout::{self, MeshFormat};
use crate::ooc::Mesh;
use crate::ooc::attributes::Attributes;
use crate::output::{AtomicFile, NamedPath};
use crate::tiling::Tiling;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

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
    /// Check them with [`crate::output::check_outputs`] before the bake reads its input, and
    /// hold the lock it returns until [`Recipe::write`] is done.
    pub fn paths(&self, recipe: &Recipe) -> Vec<NamedPath> {
        let mut paths = vec![NamedPath::flag("-o", &self.pvis)];
        if let Some(mesh) = &self.mesh {
            paths.push(NamedPath::flag("--mesh-out", mesh));
        }
        for checkpoint in recipe.checkpoints() {
            paths.push(NamedPath::new("the checkpoint of -o", "-o", checkpoint));
        }
        paths
    }
}

impl Recipe {
    /// Removes this bake's sampling checkpoints (once its output is complete, they have
    /// served their purpose); a missing one is fine.
    pub(crate) fn remove_checkpoints(&self) -> Result<(), BakeError> {
        for checkpoint in &self.checkpoints() {
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

    /// Writes `baked` (from `mesh`) to `outputs` as a set (see the module documentation), so
    /// that a failure anywhere leaves no partial output behind and no `.pvis` beside another
    /// bake's mesh; the finished bake's checkpoints are removed.
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
        let failed = |path: &Path| {
            let path = path.to_path_buf();
            move |source| BakeError::Write { path, source }
        };
        let pvis = &outputs.pvis;
        let mut pvis_tmp = AtomicFile::create(pvis).map_err(failed(pvis))?;
        pvis_tmp
            .file()
            .write_all(&baked.bytes)
            .and_then(|()| pvis_tmp.sync())
            .map_err(failed(pvis))?;
        if let (Some(tmp), Some(path)) = (mesh_tmp, &outputs.mesh) {
            // The old `.pvis` goes first: it does not describe the new mesh.
            let old = crate::output::resolve_target(pvis).map_err(failed(pvis))?;
            match std::fs::remove_file(&old) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(failed(pvis)(e));
                }
                _ => {}
            }
            tmp.commit().map_err(failed(path))?;
        }
        pvis_tmp.commit().map_err(failed(pvis))?;
        // The output is complete: its checkpoints have served their purpose.
        self.remove_checkpoints()
    }
}

/// The reordered mesh of `--mesh-out` (with the input's attributes, read again from it) in
/// its temporary file beside `path` (with the permissions of a plain create), to be committed
/// just before the `.pvis`.
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
