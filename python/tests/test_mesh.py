"""arbor.Mesh: construction, attributes and the ray queries, against a
float64 brute force and against ``arbor trace`` bit for bit."""

import re

import numpy as np
import pytest

import arbor
from helpers import box, brute_hits, random_rays, random_soup, trace_cli, write_obj


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def test_attributes_hold_the_mesh(rng):
    vertices, faces = random_soup(rng, 10)
    mesh = arbor.Mesh(vertices, faces)
    assert mesh.vertices.dtype == np.float32 and mesh.vertices.shape == (30, 3)
    np.testing.assert_array_equal(mesh.vertices, vertices.astype(np.float32))
    assert mesh.faces.dtype == np.int64
    np.testing.assert_array_equal(mesh.faces, faces)
    assert len(mesh) == 10 and mesh.accel == "bvh-wide"
    assert "10 triangles" in repr(mesh)


def test_float32_float64_lists_and_strided_inputs_agree(rng):
    vertices, faces = random_soup(rng)
    origins, directions = random_rays(rng)
    reference = arbor.Mesh(vertices.astype(np.float32), faces.astype(np.uint32))
    expected = reference.intersect(origins.astype(np.float32), directions.astype(np.float32))
    # float64, Fortran order, a strided view and plain lists: same rays.
    wide = np.zeros((len(origins), 6))
    wide[:, ::2] = origins
    variants = [
        (vertices, faces, origins, directions),
        (np.asfortranarray(vertices), faces.astype(np.int32), wide[:, ::2], directions),
        (vertices.tolist(), faces.tolist(), origins.tolist(), directions.tolist()),
    ]
    for v, f, o, d in variants:
        got = arbor.Mesh(v, f).intersect(o, d)
        for key in expected:
            np.testing.assert_array_equal(got[key], expected[key], err_msg=key)


def test_intersect_matches_brute_force(rng):
    vertices, faces = random_soup(rng)
    origins, directions = random_rays(rng)
    mesh = arbor.Mesh(vertices.astype(np.float32), faces)
    # The brute force sees the same float32 values the library does.
    v32 = vertices.astype(np.float32)
    o32, d32 = origins.astype(np.float32), directions.astype(np.float32)
    hits = mesh.intersect(o32, d32)
    brute = brute_hits(v32, faces, o32, d32)
    assert (hits["triangle"] >= 0).sum() > 100  # the test is not all misses
    for i, (t, tri) in enumerate(brute):
        if len(t) == 0:
            assert hits["triangle"][i] == -1 and hits["t"][i] == np.inf
            assert np.isnan(hits["u"][i]) and np.isnan(hits["point"][i]).all()
            continue
        assert hits["triangle"][i] == tri[0]
        assert hits["t"][i] == pytest.approx(t[0], rel=1e-5)
    hit = hits["triangle"] >= 0
    # point: on the ray at t, and equal to the barycentric combination.
    np.testing.assert_allclose(
        hits["point"][hit], o32[hit] + hits["t"][hit, None] * d32[hit], rtol=1e-5, atol=1e-5
    )
    tri = v32[faces[hits["triangle"][hit]]].astype(np.float64)
    u, v = hits["u"][hit, None], hits["v"][hit, None]
    np.testing.assert_allclose(
        hits["point"][hit], (1 - u - v) * tri[:, 0] + u * tri[:, 1] + v * tri[:, 2], atol=1e-5
    )
    # normal: the unit geometric normal of the hit triangle.
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    np.testing.assert_allclose(hits["normal"][hit], n / np.linalg.norm(n, axis=1, keepdims=True), atol=1e-6)


