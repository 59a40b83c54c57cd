"""Reading and querying: answers equal `patchvis query --json` and `info --json`, query_many
equals query, frustum queries in both depth conventions, and refused files raise
FormatError with the reader's exact message (every invalid conformance vector)."""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import patchvis
from conftest import REPO, point, seeded_eyes

EYES = 1000


def test_info_is_info_json(cli, cli_shells):
    reader = patchvis.Reader(cli_shells)
    assert reader.info == json.loads(cli("info", cli_shells, "--json"))
    assert patchvis.Reader(cli_shells.read_bytes()).info == reader.info
    assert reader.patch_count == 200 and reader.triangle_count == 99785
    ranges = reader.patch_ranges
    assert ranges.shape == (200, 2) and ranges[0, 0] == 0
    assert (ranges[1:, 0] == ranges[:-1, 0] + ranges[:-1, 1]).all()
    assert ranges[:, 1].sum() == 99785


def test_answers_are_query_json(cli, cli_shells):
    """At 1,000 seeded eyes in every band: the answer, the patches and the ranges."""
    reader = patchvis.Reader(cli_shells)
    eyes = seeded_eyes(reader, EYES, seed=1)
    with ThreadPoolExecutor(4) as pool:
        outs = list(pool.map(lambda e: cli("query", cli_shells, "--from", point(e), "--json"), eyes))
    bands = set()
    for eye, out in zip(eyes, outs):
        want = json.loads(out)
        assert reader.answer(eye) == want, eye
        np.testing.assert_array_equal(reader.query(eye), want["patches"])
        np.testing.assert_array_equal(reader.ranges(eye).reshape(-1, 2),
                                      np.asarray(want["ranges"], dtype=np.uint32).reshape(-1, 2))
        bands.add(want["band"])
    assert bands == {0, 1, 2, 3, 4, 5}, "every band of the four shells and the sphere"


def test_query_many_is_query(cli_shells):
    reader = patchvis.Reader(cli_shells)
    eyes = seeded_eyes(reader, EYES, seed=2)
    many = reader.query_many(eyes)
    assert many.shape == (EYES, 200) and many.dtype == np.bool_
    for eye, row in zip(eyes, many):
        np.testing.assert_array_equal(np.flatnonzero(row), reader.query(eye))
    packed = reader.query_many(eyes, packed=True)
    assert packed.shape == (EYES, 25) and packed.dtype == np.uint8
    np.testing.assert_array_equal(packed, np.packbits(many, axis=1, bitorder="little"))
    # Into a given array, reused.
    out = np.ones_like(many)
    assert reader.query_many(eyes, out=out) is out
    np.testing.assert_array_equal(out, many)
    out = np.zeros_like(packed)
    reader.query_many(eyes, packed=True, out=out)
    np.testing.assert_array_equal(out, packed)
    with pytest.raises(ValueError, match="out has shape"):
        reader.query_many(eyes[:10], out=many)
    with pytest.raises(TypeError, match="dtype bool"):
        reader.query_many(eyes, out=packed)
    # float64 eyes, lists, and no eyes at all.
    np.testing.assert_array_equal(reader.query_many(eyes.astype(np.float64)[:5].tolist()), many[:5])
    assert reader.query_many(np.zeros((0, 3))).shape == (0, 200)


def test_query_many_splits_many_eyes_over_threads_and_answers_alike(cli_shells):
    """Past one thread's share (4,096 eyes) the eyes are answered on several threads: each
    row is still its own eye's answer, in order."""
    reader = patchvis.Reader(cli_shells)
    eyes = seeded_eyes(reader, 12_345, seed=3)
    many = reader.query_many(eyes)
    assert many.shape == (12_345, 200)
    for i in range(0, 12_345, 97):
        np.testing.assert_array_equal(np.flatnonzero(many[i]), reader.query(eyes[i]))
    packed = reader.query_many(eyes, packed=True)
    np.testing.assert_array_equal(packed, np.packbits(many, axis=1, bitorder="little"))
    np.testing.assert_array_equal(reader.query_many(eyes[::-1]), many[::-1])


