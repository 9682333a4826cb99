"""arbor.Mesh's every-hit, count, inside/outside, closest-point and
signed-distance queries, against brute force and analytic shapes."""

import numpy as np
import pytest
import trimesh

import arbor
from helpers import box, box_distance, brute_closest, brute_hits, random_rays, random_soup, trace_cli, write_obj


@pytest.fixture
def rng():
    return np.random.default_rng(11)


def test_all_hits_match_brute_force(rng):
    vertices, faces = random_soup(rng, 80)
    origins, directions = random_rays(rng, 400)
    v32, o32, d32 = (a.astype(np.float32) for a in (vertices, origins, directions))
    mesh = arbor.Mesh(v32, faces)
    hits = mesh.all_hits(o32, d32)
    assert hits["ray"].dtype == np.int64 and hits["triangle"].dtype == np.int64
    assert np.all(np.diff(hits["ray"]) >= 0)  # sorted by ray
    counts = mesh.count(o32, d32)
    assert counts.dtype == np.uint32
    np.testing.assert_array_equal(counts, np.bincount(hits["ray"], minlength=len(o32)))
    brute = brute_hits(v32, faces, o32, d32)
    assert sum(len(t) for t, _ in brute) > 400
    for i, (t, tri) in enumerate(brute):
        mine = hits["ray"] == i
        np.testing.assert_array_equal(hits["triangle"][mine], tri, err_msg=f"ray {i}")
        np.testing.assert_allclose(hits["t"][mine], t, rtol=1e-5)
        assert np.all(np.diff(hits["t"][mine]) >= 0)
    # The first of each ray's hits is its closest hit.
    first = mesh.intersect(o32, d32)
    starts = np.searchsorted(hits["ray"], np.arange(len(o32)))
    hit = counts > 0
    np.testing.assert_array_equal(hits["triangle"][starts[hit]], first["triangle"][hit])
    np.testing.assert_array_equal(hits["t"][starts[hit]], first["t"][hit])
    np.testing.assert_allclose(hits["point"], o32[hits["ray"]] + hits["t"][:, None] * d32[hits["ray"]], rtol=1e-5, atol=1e-5)


def test_all_hits_respect_tmin_and_tmax():
    mesh = arbor.Mesh(*box())
    o = np.array([[0.0, 0, -3]] * 3)
    d = np.array([[0.0, 0, 1]] * 3)
    hits = mesh.all_hits(o, d, tmin=np.array([0.0, 3.0, 0.0]), tmax=np.array([9.0, 9.0, 3.0]))
    np.testing.assert_array_equal(hits["ray"], [0, 0, 1, 2])
    np.testing.assert_array_equal(hits["t"], [2, 4, 4, 2])
    np.testing.assert_array_equal(mesh.count(o, d, tmin=[0.0, 3.0, 0.0], tmax=3.0), [1, 0, 1])


def test_rays_through_shared_edges_and_vertices_cross_a_closed_mesh_evenly():
    vertices, faces = box()
    sphere = trimesh.creation.icosphere(subdivisions=2)
    for v, f in ((vertices, faces), (sphere.vertices, sphere.faces)):
        mesh = arbor.Mesh(v, f)
        assert mesh.open_edges() == 0
        # From outside, through every vertex and every edge midpoint.
        edges = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
        targets = np.vstack([v, v[edges].mean(axis=1)])
        origins = np.tile([[0.3, 5.1, 7.3]], (len(targets), 1))
        counts = mesh.count(origins, targets - origins)
        assert (counts % 2 == 0).all()
        assert (counts > 0).sum() > len(targets) // 2
        # From the centre out through each: exactly one crossing.
        centre = np.zeros_like(targets)
        np.testing.assert_array_equal(mesh.count(centre, targets), 1)
        hits = mesh.all_hits(centre, targets)
        np.testing.assert_array_equal(hits["ray"], np.arange(len(targets)))


def test_contains_matches_an_analytic_box_and_sphere():
    grid = np.stack(np.meshgrid(*[np.linspace(-1.5, 1.5, 13)] * 3), axis=-1).reshape(-1, 3)
    grid = grid + 0.01  # off the box's faces
    inside = arbor.Mesh(*box()).contains(grid)
    assert inside.dtype == bool
    np.testing.assert_array_equal(inside, np.all(np.abs(grid) < 1, axis=1))
    sphere = trimesh.creation.icosphere(subdivisions=3)
    radius = np.linalg.norm(grid, axis=1)
    inner = np.linalg.norm(sphere.triangles_center, axis=1).min()
    clear = (radius < inner * 0.999) | (radius > 1.001)
    got = arbor.Mesh(sphere.vertices, sphere.faces).contains(grid)
    np.testing.assert_array_equal(got[clear], radius[clear] < 1)


def exact_winding(vertices, faces, points):
    """The sum of every triangle's signed solid angle over 4 pi (Van
    Oosterom and Strackee), in float64."""
    t = vertices[faces].astype(np.float64)
    w = np.zeros(len(points))
    for i, p in enumerate(points.astype(np.float64)):
        a, b, c = t[:, 0] - p, t[:, 1] - p, t[:, 2] - p
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
        det = np.einsum("ij,ij->i", a, np.cross(b, c))
        dot = lambda x, y: np.einsum("ij,ij->i", x, y)
        den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la
        w[i] = (2 * np.arctan2(det, den)).sum() / (4 * np.pi)
    return w


