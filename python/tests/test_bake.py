"""Baking from a file and from numpy arrays: the bytes `patchvis bake` writes with the same
settings, the report, progress, warnings-free defaults and the errors of bad arguments."""

from __future__ import annotations

import numpy as np
import pytest

import patchvis
from conftest import BUNNY, FAST, SHELLS, cli_flags, read_ply


def test_bake_file_is_the_commands_bytes(cli_fast, tmp_path):
    out = tmp_path / "py.pvis"
    report = patchvis.bake(BUNNY, out, progress=False, **FAST)
    assert out.read_bytes() == cli_fast.read_bytes()
    assert report.input == str(BUNNY) and report.output == str(out)
    assert (report.triangles, report.vertices, report.patches) == (99785, 50000, 300)
    assert (report.level, report.views, report.shells) == (3, 258, 0)
    assert report.bytes == out.stat().st_size
    assert 0 < report.visibility_bytes < report.bytes
    names = [s.name for s in report.stages]
    assert names[:3] == ["input", "tiling", "sampling"] and "encoding" in names
    assert report.peak_heap_bytes == max(s.peak_heap_bytes for s in report.stages) > 0
    assert report.seconds >= sum(s.seconds for s in report.stages) * 0.99
    assert report.warnings == ()
    assert not list(tmp_path.glob("*.ckpt")), "the checkpoints are removed"


def test_bake_with_shells_and_mesh_out_is_the_commands_bytes(cli, tmp_path):
    cli("bake", BUNNY, "-o", tmp_path / "cli.pvis", "--mesh-out", tmp_path / "cli.glb",
        "--quiet", *cli_flags(SHELLS))
    report = patchvis.bake(BUNNY, tmp_path / "py.pvis", mesh_out=tmp_path / "py.glb",
                           progress=False, **SHELLS)
    assert (tmp_path / "py.pvis").read_bytes() == (tmp_path / "cli.pvis").read_bytes()
    assert (tmp_path / "py.glb").read_bytes() == (tmp_path / "cli.glb").read_bytes()
    assert report.mesh_out == str(tmp_path / "py.glb") and report.shells == 4


def test_bake_arrays_is_the_commands_bytes(cli_fast, tmp_path):
    vertices, faces = read_ply(BUNNY)
    report = patchvis.bake_arrays(vertices, faces, tmp_path / "a.pvis", progress=False, **FAST)
    assert (tmp_path / "a.pvis").read_bytes() == cli_fast.read_bytes()
    assert report.input == "<arrays>" and report.triangles == len(faces)
    # float64 positions holding the same float32 values, and int64 indices: the same bytes.
    patchvis.bake_arrays(vertices.astype(np.float64), faces.astype(np.int64),
                         tmp_path / "b.pvis", progress=False, **FAST)
    assert (tmp_path / "b.pvis").read_bytes() == cli_fast.read_bytes()


def test_read_mesh_is_the_files_arrays():
    vertices, faces = patchvis.read_mesh(BUNNY)
    want_v, want_f = read_ply(BUNNY)
    assert vertices.dtype == np.float32 and faces.dtype == np.uint32
    np.testing.assert_array_equal(vertices, want_v)
    np.testing.assert_array_equal(faces, want_f)


def test_progress_callback_is_called(tmp_path):
    calls = []
    patchvis.bake(BUNNY, tmp_path / "p.pvis", progress=lambda *a: calls.append(a), **FAST)
    steps = [c[0] for c in calls]
    assert "sampling" in steps
    sampling = [c for c in calls if c[0] == "sampling"]
    assert sampling[0][1:] == (0, 258) and sampling[-1][1:] == (258, 258)
    assert all(0 <= done <= total for _, done, total in sampling)
    assert [d for _, d, _ in sampling] == sorted(d for _, d, _ in sampling)


def test_progress_exception_is_raised_after_the_bake(tmp_path):
    class Stop(Exception):
        pass

    def progress(step, done, total):
        raise Stop(step)

    with pytest.raises(Stop):
        patchvis.bake(BUNNY, tmp_path / "x.pvis", progress=progress, **FAST)


