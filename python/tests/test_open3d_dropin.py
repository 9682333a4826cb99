"""arbor.RaycastingScene as a drop-in for open3d.t.geometry.RaycastingScene.

The steps of Open3D 0.20's ray casting and distance query tutorials (and
the example in ``list_intersections``' docstring), written with the calls
in the tutorials' form (Open3D tensors in, ``.numpy()``, ``.isfinite()``,
``.item()`` on the answers), run twice: with Open3D's class and with
arbor's in its place, nothing else changed. Both answers must agree: the
same hits, geometry and triangle ids, distances within float32 rounding.
Where they differ, arbor's must be the right one (a ray's crossings of a
closed surface from outside are even; Open3D's float test counts some
edge crossings twice). The tutorials' downloaded models are replaced by
meshes made from Open3D's primitives (``o3d_meshes``).

Needs open3d (CI installs open3d-cpu); skipped without it, which CI's
``ARBOR_NO_SKIPS=1`` turns into a failure.
"""

import numpy as np
import pytest

o3d = pytest.importorskip("open3d")

import arbor  # noqa: E402
from o3d_meshes import blob, knot  # noqa: E402

OPEN3D = o3d.t.geometry.RaycastingScene
ARBOR = arbor.RaycastingScene


def both(tutorial, *args):
    """``tutorial(RaycastingScene, ...)`` run with Open3D's class and arbor's."""
    return tutorial(OPEN3D, *args), tutorial(ARBOR, *args)


def plain(value):
    """NumPy arrays of an answer, from tensors or arrays."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    return value.numpy() if hasattr(value, "numpy") else np.asarray(value)


# --- The ray casting tutorial ----------------------------------------------


def first_rays(RaycastingScene):
    """Two rays at Open3D's box, given as an Open3D tensor."""
    cube = o3d.geometry.TriangleMesh.create_box().translate([0, 0, 0])
    cube = o3d.t.geometry.TriangleMesh.from_legacy(cube)
    scene = RaycastingScene()
    cube_id = scene.add_triangles(cube)
    rays = o3d.core.Tensor([[0.5, 0.5, 10, 0, 0, -1], [-1, -1, -1, 0, 0, -1]], dtype=o3d.core.Dtype.Float32)
    ans = scene.cast_rays(rays)
    return cube_id, sorted(ans.keys()), ans["t_hit"].numpy(), ans["geometry_ids"].numpy()


def three_meshes(RaycastingScene):
    """The tutorial's scene: a box, a torus and a sphere."""
    cube = o3d.geometry.TriangleMesh.create_box().translate([0, 0, 0])
    cube = o3d.t.geometry.TriangleMesh.from_legacy(cube)
    torus = o3d.geometry.TriangleMesh.create_torus().translate([0, 0, 2])
    torus = o3d.t.geometry.TriangleMesh.from_legacy(torus)
    sphere = o3d.geometry.TriangleMesh.create_sphere(radius=0.5).translate([1, 2, 3])
    sphere = o3d.t.geometry.TriangleMesh.from_legacy(sphere)
    scene = RaycastingScene()
    scene.add_triangles(cube)
    scene.add_triangles(torus)
    _ = scene.add_triangles(sphere)
    return scene


def depth_image(RaycastingScene):
    """The tutorial's image: pinhole rays, the hits, a virtual point cloud."""
    scene = three_meshes(RaycastingScene)
    rays = RaycastingScene.create_rays_pinhole(
        fov_deg=90,
        center=[0, 0, 2],
        eye=[2, 3, 0],
        up=[0, 1, 0],
        width_px=640,
        height_px=480,
    )
    ans = scene.cast_rays(rays)
    images = ans["t_hit"].numpy(), np.abs(ans["primitive_normals"].numpy()), ans["geometry_ids"].numpy()
    hit = ans["t_hit"].isfinite()
    points = rays[hit][:, :3] + rays[hit][:, 3:] * ans["t_hit"][hit].reshape((-1, 1))
    pcd = o3d.t.geometry.PointCloud(points)
    return scene, rays, ans, images, pcd.point.positions.numpy()


