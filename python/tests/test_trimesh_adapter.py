"""arbor.trimesh.RayMeshIntersector: trimesh's interface, built lazily,
following edits of the mesh, empty meshes, locations."""

import copy
import pickle

import numpy as np
import pytest
import trimesh

import arbor.trimesh
from helpers import brute_hits

DOWN = np.array([[0.0, 0.0, -1.0]])


def box_with_arbor(**kwargs):
    mesh = trimesh.creation.box(extents=[2, 2, 2], **kwargs)
    mesh.ray = arbor.trimesh.RayMeshIntersector(mesh)
    return mesh


def test_built_lazily_and_rebuilt_after_edits():
    mesh = box_with_arbor()
    assert mesh.ray._built is None
    origin = np.array([[0.5, 0.5, 5.0]])
    assert mesh.ray.intersects_any(origin, DOWN).tolist() == [True]
    built = mesh.ray._built[1]
    mesh.ray.intersects_first(origin, DOWN)
    assert mesh.ray._built[1] is built  # unchanged mesh: no rebuild
    mesh.apply_translation([10.0, 0, 0])
    assert mesh.ray.intersects_any(origin, DOWN).tolist() == [False]
    assert mesh.ray.intersects_any(origin + [10.0, 0, 0], DOWN).tolist() == [True]
    mesh.vertices[:, 2] += 1.0  # in place, through trimesh's tracked array
    locations, _, _ = mesh.ray.intersects_location(origin + [10.0, 0, 0], DOWN, multiple_hits=False)
    np.testing.assert_allclose(locations, [[10.5, 0.5, 2.0]])


def test_empty_mesh():
    empty = trimesh.Trimesh()
    ray = arbor.trimesh.RayMeshIntersector(empty)
    assert ray.intersects_any(np.zeros((3, 3)), np.ones((3, 3))).tolist() == [False] * 3
    assert ray.intersects_first(np.zeros((2, 3)), np.ones((2, 3))).tolist() == [-1, -1]
    tri, idx, loc = ray.intersects_id(np.zeros((2, 3)), np.ones((2, 3)), multiple_hits=False, return_locations=True)
    assert tri.shape == (0,) and idx.shape == (0,) and loc.shape == (0, 3)
    assert tri.dtype == np.int64 and idx.dtype == np.int64


def test_first_hits_match_brute_force():
    mesh = trimesh.creation.icosphere(subdivisions=2)
    mesh.ray = arbor.trimesh.RayMeshIntersector(mesh)
    rng = np.random.default_rng(5)
    origins = rng.normal(size=(300, 3)) * 2
    directions = rng.normal(size=(300, 3)) * 0.6 - origins
    first = mesh.ray.intersects_first(origins, directions)
    brute = brute_hits(mesh.vertices.astype(np.float32), mesh.faces, origins.astype(np.float32), directions.astype(np.float32))
    expected = [tri[0] if len(tri) else -1 for _, tri in brute]
    assert 50 < (first >= 0).sum() < 300
    np.testing.assert_array_equal(first, expected)
    np.testing.assert_array_equal(mesh.ray.intersects_any(origins, directions), first >= 0)
    tri, ray, loc = mesh.ray.intersects_id(origins, directions, multiple_hits=False, return_locations=True)
    np.testing.assert_array_equal(ray, np.nonzero(first >= 0)[0])
    np.testing.assert_array_equal(tri, first[ray])
    # Locations lie on the ray and on the plane of their triangle.
    d = directions[ray] / np.linalg.norm(directions[ray], axis=1, keepdims=True)
    np.testing.assert_allclose(np.cross(loc - origins[ray], d), 0, atol=1e-9)
    plane = np.einsum("ij,ij->i", mesh.face_normals[tri], loc - mesh.triangles[tri, 0])
    np.testing.assert_allclose(plane, 0, atol=1e-12)


def test_mismatched_rays_are_a_value_error():
    mesh = box_with_arbor()
    with pytest.raises(ValueError, match="Ray origin and direction don't match"):
        mesh.ray.intersects_any(np.zeros((2, 3)), np.ones((3, 3)))


