"""trimesh 5.2's `tests/test_ray.py` and `tests/test_ray_upstream.py`, run
from the shared test data with arbor as the intersector (see conftest.py)."""

from tests.test_ray import *  # noqa: F401,F403
from tests.test_ray_upstream import *  # noqa: F401,F403


def test_trimesh_builds_arbor_intersectors():
    """Meshes trimesh builds itself, with and without embree, use arbor."""
    import trimesh

    for use_embree in (True, False):
        mesh = trimesh.creation.box(use_embree=use_embree)
        assert type(mesh.ray).__module__ == "arbor.trimesh"
