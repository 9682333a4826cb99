"""arbor.RaycastingScene: Open3D's keys, dtypes, shapes and miss values,
over several geometries."""

import types

import numpy as np
import pytest

import arbor
from helpers import box, random_rays, random_soup


def two_boxes():
    """A scene of two unit boxes, the second one 3 along +x."""
    scene = arbor.RaycastingScene()
    v, f = box(-0.5, 0.5)
    assert scene.add_triangles(v.astype(np.float32), f.astype(np.uint32)) == 0
    assert scene.add_triangles(v + [3.0, 0, 0], f) == 1
    return scene, v, f


def test_cast_rays_names_geometry_and_triangle():
    scene, v, f = two_boxes()
    rays = np.array(
        [
            [0.1, 0.2, -5, 0, 0, 1],  # first box, z = -0.5 face
            [3.1, 0.2, -5, 0, 0, 2],  # second box; t in direction lengths
            [9.0, 9.0, -5, 0, 0, 1],  # miss
        ],
        dtype=np.float32,
    )
    got = scene.cast_rays(rays)
    assert got["t_hit"].dtype == np.float32
    np.testing.assert_array_equal(got["t_hit"], [4.5, 2.25, np.inf])
    assert got["geometry_ids"].dtype == np.uint32
    np.testing.assert_array_equal(got["geometry_ids"], [0, 1, scene.INVALID_ID])
    # Both hits are on the z = lo face: triangles 8 or 9 of each box.
    assert got["primitive_ids"][0] in (8, 9) and got["primitive_ids"][1] in (8, 9)
    assert got["primitive_ids"][2] == 4294967295
    np.testing.assert_array_equal(got["primitive_normals"], [[0, 0, -1], [0, 0, -1], [0, 0, 0]])
    assert got["primitive_uvs"].shape == (3, 2) and (got["primitive_uvs"][2] == 0).all()
    # The uvs are barycentrics of the hit point on its triangle.
    for i, x in ((0, [0.1, 0.2]), (1, [0.1, 0.2])):
        tri = v[f[got["primitive_ids"][i]]]
        u, w = got["primitive_uvs"][i]
        np.testing.assert_allclose(((1 - u - w) * tri[0] + u * tri[1] + w * tri[2])[:2], x, atol=1e-6)


def test_cast_rays_equals_mesh_intersect_over_the_concatenated_mesh():
    rng = np.random.default_rng(3)
    (v1, f1), (v2, f2) = random_soup(rng, 40), random_soup(rng, 40)
    scene = arbor.RaycastingScene()
    scene.add_triangles(v1, f1)
    scene.add_triangles(v2, f2)
    whole = arbor.Mesh(np.vstack([v1, v2]), np.vstack([f1, f2 + len(v1)]))
    o, d = random_rays(rng, 400)
    got = scene.cast_rays(np.hstack([o, d]))
    want = whole.intersect(o, d)
    hit = want["triangle"] >= 0
    assert 50 < hit.sum() < 400
    np.testing.assert_array_equal(got["t_hit"], want["t"])
    tri = np.where(got["geometry_ids"] == 1, got["primitive_ids"].astype(np.int64) + 40, got["primitive_ids"])
    np.testing.assert_array_equal(tri[hit], want["triangle"][hit])
    assert (got["geometry_ids"][hit] == (want["triangle"][hit] >= 40)).all()


def test_rays_keep_their_leading_shape():
    scene, _, _ = two_boxes()
    rays = np.zeros((4, 5, 6), np.float32)
    rays[..., 2] = -5
    rays[..., 5] = 1
    got = scene.cast_rays(rays)
    assert got["t_hit"].shape == (4, 5) and got["primitive_uvs"].shape == (4, 5, 2)
    assert got["primitive_normals"].shape == (4, 5, 3)
    np.testing.assert_array_equal(got["t_hit"], 4.5)
    assert scene.test_occlusions(rays).shape == (4, 5)


def test_occlusions_with_tnear_and_tfar():
    scene, _, _ = two_boxes()
    rays = np.array([[0, 0, -5, 0, 0, 1]] * 3, np.float32)
    got = scene.test_occlusions(rays, tfar=np.array([4.0, 4.5, 9.0]))
    assert got.dtype == bool
    np.testing.assert_array_equal(got, [False, True, True])
    np.testing.assert_array_equal(scene.test_occlusions(rays, tnear=5.6), [False] * 3)


