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
    # Open3D's miss values: INVALID_ID and zeros.
    assert near["geometry_ids"][0] == scene.INVALID_ID and (near["points"] == 0).all()
    assert (near["primitive_normals"] == 0).all()
    assert scene.compute_distance(np.zeros((1, 3), np.float32))[0] == np.inf


class FakeTensor:
    """Stands for an ``open3d.core.Tensor``: ``.numpy()``, ``.device``, no
    ``__array__``."""

    def __init__(self, array, device="CPU:0"):
        self.array, self.device = array, device

    def numpy(self):
        return self.array


class FakeTorch(FakeTensor):
    """Stands for a torch tensor: ``__array__``, ``detach()``, ``.device``."""

    def __array__(self, dtype=None, copy=None):
        return self.array

    def detach(self):
        return self


def test_tensors_lists_and_arrays_give_the_same_answers():
    scene, _, _ = two_boxes()
    rays = np.array([[0.1, 0.2, -5, 0, 0, 1], [3.1, 0.2, -5, 0, 0, 2]], np.float32)
    want = scene.cast_rays(rays)
    forms = [FakeTensor(rays), FakeTorch(rays), FakeTorch(rays, device="cpu"), FakeTensor(rays, "TFRT_CPU_0")]
    for given in forms + [rays.tolist(), rays.astype(np.float64)]:
        got = scene.cast_rays(given)
        for key in want:
            np.testing.assert_array_equal(got[key], want[key])
    # Integers are numbers too (as float64).
    np.testing.assert_array_equal(scene.cast_rays([[0, 0, -5, 0, 0, 1]])["t_hit"], [4.5])
    points = FakeTensor(np.array([[0, 0, 2.0]], np.float32))
    np.testing.assert_allclose(scene.compute_distance(points), [1.5])


def test_float_arrays_and_tensors_are_viewed_not_copied():
    from arbor._inputs import as_array, last_axis

    rays = np.zeros((4, 5, 6), np.float32)
    for given in (rays, FakeTensor(rays), FakeTorch(rays)):
        assert as_array(given, "rays") is rays
        flat, shape = last_axis(given, "rays", 6)
        assert shape == (4, 5) and np.shares_memory(flat, rays)
    # Rays in the columns of a wider array stay a (strided) view.
    wide = np.zeros((4, 5, 8), np.float64)
    flat, _ = last_axis(wide[..., 1:7], "rays", 6)
    assert np.shares_memory(flat, wide) and flat.shape == (20, 6)


def test_bad_arrays_are_clear_value_errors():
    scene, _, _ = two_boxes()
    cases = [
        (FakeTensor(np.zeros((2, 6), np.float32), device="CUDA:0"), "arbor runs on the CPU, got device CUDA:0"),
        (FakeTorch(np.zeros((2, 6), np.float32), device="cuda:0"), "arbor runs on the CPU"),
        ([["a"] * 6], r"rays: expected real numbers, got dtype <U1"),
        (np.zeros((2, 6), complex), "rays: expected real numbers, got dtype complex128"),
        ([[1, 2, 3, 4, 5, 6], [1, 2]], "rays: cannot be read as an array"),
        (object(), "rays: expected real numbers, got dtype object"),
        (np.zeros(6, np.float32)[:5], r"rays: expected an array of shape \(\.\.\., 6\), got shape \(5,\)"),
    ]
    for given, message in cases:
        with pytest.raises(ValueError, match=message):
            scene.cast_rays(given)
    with pytest.raises(ValueError, match="query_points: expected real numbers"):
        scene.compute_closest_points([["x", "y", "z"]])
    with pytest.raises(ValueError, match="vertex_positions: arbor runs on the CPU"):
        scene.add_triangles(FakeTensor(np.zeros((3, 3)), "CUDA:0"), np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match="vertices: NaN"):
        scene.add_triangles(np.full((3, 3), np.nan), np.array([[0, 1, 2]]))


def test_nan_rays_miss_as_in_open3d():
    scene, _, _ = two_boxes()
    rays = np.array([[np.nan, 0, -5, 0, 0, 1], [0, 0, -5, 0, 0, 1]], np.float32)
    np.testing.assert_array_equal(scene.cast_rays(rays)["t_hit"], [np.inf, 4.5])
    np.testing.assert_array_equal(scene.count_intersections(rays), [0, 2])


def test_nan_points_have_nan_distances_as_in_open3d():
    scene, _, _ = two_boxes()
    points = np.array([[np.nan, 0, 0], [0, 0, -5]], np.float32)
    for query in (scene.compute_distance, scene.compute_signed_distance):
        got = query(points)
        assert np.isnan(got[0]) and got[1] > 0, query.__name__
    assert scene.compute_occupancy(points)[0] == 0
    assert scene.compute_closest_points(points)["geometry_ids"][0] == arbor.RaycastingScene.INVALID_ID


def test_device_argument():
    assert arbor.RaycastingScene(device="CPU:0") is not None
    assert arbor.RaycastingScene(nthreads=4, device="cpu") is not None
    for device in ("CUDA:0", "SYCL:0", "cuda", 0):
        with pytest.raises(ValueError, match="RaycastingScene: arbor runs on the CPU"):
            arbor.RaycastingScene(device=device)


