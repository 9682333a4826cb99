"""arbor: exact, watertight ray casting against triangle meshes.

The queries are those of arbor's Rust library (``arbor-accel``), run in
parallel with the GIL released, over NumPy arrays::

    import numpy as np, arbor
    mesh = arbor.Mesh(vertices, faces)            # (n, 3) floats, (m, 3) ints
    hits = mesh.intersect(origins, directions)    # dict of arrays
    hits["t"], hits["triangle"]                   # inf / -1 on a miss

``arbor.load_mesh(path)`` reads a mesh file with the loader of
``arbor trace``. ``arbor.render(path)`` renders a scene or model as
``arbor render`` does, into a ``(h, w, 3)`` float32 array of linear
radiance, and ``arbor.write_image(path, image)`` writes it as PNG or EXR.

Drop-ins (docs/python.md): ``arbor.RaycastingScene`` for Open3D's
``open3d.t.geometry.RaycastingScene`` (Open3D tensors, arrays or lists in;
NumPy arrays that also answer ``.numpy()`` out), and
``arbor.trimesh.RayMeshIntersector`` for trimesh's ``mesh.ray``
(``arbor.trimesh.install()`` for every new mesh).
"""

from ._arbor import Mesh, load_mesh, render, write_image
from .raycasting import RaycastingScene

__all__ = ["Mesh", "load_mesh", "render", "write_image", "RaycastingScene"]
