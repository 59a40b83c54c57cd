"""patchvis: precomputed visibility for huge triangle meshes, from Python.

Bake a mesh (a file, or numpy arrays) into a ``.pvis`` file, and ask a ``.pvis`` file which
patches of the mesh a camera can see::

    import patchvis
    report = patchvis.bake("bunny.ply", "bunny.pvis", patches=2000, mesh_out="bunny.glb")
    reader = patchvis.Reader("bunny.pvis")
    reader.query((0.0, 0.1, 0.5))          # numpy uint32 patch ids
    reader.query_many(eyes)                # (N, patches) bool, many eyes at once

The work is done by the Rust library (the same code as the ``patchvis`` command), with the
GIL released; the same mesh and settings give the same bytes as ``patchvis bake``.
"""

from ._bake import BakeReport, Stage, bake, bake_arrays, read_mesh
from ._native import FormatError
from ._reader import Reader

__all__ = [
    "BakeReport",
    "FormatError",
    "Reader",
    "Stage",
    "bake",
    "bake_arrays",
    "read_mesh",
]
__version__ = "0.1.0"