def test_intersect_and_occluded_equal_arbor_trace(rng, tmp_path):
    vertices, faces = random_soup(rng, 200)
    origins, directions = random_rays(rng, 2000)
    o32, d32 = origins.astype(np.float32), directions.astype(np.float32)
    tmin = rng.random(len(o32)).astype(np.float32)
    tmax = (tmin + 4 * rng.random(len(o32))).astype(np.float32)
    path = tmp_path / "soup.obj"
    write_obj(path, vertices, faces)
    mesh = arbor.load_mesh(path)
    np.testing.assert_array_equal(mesh.vertices, vertices.astype(np.float32))
    np.testing.assert_array_equal(mesh.faces, faces)
    hits = mesh.intersect(o32, d32, tmin, tmax)
    t, tri, u, v = trace_cli(tmp_path, path, o32, d32, tmin, tmax)
    assert (tri >= 0).sum() > 200
    np.testing.assert_array_equal(hits["triangle"], tri)
    np.testing.assert_array_equal(hits["t"], t)
    hit = tri >= 0
    np.testing.assert_array_equal(hits["u"][hit], u[hit])
    np.testing.assert_array_equal(hits["v"][hit], v[hit])
    blocked = trace_cli(tmp_path, path, o32, d32, tmin, tmax, occluded=True)
    np.testing.assert_array_equal(mesh.occluded(o32, d32, tmin, tmax), blocked)


def test_high_quality_builds_answer_as_the_fast_build(rng):
    # Small triangles under long slivers: spatial splits cut the slivers.
    centres = rng.random((400, 1, 3))
    small = (centres + rng.normal(0, 0.02, (400, 3, 3))).reshape(-1, 3)
    starts = rng.random((60, 3))
    ends = 1 - starts
    slivers = np.stack([starts, ends, ends + 0.01], axis=1).reshape(-1, 3)
    vertices = np.concatenate([small, slivers])
    faces = np.arange(len(vertices)).reshape(-1, 3)
    origins, directions = random_rays(rng, 3000)
    for accel in ["bvh-wide", "bvh-sah"]:
        fast = arbor.Mesh(vertices, faces, accel=accel)
        high = arbor.Mesh(vertices, faces, accel=accel, quality="high")
        assert (fast.quality, high.quality) == ("fast", "high")
        a, b = fast.intersect(origins, directions), high.intersect(origins, directions)
        assert (a["triangle"] >= 0).sum() > 300
        np.testing.assert_array_equal(a["t"], b["t"])
        np.testing.assert_array_equal(fast.occluded(origins, directions), high.occluded(origins, directions))
        np.testing.assert_array_equal(fast.count(origins, directions), high.count(origins, directions))
        for key, column in fast.all_hits(origins, directions).items():
            np.testing.assert_array_equal(column, high.all_hits(origins, directions)[key], err_msg=key)


def test_tmin_and_tmax_scalars_and_arrays():
    vertices, faces = box()
    mesh = arbor.Mesh(vertices, faces)
    origins = np.array([[0.0, 0.0, -3.0]] * 3)
    directions = np.array([[0.0, 0.0, 1.0]] * 3)
    # The box's faces are at t = 2 (entry) and t = 4 (exit).
    np.testing.assert_array_equal(mesh.intersect(origins, directions)["t"], [2, 2, 2])
    np.testing.assert_array_equal(mesh.intersect(origins, directions, tmin=3.0)["t"], [4, 4, 4])
    got = mesh.intersect(origins, directions, tmin=np.array([0, 2.5, 4.5]), tmax=np.float32(5))
    np.testing.assert_array_equal(got["t"], [2, 4, np.inf])
    np.testing.assert_array_equal(got["triangle"] >= 0, [True, True, False])
    # tmin and tmax bound the interval inclusively.
    np.testing.assert_array_equal(mesh.intersect(origins, directions, tmin=2.0, tmax=2.0)["t"], [2, 2, 2])
    np.testing.assert_array_equal(
        mesh.occluded(origins, directions, tmax=[1.0, 2.0, 3.0]), [False, True, True]
    )
    np.testing.assert_array_equal(mesh.occluded(origins, directions, tmin=4.5), [False] * 3)


def test_occluded_agrees_with_intersect(rng):
    vertices, faces = random_soup(rng)
    origins, directions = random_rays(rng)
    mesh = arbor.Mesh(vertices, faces)
    tmax = rng.random(len(origins)) * 4
    hits = mesh.intersect(origins, directions, tmax=tmax)
    blocked = mesh.occluded(origins, directions, tmax=tmax)
    assert blocked.dtype == bool and 0 < blocked.sum() < len(blocked)
    np.testing.assert_array_equal(blocked, hits["triangle"] >= 0)