def test_answers_also_answer_open3d_tensor_methods():
    scene, _, _ = two_boxes()
    rays = np.array([[0.1, 0.2, -5, 0, 0, 1], [9, 9, -5, 0, 0, 1]], np.float32)
    ans = scene.cast_rays(rays)
    t = ans["t_hit"]
    assert isinstance(t, np.ndarray) and t.shape == (2,) and t.dtype == np.float32
    plain = t.numpy()
    assert type(plain) is np.ndarray and np.shares_memory(plain, t)
    assert t.cpu() is t and t.contiguous().flags.c_contiguous
    np.testing.assert_array_equal(t.isfinite(), [True, False])
    np.testing.assert_array_equal(t.isinf(), [False, True])
    assert not t.isnan().any()
    assert ans["geometry_ids"][0].item() == 0
    assert scene.test_occlusions(rays).numpy().dtype == bool
    assert scene.count_intersections(rays).numpy().dtype == np.int32
    assert type(scene.list_intersections(rays)["ray_splits"].numpy()) is np.ndarray
    assert scene.compute_occupancy(rays[:, :3]).numpy().dtype == np.float32


def test_nsamples_is_accepted_and_checked_as_open3d_checks_it():
    scene, _, _ = two_boxes()
    points = np.array([[0, 0, 0], [3, 0, 0.25], [1.5, 0, 0]], np.float32)
    for nsamples in (1, 3, 11):
        np.testing.assert_array_equal(scene.compute_occupancy(points, nsamples=nsamples), [1, 1, 0])
        np.testing.assert_allclose(scene.compute_signed_distance(points, nsamples=nsamples), [-0.5, -0.25, 1.0])
    for nsamples in (0, 2, -1, 1.0):
        with pytest.raises(ValueError, match="nsamples: expected a positive odd integer"):
            scene.compute_occupancy(points, nsamples=nsamples)
        with pytest.raises(ValueError, match="nsamples"):
            scene.compute_signed_distance(points, nsamples=nsamples)


def test_pinhole_rays_by_hand():
    # A 60 degree field of view over 2 pixels: focal length sqrt(3), pixel
    # centres at +-0.5 from the image's centre.
    rays = arbor.RaycastingScene.create_rays_pinhole(
        fov_deg=60, center=[0, 0, 1], eye=[0, 0, 0], up=[0, 1, 0], width_px=2, height_px=2
    )
    assert rays.shape == (2, 2, 6) and rays.dtype == np.float32
    a = 0.5 / np.sqrt(3)
    np.testing.assert_allclose(rays[..., :3], 0, atol=1e-7)
    np.testing.assert_allclose(rays[0, 0, 3:], [-a, -a, 1], rtol=1e-6)
    np.testing.assert_allclose(rays[1, 0, 3:], [-a, a, 1], rtol=1e-6)
    np.testing.assert_allclose(rays[0, 1, 3:], [a, -a, 1], rtol=1e-6)
    # The intrinsic form: K^-1 of the pixel centres, turned and moved by
    # the inverse of the world-to-camera matrix.
    k = np.array([[100.0, 3, 20], [0, 110, 15], [0, 0, 1]])
    e = np.eye(4)
    e[:3, :3] = [[0, 1, 0], [-1, 0, 0], [0, 0, 1]]
    e[:3, 3] = [1, 2, 3]
    rays = arbor.RaycastingScene.create_rays_pinhole(k, e, 3, 2)
    assert rays.shape == (2, 3, 6)
    np.testing.assert_allclose(rays[..., :3], np.broadcast_to([2, -1, -3], (2, 3, 3)))
    y = (1.5 - 15) / 110
    camera = np.array([(2.5 - 20 - 3 * y) / 100, y, 1])
    np.testing.assert_allclose(rays[1, 2, 3:], e[:3, :3].T @ camera, rtol=1e-6)


def test_pinhole_bad_arguments():
    make = arbor.RaycastingScene.create_rays_pinhole
    fov = dict(fov_deg=60, center=[0, 0, 1], eye=[0, 0, 0], up=[0, 1, 0], width_px=4, height_px=3)
    k, e = np.eye(3), np.eye(4)
    with pytest.raises(TypeError, match=r"create_rays_pinhole: expected \(intrinsic_matrix"):
        make(k, e, 4)
    cases = [
        (dict(fov, center=[0, 0, 0]), "center and eye: expected two different points"),
        (dict(fov, up=[0, 0, 2]), "up: expected a vector not parallel"),
        (dict(fov, fov_deg=180), "fov_deg: expected an angle between 0 and 180"),
        (dict(fov, eye=[np.nan, 0, 0]), "eye: expected finite values"),
        (dict(fov, up=[0, 1]), r"up: expected shape \(3,\)"),
        (dict(fov, width_px=0), "width_px: expected a positive number of pixels"),
    ]
    for kwargs, message in cases:
        with pytest.raises(ValueError, match=message):
            make(**kwargs)
    with pytest.raises(TypeError, match="height_px: expected an integer"):
        make(**dict(fov, height_px=2.5))
    with pytest.raises(ValueError, match="intrinsic_matrix: expected an upper triangular"):
        make(k.T + np.tri(3, k=-1), e, 4, 3)
    with pytest.raises(ValueError, match="intrinsic_matrix: the focal lengths"):
        make(np.zeros((3, 3)), e, 4, 3)
    with pytest.raises(ValueError, match=r"extrinsic_matrix: expected shape \(4, 4\), got shape \(3, 4\)"):
        make(k, e[:3], 4, 3)
