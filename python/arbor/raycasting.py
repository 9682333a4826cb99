"""An Open3D-shaped ray casting scene over arbor.

``arbor.RaycastingScene`` is a drop-in for ``open3d.t.geometry.RaycastingScene``:
geometries are added with :meth:`RaycastingScene.add_triangles` and queried
with rays given as ``(..., 6)`` arrays of origin and direction, or points
as ``(..., 3)`` arrays, any leading shape kept in the answers. Arguments
may be NumPy arrays, ``open3d.core.Tensor`` objects, CPU torch tensors or
nested lists. Answers have Open3D's keys, dtypes and miss values; they are
NumPy arrays that also answer ``.numpy()``, ``.cpu()`` and ``.isfinite()``
as Open3D's tensors do (:class:`arbor._answers.Answer`), so code written for
either reads them. All geometries are indexed together by one
:class:`arbor.Mesh`, built on the first query after a change.
"""

import inspect

import numpy as np

from ._answers import answer, answers
from ._arbor import Mesh
from ._inputs import as_array, check_device, last_axis
from ._pinhole import rays_from_look_at, rays_from_matrices

#: The id of "no geometry" / "no triangle", as Open3D reports it.
INVALID_ID = np.iinfo(np.uint32).max

# create_rays_pinhole's two forms, told apart by their arguments.
_PINHOLE_FORMS = [(inspect.signature(f), f) for f in (rays_from_matrices, rays_from_look_at)]


def _as_arrays(vertex_positions, triangle_indices):
    """The vertex and index arrays of what ``add_triangles`` was given."""
    if triangle_indices is not None:
        return (
            as_array(vertex_positions, "vertex_positions"),
            as_array(triangle_indices, "triangle_indices", floats=False),
        )
    mesh = vertex_positions
    if hasattr(mesh, "vertex") and hasattr(mesh, "triangle"):
        # open3d.t.geometry.TriangleMesh: tensors behind attribute maps,
        # absent in a mesh without vertices or triangles.
        positions = mesh.vertex.positions if "positions" in mesh.vertex else np.zeros((0, 3))
        indices = mesh.triangle.indices if "indices" in mesh.triangle else np.zeros((0, 3), np.int64)
        return as_array(positions, "vertex positions"), as_array(indices, "triangle indices", floats=False)
    if hasattr(mesh, "vertices") and (hasattr(mesh, "triangles") or hasattr(mesh, "faces")):
        # open3d.geometry.TriangleMesh (triangles) or a trimesh (faces).
        faces = mesh.triangles if hasattr(mesh, "triangles") else mesh.faces
        return as_array(mesh.vertices, "vertices"), as_array(faces, "triangles", floats=False)
    raise TypeError(
        "add_triangles: expected (vertex_positions, triangle_indices) arrays "
        "or a triangle mesh"
    )


def _bound(value, what):
    """A ray bound: a number as it is (the fast path), else an array."""
    if isinstance(value, (int, float)):
        return value
    return as_array(value, what)


def _check_nsamples(nsamples):
    """Raises as Open3D does unless ``nsamples`` is a positive odd integer."""
    if not isinstance(nsamples, (int, np.integer)) or nsamples < 1 or nsamples % 2 == 0:
        raise ValueError(f"nsamples: expected a positive odd integer, got {nsamples!r}")