def test_winding_numbers_match_the_exact_sum_and_contains():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    rng = np.random.default_rng(5)
    points = (rng.random((300, 3)) * 3 - 1.5).astype(np.float32)
    mesh = arbor.Mesh(sphere.vertices, sphere.faces)
    w = mesh.winding_number(points)
    assert w.dtype == np.float32 and w.shape == (300,)
    np.testing.assert_allclose(w, exact_winding(sphere.vertices, sphere.faces, points), atol=1e-2)
    radius = np.linalg.norm(points, axis=1)
    clear = (radius < 0.98) | (radius > 1.001)
    np.testing.assert_array_equal((w >= 0.5)[clear], mesh.contains(points)[clear])
    # With a hole (a third of the sphere gone), the centre still winds
    # most of the way round.
    kept = sphere.faces[sphere.triangles_center[:, 2] < 0.5]
    centre = np.zeros((1, 3), dtype=np.float32)
    exact = exact_winding(sphere.vertices, kept, centre)[0]
    assert 0.6 < exact < 0.9
    assert abs(arbor.Mesh(sphere.vertices, kept).winding_number(centre)[0] - exact) < 1e-2


def test_closest_points_match_brute_force(rng):
    vertices, faces = random_soup(rng, 50)
    points = (rng.random((200, 3)) * 2 - 0.5).astype(np.float32)
    v32 = vertices.astype(np.float32)
    got = arbor.Mesh(v32, faces).closest_points(points)
    assert got["triangle"].dtype == np.int64 and got["distance"].dtype == np.float32
    for i, p in enumerate(points):
        distance, tri = brute_closest(v32, faces, p)
        assert got["distance"][i] == pytest.approx(distance, rel=1e-6, abs=1e-7)
        assert got["triangle"][i] == tri
    # The point is on its triangle at its barycentrics, at its distance.
    t = v32[faces[got["triangle"]]].astype(np.float64)
    u, v = got["u"][:, None], got["v"][:, None]
    np.testing.assert_allclose(got["point"], (1 - u - v) * t[:, 0] + u * t[:, 1] + v * t[:, 2], atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(got["point"] - points, axis=1), got["distance"], rtol=1e-5)


def test_closest_points_within_a_maximum_distance():
    mesh = arbor.Mesh(*box())
    points = np.array([[0.0, 0, 3], [0.0, 0, 3], [0.0, 0, 0.5]])
    got = mesh.closest_points(points, max_distance=np.array([1.5, 2.0, 0.1]))
    np.testing.assert_array_equal(got["triangle"] >= 0, [False, True, False])
    np.testing.assert_array_equal(got["distance"], [np.inf, 2.0, np.inf])
    assert np.isnan(got["point"][0]).all() and np.isnan(got["u"][2])
    np.testing.assert_array_equal(got["point"][1], [0, 0, 1])
    np.testing.assert_array_equal(mesh.closest_points(points, 0.5)["distance"], [np.inf, np.inf, 0.5])


def test_signed_distance_matches_an_analytic_box(rng):
    points = rng.random((500, 3)) * 4 - 2
    got = arbor.Mesh(*box()).signed_distance(points)
    assert got.dtype == np.float32
    np.testing.assert_allclose(got, box_distance(points), atol=1e-6)
    assert (got < 0).sum() > 20
    np.testing.assert_array_equal(got < 0, arbor.Mesh(*box()).contains(points))


def test_point_queries_read_every_layout_alike(rng):
    points = rng.random((50, 3)) * 4 - 2
    mesh = arbor.Mesh(*box())
    want = mesh.signed_distance(points.astype(np.float32))
    wide = np.zeros((50, 6), np.float32)
    wide[:, ::2] = points
    for p in (points, np.asfortranarray(points.astype(np.float32)), wide[:, ::2], points.tolist()):
        np.testing.assert_array_equal(mesh.signed_distance(p), want)
        np.testing.assert_array_equal(mesh.contains(p), want < 0)


@pytest.mark.parametrize("accel", ["list", "bvh-center", "bvh-median", "bvh-sah", "bvh-sweep", "bvh-cluster", "grid", "kdtree"])
def test_every_accelerator_answers_alike(accel, rng):
    vertices, faces = random_soup(rng, 60)
    origins, directions = random_rays(rng, 300)
    points = rng.random((100, 3))
    reference, other = arbor.Mesh(vertices, faces), arbor.Mesh(vertices, faces, accel=accel)
    assert other.accel == accel
    for query in ("intersect", "all_hits"):
        a, b = getattr(reference, query)(origins, directions), getattr(other, query)(origins, directions)
        for key in a:
            np.testing.assert_array_equal(a[key], b[key], err_msg=f"{query} {key}")
    np.testing.assert_array_equal(reference.occluded(origins, directions), other.occluded(origins, directions))
    np.testing.assert_array_equal(reference.count(origins, directions), other.count(origins, directions))
    np.testing.assert_array_equal(reference.signed_distance(points), other.signed_distance(points))


def test_empty_mesh_point_queries():
    empty = arbor.Mesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    p = np.zeros((2, 3))
    assert empty.contains(p).tolist() == [False, False]
    assert empty.closest_points(p)["triangle"].tolist() == [-1, -1]
    assert empty.signed_distance(p).tolist() == [np.inf, np.inf]
    assert empty.all_hits(p, np.ones((2, 3)))["ray"].shape == (0,)
    assert empty.count(p, np.ones((2, 3))).tolist() == [0, 0]
