"""Baking: ``bake`` (a mesh file) and ``bake_arrays`` (numpy arrays), and their report.

Each keyword argument is the ``patchvis bake`` flag of the same name (``docs/bake.md``
explains them all); an argument left at ``None`` keeps that command's default, which the
Rust library decides, so the two cannot drift apart. The bake runs in Rust with the GIL
released; ``progress`` is called from the bake's threads with the GIL taken for the call.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from typing import Any, Callable, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native

PathLike = Union[str, "os.PathLike[str]"]
#: ``progress(step, done, total)``: the step's name ("sampling", ...), units done, units in all.
ProgressCallback = Callable[[str, int, int], Any]


@dataclass(frozen=True)
class Stage:
    """One stage of a bake: its name (``input``, ``tiling``, ``sampling``, ...), wall time and
    the highest live heap of the Rust code while it ran."""

    name: str
    seconds: float
    peak_heap_bytes: int


@dataclass(frozen=True)
class BakeReport:
    """What a bake did (the figures of ``patchvis bake --stats``)."""

    input: str
    """The mesh's path, or ``"<arrays>"``."""
    output: str
    mesh_out: Optional[str]
    triangles: int
    vertices: int
    patches: int
    level: int
    """The sphere level of the stored views."""
    views: int
    shells: int
    """Sampling shells in the file (near and far)."""
    sampled_views: int
    visible_fraction: float
    """The fraction of the patches a query answers, averaged over the sphere's faces."""
    bytes: int
    """Size of the ``.pvis`` file."""
    visibility_bytes: int
    seconds: float
    peak_heap_bytes: int
    stages: Tuple[Stage, ...]
    warnings: Tuple[str, ...]


def _terminal_bar(step: str, done: int, total: int) -> None:
    """The default progress: one bar on stderr, redrawn in place."""
    width = 40
    filled = width * done // total if total else width
    bar = "=" * filled + (">" if filled < width else "") + " " * (width - filled - 1)
    end = "\n" if done >= total else ""
    sys.stderr.write(f"\r{step:>10} [{bar[:width]}] {done}/{total}{end}")
    sys.stderr.flush()


def _progress(progress: Union[ProgressCallback, bool, None]) -> Optional[ProgressCallback]:
    if progress is None:
        return _terminal_bar if sys.stderr is not None and sys.stderr.isatty() else None
    if progress is False:
        return None
    if progress is True:
        return _terminal_bar
    if not callable(progress):
        raise TypeError(f"progress must be a callable, True, False or None, not {progress!r}")
    return progress


def _options(**options: Any) -> dict:
    return {k: os.fspath(v) if k == "mesh_out" and v is not None else v for k, v in options.items()}


def _report(d: dict) -> BakeReport:
    stages = tuple(Stage(*s) for s in d.pop("stages"))
    warnings = tuple(d.pop("warnings"))
    output = os.fspath(d.pop("output"))
    mesh_out = d.pop("mesh_out")
    return BakeReport(
        output=output,
        mesh_out=None if mesh_out is None else os.fspath(mesh_out),
        stages=stages,
        warnings=warnings,
        **d,
    )


