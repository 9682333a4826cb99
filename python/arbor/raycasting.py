"""An Open3D-shaped ray casting scene over arbor.

``arbor.RaycastingScene`` follows ``open3d.t.geometry.RaycastingScene``:
geometries are added with :meth:`RaycastingScene.add_triangles` and queried
with rays given as ``(..., 6)`` arrays of origin and direction. Answers are
NumPy arrays (Open3D returns tensors) with Open3D's keys, dtypes and miss
values. All geometries are indexed together by one :class:`arbor.Mesh`,
built on the first query after a change.
"""

import numpy as np

from ._arbor import Mesh

#: The id of "no geometry" / "no triangle", as Open3D reports it.
INVALID_ID = np.iinfo(np.uint32).max


def _as_arrays(vertex_positions, triangle_indices):
    """The vertex and index arrays of what ``add_triangles`` was given."""
    if triangle_indices is not None:
        return vertex_positions, triangle_indices
    mesh = vertex_positions
    if hasattr(mesh, "vertex") and hasattr(mesh, "triangle"):
        # open3d.t.geometry.TriangleMesh: tensors behind attribute maps.
        return mesh.vertex.positions.numpy(), mesh.triangle.indices.numpy()
    if hasattr(mesh, "vertices") and (hasattr(mesh, "triangles") or hasattr(mesh, "faces")):
        # open3d.geometry.TriangleMesh (triangles) or a trimesh (faces).
        faces = mesh.triangles if hasattr(mesh, "triangles") else mesh.faces
        return np.asarray(mesh.vertices), np.asarray(faces)
    raise TypeError(
        "add_triangles: expected (vertex_positions, triangle_indices) arrays "
        "or a triangle mesh"
    )


