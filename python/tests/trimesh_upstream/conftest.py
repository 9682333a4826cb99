"""Runs trimesh 5.2's own ray tests with arbor as trimesh's intersector.

The tests are not copied: they are imported from the shared test data
(``$ARBOR_SHARED/peers/trimesh-5.2/tests``, default ``../shared`` beside
the repository) by ``test_trimesh_own.py``. Both of trimesh's intersectors,
the pure-Python ``ray_triangle`` one and the Embree ``ray_pyembree`` one,
are replaced by ``arbor.trimesh.RayMeshIntersector`` before they load
(``arbor.trimesh.install()``), so every mesh they build casts its rays
with arbor.
"""

import os
import pathlib
import sys

import pytest
import trimesh.ray.ray_pyembree
import trimesh.ray.ray_triangle

import arbor.trimesh

REPO = pathlib.Path(__file__).resolve().parents[3]
SHARED = pathlib.Path(os.environ.get("ARBOR_SHARED", REPO.parent / "shared"))
UPSTREAM = SHARED / "peers" / "trimesh-5.2"

# trimesh's modules are placeholders when embreex is missing: then the
# upstream file would skip itself, which counts as a failure here.
if not isinstance(trimesh.ray.ray_pyembree, type(trimesh)):
    raise ImportError("embreex is needed to run trimesh's ray tests: pip install embreex")

arbor.trimesh.install()

if (UPSTREAM / "tests" / "test_ray.py").is_file():
    # Imported as the package `tests`, as trimesh's tests import each other.
    sys.path.insert(0, str(UPSTREAM))
    collect_ignore = []
elif os.environ.get("ARBOR_REQUIRE_TEST_DATA") == "1":
    raise FileNotFoundError(f"trimesh's tests are not in {UPSTREAM}")
else:
    collect_ignore = ["test_trimesh_own.py"]


@pytest.fixture(autouse=True)
def _arbor_is_the_intersector():
    """Checks, around every test, that trimesh still uses arbor."""
    yield
    assert trimesh.ray.ray_pyembree.RayMeshIntersector is arbor.trimesh.RayMeshIntersector
    assert trimesh.ray.ray_triangle.RayMeshIntersector is arbor.trimesh.RayMeshIntersector
