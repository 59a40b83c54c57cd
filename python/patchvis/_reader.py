"""``Reader``: a ``.pvis`` file parsed once, answering "which patches can a camera at this
eye see?" as numpy arrays.

A thin layer over the Rust reader (``_native.Reader``): it converts eyes and matrices to the
float32 values the reader takes and names the depth conventions. Single queries use the
stateless query, the one ``patchvis query`` answers with; ``query_many`` the expanded reader
(every row decoded once, on its first call), with the GIL released. Both give the same sets.
"""

from __future__ import annotations

import os
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

from . import _native

_DEPTHS = {"gl": False, "zero-to-one": True}


def _eye(eye: Any) -> Tuple[float, float, float]:
    e = np.asarray(eye, dtype=np.float32).reshape(-1)
    if e.shape != (3,):
        raise ValueError(f"an eye is 3 coordinates (x, y, z), got {np.shape(eye)}")
    return (float(e[0]), float(e[1]), float(e[2]))


def _view_proj(matrix: Any) -> Tuple[float, ...]:
    m = np.asarray(matrix, dtype=np.float32)
    if m.shape == (4, 4):
        # m[row, col], clip = m @ (x, y, z, 1): stored column by column for the reader.
        m = m.T.reshape(16)
    elif m.shape != (16,):
        raise ValueError(
            f"view_proj has shape {m.shape}, expected (4, 4) (m[row, col]) or (16,) "
            "(column-major, as OpenGL and WebGPU store it)"
        )
    return tuple(float(x) for x in m)


def _camera_of(view_proj: Tuple[float, ...]) -> np.ndarray:
    """The eye of a perspective view-projection (16 numbers, column-major): the point whose
    clip coordinates have x = y = w = 0."""
    m = np.asarray(view_proj, dtype=np.float64).reshape(4, 4).T
    rows = m[[0, 1, 3]]
    try:
        return np.linalg.solve(rows[:, :3], -rows[:, 3])
    except np.linalg.LinAlgError:
        raise ValueError("view_proj has no eye (an orthographic projection?): pass eye=") from None


def _zero_to_one(depth: str) -> bool:
    try:
        return _DEPTHS[depth]
    except KeyError:
        raise ValueError(f'depth must be "gl" or "zero-to-one", not {depth!r}') from None


class Reader:
    """A ``.pvis`` file, validated once; queries cannot fail afterwards.

    ``Reader(path)`` reads the file at ``path``; ``Reader(data)`` takes its bytes (``bytes``,
    ``bytearray`` or ``memoryview``). A file the reader refuses raises
    :class:`patchvis.FormatError` with the reader's message (the spec's rule it breaks).

    An eye is a model-space position ``(x, y, z)``, rounded to float32. An eye inside the
    innermost sampling shell (or the sampling sphere) is answered with every patch.
    """

    def __init__(self, source: Union[str, "os.PathLike[str]", bytes, bytearray, memoryview]):
        if isinstance(source, (bytes, bytearray, memoryview)):
            self._native = _native.Reader(bytes(source))
        else:
            self._native = _native.Reader.open(os.fspath(source))

    @property
    def info(self) -> Dict[str, Any]:
        """What the file holds, as ``patchvis info --json`` prints it: ``version``,
        ``patches``, ``triangles``, ``level``, ``views``, ``camera`` (``center``, ``radius``,
        ``distance``, ``fov_deg``, ``resolution``), ``bytes`` (``total``, ``visibility``,
        ``patch_table``, ``shells``), ``sampling_shell``, ``sampling_reach`` and ``shells``."""
        return self._native.info

    @property
    def patch_count(self) -> int:
        """Number of patches: the width of ``query_many``'s answer."""
        return self._native.patch_count

    @property
    def triangle_count(self) -> int:
        """Number of triangles of the mesh the file was baked from."""
        return self._native.triangle_count

    @property
    def patch_ranges(self) -> np.ndarray:
        """Each patch's triangles as a ``(patches, 2)`` uint32 array: first triangle and count,
        in the order of the mesh written by ``mesh_out``."""
        return self._native.patch_ranges

    def query(self, eye: Any) -> np.ndarray:
        """The patches visible from ``eye``: ascending uint32 patch ids."""
        return self._native.query(_eye(eye))

    def ranges(self, eye: Any) -> np.ndarray:
        """The triangles of ``query(eye)``'s patches as a ``(K, 2)`` uint32 array of
        ``(first, count)``, neighbouring patches merged: one draw call each."""
        return self._native.ranges(_eye(eye))

    def query_frustum(self, view_proj: Any, depth: str = "gl", eye: Optional[Any] = None) -> np.ndarray:
        """The patches visible from the camera of ``view_proj`` and not wholly outside its
        frustum (their bounding spheres): ascending uint32 patch ids.

        ``view_proj`` maps model space to clip space: ``(4, 4)`` as ``m[row, col]``, or 16
        numbers column-major. ``depth``: ``"gl"`` (-w <= z <= w: OpenGL, WebGL) or
        ``"zero-to-one"`` (0 <= z <= w: Direct3D, Vulkan, Metal, WebGPU). ``eye``: the
        camera's position; by default the one of a perspective ``view_proj`` (the point it maps
        to x = y = w = 0), which an orthographic one has not (then pass ``eye``)."""
        m = _view_proj(view_proj)
        e = _eye(_camera_of(m) if eye is None else eye)
        return self._native.query(e, m, _zero_to_one(depth))

    def answer(
        self, eye: Any, view_proj: Optional[Any] = None, depth: str = "gl"
    ) -> Dict[str, Any]:
        """The whole answer, as ``patchvis query --json`` prints it: ``patches``, ``ranges``,
        ``inside_sphere``, ``band``, ``shells``, ``triangles``, ``views``, ``inner_views``
        (and ``outside_frustum`` with ``view_proj``), in plain Python lists."""
        if view_proj is None:
            return self._native.answer(_eye(eye))
        return self._native.answer(_eye(eye), _view_proj(view_proj), _zero_to_one(depth))

    def query_many(self, eyes: Any, packed: bool = False, out: Optional[np.ndarray] = None) -> np.ndarray:
        """The visible sets of many eyes (``(N, 3)``), as an ``(N, patch_count)`` bool array:
        ``out[i, p]`` says whether eye ``i`` sees patch ``p``. With ``packed``, an
        ``(N, ceil(patch_count / 8))`` uint8 array of the same bits, 8 patches a byte
        (``numpy.unpackbits(out, axis=1, count=patch_count, bitorder="little")`` unpacks it):
        an eighth of the memory, and faster. ``out``: a C-contiguous array of that shape and
        dtype to fill instead of a new one (reusing it saves the new memory's page faults,
        most of the time of a large call). The GIL is released while it runs, and past a few
        thousand eyes they are shared out over the machine's cores."""
        e = np.require(eyes, dtype=np.float32, requirements=["C", "A"])
        if e.ndim != 2 or e.shape[1] != 3:
            raise ValueError(f"eyes has shape {e.shape}, expected (N, 3)")
        if out is None:
            got = self._native.query_many(e, packed)
            return got if packed else got.view(np.bool_)
        want = np.uint8 if packed else np.bool_
        if not isinstance(out, np.ndarray) or out.dtype != want:
            raise TypeError(f"out must be a numpy array of dtype {np.dtype(want)}")
        self._native.query_many(e, packed, out if packed else out.view(np.uint8))
        return out

    def __repr__(self) -> str:
        return repr(self._native)