class RaycastingScene:
    """A scene of triangle meshes for ray casting, shaped like Open3D's.

    ``nthreads`` is accepted for compatibility; queries use arbor's thread
    pool (all cores, or ``RAYON_NUM_THREADS``). ``device`` may be left out
    or name the CPU (``open3d.core.Device("CPU:0")`` or ``"CPU:0"``); any
    other device is a ValueError, arbor running on the CPU.
    """

    INVALID_ID = INVALID_ID

    def __init__(self, nthreads=0, device=None):
        check_device(device, "RaycastingScene")
        self._vertices = []
        self._faces = []
        self._mesh = None
        # first triangle of each geometry, then the total
        self._offsets = np.zeros(1, dtype=np.int64)

    def add_triangles(self, vertex_positions, triangle_indices=None):
        """Adds a mesh; returns its geometry id (0, 1, ...).

        Takes ``(n, 3)`` float vertex positions and ``(m, 3)`` integer
        triangle indices (arrays, tensors or lists), or one mesh object
        (Open3D's tensor or legacy ``TriangleMesh``, or anything with
        ``vertices`` and ``faces``). Raises ValueError for wrong shapes or
        dtypes, NaN positions, an index out of range or a GPU device.
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
        flat, shape = last_axis(rays, "rays", 6)
        return flat[:, :3], flat[:, 3:], shape

    @staticmethod
    def create_rays_pinhole(*args, **kwargs):
        """The ``(height_px, width_px, 6)`` float32 rays of a pinhole camera,
        as Open3D makes them, in either of Open3D's two forms:

        ``create_rays_pinhole(intrinsic_matrix, extrinsic_matrix, width_px,
        height_px)``: an upper triangular ``(3, 3)`` intrinsic matrix and a
        rigid ``(4, 4)`` world-to-camera extrinsic matrix;

        ``create_rays_pinhole(fov_deg, center, eye, up, width_px,
        height_px)``: a horizontal field of view in degrees, the point
        looked at, the camera's position and its up vector.

        Each ray starts at the camera's centre and passes through a pixel's
        centre; its direction has length 1 along the optical axis. Matrices
        and vectors may be arrays, tensors or lists.
        """
        for signature, build in _PINHOLE_FORMS:
            try:
                bound = signature.bind(*args, **kwargs)
            except TypeError:
                continue
            return answer(build(*bound.args, **bound.kwargs))
        raise TypeError(
            "create_rays_pinhole: expected (intrinsic_matrix, extrinsic_matrix, "
            "width_px, height_px) or (fov_deg, center, eye, up, width_px, height_px)"
        )

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
        return answers(
            {
                "t_hit": hits["t"].reshape(shape),
                "geometry_ids": geometry.reshape(shape),
                "primitive_ids": primitive.reshape(shape),
                "primitive_uvs": uvs.reshape(shape + (2,)),
                "primitive_normals": normals.reshape(shape + (3,)),
            }
        )

    def test_occlusions(self, rays, tnear=0.0, tfar=np.inf, nthreads=0):
        """Whether anything lies on each ray with ``tnear <= t <= tfar``:
        a bool array of the rays' leading shape."""
        origins, directions, shape = self._rays(rays)
        tnear, tfar = _bound(tnear, "tnear"), _bound(tfar, "tfar")
        return answer(self._scene().occluded(origins, directions, tnear, tfar).reshape(shape))

    def count_intersections(self, rays, nthreads=0):
        """How many times each ray crosses the surfaces (int32), each
        crossing once even where a ray passes through a shared edge or
        vertex."""
        origins, directions, shape = self._rays(rays)
        return answer(self._scene().count(origins, directions).astype(np.int32).reshape(shape))

    def list_intersections(self, rays, nthreads=0):
        """Every crossing of every ray, sorted by ray, then distance.

        Returns a dict: ``ray_splits`` (uint32, one more than rays: ray
        ``i``'s hits are entries ``ray_splits[i]:ray_splits[i + 1]``, rays
        numbered in C order over their leading shape), ``ray_ids``,
        ``geometry_ids``, ``primitive_ids`` (uint32), ``primitive_uvs``
        (float32 ``(h, 2)``) and ``t_hit`` (float32).
        """
        origins, directions, _ = self._rays(rays)
        hits = self._scene().all_hits(origins, directions)
        geometry, primitive = self._ids(hits["triangle"])
        counts = np.bincount(hits["ray"], minlength=len(origins))
        splits = np.zeros(len(origins) + 1, dtype=np.uint32)
        np.cumsum(counts, out=splits[1:])
        return answers(
            {
                "ray_splits": splits,
                "ray_ids": hits["ray"].astype(np.uint32),
                "geometry_ids": geometry,
                "primitive_ids": primitive,
                "primitive_uvs": np.stack([hits["u"], hits["v"]], axis=-1).reshape(-1, 2),
                "t_hit": hits["t"],
            }
        )

    @staticmethod
    def _points(query_points):
        """``(..., 3)`` query points as ``(k, 3)``, and the leading shape."""
        return last_axis(query_points, "query_points", 3)

    def compute_closest_points(self, query_points, nthreads=0):
        """The closest point of the surfaces to each query point.

        Returns a dict: ``points`` (float32 ``(..., 3)``), ``geometry_ids``
        and ``primitive_ids`` (uint32), ``primitive_uvs`` (float32
        ``(..., 2)``) and ``primitive_normals`` (float32 ``(..., 3)``). In an
        empty scene the ids are ``INVALID_ID`` and the rest 0, as in Open3D.
        """
        points, shape = self._points(query_points)
        near = self._scene().closest_points(points)
        triangle = near["triangle"]
        geometry, primitive = self._ids(triangle)
        found = triangle >= 0
        uvs = np.zeros((len(points), 2), np.float32)
        uvs[found] = np.stack([near["u"], near["v"]], axis=-1)[found]
        closest, normals = near["point"], near["normal"]
        closest[~found] = 0
        normals[~found] = 0
        return answers(
            {
                "points": closest.reshape(shape + (3,)),
                "geometry_ids": geometry.reshape(shape),
                "primitive_ids": primitive.reshape(shape),
                "primitive_uvs": uvs.reshape(shape + (2,)),
                "primitive_normals": normals.reshape(shape + (3,)),
            }
        )

    def compute_distance(self, query_points, nthreads=0):
        """The distance from each query point to the surfaces (float32; inf
        in an empty scene, NaN for a point with a NaN coordinate, as in
        Open3D and :meth:`compute_signed_distance`)."""
        points, shape = self._points(query_points)
        near = self._scene().closest_points(points)
        distance = near["distance"]
        # A NaN point finds no triangle (distance inf); its distance is
        # unknown. Only points without a triangle are looked at: a pass over
        # all of them would cost 2% of the query.
        lost = np.flatnonzero(near["triangle"] < 0)
        distance[lost[np.isnan(points[lost]).any(axis=1)]] = np.nan
        return answer(distance.reshape(shape))

    def compute_signed_distance(self, query_points, nthreads=0, nsamples=1):
        """The distance to the surfaces, negative inside (float32).

        Inside is decided by the parity of one ray's crossings, which in
        arbor is exact: its watertight triangle test counts a ray through
        an edge or vertex shared by several triangles as one crossing, never
        zero or two. Open3D's test can miscount there, so it votes over
        ``nsamples`` rays; arbor's answer is the same for any ``nsamples``,
        which is accepted (a positive odd integer, as Open3D requires) and
        not needed.
        """
        _check_nsamples(nsamples)
        points, shape = self._points(query_points)
        return answer(self._scene().signed_distance(points).reshape(shape))

    def compute_occupancy(self, query_points, nthreads=0, nsamples=1):
        """1.0 for query points inside the surfaces, 0.0 outside (float32).

        Inside is the exact parity of one ray's crossings (see
        :meth:`compute_signed_distance`): ``nsamples``, the number of rays
        Open3D votes over, is accepted (a positive odd integer) and not
        needed.
        """
        _check_nsamples(nsamples)
        points, shape = self._points(query_points)
        return answer(self._scene().contains(points).astype(np.float32).reshape(shape))