def test_intersect_into_out_reuses_the_arrays_and_answers_alike(rng):
    mesh = arbor.Mesh(*random_soup(rng))
    origins, directions = random_rays(rng)
    fresh = mesh.intersect(origins, directions, tmax=3.0)
    # An earlier result for other rays (so every entry must be rewritten).
    out = mesh.intersect(origins[::-1].copy(), -directions)
    arrays = {key: out[key] for key in out}
    assert mesh.intersect(origins, directions, tmax=3.0, out=out) is out
    for key in fresh:
        assert out[key] is arrays[key]
        np.testing.assert_array_equal(out[key], fresh[key])


def test_results_in_recycled_memory_stay_their_own(rng):
    # Columns of a megabyte or more come from memory earlier results let go
    # of: a later call may reuse a dropped result's memory, never a live one.
    mesh = arbor.Mesh(*random_soup(rng))
    k = 300_000
    a_rays = random_rays(rng, k)
    b_rays = random_rays(rng, k)
    a = mesh.intersect(*a_rays)
    b = mesh.intersect(*b_rays)
    assert np.isfinite(a["t"]).sum() > 1000
    a_copy = {key: value.copy() for key, value in a.items()}
    b_copy = {key: value.copy() for key, value in b.items()}
    freed = {value.ctypes.data for key, value in (*a.items(), *b.items()) if key != "point" or value is a["point"]}
    view = b["point"][::7]  # keeps b's point column alive
    del a, b
    c = mesh.intersect(*a_rays)
    d = mesh.intersect(*b_rays)
    assert c["t"].ctypes.data in freed  # recycled
    for key in a_copy:
        np.testing.assert_array_equal(c[key], a_copy[key])
        np.testing.assert_array_equal(d[key], b_copy[key])
        assert c[key].flags.c_contiguous and c[key].flags.writeable
    np.testing.assert_array_equal(view, b_copy["point"][::7])
    assert view.ctypes.data not in {value.ctypes.data for value in (*c.values(), *d.values())}


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda out: out.pop("normal"), 'missing "normal"'),
        (lambda out: out.update(t=out["t"].astype(np.float64)), 'out["t"]: expected a writeable C-contiguous float32 array of shape (500,)'),
        (lambda out: out.update(triangle=out["triangle"].astype(np.int32)), 'out["triangle"]: expected a writeable C-contiguous int64'),
        (lambda out: out.update(point=out["point"][:7]), 'out["point"]: expected a writeable C-contiguous float32 array of shape (500, 3)'),
        (lambda out: out.update(normal=np.asfortranarray(out["normal"])), 'out["normal"]: expected'),
        (lambda out: out["u"].setflags(write=False), "not writeable"),
        (lambda out: out.update(v=out["u"]), "already borrowed"),
    ],
)
def test_bad_out_arrays_are_value_errors(rng, change, message):
    mesh = arbor.Mesh(*random_soup(rng))
    origins, directions = random_rays(rng)
    out = mesh.intersect(origins, directions)
    change(out)
    with pytest.raises(ValueError, match=re.escape(message)):
        mesh.intersect(origins, directions, out=out)


def test_empty_mesh_and_no_rays():
    empty = arbor.Mesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    hits = empty.intersect([[0.0, 0, 0]], [[0.0, 0, 1]])
    assert hits["triangle"].tolist() == [-1] and hits["t"].tolist() == [np.inf]
    assert not empty.occluded([[0.0, 0, 0]], [[0.0, 0, 1]]).any()
    mesh = arbor.Mesh(*box())
    none = mesh.intersect(np.zeros((0, 3)), np.zeros((0, 3)))
    assert none["t"].shape == (0,) and none["point"].shape == (0, 3)