def test_copies_and_pickles_follow_the_same_mesh():
    mesh = box_with_arbor()
    mesh.ray.intersects_any([[0.0, 0, 5]], DOWN)
    for other in (copy.copy(mesh.ray), copy.deepcopy(mesh.ray)):
        assert other.mesh is mesh and other._built is None
    restored = pickle.loads(pickle.dumps(mesh.ray))
    assert restored._built is None
    assert restored.intersects_any([[0.0, 0, 5]], DOWN).tolist() == [True]


def test_multiple_hits_each_crossing_once_and_max_hits():
    mesh = box_with_arbor()
    # Down through the box's centre: the top and bottom faces' diagonals.
    origins = np.array([[0.0, 0.0, 5.0], [0.3, 0.2, 5.0], [7.0, 7.0, 5.0]])
    directions = np.tile(DOWN, (3, 1))
    tri, ray, loc = mesh.ray.intersects_id(origins, directions, return_locations=True)
    np.testing.assert_array_equal(ray, [0, 0, 1, 1])
    np.testing.assert_allclose(loc[:, 2], [1, -1, 1, -1])
    np.testing.assert_allclose(mesh.face_normals[tri][:, 2], [1, -1, 1, -1])
    tri, ray = mesh.ray.intersects_id(origins, directions, max_hits=1)
    np.testing.assert_array_equal(ray, [0, 1])
    locations, index_ray, index_tri = mesh.ray.intersects_location(origins, directions)
    np.testing.assert_array_equal(index_ray, [0, 0, 1, 1])
    assert locations.shape == (4, 3) and index_tri.dtype == np.int64


def test_contains_points_is_exact_parity():
    mesh = trimesh.creation.icosphere(subdivisions=2)
    mesh.ray = arbor.trimesh.RayMeshIntersector(mesh)
    points = np.array([[0.0, 0, 0], [0.5, 0.1, 0.2], [2.0, 0, 0], [0.0, 0, -1.5]])
    np.testing.assert_array_equal(mesh.contains(points), [True, True, False, False])
    np.testing.assert_array_equal(mesh.ray.contains_points(points), [True, True, False, False])
    assert arbor.trimesh.RayMeshIntersector(trimesh.Trimesh()).contains_points(points).tolist() == [False] * 4


def test_install_makes_arbor_the_intersector_of_new_meshes(monkeypatch):
    class Other:
        def __init__(self, mesh, **kwargs):
            self.mesh = mesh

    monkeypatch.setattr(trimesh.ray.ray_triangle, "RayMeshIntersector", Other)
    monkeypatch.setattr(trimesh.ray.ray_pyembree, "RayMeshIntersector", Other)
    before = trimesh.creation.box()
    arbor.trimesh.install()
    for use_embree in (True, False):
        mesh = trimesh.creation.box(use_embree=use_embree)
        assert isinstance(mesh.ray, arbor.trimesh.RayMeshIntersector)
        assert mesh.contains([[0.0, 0, 0], [2.0, 0, 0]]).tolist() == [True, False]
    assert isinstance(before.ray, Other)  # meshes made before keep theirs


def test_intersects_location_passes_max_hits_on():
    mesh = box_with_arbor()
    origins = np.array([[0.0, 0.0, 5.0], [0.3, 0.2, 5.0]])
    locations, index_ray, _ = mesh.ray.intersects_location(origins, np.tile(DOWN, (2, 1)), max_hits=1)
    np.testing.assert_array_equal(index_ray, [0, 1])
    np.testing.assert_allclose(locations[:, 2], [1, 1])


def test_tensors_and_float32_rays():
    mesh = box_with_arbor()
    origins = np.array([[0.5, 0.5, 5.0]], np.float32)
    first = mesh.ray.intersects_first(origins, DOWN.astype(np.float32))
    assert first.tolist() == mesh.ray.intersects_first(origins.astype(float), DOWN).tolist() == [4]
    with pytest.raises(ValueError, match="ray_origins: expected real numbers"):
        mesh.ray.intersects_any([["a", "b", "c"]], DOWN)
