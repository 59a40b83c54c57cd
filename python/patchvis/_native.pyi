# Type stubs of the Rust extension module (python/src/). The public API is patchvis/__init__.py.
from typing import Any, Dict, Optional, Tuple

import numpy as np
import numpy.typing as npt

MAX_PROBE_PIXELS: int

class FormatError(ValueError):
    """A .pvis file the reader refuses; the message is the reader's."""

def bake(
    mesh_path: str,
    out_path: str,
    options: Dict[str, Any],
    progress: Optional[Any] = None,
) -> Dict[str, Any]: ...
def bake_arrays(
    vertices: npt.NDArray[np.float32],
    faces: npt.NDArray[np.uint32],
    out_path: str,
    options: Dict[str, Any],
    progress: Optional[Any] = None,
) -> Dict[str, Any]: ...
def read_mesh(path: str) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.uint32]]: ...

class Reader:
    def __init__(self, data: bytes) -> None: ...
    @staticmethod
    def open(path: str) -> Reader: ...
    @property
    def patch_count(self) -> int: ...
    @property
    def triangle_count(self) -> int: ...
    @property
    def info(self) -> Dict[str, Any]: ...
    @property
    def patch_ranges(self) -> npt.NDArray[np.uint32]: ...
    def query(
        self,
        eye: Tuple[float, float, float],
        view_proj: Optional[Tuple[float, ...]] = None,
        zero_to_one: bool = False,
    ) -> npt.NDArray[np.uint32]: ...
    def ranges(
        self,
        eye: Tuple[float, float, float],
        view_proj: Optional[Tuple[float, ...]] = None,
        zero_to_one: bool = False,
    ) -> npt.NDArray[np.uint32]: ...
    def answer(
        self,
        eye: Tuple[float, float, float],
        view_proj: Optional[Tuple[float, ...]] = None,
        zero_to_one: bool = False,
    ) -> Dict[str, Any]: ...
    def query_many(
        self,
        eyes: npt.NDArray[np.float32],
        packed: bool = False,
        out: Optional[npt.NDArray[np.uint8]] = None,
    ) -> npt.NDArray[np.uint8]: ...