def test_first_rays_agree():
    theirs, ours = both(first_rays)
    assert ours[0] == theirs[0] == 0
    assert ours[1] == theirs[1]
    np.testing.assert_allclose(ours[2], theirs[2], rtol=2e-6)
    assert ours[2][1] == np.inf and ours[2].dtype == theirs[2].dtype == np.float32
    np.testing.assert_array_equal(ours[3], theirs[3])
    assert ours[3].dtype == np.uint32


def assert_same_closest_hits(ours, theirs):
    """The same rays hit, the same geometry and triangle; t, uvs and normals
    within float32 rounding (Open3D's t is off by up to ~1e-5 relative)."""
    ours, theirs = plain(ours), plain(theirs)
    assert ours.keys() == theirs.keys()
    for key in ours:
        assert ours[key].dtype == theirs[key].dtype and ours[key].shape == theirs[key].shape, key
    np.testing.assert_array_equal(ours["geometry_ids"], theirs["geometry_ids"])
    np.testing.assert_array_equal(ours["primitive_ids"], theirs["primitive_ids"])
    np.testing.assert_allclose(ours["t_hit"], theirs["t_hit"], rtol=2e-5)
    np.testing.assert_allclose(ours["primitive_normals"], theirs["primitive_normals"], atol=1e-5)
    np.testing.assert_allclose(ours["primitive_uvs"], theirs["primitive_uvs"], atol=1e-3)


def test_depth_image_agrees():
    theirs, ours = both(depth_image)
    # Open3D's rays, to 1e-6.
    assert ours[1].shape == (480, 640, 6) and ours[1].dtype == np.float32
    np.testing.assert_allclose(ours[1].numpy(), theirs[1].numpy(), rtol=1e-6, atol=1e-6)
    assert_same_closest_hits(ours[2], theirs[2])
    hit = np.isfinite(ours[2]["t_hit"])
    assert 0.1 < hit.mean() < 0.9
    assert set(np.unique(ours[2]["geometry_ids"][hit])) == {0, 1, 2}
    for mine, open3d_image in zip(ours[3], theirs[3]):
        np.testing.assert_allclose(mine, open3d_image, rtol=2e-5, atol=1e-5)
    np.testing.assert_allclose(ours[4], theirs[4], rtol=1e-4, atol=1e-4)
    assert len(ours[4]) == hit.sum()


def sorted_crossings(listed, keep=None):
    """The entries of a ``list_intersections`` answer (``keep`` of them),
    sorted by ray, then distance: arbor sorts them so, Open3D lists each
    ray's crossings in the order its traversal found them."""
    listed = {k: v[keep] for k, v in listed.items() if k != "ray_splits"} if keep is not None else listed
    order = np.lexsort((listed["t_hit"], listed["ray_ids"]))
    return {k: v[order] for k, v in listed.items() if k != "ray_splits"}


def assert_same_crossings(ours, theirs):
    """Two sorted lists of crossings agree: ids equal, distances within
    float32 rounding, uvs within Open3D's precision."""
    for key in ("ray_ids", "geometry_ids", "primitive_ids"):
        assert ours[key].dtype == theirs[key].dtype == np.uint32
        np.testing.assert_array_equal(ours[key], theirs[key])
    np.testing.assert_allclose(ours["t_hit"], theirs["t_hit"], rtol=2e-5)
    np.testing.assert_allclose(ours["primitive_uvs"], theirs["primitive_uvs"], atol=1e-3)


