#!/usr/bin/env python3
"""Time arbor's mesh queries against Open3D's RaycastingScene on the same
rays and points, and check that the answers agree.

  queries_vs_open3d.py --arbor target/release/arbor --mesh MESH.{obj,msh}
                       [--rays RAYS] [--points N] [--threads 2] [--repeat 5]

Rays: a ray file of shared/peers/FORMAT.md (for example the diffuse rays of
`embree_trace gen`); without --rays, rays from random points of the mesh's
box in random directions. Points: N uniform points in the mesh's box grown
by 10 %. Both tools see the same arrays. arbor runs as `arbor trace --query
count|all`, `arbor inside`, `arbor nearest [--signed]` (its JSON line gives
the query time); Open3D's calls are timed around the call alone, best and
median of --repeat. Open3D counts every triangle a ray meets (twice at a
shared edge), arbor each crossing once, so a few counts differ; distances
agree to float rounding. Needs numpy and open3d (pip install open3d-cpu;
Debian's libusb-1.0-0).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np


def read_mesh(path):
    """Vertices (n, 3) float32 and triangles (m, 3) uint32, numbered as
    `arbor trace` numbers them (.msh in order, .obj polygons as fans)."""
    if path.endswith(".msh"):
        tok = open(path).read().split()
        nv, nt = int(tok[0]), int(tok[1])
        i = tok.index("vertices") + 1
        v = np.array(tok[i:i + 3 * nv], dtype=np.float32).reshape(nv, 3)
        j = tok.index("triangles", i + 3 * nv) + 1
        t = np.array(tok[j:j + 3 * nt], dtype=np.uint32).reshape(nt, 3)
        return v, t
    verts, tris = [], []
    for line in open(path):
        w = line.split()
        if not w:
            continue
        if w[0] == "v":
            verts.append([float(x) for x in w[1:4]])
        elif w[0] == "f":
            idx = [int(x.split("/")[0]) for x in w[1:]]
            idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
            for k in range(1, len(idx) - 1):
                tris.append([idx[0], idx[k], idx[k + 1]])
    return np.array(verts, dtype=np.float32), np.array(tris, dtype=np.uint32)


def arbor_json(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{p.stderr}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def timed(repeat, f):
    times, out = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        out = f()
        times.append((time.perf_counter() - start) * 1e3)
    return out, statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--arbor", required=True)
    ap.add_argument("--mesh", required=True)
    ap.add_argument("--rays")
    ap.add_argument("--points", type=int, default=100_000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    import open3d as o3d

    v, t = read_mesh(a.mesh)
    lo, hi = v.min(axis=0), v.max(axis=0)
    rng = np.random.default_rng(1)
    work = tempfile.mkdtemp(prefix="queries-")
    if a.rays:
        rays = np.fromfile(a.rays, dtype=np.float32).reshape(-1, 8)
    else:
        n = 100_000
        o = rng.uniform(lo, hi, (n, 3)).astype(np.float32)
        d = rng.normal(size=(n, 3)).astype(np.float32)
        rays = np.concatenate([o, np.zeros((n, 1), np.float32), d, np.full((n, 1), np.inf, np.float32)], axis=1)
    rays_path = os.path.join(work, "q.rays")
    rays.astype("<f4").tofile(rays_path)
    pad = (hi - lo) * 0.1
    pts = rng.uniform(lo - pad, hi + pad, (a.points, 3)).astype(np.float32)
    pts_path = os.path.join(work, "q.points")
    np.concatenate([pts, np.full((len(pts), 1), np.inf, np.float32)], axis=1).astype("<f4").tofile(pts_path)

    scene = o3d.t.geometry.RaycastingScene(nthreads=a.threads)
    scene.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(t))
    # Open3D's rays are (origin, direction) with t from 0 to inf; the ray
    # files used here have tnear 0 and tfar inf.
    o3_rays = o3d.core.Tensor(np.ascontiguousarray(np.concatenate([rays[:, 0:3], rays[:, 4:7]], axis=1)))
    o3_pts = o3d.core.Tensor(pts)
    scene.count_intersections(o3_rays)  # builds the BVH outside the timing

    common = ["--mesh", a.mesh, "--threads", str(a.threads), "--repeat", str(a.repeat)]
    rows = []
    count_path, all_path = os.path.join(work, "count.bin"), os.path.join(work, "all.bin")
    inside_path, near_path = os.path.join(work, "inside.bin"), os.path.join(work, "near.bin")

    r = arbor_json([a.arbor, "trace", "--rays", rays_path, "--query", "count", "--hits", count_path] + common)
    o3_count, ms = timed(a.repeat, lambda: scene.count_intersections(o3_rays).numpy())
    ours = np.fromfile(count_path, dtype="<u4")
    rows.append(("count", len(rays), r["trace_ms_median"], ms, f"{np.mean(ours == o3_count):.4f} of counts equal"))

    r = arbor_json([a.arbor, "trace", "--rays", rays_path, "--query", "all", "--hits", all_path] + common)
    _, ms = timed(a.repeat, lambda: scene.list_intersections(o3_rays))
    rows.append(("all hits", len(rays), r["trace_ms_median"], ms, f"{r['hits']} hits"))

    r = arbor_json([a.arbor, "trace", "--rays", rays_path, "--hits", os.path.join(work, "closest.bin")] + common)
    _, ms = timed(a.repeat, lambda: scene.cast_rays(o3_rays))
    rows.append(("closest", len(rays), r["trace_ms_median"], ms, ""))

    r = arbor_json([a.arbor, "nearest", "--points", pts_path, "--out", near_path] + common)
    o3_near, ms = timed(a.repeat, lambda: scene.compute_closest_points(o3_pts))
    near = np.fromfile(near_path, dtype="<f4").reshape(-1, 8)
    o3_d = np.linalg.norm(o3_near["points"].numpy() - pts, axis=1)
    err = np.max(np.abs(near[:, 6] - o3_d) / np.maximum(1.0, o3_d))
    rows.append(("closest point", len(pts), r["query_ms_median"], ms, f"max rel. distance difference {err:.1e}"))

    r = arbor_json([a.arbor, "inside", "--points", pts_path, "--out", inside_path] + common)
    ours_in = np.fromfile(inside_path, dtype=np.uint8)
    # Open3D's occupancy (its inside test, by ray votes).
    o3_in, ms = timed(a.repeat, lambda: scene.compute_occupancy(o3_pts).numpy())
    rows.append(("inside", len(pts), r["query_ms_median"], ms, f"{np.mean(ours_in == (o3_in > 0.5)):.4f} agree"))

    r = arbor_json([a.arbor, "nearest", "--signed", "--points", pts_path, "--out", near_path] + common)
    o3_sd, ms = timed(a.repeat, lambda: scene.compute_signed_distance(o3_pts).numpy())
    sd = np.fromfile(near_path, dtype="<f4").reshape(-1, 8)[:, 6]
    rows.append(("signed distance", len(pts), r["query_ms_median"], ms, f"{np.mean(np.sign(sd) == np.sign(o3_sd)):.4f} signs agree"))

    print(f"mesh {a.mesh}: {len(t)} triangles, {a.threads} threads, median of {a.repeat}")
    print(f"| query | queries | arbor M/s | Open3D M/s | arbor / Open3D | answers |")
    print(f"| --- | --- | --- | --- | --- | --- |")
    for name, n, ams, oms, note in rows:
        ar, orr = n / (ams * 1e3), n / (oms * 1e3)
        print(f"| {name} | {n} | {ar:.3f} | {orr:.3f} | {ar / orr:.2f} | {note} |")


if __name__ == "__main__":
    main()
