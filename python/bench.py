#!/usr/bin/env python3
"""Time arbor's Python queries against `arbor trace`, Open3D, embreex and
trimesh's own caster on the same meshes, rays and points.

  python/bench.py --arbor target/release/arbor --mesh MESH --rays KIND=FILE ...
                  [--threads 2] [--repeat 3] [--points 100000] [--subset 2000]

MESH is a file `arbor trace` reads (the Python side loads it with
`arbor.load_mesh`, so both number triangles alike); each --rays names a ray
file of shared/peers/FORMAT.md (`embree_trace gen --kind primary|diffuse`)
by its kind. Points for `closest_points`: --points uniform in the mesh's box
grown by 10 %.

Per query and tool the rate is millions of queries per second, the median
of --repeat timed calls around the call alone (structures built before,
outside the timing). `arbor trace` and `arbor nearest` time themselves
(their JSON line), the rest is timed here. The Python binding's rates are
compared with `arbor trace`'s on the same rays (its target: within 10 %);
closest hits are timed twice, into fresh arrays and with `out=` into the
arrays of the call before (as `arbor trace` reuses its hit buffer).
Open3D runs with `nthreads=--threads`; arbor's binding with
RAYON_NUM_THREADS=--threads (set here before arbor is imported); embreex
traces on one thread (its `run` loops over the rays); trimesh's fallback
(`trimesh.ray.ray_triangle`, what trimesh uses without embreex) runs on the
first --subset rays or points only, being slow, and its rate is of that
subset. Answers are checked against arbor's: the fraction of rays with the
same triangle (closest), the same answer (occluded, count), the largest
relative distance difference (closest points).

Needs numpy and the arbor package; open3d (pip install open3d-cpu, with
Debian's libusb-1.0-0), embreex and trimesh are each used when installed.
"""
import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time