def test_occlusions_counts_and_lists_on_the_image_rays():
    (scene_o3d, rays, _, _, _), (scene, rays_arbor, _, _, _) = both(depth_image)
    np.testing.assert_array_equal(
        scene.test_occlusions(rays).numpy(), scene_o3d.test_occlusions(rays).numpy()
    )
    for tnear, tfar in ((0.0, 3.0), (2.5, np.inf)):
        np.testing.assert_array_equal(
            scene.test_occlusions(rays_arbor, tnear=tnear, tfar=tfar).numpy(),
            scene_o3d.test_occlusions(rays, tnear=tnear, tfar=tfar).numpy(),
        )
    ours, theirs = scene.count_intersections(rays).numpy(), scene_o3d.count_intersections(rays).numpy()
    assert ours.dtype == theirs.dtype == np.int32
    # From outside three closed meshes every ray crosses them an even
    # number of times: arbor always, Open3D but for a few edge crossings.
    assert (ours % 2 == 0).all()
    differ = ours != theirs
    assert differ.sum() <= 5 and (theirs[differ] % 2 == 1).all()
    listed, listed_o3d = plain(scene.list_intersections(rays)), plain(scene_o3d.list_intersections(rays))
    assert listed.keys() == listed_o3d.keys()
    np.testing.assert_array_equal(listed["ray_splits"], np.concatenate([[0], np.cumsum(ours.ravel())]))
    # The same crossings on the other rays.
    mine = sorted_crossings(listed, ~np.repeat(differ.ravel(), ours.ravel()))
    open3d_ones = sorted_crossings(listed_o3d, ~np.repeat(differ.ravel(), theirs.ravel()))
    assert_same_crossings(mine, open3d_ones)


def test_both_pinhole_forms_from_arrays_and_tensors():
    fov = dict(
        fov_deg=60.0, center=[0.5, 0.2, -1.0], eye=[3.0, 1.0, 4.0], up=[0.0, 0.0, 1.0], width_px=33, height_px=17
    )
    tensors = {k: o3d.core.Tensor(np.float32(v)) if isinstance(v, list) else v for k, v in fov.items()}
    want = OPEN3D.create_rays_pinhole(**fov).numpy()
    for given in (fov, tensors):
        np.testing.assert_allclose(ARBOR.create_rays_pinhole(**given), want, rtol=1e-6, atol=1e-6)
    positional = ARBOR.create_rays_pinhole(*fov.values())
    np.testing.assert_allclose(positional, want, rtol=1e-6, atol=1e-6)
    intrinsic = np.array([[300.0, 2.0, 160.5], [0, 310.0, 99.0], [0, 0, 1]])
    angle = 0.4
    extrinsic = np.eye(4)
    extrinsic[:3, :3] = [[np.cos(angle), 0, np.sin(angle)], [0, 1, 0], [-np.sin(angle), 0, np.cos(angle)]]
    extrinsic[:3, 3] = [0.3, -1.0, 5.0]
    want = OPEN3D.create_rays_pinhole(intrinsic, extrinsic, 320, 200).numpy()
    forms = [(intrinsic, extrinsic), (o3d.core.Tensor(intrinsic), o3d.core.Tensor(extrinsic))]
    for k, e in forms + [(intrinsic.tolist(), extrinsic.tolist())]:
        got = ARBOR.create_rays_pinhole(k, e, 320, 200)
        assert got.shape == (200, 320, 6) and got.dtype == np.float32
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-6)
    got = ARBOR.create_rays_pinhole(
        intrinsic_matrix=intrinsic, extrinsic_matrix=extrinsic, width_px=320, height_px=200
    )
    np.testing.assert_allclose(got.numpy(), want, rtol=1e-6, atol=1e-6)


# --- The distance queries tutorial -----------------------------------------


def distances(RaycastingScene, mesh):
    """A point, random points and a 32^3 grid: distances and occupancy."""
    scene = RaycastingScene()
    _ = scene.add_triangles(mesh)
    query_point = o3d.core.Tensor([[10, 10, 10]], dtype=o3d.core.Dtype.Float32)
    unsigned_distance = scene.compute_distance(query_point)
    signed_distance = scene.compute_signed_distance(query_point)
    occupancy = scene.compute_occupancy(query_point)
    one = unsigned_distance.numpy(), signed_distance.numpy(), occupancy.numpy()
    min_bound = mesh.vertex.positions.min(0).numpy()
    max_bound = mesh.vertex.positions.max(0).numpy()
    N = 256
    query_points = np.random.default_rng(1).uniform(low=min_bound, high=max_bound, size=[N, 3]).astype(np.float32)
    random = scene.compute_signed_distance(query_points).numpy()
    xyz_range = np.linspace(min_bound, max_bound, num=32)
    query_points = np.stack(np.meshgrid(*xyz_range.T), axis=-1).astype(np.float32)
    signed_distance = scene.compute_signed_distance(query_points)
    grid = (
        signed_distance.numpy()[:, :, 15],
        signed_distance.numpy(),
        scene.compute_distance(query_points).numpy(),
        scene.compute_occupancy(query_points).numpy(),
        scene.compute_occupancy(query_points, nsamples=3).numpy(),
    )
    return one, random, grid