def test_bad_arguments(tmp_path):
    out = tmp_path / "bad.pvis"
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
    with pytest.raises(ValueError, match="triangle 0 has vertex index 3"):
        patchvis.bake_arrays(v, [[0, 1, 3]], out, progress=False)
    with pytest.raises(ValueError, match=r"expected \(N, 3\)"):
        patchvis.bake_arrays(v[:, :2], [[0, 1, 2]], out)
    with pytest.raises(ValueError, match="expected vertex indices from 0"):
        patchvis.bake_arrays(v, [[0, 1, -1]], out)
    with pytest.raises(TypeError, match="integer dtype"):
        patchvis.bake_arrays(v, [[0.0, 1.0, 2.0]], out)
    with pytest.raises(TypeError, match="unexpected keyword argument 'patchez'"):
        patchvis.bake_arrays(v, [[0, 1, 2]], out, patchez=3)
    with pytest.raises(ValueError, match="probe"):
        patchvis.bake(BUNNY, out, probe=patchvis._native.MAX_PROBE_PIXELS + 1)
    with pytest.raises(ValueError, match="--apertures 17"):
        patchvis.bake(BUNNY, out, apertures=17)
    with pytest.raises(ValueError, match="apertures"):
        patchvis.bake(BUNNY, out, apertures=2, probe="off")
    with pytest.raises(ValueError, match="level"):
        patchvis.bake(BUNNY, out, level=9)
    with pytest.raises(ValueError):
        patchvis.bake(tmp_path / "missing.ply", out, progress=False)
    assert not out.exists()


def test_the_gil_is_released_while_baking(tmp_path):
    """Another Python thread runs while a bake does."""
    import threading

    done = threading.Event()
    ticks = 0

    def run():
        patchvis.bake(BUNNY, tmp_path / "g.pvis", progress=False, **FAST)
        done.set()

    worker = threading.Thread(target=run)
    worker.start()
    while not done.is_set():
        ticks += 1
        done.wait(0.001)
    worker.join()
    assert ticks > 20, ticks


@pytest.mark.parametrize("conservative", [False, True])
def test_default_pipeline_is_the_commands_bytes(cli, tmp_path, conservative):
    """The default passes (probe, view supersampling, near and far shells; or the
    conservative preset's), on a small mesh at a coarse level and resolution."""
    ant = BUNNY.with_name("ant.ply")
    options = dict(patches=100, level=2, resolution=64)
    flags = cli_flags(options) + (["--conservative"] if conservative else [])
    cli("bake", ant, "-o", tmp_path / "cli.pvis", "--quiet", *flags)
    report = patchvis.bake(ant, tmp_path / "py.pvis", conservative=conservative, progress=False,
                           **options)
    assert (tmp_path / "py.pvis").read_bytes() == (tmp_path / "cli.pvis").read_bytes()
    assert report.shells > 0
    vertices, faces = patchvis.read_mesh(ant)
    patchvis.bake_arrays(vertices, faces, tmp_path / "arrays.pvis", conservative=conservative,
                         progress=False, **options)
    assert (tmp_path / "arrays.pvis").read_bytes() == (tmp_path / "cli.pvis").read_bytes()


def test_apertures_are_the_commands_bytes(cli, tmp_path):
    """`apertures` reaches the bake as `--apertures` does, and changes the rows."""
    ant = BUNNY.with_name("ant.ply")
    options = dict(patches=100, level=2, resolution=64, apertures=4)
    cli("bake", ant, "-o", tmp_path / "cli.pvis", "--quiet", "--conservative",
        *cli_flags(options))
    patchvis.bake(ant, tmp_path / "py.pvis", conservative=True, progress=False, **options)
    assert (tmp_path / "py.pvis").read_bytes() == (tmp_path / "cli.pvis").read_bytes()
    del options["apertures"]
    patchvis.bake(ant, tmp_path / "none.pvis", conservative=True, progress=False, **options)
    assert (tmp_path / "none.pvis").read_bytes() != (tmp_path / "py.pvis").read_bytes()