def cpu_model():
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        for line in out.splitlines():
            if line.startswith("Model name:"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def median_ms(repeat, call):
    """The answer of `call` and the median of `repeat` timings, in ms."""
    times, out = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        out = call()
        times.append((time.perf_counter() - start) * 1e3)
    return out, statistics.median(times)


def cli_json(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"bench: {' '.join(cmd)} failed:\n{p.stderr}")
    return json.loads(p.stdout.strip().splitlines()[-1])


class Table:
    """Rates by mesh, (query, rays) and tool, with notes on the answers."""

    TOOLS = ["arbor trace", "arbor (Python)", "arbor (Python, out=)", "Open3D", "embreex", "trimesh"]

    def __init__(self):
        self.rates, self.notes = {}, []

    def add(self, mesh, rays, query, tool, n, ms, note=""):
        rate = n / (ms * 1e3)
        self.rates[(mesh, query, rays, tool)] = rate
        if note:
            self.notes.append(f"{mesh}, {query}, {rays}, {tool}: {note}")
        print(f"  {query:<14} {rays:<8} {tool:<15} {rate:9.3g} M/s  {note}", flush=True)

    def markdown(self):
        """One table per mesh: M queries/s per tool, the binding's rate over
        `arbor trace`'s in brackets."""
        out = []
        for mesh in dict.fromkeys(k[0] for k in self.rates):
            out += ["", f"| {mesh} | " + " | ".join(self.TOOLS) + " |", "| --- |" + " --- |" * len(self.TOOLS)]
            for query, rays in dict.fromkeys((k[1], k[2]) for k in self.rates if k[0] == mesh):
                cells = []
                for tool in self.TOOLS:
                    rate = self.rates.get((mesh, query, rays, tool))
                    cell = "" if rate is None else f"{rate:.3g}"
                    base = self.rates.get((mesh, query, rays, "arbor trace"))
                    if rate is not None and tool != "arbor trace" and base:
                        cell += f" ({rate / base:.2f})"
                    cells.append(cell)
                out.append(f"| {query}, {rays} | " + " | ".join(cells) + " |")
        return "\n".join(out + [""] + self.notes)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--arbor", required=True, help="the arbor command (a release build)")
    ap.add_argument("--mesh", required=True, action="append")
    ap.add_argument("--rays", required=True, action="append", metavar="KIND=FILE",
                    help="ray file per kind; FILE may contain {mesh}, the mesh's file name")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--points", type=int, default=100_000)
    ap.add_argument("--subset", type=int, default=2000)
    a = ap.parse_args()
    os.environ["RAYON_NUM_THREADS"] = str(a.threads)
    import numpy as np

    import arbor

    optional = {}
    for name in ("open3d", "embreex", "trimesh"):
        try:
            optional[name] = __import__(name)
        except ImportError:
            print(f"bench: {name} is not installed; its rows are left out", file=sys.stderr)
    print(f"CPU: {cpu_model()}; {a.threads} threads; median of {a.repeat}")
    table = Table()
    work = tempfile.mkdtemp(prefix="arbor-bench-")
    common = ["--threads", str(a.threads), "--repeat", str(a.repeat)]
    for mesh_path in a.mesh:
        mesh_name = os.path.splitext(os.path.basename(mesh_path))[0]
        mesh = arbor.load_mesh(mesh_path)
        v, f = mesh.vertices, mesh.faces
        print(f"{mesh_name}: {len(f)} triangles", flush=True)
        o3d_scene = tm_caster = embree = None
        if "open3d" in optional:
            o3d = optional["open3d"]
            o3d_scene = o3d.t.geometry.RaycastingScene(nthreads=a.threads)
            o3d_scene.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f.astype(np.uint32)))
        if "embreex" in optional:
            from embreex import rtcore_scene
            from embreex.mesh_construction import TriangleMesh

            embree = rtcore_scene.EmbreeScene()
            TriangleMesh(embree, v[f])
        if "trimesh" in optional:
            tm = optional["trimesh"].Trimesh(v, f, process=False)
            from trimesh.ray.ray_triangle import RayMeshIntersector

            tm_caster = RayMeshIntersector(tm)
        for spec in a.rays:
            kind, _, pattern = spec.partition("=")
            ray_path = pattern.format(mesh=os.path.basename(mesh_path))
            rays = np.fromfile(ray_path, dtype="<f4").reshape(-1, 8)
            o, tmin = np.ascontiguousarray(rays[:, 0:3]), rays[:, 3].copy()
            d, tmax = np.ascontiguousarray(rays[:, 4:7]), rays[:, 7].copy()
            k = len(rays)
            # Open3D and embreex take rays from 0 to infinity: only such rays
            # compare like for like.
            plain = bool(np.all(tmin == 0) and np.all(tmax == np.inf))
            print(f" {kind} rays: {k}", flush=True)
            queries = [("closest", "closest"), ("occluded", "occluded"), ("count", "count")]
            for query, cli_query in queries:
                out = os.path.join(work, "hits.bin")
                r = cli_json([a.arbor, "trace", "--mesh", mesh_path, "--rays", ray_path, "--query", cli_query, "--hits", out] + common)
                table.add(mesh_name, kind, query, "arbor trace", k, r["trace_ms_median"])
                if query == "closest":
                    ours, ms = median_ms(a.repeat, lambda: mesh.intersect(o, d, tmin, tmax))
                    rec = np.fromfile(out, np.dtype([("t", "<f4"), ("tri", "<u4"), ("u", "<f4"), ("v", "<f4")]))
                    cli_tri = rec["tri"].astype(np.int64)
                    cli_tri[rec["tri"] == 0xFFFFFFFF] = -1
                    same = np.array_equal(ours["triangle"], cli_tri) and np.array_equal(ours["t"], rec["t"])
                    table.add(mesh_name, kind, query, "arbor (Python)", k, ms, "same as arbor trace" if same else "DIFFERS from arbor trace")
                    # Into the arrays of the call before, as `arbor trace` reuses its buffer.
                    again, ms = median_ms(a.repeat, lambda: mesh.intersect(o, d, tmin, tmax, out=ours))
                    same = np.array_equal(again["triangle"], cli_tri) and np.array_equal(again["t"], rec["t"])
                    table.add(mesh_name, kind, query, "arbor (Python, out=)", k, ms, "same as arbor trace" if same else "DIFFERS from arbor trace")
                    tri = ours["triangle"]
                elif query == "occluded":
                    blocked, ms = median_ms(a.repeat, lambda: mesh.occluded(o, d, tmin, tmax))
                    same = np.array_equal(blocked, np.fromfile(out, np.uint8).astype(bool))
                    table.add(mesh_name, kind, query, "arbor (Python)", k, ms, "same as arbor trace" if same else "DIFFERS from arbor trace")
                else:
                    counts, ms = median_ms(a.repeat, lambda: mesh.count(o, d, tmin, tmax))
                    same = np.array_equal(counts, np.fromfile(out, "<u4"))
                    table.add(mesh_name, kind, query, "arbor (Python)", k, ms, "same as arbor trace" if same else "DIFFERS from arbor trace")
                if o3d_scene is not None and plain:
                    o3_rays = o3d.core.Tensor(np.ascontiguousarray(np.concatenate([o, d], axis=1)))
                    if query == "closest":
                        o3_count = o3d_scene.count_intersections(o3_rays)  # builds its BVH
                        res, ms = median_ms(a.repeat, lambda: o3d_scene.cast_rays(o3_rays))
                        ids = res["primitive_ids"].numpy().astype(np.int64)
                        ids[ids == 0xFFFFFFFF] = -1
                        note = f"{np.mean(ids == tri):.4f} same triangle"
                    elif query == "occluded":
                        res, ms = median_ms(a.repeat, lambda: o3d_scene.test_occlusions(o3_rays))
                        note = f"{np.mean(res.numpy().astype(bool) == blocked):.4f} same answer"
                    else:
                        res, ms = median_ms(a.repeat, lambda: o3d_scene.count_intersections(o3_rays))
                        note = f"{np.mean(res.numpy() == counts):.4f} same count"
                    table.add(mesh_name, kind, query, "Open3D", k, ms, note)
                if embree is not None and plain and query != "count":
                    if query == "closest":
                        res, ms = median_ms(a.repeat, lambda: embree.run(o, d, query="INTERSECT", output=1))
                        note = f"{np.mean(res['primID'].astype(np.int64) == tri):.4f} same triangle; 1 thread"
                    else:
                        res, ms = median_ms(a.repeat, lambda: embree.run(o, d, query="OCCLUDED"))
                        note = f"{np.mean((np.asarray(res) != -1) == blocked):.4f} same answer; 1 thread"
                    table.add(mesh_name, kind, query, "embreex", k, ms, note)
                if tm_caster is not None and plain:
                    s = min(a.subset, k)
                    os_, ds = o[:s].astype(np.float64), d[:s].astype(np.float64)
                    if query == "closest":
                        res, ms = median_ms(1, lambda: tm_caster.intersects_first(os_, ds))
                        note = f"{np.mean(res == tri[:s]):.4f} same triangle"
                    elif query == "occluded":
                        res, ms = median_ms(1, lambda: tm_caster.intersects_any(os_, ds))
                        note = f"{np.mean(res == blocked[:s]):.4f} same answer"
                    else:
                        def tm_count():
                            _, ray = tm_caster.intersects_id(os_, ds, multiple_hits=True)
                            return np.bincount(ray, minlength=s)

                        res, ms = median_ms(1, tm_count)
                        note = f"{np.mean(res == counts[:s]):.4f} same count"
                    table.add(mesh_name, kind, query, "trimesh", s, ms, note + f"; first {s} rays, once")
        # Closest points.
        rng = np.random.default_rng(1)
        lo, hi = v.min(axis=0), v.max(axis=0)
        pad = (hi - lo) * 0.1
        pts = rng.uniform(lo - pad, hi + pad, (a.points, 3)).astype(np.float32)
        pts_path = os.path.join(work, "points.bin")
        np.concatenate([pts, np.full((len(pts), 1), np.inf, np.float32)], axis=1).astype("<f4").tofile(pts_path)
        near_path = os.path.join(work, "near.bin")
        r = cli_json([a.arbor, "nearest", "--mesh", mesh_path, "--points", pts_path, "--out", near_path] + common)
        table.add(mesh_name, "points", "closest point", "arbor trace", len(pts), r["query_ms_median"], "arbor nearest")
        near, ms = median_ms(a.repeat, lambda: mesh.closest_points(pts))
        cli_d = np.fromfile(near_path, "<f4").reshape(-1, 8)[:, 6]
        same = np.array_equal(near["distance"], cli_d)
        table.add(mesh_name, "points", "closest point", "arbor (Python)", len(pts), ms, "same as arbor nearest" if same else "DIFFERS from arbor nearest")
        dist = near["distance"].astype(np.float64)
        if o3d_scene is not None:
            res, ms = median_ms(a.repeat, lambda: o3d_scene.compute_closest_points(o3d.core.Tensor(pts)))
            o3_d = np.linalg.norm(res["points"].numpy().astype(np.float64) - pts, axis=1)
            err = np.max(np.abs(o3_d - dist) / np.maximum(1.0, dist))
            table.add(mesh_name, "points", "closest point", "Open3D", len(pts), ms, f"distances within {err:.1e} relative")
        if tm_caster is not None:
            s = min(a.subset, len(pts))
            import trimesh.proximity

            (_, tm_d, _), ms = median_ms(1, lambda: trimesh.proximity.closest_point(tm, pts[:s].astype(np.float64)))
            err = np.max(np.abs(tm_d - dist[:s]) / np.maximum(1.0, dist[:s]))
            table.add(mesh_name, "points", "closest point", "trimesh", s, ms, f"distances within {err:.1e} relative; first {s} points, once")
    print()
    print(f"CPU: {cpu_model()}; {a.threads} threads; median of {a.repeat}")
    print(table.markdown())


if __name__ == "__main__":
    main()
