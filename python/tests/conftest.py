"""Shared fixtures: the repository's files, the `patchvis` binary the Python package is
compared with, and the bakes the tests query.

The binary is PATCHVIS_BIN, else the first of target/{release,debug}/patchvis that exists
(CARGO_TARGET_DIR honoured). Without one the comparisons are skipped, except under CI, where
.ci/run builds it and a missing binary is an error.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import patchvis

REPO = Path(__file__).resolve().parents[2]
BUNNY = REPO / "assets" / "bunny.ply"

#: Fast settings: 258 views at 256 px, no shells, no supersampling, no probe (under a
#: second of sampling in a release build).
FAST = dict(patches=300, level=3, resolution=256, shells=0, far_shells="none",
            view_supersample=0, probe="off")
#: The same with near and far sampling shells, so that queries cross every band.
SHELLS = dict(FAST, patches=200, level=2, shells=2, far_shells=[2.0, 8.0])


def cli_flags(options: dict) -> list:
    """`patchvis bake` flags of `patchvis.bake` keyword arguments."""
    flags = []
    for key, value in options.items():
        flag = "--" + key.replace("_", "-")
        if isinstance(value, (list, tuple)):
            value = ",".join(repr(float(v)) for v in value)
        flags += [flag, str(value)]
    return flags


def find_binary():
    if os.environ.get("PATCHVIS_BIN"):
        return Path(os.environ["PATCHVIS_BIN"])
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    for profile in ("release", "debug"):
        if (target / profile / "patchvis").exists():
            return target / profile / "patchvis"
    return None


@pytest.fixture(scope="session")
def cli():
    """Runs the `patchvis` binary; returns its stdout."""
    binary = find_binary()
    if binary is None or not binary.exists():
        if os.environ.get("CI"):
            pytest.fail("no patchvis binary: set PATCHVIS_BIN (.ci/run builds it)")
        pytest.skip("no patchvis binary (set PATCHVIS_BIN or cargo build --bin patchvis)")

    def run(*args) -> str:
        done = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        return done.stdout

    return run


@pytest.fixture(scope="session")
def cli_fast(cli, tmp_path_factory) -> Path:
    """The bunny baked by `patchvis bake` with FAST."""
    out = tmp_path_factory.mktemp("cli") / "fast.pvis"
    cli("bake", BUNNY, "-o", out, "--quiet", *cli_flags(FAST))
    return out


@pytest.fixture(scope="session")
def cli_shells(cli, tmp_path_factory) -> Path:
    """The bunny baked by `patchvis bake` with SHELLS."""
    out = tmp_path_factory.mktemp("cli") / "shells.pvis"
    cli("bake", BUNNY, "-o", out, "--quiet", *cli_flags(SHELLS))
    return out


@pytest.fixture(scope="session")
def shells_file(tmp_path_factory) -> Path:
    """The bunny baked by `patchvis.bake` with SHELLS (no binary needed)."""
    out = tmp_path_factory.mktemp("py") / "shells.pvis"
    patchvis.bake(BUNNY, out, progress=False, **SHELLS)
    return out


def read_ply(path: Path):
    """The bunny's binary little-endian PLY read with numpy alone: float32 positions, int32
    triangles."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    count = {l.split()[1]: int(l.split()[2]) for l in header if l.startswith("element ")}
    nv, nf = count["vertex"], count["face"]
    vertices = np.frombuffer(data, dtype="<f4", count=3 * nv, offset=end).reshape(nv, 3)
    face = np.dtype([("n", "u1"), ("i", "<i4", (3,))])
    faces = np.frombuffer(data, dtype=face, count=nf, offset=end + 12 * nv)
    assert (faces["n"] == 3).all()
    return vertices, faces["i"]


def seeded_eyes(reader: patchvis.Reader, n: int, seed: int, near=0.3, far=12.0) -> np.ndarray:
    """`n` float32 eyes around the model, from `near` to `far` sampling distances from its
    centre (log-uniform), so that every band of a file with shells is asked."""
    camera = reader.info["camera"]
    rng = np.random.default_rng(seed)
    d = rng.standard_normal((n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    r = camera["distance"] * np.exp(rng.uniform(np.log(near), np.log(far), n))
    return (np.asarray(camera["center"]) + d * r[:, None]).astype(np.float32)


def point(eye) -> str:
    """An eye as `--from` takes it; the decimal reads back to the same float32."""
    return ",".join(repr(float(c)) for c in np.asarray(eye, dtype=np.float32))
