"""query_many's time per eye against the Rust expanded query's, on the same file and machine.

    python python/bench/query_many.py [--pvis b2000.pvis] [--eyes 100000] [--bin patchvis]

Without --pvis, bakes the bunny at 2000 patches with the default settings (the file of
BENCHMARKS.md's query rows: `patchvis bake assets/bunny.ply -o b2000.pvis --patches 2000`)
into a temporary folder. The eyes are seeded, at 1.5 times the sampling distance from the
centre, as `patchvis query --bench` places its eyes. Times `Reader.query_many` (bool and
packed answers, each into a new array and into a reused `out=`; the first call, which
expands the file, is left out) as the median of 5 runs, then runs `patchvis query FILE --bench N` and reads its "expanded query, random eyes"
median: the baseline, in the same run on the same machine. Prints one line per figure and
the ratios (target: bool answers within 3x the baseline).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import patchvis

REPO = Path(__file__).resolve().parents[2]


def eyes_around(reader: patchvis.Reader, n: int) -> np.ndarray:
    camera = reader.info["camera"]
    rng = np.random.default_rng(0x5EED)
    d = rng.standard_normal((n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return (np.asarray(camera["center"]) + 1.5 * camera["distance"] * d).astype(np.float32)


def median_ns_per_eye(f, n: int, runs: int = 5) -> float:
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return 1e9 * float(np.median(times)) / n


def baseline_ns(binary: str, pvis: Path, n: int) -> float:
    out = subprocess.run([binary, "query", str(pvis), "--bench", str(n)], check=True,
                         capture_output=True, text=True).stdout
    m = re.search(r"expanded query, random eyes\s+([\d.]+) ns", out)
    if not m:
        sys.exit(f"no expanded-query line in:\n{out}")
    return float(m.group(1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pvis", type=Path)
    parser.add_argument("--eyes", type=int, default=100_000)
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    parser.add_argument("--bin", default=os.environ.get("PATCHVIS_BIN", str(target / "release" / "patchvis")))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        pvis = args.pvis
        if pvis is None:
            pvis = Path(tmp) / "b2000.pvis"
            t = time.perf_counter()
            patchvis.bake(REPO / "assets" / "bunny.ply", pvis, patches=2000)
            print(f"baked {pvis.name} in {time.perf_counter() - t:.1f} s")
        reader = patchvis.Reader(pvis)
        eyes = eyes_around(reader, args.eyes)
        n = len(eyes)
        t = time.perf_counter()
        reader.query_many(eyes[:1])
        print(f"{reader!r}; first query_many (expands the file): {1e3 * (time.perf_counter() - t):.1f} ms")
        bool_out = np.empty((n, reader.patch_count), dtype=np.bool_)
        packed_out = np.empty((n, (reader.patch_count + 7) // 8), dtype=np.uint8)
        figures = [
            (f"bool (N, {reader.patch_count}), new array", lambda: reader.query_many(eyes)),
            ("bool, into a reused out=", lambda: reader.query_many(eyes, out=bool_out)),
            ("packed bits, new array", lambda: reader.query_many(eyes, packed=True)),
            ("packed bits, into a reused out=", lambda: reader.query_many(eyes, packed=True, out=packed_out)),
        ]
        times = [(name, median_ns_per_eye(f, n)) for name, f in figures]
        base = baseline_ns(args.bin, pvis, n)
        for name, ns in times:
            print(f"query_many, {n} eyes, {name:34} {ns:7.0f} ns/eye  ({ns / base:.2f}x)")
        print(f"baseline: patchvis query --bench {n}, expanded query, random eyes: {base:.0f} ns")


if __name__ == "__main__":
    main()