def test_queries_release_the_gil(rng):
    """Another Python thread runs while a query works: it counts how often it
    got to run between the query's start and end, which with the GIL held
    throughout would be (almost) never."""
    import threading

    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=5)
    origins, directions = random_rays(rng, 1_000_000)
    mesh = arbor.Mesh(sphere.vertices, sphere.faces)
    started, done = threading.Event(), threading.Event()

    def query():
        started.set()
        mesh.intersect(origins, directions)
        done.set()

    worker = threading.Thread(target=query)
    worker.start()
    started.wait()
    turns = 0
    while not done.is_set():
        turns += 1
        done.wait(0.0001)
    worker.join()
    assert turns > 50


def write_gltf(path, vertices, faces, nodes, roots):
    """A glTF file with one mesh (float32 vertices, uint32 faces in a data:
    URI buffer) placed by `nodes` (glTF node dicts, mesh 0), `roots` the
    scene's nodes."""
    import base64
    import json

    v = np.asarray(vertices, np.float32)
    f = np.asarray(faces, np.uint32).ravel()
    data = v.tobytes() + f.tobytes()
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": roots}],
        "nodes": nodes,
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(v), "type": "VEC3",
             "min": v.min(axis=0).tolist(), "max": v.max(axis=0).tolist()},
            {"bufferView": 1, "componentType": 5125, "count": len(f), "type": "SCALAR"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": v.nbytes},
            {"buffer": 0, "byteOffset": v.nbytes, "byteLength": f.nbytes},
        ],
        "buffers": [{"byteLength": len(data),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
    }
    path.write_text(json.dumps(doc))


def test_gltf_meshes_are_placed_and_numbered_as_arbor_trace_numbers_them(rng, tmp_path):
    """Node transforms applied, nodes depth first (a node's mesh before its
    children), one copy per placement; the answers are arbor trace's on the
    same file."""
    vertices, faces = box()
    nodes = [
        {"mesh": 0, "translation": [3, 0, 0], "children": [1]},
        {"mesh": 0, "translation": [0, 3, 0], "scale": [0.5, 0.5, 0.5]},
        {"mesh": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -3, 0, 1]},
    ]
    path = tmp_path / "boxes.gltf"
    write_gltf(path, vertices, faces, nodes, roots=[2, 0])
    mesh = arbor.load_mesh(path)
    v = vertices.astype(np.float32)
    want = np.concatenate([v + [0, -3, 0], v + [3, 0, 0], 0.5 * v + [3, 3, 0]]).astype(np.float32)
    np.testing.assert_array_equal(mesh.vertices, want)
    np.testing.assert_array_equal(mesh.faces, np.concatenate([faces, faces + 8, faces + 16]))
    # From far away towards points around the three boxes.
    o32 = (20 * rng.normal(size=(3000, 3))).astype(np.float32)
    d32 = (rng.uniform([-1, -4, -1], [4, 4, 1], (3000, 3)) - o32).astype(np.float32)
    hits = mesh.intersect(o32, d32)
    t, tri, u, v = trace_cli(tmp_path, path, o32, d32, 0.0, np.inf)
    assert len(np.unique(tri[tri >= 0] // 12)) == 3  # every placement is hit
    np.testing.assert_array_equal(hits["triangle"], tri)
    np.testing.assert_array_equal(hits["t"], t)
    # The same file as GLB: the same mesh.
    import json
    import struct

    text = json.loads(path.read_text())
    uri = text["buffers"][0].pop("uri")
    import base64

    blob = base64.b64decode(uri.split(",", 1)[1])
    chunk = json.dumps(text).encode()
    chunk += b" " * (-len(chunk) % 4)
    blob += b"\0" * (-len(blob) % 4)
    glb = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(chunk) + 8 + len(blob))
    glb += struct.pack("<I4s", len(chunk), b"JSON") + chunk + struct.pack("<I4s", len(blob), b"BIN\0") + blob
    (tmp_path / "boxes.glb").write_bytes(glb)
    binary = arbor.load_mesh(tmp_path / "boxes.glb")
    np.testing.assert_array_equal(binary.vertices, mesh.vertices)
    np.testing.assert_array_equal(binary.faces, mesh.faces)
