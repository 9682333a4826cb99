#!/usr/bin/env python3
"""Writes a small hand-made explain document (docs/explain-data.md, version 1)
for working on the page without `arbor explain`: a room of triangles with two
boxes and a sphere, a median-split BVH, a 4x4x4 grid and a k-d tree of two
levels, and picks traced through them by simple reference traversals.

Usage: make_sample.py OUT.json
"""
import base64
import json
import math
import struct
import sys
import zlib

W, H, STRIDE = 64, 48, 4


def quad(a, b, c, d):
    return [(a, b, c), (a, c, d)]


def box_tris(lo, hi):
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    p = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0),
         (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    faces = [(0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (3, 2, 6, 7), (0, 3, 7, 4), (1, 2, 6, 5)]
    out = []
    for f in faces:
        out += quad(*[p[i] for i in f])
    return out


tris = []
tris += quad((-2, 0, -2), (2, 0, -2), (2, 0, 2), (-2, 0, 2))   # floor
tris += quad((-2, 0, -2), (2, 0, -2), (2, 3, -2), (-2, 3, -2))  # back wall
tris += box_tris((-1.4, 0, -1.2), (-0.4, 1.6, -0.2))
tris += box_tris((0.3, 0, 0.0), (1.1, 0.8, 0.8))
SPHERE = (0.9, 1.4, -1.0, 0.45)
NT = len(tris)
NPRIM = NT + 1  # the sphere is the last primitive


def prim_box(i):
    if i < NT:
        t = tris[i]
        return [[min(v[k] for v in t) for k in range(3)], [max(v[k] for v in t) for k in range(3)]]
    cx, cy, cz, r = SPHERE
    return [[cx - r, cy - r, cz - r], [cx + r, cy + r, cz + r]]


def union(boxes):
    return [[min(b[0][k] for b in boxes) for k in range(3)], [max(b[1][k] for b in boxes) for k in range(3)]]


def slab(box, o, d, tmax):
    t0, t1 = 0.0, tmax
    for k in range(3):
        inv = 1.0 / d[k] if d[k] != 0 else math.inf
        a, b = (box[0][k] - o[k]) * inv, (box[1][k] - o[k]) * inv
        if a > b:
            a, b = b, a
        if math.isnan(a) or math.isnan(b):
            continue
        t0, t1 = max(t0, a), min(t1, b)
    return t0 <= t1, t0


def hit_prim(i, o, d):
    if i < NT:
        a, b, c = tris[i]
        e1 = [b[k] - a[k] for k in range(3)]
        e2 = [c[k] - a[k] for k in range(3)]
        pv = cross(d, e2)
        det = dot(e1, pv)
        if abs(det) < 1e-12:
            return None
        s = [o[k] - a[k] for k in range(3)]
        u = dot(s, pv) / det
        qv = cross(s, e1)
        v = dot(d, qv) / det
        t = dot(e2, qv) / det
        return t if u >= 0 and v >= 0 and u + v <= 1 and t > 1e-6 else None
    cx, cy, cz, r = SPHERE
    oc = [o[0] - cx, o[1] - cy, o[2] - cz]
    b = dot(oc, d)
    c = dot(oc, oc) - r * r
    disc = b * b - c
    if disc < 0:
        return None
    t = -b - math.sqrt(disc)
    return t if t > 1e-6 else None


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    n = math.sqrt(dot(a, a))
    return [x / n for x in a]


def build_bvh(prims, depth, nodes, leaf_size=2):
    idx = len(nodes)
    box = union([prim_box(p) for p in prims])
    nodes.append({"box": box, "depth": depth, "children": [], "primitives": 0, "_prims": prims})
    if len(prims) <= leaf_size:
        nodes[idx]["primitives"] = len(prims)
        return idx
    ext = [box[1][k] - box[0][k] for k in range(3)]
    axis = ext.index(max(ext))
    order = sorted(prims, key=lambda p: sum(prim_box(p)[0][axis] + prim_box(p)[1][axis] for _ in [0]))
    half = len(order) // 2
    left = build_bvh(order[:half], depth + 1, nodes)
    right = build_bvh(order[half:], depth + 1, nodes)
    nodes[idx]["children"] = [left, right]
    return idx


def trace_tree(nodes, o, d):
    visits, tests, best = [], [], (math.inf, None)
    stack = [0]
    while stack:
        n = stack.pop()
        ok, _ = slab(nodes[n]["box"], o, d, best[0])
        visits.append({"node": n, "entered": ok})
        if not ok:
            continue
        if nodes[n]["children"]:
            stack += reversed(nodes[n]["children"])
        else:
            for p in nodes[n]["_prims"]:
                tests.append(p)
                t = hit_prim(p, o, d)
                if t is not None and t < best[0]:
                    best = (t, p)
    return visits, tests, best


RES = [4, 4, 4]
SCENE = union([prim_box(p) for p in range(NPRIM)])
CELL = [(SCENE[1][k] - SCENE[0][k]) / RES[k] for k in range(3)]


def cell_box(c):
    ix, iy, iz = c % RES[0], (c // RES[0]) % RES[1], c // (RES[0] * RES[1])
    lo = [SCENE[0][0] + ix * CELL[0], SCENE[0][1] + iy * CELL[1], SCENE[0][2] + iz * CELL[2]]
    return [lo, [lo[k] + CELL[k] for k in range(3)]]


def overlaps(a, b):
    return all(a[0][k] <= b[1][k] and b[0][k] <= a[1][k] for k in range(3))


CELL_PRIMS = {c: [p for p in range(NPRIM) if overlaps(prim_box(p), cell_box(c))] for c in range(64)}


def trace_grid(o, d):
    crossed = []
    for c in range(64):
        ok, t0 = slab(cell_box(c), o, d, math.inf)
        if ok:
            crossed.append((t0, c))
    visits, tests, best, seen = [], [], (math.inf, None), set()
    for t0, c in sorted(crossed):
        if t0 > best[0]:
            break
        visits.append({"node": c, "entered": True})
        for p in CELL_PRIMS[c]:
            if p in seen:
                continue
            seen.add(p)
            tests.append(p)
            t = hit_prim(p, o, d)
            if t is not None and t < best[0]:
                best = (t, p)
    return visits, tests, best


def build_kd(nodes, box, prims, depth):
    idx = len(nodes)
    nodes.append({"box": box, "depth": depth, "axis": None, "split": None, "children": [],
                  "primitives": len(prims), "_prims": prims})
    if depth == 2 or len(prims) <= 2:
        return idx
    axis = depth % 2 * 2  # x, then z
    split = (box[0][axis] + box[1][axis]) / 2
    lb = [box[0][:], box[1][:]]
    lb[1][axis] = split
    rb = [box[0][:], box[1][:]]
    rb[0][axis] = split
    nodes[idx].update(axis=axis, split=split, primitives=0)
    left = build_kd(nodes, lb, [p for p in prims if overlaps(prim_box(p), lb)], depth + 1)
    right = build_kd(nodes, rb, [p for p in prims if overlaps(prim_box(p), rb)], depth + 1)
    nodes[idx]["children"] = [left, right]
    return idx


EYE, TARGET, UP, VFOV = [0.0, 1.6, 5.5], [0.0, 0.9, 0.0], [0.0, 1.0, 0.0], 40.0


def camera_ray(x, y):
    f = norm([TARGET[k] - EYE[k] for k in range(3)])
    r = norm(cross(f, UP))
    u = cross(r, f)
    h = math.tan(math.radians(VFOV) / 2)
    sx = (2 * (x + 0.5) / W - 1) * h * W / H
    sy = (1 - 2 * (y + 0.5) / H) * h
    return EYE, norm([f[k] + sx * r[k] + sy * u[k] for k in range(3)])


def png(rgb):
    raw = b"".join(b"\x00" + bytes(rgb[y * W * 3:(y + 1) * W * 3]) for y in range(H))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", W, H, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def u32s(values):
    return base64.b64encode(struct.pack("<%dI" % len(values), *values)).decode()


def strip(nodes):
    return [{k: v for k, v in n.items() if not k.startswith("_")} for n in nodes]


def main(out):
    bvh = []
    build_bvh(list(range(NPRIM)), 0, bvh)
    kd = []
    build_kd(kd, SCENE, list(range(NPRIM)), 0)
    tracers = [("bvh-median", "bvh", lambda o, d: trace_tree(bvh, o, d)),
               ("grid", "grid", trace_grid),
               ("kdtree", "kdtree", lambda o, d: trace_tree(kd, o, d))]
    heat = {name: ([], []) for name, _, _ in tracers}
    rgb, picks = [], []
    for y in range(H):
        for x in range(W):
            o, d = camera_ray(x, y)
            ray = {"pixel": [x, y], "ray": {"origin": o, "direction": d}, "structures": []}
            shade = 0
            for name, _, trace in tracers:
                visits, tests, (t, p) = trace(o, d)
                heat[name][0].append(len(visits))
                heat[name][1].append(len(tests))
                ray["structures"].append({
                    "accel": name, "visits": visits, "tests": tests,
                    "hit": None if p is None else {"t": t, "primitive": p},
                    "counts": {"nodes": len(visits), "tests": len(tests)}})
                shade = 0 if p is None else 60 + (p * 37) % 180
            rgb += [shade, shade, min(255, shade + 30)]
            if x % STRIDE == 0 and y % STRIDE == 0:
                picks.append(ray)
    structures = []
    for name, family, _ in tracers:
        nodes, tests = heat[name]
        s = {"accel": name, "family": family,
             "stats": {"nodes": len(bvh) if family == "bvh" else (64 if family == "grid" else len(kd)),
                       "leaves": 0, "max_depth": 0, "memory_bytes": 0},
             "left_out": 0,
             "heatmap": {"nodes_base64": u32s(nodes), "tests_base64": u32s(tests),
                         "max_nodes": max(nodes), "max_tests": max(tests)}}
        if family == "bvh":
            s["nodes"] = strip(bvh)
        elif family == "kdtree":
            s["nodes"] = strip(kd)
        else:
            s.update(origin=SCENE[0], cell_size=CELL, resolution=RES,
                     occupied=[c for c in range(64) if CELL_PRIMS[c]])
        structures.append(s)
    flat = [c for t in tris for v in t for c in v]
    doc = {
        "format": "arbor-explain", "version": 1, "input": "hand-made sample",
        "notes": ["a hand-made sample document, not arbor's output",
                  "picks are kept every %d pixels" % STRIDE],
        "image": {"width": W, "height": H, "png_base64": base64.b64encode(png(rgb)).decode()},
        "camera": {"eye": EYE, "target": TARGET, "up": UP, "vfov_degrees": VFOV},
        "scene_graph": {
            "root": 0,
            "nodes": [
                {"id": 0, "kind": "group", "label": "scene", "transform": None, "children": [1, 2, 3, 6]},
                {"id": 1, "kind": "surface", "label": "room (4 triangles)", "transform": None, "children": []},
                {"id": 2, "kind": "instance", "label": "box A", "transform": [[1, 0, 0, -0.9], [0, 1, 0, 0], [0, 0, 1, -0.7]], "children": [4]},
                {"id": 3, "kind": "instance", "label": "box B", "transform": [[0.8, 0, 0, 0.7], [0, 0.5, 0, 0], [0, 0, 0.8, 0.4]], "children": [4]},
                {"id": 4, "kind": "definition", "label": "unit box", "transform": None, "children": [5]},
                {"id": 5, "kind": "surface", "label": "box (12 triangles)", "transform": None, "children": []},
                {"id": 6, "kind": "transform", "label": "lift", "transform": [[1, 0, 0, 0.9], [0, 1, 0, 1.4], [0, 0, 1, -1]], "children": [7]},
                {"id": 7, "kind": "surface", "label": "sphere r=0.45", "transform": None, "children": []},
            ],
            "flattening": {"baked": 2, "shared": [{"definition": 4, "label": "unit box", "placements": 2}],
                           "summary": ["the room and the sphere were baked into world space",
                                       "the unit box stays shared: 2 placements"]},
        },
        "primitives": {"total": NPRIM, "left_out": 0, "triangles": flat,
                       "triangle_ids": list(range(NT)), "spheres": [[*SPHERE, NT]], "other": []},
        "bounding_volumes": [
            {"kind": "sphere", "surface": 7, "center": list(SPHERE[:3]), "radius": SPHERE[3]},
            {"kind": "aabb", "surface": 2, "box": prim_box(4)},
            {"kind": "obb", "surface": 3, "center": [0.7, 0.4, 0.4], "axes": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "half": [0.4, 0.4, 0.4]},
        ],
        "structures": structures,
        "picks": {"stride": STRIDE, "rays": picks},
    }
    with open(out, "w") as f:
        json.dump(doc, f)


if __name__ == "__main__":
    main(sys.argv[1])
