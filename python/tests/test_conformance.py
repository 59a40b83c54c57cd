"""The package through ``patchvis conformance``: every vector, truncated copies and frustum
queries included, through conformance_adapter.py run by this interpreter."""

import shlex
import sys
from pathlib import Path

from conftest import REPO


def test_every_conformance_vector_passes(cli):
    adapter = Path(__file__).with_name("conformance_adapter.py")
    command = f"{shlex.quote(sys.executable)} {shlex.quote(str(adapter))}"
    out = cli("conformance", "--vectors", REPO / "tests" / "conformance", "--reader", command)
    lines = out.splitlines()
    assert all(line.startswith("pass ") for line in lines[:-1]), out
    summary = lines[-1]
    vectors = len(lines) - 1
    assert summary.startswith(f"{vectors} of {vectors} vectors pass"), summary
    assert "reader: full, frustum" in summary and " 0 frustum" not in summary, summary
