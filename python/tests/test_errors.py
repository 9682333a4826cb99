"""Bad input: a Python exception that says what is wrong, never a crash."""

import re
import numpy as np
import pytest

import arbor
from helpers import box

V, F = box()
O = np.zeros((2, 3))
D = np.ones((2, 3))


@pytest.mark.parametrize(
    "vertices, faces, message",
    [
        (V[:, :2], F, r"vertices: expected an array of shape \(k, 3\), got shape \(8, 2\)"),
        (V.ravel(), F, r"vertices: .*got shape \(24,\)"),
        (V.astype(np.int64), F, "vertices: expected float32 or float64 values, got dtype int64"),
        (V.astype(np.float16), F, "got dtype float16"),
        (V, F[:, :2], r"faces: expected an array of shape \(k, 3\)"),
        (V, F.astype(np.float64), "faces: expected integer vertex indices, got dtype float64"),
        (V, F + 8, "faces: triangle 0 names vertex 8, but the mesh has 8 vertices"),
        (V, -F - 1, "faces: triangle 0 has vertex index -1, out of range"),
        (V, F.astype(np.uint64) + np.uint64(2**63), "out of range"),
        (np.where(np.arange(24).reshape(8, 3) == 5, np.nan, V), F, "vertices: NaN coordinates"),
        ("not numbers", F, "vertices: cannot be read as an array"),
    ],
)
def test_bad_meshes_are_value_errors(vertices, faces, message):
    with pytest.raises(ValueError, match=message):
        arbor.Mesh(vertices, faces)


def test_unknown_accel_is_a_value_error():
    with pytest.raises(ValueError, match="accel: unknown accelerator 'octree'; expected one of"):
        arbor.Mesh(V, F, accel="octree")


def test_bad_quality_is_a_value_error():
    with pytest.raises(ValueError, match='quality: unknown build quality "best" \\(expected fast or high\\)'):
        arbor.Mesh(V, F, quality="best")
    with pytest.raises(ValueError, match='quality: "high" builds spatial splits, which only bvh-wide and bvh-sah have, not grid'):
        arbor.Mesh(V, F, accel="grid", quality="high")


@pytest.mark.parametrize("query", ["intersect", "occluded"])
@pytest.mark.parametrize(
    "args, kwargs, message",
    [
        ((O[:, :2], D), {}, r"origins: expected an array of shape \(k, 3\)"),
        ((O, D[:1]), {}, "directions: expected 2 rows, one per origin, got 1"),
        ((O, D.astype(np.int32)), {}, "directions: expected float32 or float64"),
        ((O, D), {"tmin": [0.0, 1.0, 2.0]}, r"tmin: expected a number or an array of shape \(2,\), got shape \(3,\)"),
        ((O, D), {"tmax": np.ones((2, 1))}, r"tmax: .*got shape \(2, 1\)"),
        ((O, D), {"tmax": np.array([1, 2])}, "tmax: expected float32 or float64 values, got dtype int64"),
        ((O, D), {"tmin": "soon"}, "tmin: cannot be read as an array"),
    ],
)
def test_bad_rays_are_value_errors(query, args, kwargs, message):
    mesh = arbor.Mesh(V, F)
    with pytest.raises(ValueError, match=message):
        getattr(mesh, query)(*args, **kwargs)


def test_missing_model_is_an_os_error_naming_the_file(tmp_path):
    missing = tmp_path / "missing.obj"
    with pytest.raises(OSError, match=f"{missing}: cannot read the mesh file"):
        arbor.load_mesh(missing)


def test_broken_model_is_an_os_error_naming_file_and_line(tmp_path):
    broken = tmp_path / "broken.obj"
    broken.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n")
    with pytest.raises(OSError, match=f"{broken}:4: "):
        arbor.load_mesh(broken)
    unknown = tmp_path / "model.xyz"
    unknown.write_text("")
    with pytest.raises(OSError, match=re.escape(f"{unknown}: not a format arbor reads (.xyz)")):
        arbor.load_mesh(str(unknown))


@pytest.mark.parametrize("query", ["all_hits", "count"])
def test_bad_rays_of_the_crossing_queries(query):
    mesh = arbor.Mesh(V, F)
    with pytest.raises(ValueError, match="directions: expected 2 rows"):
        getattr(mesh, query)(O, D[:1])
    with pytest.raises(ValueError, match=r"tmax: .*got shape \(3,\)"):
        getattr(mesh, query)(O, D, tmax=[1.0, 2.0, 3.0])


@pytest.mark.parametrize("query", ["contains", "winding_number", "closest_points", "signed_distance"])
def test_bad_points_are_value_errors(query):
    mesh = arbor.Mesh(V, F)
    with pytest.raises(ValueError, match=r"points: expected an array of shape \(k, 3\), got shape \(2, 2\)"):
        getattr(mesh, query)(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="points: expected float32 or float64 values, got dtype int64"):
        getattr(mesh, query)(np.zeros((2, 3), np.int64))


def test_bad_maximum_distances_are_value_errors():
    mesh = arbor.Mesh(V, F)
    with pytest.raises(ValueError, match=r"max_distance: expected a number or an array of shape \(2,\)"):
        mesh.closest_points(np.zeros((2, 3)), max_distance=[1.0])


def test_broken_gltf_is_an_os_error_naming_the_file(tmp_path):
    broken = tmp_path / "broken.gltf"
    broken.write_text('{"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": {"POSITION": 4}}]}]}')
    with pytest.raises(OSError, match=re.escape(f"{broken}: mesh 0: POSITION names an accessor that does not exist")):
        arbor.load_mesh(broken)
    empty = tmp_path / "empty.glb"
    empty.write_bytes(b"")
    with pytest.raises(OSError, match=re.escape(f"{empty}: the file is empty")):
        arbor.load_mesh(empty)