def test_empty_scene_misses_and_mesh_objects_are_accepted():
    scene = arbor.RaycastingScene()
    got = scene.cast_rays(np.array([[0, 0, 0, 0, 0, 1]], np.float32))
    assert got["t_hit"][0] == np.inf and got["geometry_ids"][0] == scene.INVALID_ID
    v, f = box()
    legacy = types.SimpleNamespace(vertices=v, triangles=f)
    assert scene.add_triangles(legacy) == 0
    assert scene.cast_rays(np.array([[0.0, 0, -5, 0, 0, 1]]))["t_hit"][0] == 4


def test_bad_input():
    scene = arbor.RaycastingScene()
    v, f = box()
    with pytest.raises(ValueError, match="but the mesh has 8 vertices"):
        scene.add_triangles(v, f + 1)
    with pytest.raises(TypeError, match="add_triangles: expected"):
        scene.add_triangles(42)
    with pytest.raises(ValueError, match=r"rays: expected an array of shape \(\.\.\., 6\)"):
        scene.cast_rays(np.zeros((3, 3)))
    # the failed call added nothing
    assert scene.add_triangles(v, f) == 0


def test_counts_and_lists_of_intersections():
    scene, _, _ = two_boxes()
    rays = np.array(
        [[-5, 0, 0, 1, 0, 0], [9, 9, 9, 1, 0, 0], [-0.5, -0.5, -5, 0, 0, 1]], np.float32
    )
    counts = scene.count_intersections(rays)
    assert counts.dtype == np.int32
    # Through both boxes; a miss; along the edge x = y = -0.5 of the first box,
    # which touches its silhouette: 0 or 2 crossings, never 1.
    assert counts[0] == 4 and counts[1] == 0 and counts[2] in (0, 2)
    listed = scene.list_intersections(rays)
    n = counts.sum()
    np.testing.assert_array_equal(listed["ray_splits"], np.concatenate([[0], np.cumsum(counts)]))
    assert listed["ray_ids"].dtype == np.uint32 and len(listed["ray_ids"]) == n
    np.testing.assert_array_equal(listed["t_hit"][:4], [4.5, 5.5, 7.5, 8.5])
    np.testing.assert_array_equal(listed["geometry_ids"][:4], [0, 0, 1, 1])
    assert listed["primitive_uvs"].shape == (n, 2)
    assert (listed["primitive_ids"][:4] < 12).all()


def test_point_queries():
    scene, _, _ = two_boxes()
    points = np.array([[0, 0, 2.0], [3, 0, 0.25], [1.5, 0, 0]], np.float32)
    near = scene.compute_closest_points(points)
    np.testing.assert_allclose(near["points"], [[0, 0, 0.5], [3, 0, 0.5], [0.5, 0, 0]], atol=1e-7)
    np.testing.assert_array_equal(near["geometry_ids"], [0, 1, 0])
    np.testing.assert_array_equal(near["primitive_normals"], [[0, 0, 1], [0, 0, 1], [1, 0, 0]])
    assert near["primitive_uvs"].shape == (3, 2) and near["primitive_ids"].dtype == np.uint32
    np.testing.assert_allclose(scene.compute_distance(points), [1.5, 0.25, 1.0])
    np.testing.assert_allclose(scene.compute_signed_distance(points), [1.5, -0.25, 1.0])
    np.testing.assert_array_equal(scene.compute_occupancy(points), [0, 1, 0])
    grid = np.zeros((2, 4, 3), np.float32)
    assert scene.compute_signed_distance(grid).shape == (2, 4)
    assert scene.compute_closest_points(grid)["points"].shape == (2, 4, 3)
    with pytest.raises(ValueError, match=r"query_points: expected an array of shape \(\.\.\., 3\)"):
        scene.compute_distance(np.zeros((3, 2)))


def test_empty_scene_point_queries():
    scene = arbor.RaycastingScene()
    near = scene.compute_closest_points(np.zeros((1, 3), np.float32))
    assert near["geometry_ids"][0] == scene.INVALID_ID and np.isnan(near["points"]).all()
    assert (near["primitive_normals"] == 0).all()
    assert scene.compute_distance(np.zeros((1, 3), np.float32))[0] == np.inf