@pytest.mark.parametrize("make", [knot, blob], ids=["knot", "blob"])
def test_distance_fields_agree(make):
    mesh = make()
    (one_o3d, random_o3d, grid_o3d), (one, random, grid) = both(distances, mesh)
    for mine, theirs in zip(one, one_o3d):
        assert mine.dtype == theirs.dtype == np.float32 and mine.shape == theirs.shape == (1,)
        np.testing.assert_allclose(mine, theirs, rtol=1e-5)
    np.testing.assert_allclose(random, random_o3d, rtol=1e-4, atol=1e-5)
    assert grid[1].shape == (32, 32, 32)
    for mine, theirs in zip(grid, grid_o3d):
        assert mine.dtype == theirs.dtype and mine.shape == theirs.shape
        np.testing.assert_allclose(mine, theirs, rtol=1e-4, atol=1e-5)
    inside = grid[3] == 1
    assert 0.05 < inside.mean() < 0.6
    np.testing.assert_array_equal(grid[1] < 0, inside)


def closest_geometry(RaycastingScene):
    """Closest points, an inside test by counting crossings, and the
    tutorial's signed distance with the closest geometry on a grid."""
    cube = o3d.t.geometry.TriangleMesh.from_legacy(
        o3d.geometry.TriangleMesh.create_box().translate([-1.2, -1.2, 0])
    )
    sphere = o3d.t.geometry.TriangleMesh.from_legacy(
        o3d.geometry.TriangleMesh.create_sphere(0.5).translate([0.7, 0.8, 0])
    )
    scene = RaycastingScene()
    mesh_ids = {}
    mesh_ids[scene.add_triangles(cube)] = "cube"
    mesh_ids[scene.add_triangles(sphere)] = "sphere"
    query_point = o3d.core.Tensor([[0, 0, 0]], dtype=o3d.core.Dtype.Float32)
    ans = scene.compute_closest_points(query_point)
    one = ans["points"].numpy(), mesh_ids[ans["geometry_ids"][0].item()], ans["primitive_ids"][0].item()
    rays = np.concatenate([query_point.numpy(), np.ones(query_point.shape, dtype=np.float32)], axis=-1)
    intersection_counts = scene.count_intersections(rays).numpy()
    is_inside = intersection_counts % 2 == 1

    def compute_signed_distance_and_closest_geometry(query_points):
        closest_points = scene.compute_closest_points(query_points)
        distance = np.linalg.norm(query_points - closest_points["points"].numpy(), axis=-1)
        rays = np.concatenate([query_points, np.ones_like(query_points)], axis=-1)
        intersection_counts = scene.count_intersections(rays).numpy()
        is_inside = intersection_counts % 2 == 1
        distance[is_inside] *= -1
        return distance, closest_points["geometry_ids"].numpy()

    xyz_range = np.linspace([-2, -2, -2], [2, 2, 2], num=32)
    query_points = np.stack(np.meshgrid(*xyz_range.T), axis=-1).astype(np.float32)
    sdf, closest_geom = compute_signed_distance_and_closest_geometry(query_points)
    return one, is_inside, sdf, closest_geom


def test_closest_geometry_agrees():
    theirs, ours = both(closest_geometry)
    np.testing.assert_allclose(ours[0][0], theirs[0][0], atol=1e-6)
    assert ours[0][1:] == theirs[0][1:] == ("cube", ours[0][2])
    np.testing.assert_array_equal(ours[1], theirs[1])
    np.testing.assert_allclose(ours[2], theirs[2], rtol=1e-4, atol=1e-5)
    assert (ours[2] < 0).any()
    np.testing.assert_array_equal(ours[3], theirs[3])


# --- list_intersections' docstring example ---------------------------------