def look_at(eye, target, fov_deg=45.0, near=1.0, far=1000.0, zero_to_one=False) -> np.ndarray:
    """A perspective view-projection (m[row, col], world up +Y)."""
    eye, target = np.asarray(eye, np.float64), np.asarray(target, np.float64)
    f = target - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, [0.0, 1.0, 0.0])
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = s, u, -f
    view[:3, 3] = -view[:3, :3] @ eye
    t = 1.0 / np.tan(np.radians(fov_deg) / 2)
    proj = np.zeros((4, 4))
    proj[0, 0] = proj[1, 1] = t
    if zero_to_one:
        proj[2, 2], proj[2, 3] = far / (near - far), near * far / (near - far)
    else:
        proj[2, 2], proj[2, 3] = (far + near) / (near - far), 2 * far * near / (near - far)
    proj[3, 2] = -1.0
    return proj @ view


@pytest.mark.parametrize("depth", ["gl", "zero-to-one"])
def test_query_frustum_is_query_json(cli, cli_shells, depth):
    reader = patchvis.Reader(cli_shells)
    center = np.asarray(reader.info["camera"]["center"])
    eyes = seeded_eyes(reader, 40, seed=3, near=0.5, far=3.0)
    rng = np.random.default_rng(4)
    culled = same = 0
    for eye in eyes:
        # Looking near the model, often past its edge, so the frustum cuts some patches.
        target = center + rng.normal(0, 30.0, 3)
        m = look_at(eye, target, zero_to_one=depth == "zero-to-one").astype(np.float32)
        flat = ",".join(repr(float(x)) for x in m.T.reshape(16))
        want = json.loads(cli("query", cli_shells, "--from", point(eye), "--view-proj", flat,
                              "--depth", depth, "--json"))
        got = reader.query_frustum(m, depth=depth, eye=eye)
        np.testing.assert_array_equal(got, want["patches"])
        assert reader.answer(eye, m, depth) == want
        # Column-major 16 numbers are the same matrix.
        np.testing.assert_array_equal(reader.query_frustum(m.T.reshape(16), depth, eye=eye), got)
        # The eye recovered from the matrix: within float32 rounding of the camera's.
        from patchvis._reader import _camera_of, _view_proj
        np.testing.assert_allclose(_camera_of(_view_proj(m)), eye, rtol=0, atol=1e-3 * np.linalg.norm(eye))
        same += np.array_equal(reader.query_frustum(m, depth), got)
        culled += want["outside_frustum"]
    assert culled > 0, "some frustum cut a patch"
    assert same >= 0.9 * len(eyes), "the recovered eye mostly answers as the camera's"
    with pytest.raises(ValueError, match="depth"):
        reader.query_frustum(np.eye(4), depth="dx", eye=eyes[0])
    with pytest.raises(ValueError, match="orthographic"):
        reader.query_frustum(np.eye(4))


def test_refused_files_raise_format_error(shells_file, tmp_path):
    data = shells_file.read_bytes()
    with pytest.raises(patchvis.FormatError, match=f"header says {len(data)} bytes, data has 100"):
        patchvis.Reader(data[:100])
    with pytest.raises(patchvis.FormatError, match="truncated"):
        patchvis.Reader(data[:8])
    with pytest.raises(patchvis.FormatError, match="bad signature"):
        patchvis.Reader(b"XXXX" + data[4:])
    corrupt = bytearray(data)
    corrupt[len(data) // 2] ^= 0x40
    (tmp_path / "corrupt.pvis").write_bytes(corrupt)
    with pytest.raises(patchvis.FormatError, match="checksum mismatch"):
        patchvis.Reader(tmp_path / "corrupt.pvis")
    assert issubclass(patchvis.FormatError, ValueError)
    with pytest.raises(FileNotFoundError):
        patchvis.Reader(tmp_path / "missing.pvis")


def test_conformance_vectors():
    """Every valid vector opens with its dump's counts; every invalid one is refused with the
    reference reader's exact message."""
    vectors = REPO / "tests" / "conformance"
    valid = sorted((vectors / "valid").glob("*.pvis"))
    for path in valid:
        dump = path.with_suffix(".dump").read_text()
        fields = dict(l.split(": ", 1) for l in dump.splitlines() if l.startswith(("patches: ", "triangles: ")))
        reader = patchvis.Reader(path)
        assert reader.patch_count == int(fields["patches"]), path.name
        assert reader.triangle_count == int(fields["triangles"]), path.name
    invalid = sorted((vectors / "invalid").glob("*.pvis"))
    for path in invalid:
        expected = path.with_suffix(".err").read_text().rstrip("\n")
        with pytest.raises(patchvis.FormatError) as refused:
            patchvis.Reader(path.read_bytes())
        assert str(refused.value) == expected, path.name
    assert len(valid) > 10 and len(invalid) > 50