def bake(
    mesh_path: PathLike,
    out_path: PathLike,
    *,
    patches: Optional[int] = None,
    conservative: bool = False,
    memory: Optional[int] = None,
    mesh_out: Optional[PathLike] = None,
    progress: Union[ProgressCallback, bool, None] = None,
    level: Optional[int] = None,
    resolution: Optional[int] = None,
    fov: Optional[float] = None,
    shells: Optional[int] = None,
    shell_min: Optional[float] = None,
    shell_level: Optional[int] = None,
    shell_resolution: Optional[int] = None,
    far_shells: Union[Sequence[float], str, None] = None,
    view_supersample: Optional[int] = None,
    probe: Union[int, str, None] = None,
    apertures: Optional[int] = None,
    patch_order: Optional[str] = None,
    encoding: Optional[str] = None,
) -> BakeReport:
    """Bake the mesh at ``mesh_path`` (PLY, OBJ, STL, glTF/GLB) into ``out_path`` (``.pvis``).

    The same as ``patchvis bake MESH -o OUT`` with the flags of the same names, byte for byte:
    ``patches`` (default 1000), ``conservative`` (the never-miss preset), ``memory`` (heap
    budget in bytes; default half the available memory), ``mesh_out`` (also write the mesh
    reordered by patch: ``.glb``/``.gltf`` or PLY), ``level``, ``resolution``, ``fov``,
    ``shells``, ``shell_min``, ``shell_level``, ``shell_resolution``, ``far_shells`` (a list of
    multiples of the sampling distance, or ``"none"``), ``view_supersample``, ``probe``
    (pixels or ``"off"``), ``apertures`` (pixels; the probe also looks through gaps up to that
    wide), ``patch_order`` (``"covisibility"``/``"spatial"``), ``encoding``
    (``"tree"``/``"table"``/``"raw"``). ``None`` keeps the command's default.

    ``progress``: a callable ``progress(step, done, total)``, called at the start and end of
    each step and at most ten times a second between; ``None`` (default) draws a bar on stderr
    only when stderr is a terminal; ``False`` nothing. An exception it raises is re-raised
    when the bake ends (a bake cannot stop half way).

    The GIL is released while baking. Returns a :class:`BakeReport`. Raises ``ValueError``
    for bad settings or an unreadable mesh, ``OSError`` when an output cannot be written.
    Warnings of the bake (an input read differently from what it says) become Python
    warnings and are listed in the report.
    """
    options = _options(
        patches=patches, conservative=conservative, memory=memory, mesh_out=mesh_out,
        level=level, resolution=resolution, fov=fov, shells=shells, shell_min=shell_min,
        shell_level=shell_level, shell_resolution=shell_resolution, far_shells=far_shells,
        view_supersample=view_supersample, probe=probe, apertures=apertures,
        patch_order=patch_order, encoding=encoding,
    )
    d = _native.bake(os.fspath(mesh_path), os.fspath(out_path), options, _progress(progress))
    return _report(d)


def _positions(vertices: Any) -> np.ndarray:
    v = np.asarray(vertices)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"vertices has shape {v.shape}, expected (N, 3)")
    if not np.issubdtype(v.dtype, np.floating):
        raise TypeError(f"vertices has dtype {v.dtype}, expected float32 or float64")
    # float64 rounds to the nearest float32, as the mesh readers round a double PLY.
    return np.require(v, dtype=np.float32, requirements=["C", "A"])


def _triangles(faces: Any) -> np.ndarray:
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"faces has shape {f.shape}, expected (M, 3)")
    if not np.issubdtype(f.dtype, np.integer):
        raise TypeError(f"faces has dtype {f.dtype}, expected an integer dtype")
    if f.size and (int(f.min()) < 0 or int(f.max()) > 0xFFFFFFFF):
        raise ValueError(f"faces holds index {int(f.min()) if f.min() < 0 else int(f.max())}, "
                         "expected vertex indices from 0")
    return np.require(f, dtype=np.uint32, requirements=["C", "A"])


def bake_arrays(
    vertices: Any,
    faces: Any,
    out_path: PathLike,
    **options: Any,
) -> BakeReport:
    """Bake a mesh given as numpy arrays: ``vertices`` ``(N, 3)`` float32 or float64 (rounded
    to float32, as the file readers do), ``faces`` ``(M, 3)`` of any integer dtype, indices into
    ``vertices``. Takes the keyword arguments of :func:`bake`.

    Writes the same bytes as :func:`bake` (and ``patchvis bake``) of a file holding the same
    float32 positions and triangles, with the same settings. The mesh is built in memory: no
    file is written but the outputs.
    """
    progress = options.pop("progress", None)
    for name in options:
        if name not in _BAKE_OPTIONS:
            raise TypeError(f"bake_arrays() got an unexpected keyword argument {name!r}")
    positions = _positions(vertices)
    triangles = _triangles(faces)
    d = _native.bake_arrays(positions, triangles, os.fspath(out_path), _options(**options),
                            _progress(progress))
    return _report(d)


_BAKE_OPTIONS = frozenset(
    "patches conservative memory mesh_out level resolution fov shells shell_min shell_level "
    "shell_resolution far_shells view_supersample probe apertures patch_order encoding".split()
)


def read_mesh(path: PathLike) -> Tuple[np.ndarray, np.ndarray]:
    """The positions (``(N, 3)`` float32) and triangles (``(M, 3)`` uint32) of the mesh file
    at ``path``, as :func:`bake` reads them (PLY, OBJ, STL, glTF/GLB)."""
    return _native.read_mesh(os.fspath(path))