def ray_grid(RaycastingScene, mesh):
    """Rays on a grid across the mesh's box, all crossings listed, and the
    crossings' points from the uvs and from the rays."""
    scene = RaycastingScene()
    mesh_id = scene.add_triangles(mesh)
    bb_min = mesh.vertex["positions"].min(dim=0).numpy()
    bb_max = mesh.vertex["positions"].max(dim=0).numpy()
    x, y = np.linspace(bb_min, bb_max, num=37)[:, :2].T
    xv, yv = np.meshgrid(x, y)
    orig = np.stack([xv, yv, np.full_like(xv, bb_min[2] - 1)], axis=-1).reshape(-1, 3)
    dest = orig + np.full(orig.shape, (0, 0, 2 + bb_max[2] - bb_min[2]), dtype=np.float32)
    rays = np.concatenate([orig, dest - orig], axis=-1).astype(np.float32)
    lx = scene.list_intersections(rays)
    lx = {k: v.numpy() for k, v in lx.items()}
    v = mesh.vertex["positions"].numpy()
    t = mesh.triangle["indices"].numpy()
    tidx = lx["primitive_ids"]
    uv = lx["primitive_uvs"]
    w = 1 - np.sum(uv, axis=1)
    from_uvs = v[t[tidx, 1]] * uv[:, 0][:, None] + v[t[tidx, 2]] * uv[:, 1][:, None] + v[t[tidx, 0]] * w[:, None]
    from_rays = rays[lx["ray_ids"]][:, :3] + rays[lx["ray_ids"]][:, 3:] * lx["t_hit"][..., None]
    return mesh_id, lx, from_uvs, from_rays


@pytest.mark.parametrize("make", [knot, blob], ids=["knot", "blob"])
def test_listed_intersections_agree(make):
    mesh = make()
    theirs, ours = both(ray_grid, mesh)
    assert ours[0] == theirs[0] == 0
    lx, lx_o3d = ours[1], theirs[1]
    assert lx.keys() == lx_o3d.keys()
    for key in lx:
        assert lx[key].dtype == lx_o3d[key].dtype, key
    assert len(lx["t_hit"]) > 300
    np.testing.assert_array_equal(lx["ray_splits"], lx_o3d["ray_splits"])
    # arbor's are sorted already.
    assert all((sorted_crossings(lx)[k] == lx[k]).all() for k in lx if k != "ray_splits")
    assert_same_crossings(lx, sorted_crossings(lx_o3d))
    np.testing.assert_allclose(ours[2], ours[3], atol=1e-5)
    np.testing.assert_allclose(np.sort(ours[2], axis=0), np.sort(theirs[2], axis=0), atol=1e-4)


# --- Open3D's arguments and answers ----------------------------------------


def test_device_and_thread_arguments():
    scene = ARBOR(device=o3d.core.Device("CPU:0"))
    assert ARBOR(nthreads=2, device="CPU:0") is not None
    box = o3d.t.geometry.TriangleMesh.from_legacy(o3d.geometry.TriangleMesh.create_box())
    assert scene.add_triangles(box) == 0
    for device in (o3d.core.Device("CUDA:0"), "CUDA:0", "SYCL:0"):
        with pytest.raises(ValueError, match="arbor runs on the CPU"):
            ARBOR(device=device)


def test_answers_read_as_tensors_and_as_arrays():
    scene = three_meshes(ARBOR)
    rays = o3d.core.Tensor(np.array([[0.5, 0.5, 10, 0, 0, -1]] * 4, np.float32).reshape(2, 2, 6))
    ans = scene.cast_rays(rays)
    t = ans["t_hit"]
    assert isinstance(t, np.ndarray) and t.shape == (2, 2) and t.dtype == np.float32
    assert type(t.numpy()) is np.ndarray and np.shares_memory(t.numpy(), t)
    assert t.cpu() is t and t.isfinite().all() and not t.isnan().any()
    want = three_meshes(OPEN3D).cast_rays(rays)
    np.testing.assert_allclose(t + 1, want["t_hit"].numpy() + 1, rtol=1e-6)
    assert ans["geometry_ids"][0, 0].item() == 1  # the torus, above the box
    points = np.ones((3, 3), np.float32)
    for given in (o3d.core.Tensor(points), points.tolist(), points):
        assert scene.compute_distance(given).shape == (3,)