class RaycastingScene:
    """A scene of triangle meshes for ray casting, shaped like Open3D's.

    ``nthreads`` is accepted for compatibility; queries use arbor's thread
    pool (all cores, or ``RAYON_NUM_THREADS``).
    """

    INVALID_ID = INVALID_ID

    def __init__(self, nthreads=0):
        self._vertices = []
        self._faces = []
        self._mesh = None
        # first triangle of each geometry, then the total
        self._offsets = np.zeros(1, dtype=np.int64)

    def add_triangles(self, vertex_positions, triangle_indices=None):
        """Adds a mesh; returns its geometry id (0, 1, ...).

        Takes ``(n, 3)`` float vertex positions and ``(m, 3)`` integer
        triangle indices, or one mesh object (Open3D's tensor or legacy
        ``TriangleMesh``, or anything with ``vertices`` and ``faces``).
        Raises ValueError for wrong shapes or dtypes, NaN positions or an
        index out of range.
        """
        vertices, faces = _as_arrays(vertex_positions, triangle_indices)
        # Checked now, so the error points at the call that caused it.
        checked = Mesh(vertices, faces)
        vertices = checked.vertices
        faces = checked.faces
        self._faces.append(faces + sum(len(v) for v in self._vertices))
        self._vertices.append(vertices)
        self._offsets = np.append(self._offsets, self._offsets[-1] + len(faces))
        self._mesh = None
        return len(self._faces) - 1

    def _scene(self):
        """The one mesh of every geometry, built once after each change."""
        if self._mesh is None:
            if self._faces:
                vertices = np.concatenate(self._vertices)
                faces = np.concatenate(self._faces)
            else:
                vertices = np.zeros((0, 3), np.float32)
                faces = np.zeros((0, 3), np.int64)
            self._mesh = Mesh(vertices, faces)
        return self._mesh

    def _ids(self, triangle):
        """Open3D's geometry and primitive ids of scene triangles (-1: none)."""
        hit = triangle >= 0
        geometry = np.full(triangle.shape, INVALID_ID, dtype=np.uint32)
        primitive = np.full(triangle.shape, INVALID_ID, dtype=np.uint32)
        g = np.searchsorted(self._offsets, triangle[hit], side="right") - 1
        geometry[hit] = g
        primitive[hit] = triangle[hit] - self._offsets[g]
        return geometry, primitive

    @staticmethod
    def _rays(rays):
        """Origins and directions of ``(..., 6)`` rays, and the leading shape."""
        rays = np.asarray(rays)
        if rays.ndim < 1 or rays.shape[-1] != 6:
            raise ValueError(f"rays: expected an array of shape (..., 6), got shape {rays.shape}")
        flat = rays.reshape(-1, 6)
        return flat[:, :3], flat[:, 3:], rays.shape[:-1]

    def cast_rays(self, rays, nthreads=0):
        """The closest hit of each ray ``(ox, oy, oz, dx, dy, dz)``.

        Returns a dict: ``t_hit`` (float32, inf on a miss, in units of the
        direction's length), ``geometry_ids`` and ``primitive_ids`` (uint32,
        ``INVALID_ID`` on a miss), ``primitive_uvs`` (float32 ``(..., 2)``
        barycentrics, 0 on a miss) and ``primitive_normals`` (float32
        ``(..., 3)`` unit geometric normals, 0 on a miss).
        """
        origins, directions, shape = self._rays(rays)
        hits = self._scene().intersect(origins, directions)
        geometry, primitive = self._ids(hits["triangle"])
        miss = hits["triangle"] < 0
        uvs = np.stack([hits["u"], hits["v"]], axis=-1)
        uvs[miss] = 0
        normals = hits["normal"]
        normals[miss] = 0
        return {
            "t_hit": hits["t"].reshape(shape),
            "geometry_ids": geometry.reshape(shape),
            "primitive_ids": primitive.reshape(shape),
            "primitive_uvs": uvs.reshape(shape + (2,)),
            "primitive_normals": normals.reshape(shape + (3,)),
        }

    @staticmethod
    def _points(query_points):
        """``(..., 3)`` query points as ``(k, 3)``, and the leading shape."""
        points = np.asarray(query_points)
        if points.ndim < 1 or points.shape[-1] != 3:
            raise ValueError(
                f"query_points: expected an array of shape (..., 3), got shape {points.shape}"
            )
        return points.reshape(-1, 3), points.shape[:-1]

    def test_occlusions(self, rays, tnear=0.0, tfar=np.inf, nthreads=0):
        """Whether anything lies on each ray with ``tnear <= t <= tfar``:
        a bool array of the rays' leading shape."""
        origins, directions, shape = self._rays(rays)
        return self._scene().occluded(origins, directions, tnear, tfar).reshape(shape)

    def count_intersections(self, rays, nthreads=0):
        """How many times each ray crosses the surfaces (int32), each
        crossing once even where a ray passes through a shared edge or
        vertex."""
        origins, directions, shape = self._rays(rays)
        return self._scene().count(origins, directions).astype(np.int32).reshape(shape)

    def list_intersections(self, rays, nthreads=0):
        """Every crossing of every ray, sorted by ray, then distance.

        Returns a dict: ``ray_splits`` (uint32, one more than rays: ray
        ``i``'s hits are entries ``ray_splits[i]:ray_splits[i + 1]``),
        ``ray_ids``, ``geometry_ids``, ``primitive_ids`` (uint32),
        ``primitive_uvs`` (float32 ``(h, 2)``) and ``t_hit`` (float32).
        """
        origins, directions, _ = self._rays(rays)
        hits = self._scene().all_hits(origins, directions)
        geometry, primitive = self._ids(hits["triangle"])
        counts = np.bincount(hits["ray"], minlength=len(origins))
        splits = np.zeros(len(origins) + 1, dtype=np.uint32)
        np.cumsum(counts, out=splits[1:])
        return {
            "ray_splits": splits,
            "ray_ids": hits["ray"].astype(np.uint32),
            "geometry_ids": geometry,
            "primitive_ids": primitive,
            "primitive_uvs": np.stack([hits["u"], hits["v"]], axis=-1),
            "t_hit": hits["t"],
        }

    def compute_closest_points(self, query_points, nthreads=0):
        """The closest point of the surfaces to each query point.

        Returns a dict: ``points`` (float32 ``(..., 3)``), ``geometry_ids``
        and ``primitive_ids`` (uint32), ``primitive_uvs`` (float32
        ``(..., 2)``) and ``primitive_normals`` (float32 ``(..., 3)``). In an
        empty scene the ids are ``INVALID_ID``, the points NaN and the rest 0.
        """
        points, shape = self._points(query_points)
        near = self._scene().closest_points(points)
        triangle = near["triangle"]
        geometry, primitive = self._ids(triangle)
        found = triangle >= 0
        uvs = np.zeros((len(points), 2), np.float32)
        uvs[found] = np.stack([near["u"], near["v"]], axis=-1)[found]
        normals = near["normal"]
        normals[~found] = 0
        return {
            "points": near["point"].reshape(shape + (3,)),
            "geometry_ids": geometry.reshape(shape),
            "primitive_ids": primitive.reshape(shape),
            "primitive_uvs": uvs.reshape(shape + (2,)),
            "primitive_normals": normals.reshape(shape + (3,)),
        }

    def compute_distance(self, query_points, nthreads=0):
        """The distance from each query point to the surfaces (float32)."""
        points, shape = self._points(query_points)
        return self._scene().closest_points(points)["distance"].reshape(shape)

    def compute_signed_distance(self, query_points, nthreads=0, nsamples=1):
        """The distance to the surfaces, negative inside (float32): the sign
        is the exact parity of one ray's crossings, so ``nsamples`` (Open3D's
        number of voting rays) is accepted and not needed."""
        points, shape = self._points(query_points)
        return self._scene().signed_distance(points).reshape(shape)

    def compute_occupancy(self, query_points, nthreads=0, nsamples=1):
        """1.0 for query points inside the surfaces, 0.0 outside (float32),
        by the exact parity of one ray's crossings."""
        points, shape = self._points(query_points)
        return self._scene().contains(points).astype(np.float32).reshape(shape)
