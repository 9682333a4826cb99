"""Shared test helpers: small random meshes and rays, a float64 brute-force
ray caster, and the ``arbor`` command line (``arbor trace``) for answers to
compare with."""

import os
import pathlib
import subprocess

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def random_soup(rng, triangles=60):
    """A triangle soup in the unit cube: vertices (3m, 3), faces (m, 3)."""
    vertices = rng.random((3 * triangles, 3))
    faces = np.arange(3 * triangles).reshape(-1, 3)
    return vertices, faces


def random_rays(rng, k=500):
    """Rays from a sphere of radius 3 towards points in the unit cube."""
    origins = rng.normal(size=(k, 3))
    origins = 0.5 + 3.0 * origins / np.linalg.norm(origins, axis=1, keepdims=True)
    directions = rng.random((k, 3)) - origins
    return origins, directions


def box(lo=-1.0, hi=1.0):
    """A closed, outward-oriented cube as 12 triangles."""
    vertices = np.array(
        [[x, y, z] for x in (lo, hi) for y in (lo, hi) for z in (lo, hi)], dtype=np.float64
    )
    faces = np.array(
        [
            [0, 1, 3], [0, 3, 2],  # x = lo
            [4, 6, 7], [4, 7, 5],  # x = hi
            [0, 4, 5], [0, 5, 1],  # y = lo
            [2, 3, 7], [2, 7, 6],  # y = hi
            [0, 2, 6], [0, 6, 4],  # z = lo
            [1, 5, 7], [1, 7, 3],  # z = hi
        ]
    )
    return vertices, faces


def brute_hits(vertices, faces, origins, directions):
    """Every (t, triangle) of each ray, t >= 0, by float64 Moller-Trumbore:
    a list with one (t array, triangle array) pair per ray, sorted by t."""
    tri = np.asarray(vertices, np.float64)[np.asarray(faces)]
    p0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    out = []
    for o, d in zip(np.asarray(origins, np.float64), np.asarray(directions, np.float64)):
        h = np.cross(d, e2)
        a = np.einsum("ij,ij->i", e1, h)
        with np.errstate(divide="ignore", invalid="ignore"):
            f = 1.0 / a
            s = o - p0
            u = f * np.einsum("ij,ij->i", s, h)
            q = np.cross(s, e1)
            v = f * (q @ d)
            t = f * np.einsum("ij,ij->i", e2, q)
        ok = (a != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0)
        idx = np.nonzero(ok)[0]
        order = np.lexsort((idx, t[idx]))
        out.append((t[idx][order], idx[order]))
    return out


def arbor_cli():
    """The ``arbor`` executable: ``ARBOR_CLI``, or the repository's release
    or debug build. Missing, it fails the test when ``ARBOR_REQUIRE_CLI=1``
    (as CI sets it) and skips it otherwise."""
    candidates = [os.environ.get("ARBOR_CLI")] + [
        str(REPO / "target" / p / "arbor") for p in ("release", "debug")
    ]
    for c in candidates:
        if c and os.access(c, os.X_OK):
            return c
    if os.environ.get("ARBOR_REQUIRE_CLI") == "1":
        pytest.fail("the arbor command line is needed (set ARBOR_CLI or build arbor-cli)")
    pytest.skip("the arbor command line is not built")


def write_obj(path, vertices, faces):
    """Writes an OBJ file with the vertices exactly as float32 values."""
    with open(path, "w") as f:
        for v in np.asarray(vertices, np.float32):
            f.write("v {} {} {}\n".format(*(repr(float(x)) for x in v)))
        for t in faces:
            f.write("f {} {} {}\n".format(*(int(i) + 1 for i in t)))


def trace_cli(tmp_path, mesh_path, origins, directions, tmin, tmax, occluded=False):
    """``arbor trace`` on float32 rays: (t, triangle, u, v) arrays, or the
    occlusion answers as bools."""
    k = len(origins)
    rays = np.zeros((k, 8), np.float32)
    rays[:, 0:3] = origins
    rays[:, 3] = tmin
    rays[:, 4:7] = directions
    rays[:, 7] = tmax
    ray_file = tmp_path / "rays.bin"
    hit_file = tmp_path / "hits.bin"
    rays.astype("<f4").tofile(ray_file)
    cmd = [arbor_cli(), "trace", "--mesh", str(mesh_path), "--rays", str(ray_file), "--hits", str(hit_file)]
    if occluded:
        cmd.append("--occluded")
    subprocess.run(cmd, check=True, capture_output=True)
    if occluded:
        return np.fromfile(hit_file, np.uint8).astype(bool)
    rec = np.fromfile(hit_file, np.dtype([("t", "<f4"), ("tri", "<u4"), ("u", "<f4"), ("v", "<f4")]))
    tri = rec["tri"].astype(np.int64)
    tri[rec["tri"] == 0xFFFFFFFF] = -1
    return rec["t"], tri, rec["u"], rec["v"]


def brute_closest(vertices, faces, point):
    """The distance from `point` to the nearest triangle, and that
    triangle's index, by checking every triangle in float64 (the closest
    point of each triangle by its Voronoi regions, as in Ericson's
    "Real-Time Collision Detection", 5.1.5)."""
    tri = np.asarray(vertices, np.float64)[np.asarray(faces)]
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    p = np.asarray(point, np.float64)
    dot = lambda x, y: np.einsum("ij,ij->i", x, y)  # noqa: E731
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = dot(ab, ap), dot(ac, ap)
    bp, cp = p - b, p - c
    d3, d4 = dot(ab, bp), dot(ac, bp)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = 1.0 / (va + vb + vc)
        closest = a + ab * (vb * denom)[:, None] + ac * (vc * denom)[:, None]  # inside the face
        regions = [
            ((d1 <= 0) & (d2 <= 0), a),
            ((d3 >= 0) & (d4 <= d3), b),
            ((d6 >= 0) & (d5 <= d6), c),
            ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + ab * (d1 / (d1 - d3))[:, None]),
            ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + ac * (d2 / (d2 - d6))[:, None]),
            (
                (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),
                b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))[:, None],
            ),
        ]
    # The first region that applies wins, as in the sequential tests.
    for mask, q in reversed(regions):
        closest = np.where(mask[:, None], q, closest)
    distance = np.linalg.norm(closest - p, axis=1)
    return distance.min(), int(np.argmin(distance))


def box_distance(points, lo=-1.0, hi=1.0):
    """The signed distance from points to the surface of the axis-aligned
    box [lo, hi]^3, negative inside."""
    p = np.asarray(points, np.float64)
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    q = np.abs(p - centre) - half
    outside = np.linalg.norm(np.maximum(q, 0), axis=1)
    inside = np.minimum(q.max(axis=1), 0)
    return outside + inside
