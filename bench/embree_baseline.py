#!/usr/bin/env python3
"""Baseline for the sampling stage: Embree 4 (through the `embreex` package) casting one primary
ray per pixel from every sampling view, the way a user would script it without patchvis.

    pip install embreex trimesh
    python3 bench/embree_baseline.py assets/bunny.ply --level 4 --resolution 512 [--threads 2]

Cameras follow spec/FORMAT.md ("Sampling sphere"): octahedron subdivided `level` times, eye at
centre + d * radius / sin(fov/2) looking at the centre of the bounding-box-centred sphere.
Prints BVH build time, total and per-view ray time, and peak memory (ru_maxrss).
"""
import argparse
import os
import resource
import time

# numpy's BLAS threads busy-wait after each product and would count as CPU time here.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import trimesh
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh


def sphere_views(level):
    verts = [np.array(v, dtype=np.float64) for v in
             [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]]
    faces = []
    for sx in (1, -1):
        for sy in (1, -1):
            for sz in (1, -1):
                a, b, c = (0 if sx > 0 else 1), (2 if sy > 0 else 3), (4 if sz > 0 else 5)
                faces.append((a, b, c) if sx * sy * sz > 0 else (a, c, b))
    for _ in range(level):
        mids, new_faces = {}, []

        def mid(i, j):
            key = (min(i, j), max(i, j))
            if key not in mids:
                m = verts[i] + verts[j]
                verts.append(m / np.linalg.norm(m))
                mids[key] = len(verts) - 1
            return mids[key]
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new_faces += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
        faces = new_faces
    return np.array(verts)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mesh")
    ap.add_argument("--level", type=int, default=4)
    ap.add_argument("--resolution", type=int, default=512)
    ap.add_argument("--fov", type=float, default=45.0)
    ap.add_argument("--threads", type=int, default=1,
                    help="views cast concurrently (Python threads; embreex releases the GIL "
                         "only if its build does, so compare the printed CPU time)")
    args = ap.parse_args()

    mesh = trimesh.load(args.mesh, process=False)
    v = np.asarray(mesh.vertices, dtype=np.float32)
    f = np.asarray(mesh.faces, dtype=np.int32)
    lo, hi = v.min(axis=0).astype(np.float64), v.max(axis=0).astype(np.float64)
    center = (lo + hi) / 2
    radius = np.sqrt(((v.astype(np.float64) - center) ** 2).sum(axis=1).max())
    distance = radius / np.sin(np.radians(args.fov) / 2)

    t0 = time.perf_counter()
    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, v[f])
    # The BVH is built lazily on the first query: time a single ray to include it.
    scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))
    build = time.perf_counter() - t0

    n = args.resolution
    tan = np.tan(np.radians(args.fov) / 2)
    px = ((np.arange(n) + 0.5) / n * 2 - 1) * tan
    sx, sy = np.meshgrid(px, -px)
    # Pixel rays in camera space (right, up, forward), float32: one small matrix product
    # per view turns them into world directions, so Python adds as little as possible to
    # Embree's own time (which is also timed alone: `in scene.run`).
    local = np.stack([sx.ravel(), sy.ravel(), np.ones(n * n)], axis=1).astype(np.float32)
    views = sphere_views(args.level)
    in_run = []
    in_run_cpu = []

    def cast(d):
        eye = center + d * distance
        fw = -d
        up0 = np.array([0.0, 0.0, 1.0]) if abs(fw[1]) > 0.999 else np.array([0.0, 1.0, 0.0])
        r = np.cross(fw, up0)
        r /= np.linalg.norm(r)
        u = np.cross(r, fw)
        dirs = local @ np.stack([r, u, fw]).astype(np.float32)
        origins = np.empty_like(dirs)
        origins[:] = eye.astype(np.float32)
        t, c = time.perf_counter(), time.thread_time()
        ids = scene.run(origins, dirs)
        in_run.append(time.perf_counter() - t)
        in_run_cpu.append(time.thread_time() - c)
        seen = np.zeros(len(f) + 1, dtype=bool)
        seen[ids + 1] = True
        return int(seen[1:].sum())

    t0 = time.perf_counter()
    c0 = time.process_time()
    if args.threads > 1:
        from concurrent.futures import ThreadPoolExecutor
        with ThreadPoolExecutor(args.threads) as pool:
            seen_total = sum(pool.map(cast, views))
    else:
        seen_total = sum(map(cast, views))
    rays = time.perf_counter() - t0
    cpu = time.process_time() - c0
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"embree: {len(f)} triangles, {len(views)} views at {n}x{n}: build {build:.3f} s, "
          f"rays {rays:.2f} s wall, {cpu:.2f} s CPU ({rays / len(views) * 1000:.1f} ms/view), "
          f"{args.threads} thread(s), in scene.run {sum(in_run):.2f} s wall / "
          f"{sum(in_run_cpu):.2f} s CPU, peak RSS {rss:.0f} MiB, "
          f"mean triangles seen per view {seen_total / len(views):.0f}")


if __name__ == "__main__":
    main()
