"""A drop-in ray intersector for trimesh, backed by arbor.

``mesh.ray = arbor.trimesh.RayMeshIntersector(mesh)`` makes trimesh cast
one mesh's rays (``mesh.ray.intersects_*``, ``mesh.contains``) with arbor;
``arbor.trimesh.install()`` makes arbor the intersector of every mesh
trimesh builds from then on. The interface is that of trimesh 5.2's own
intersectors; only ``install`` imports trimesh. Hits are arbor's exact,
watertight ones: a ray through an edge or vertex shared by several
triangles crosses the surface once, so ``multiple_hits`` reports each
crossing once and ``contains_points`` is the exact parity of one ray's
crossings. Rays and points may be NumPy arrays (float32 and float64 ones
are read without a copy), tensors or lists.
"""

import numpy as np

from ._arbor import Mesh
from ._inputs import as_array


def install():
    """Makes ``arbor.trimesh.RayMeshIntersector`` the ``mesh.ray`` of every
    ``trimesh.Trimesh`` created after the call, with or without embreex.

    trimesh picks a new mesh's intersector from
    ``trimesh.ray.ray_pyembree`` (when embreex is installed and
    ``use_embree``) or ``trimesh.ray.ray_triangle``; both are pointed at
    arbor's. Meshes that exist already keep theirs (``mesh.ray = ...``
    changes one).
    """
    import trimesh.ray

    trimesh.ray.ray_triangle.RayMeshIntersector = RayMeshIntersector
    if trimesh.ray.has_embree:
        trimesh.ray.ray_pyembree.RayMeshIntersector = RayMeshIntersector


def _rays(ray_origins, ray_directions):
    """Origins and directions as (n, 3) float arrays of equal shape."""
    origins = as_array(ray_origins, "ray_origins")
    directions = as_array(ray_directions, "ray_directions")
    if origins.shape != directions.shape:
        raise ValueError("Ray origin and direction don't match!")
    if origins.ndim == 1:
        origins, directions = origins.reshape(-1, 3), directions.reshape(-1, 3)
    return origins, directions


def _geometry_key(vertices, faces):
    """Something that changes when the mesh's vertices or faces do; cheap
    for trimesh's tracked arrays, which cache their hash until edited."""
    try:
        return hash(vertices), hash(faces)
    except TypeError:
        vertices, faces = np.asarray(vertices), np.asarray(faces)
        return hash((vertices.tobytes(), vertices.shape, faces.tobytes(), faces.shape))


class RayMeshIntersector:
    """Ray queries on a trimesh ``Trimesh`` (or anything with ``vertices``
    and ``faces``), with the interface of trimesh's intersectors.

    The arbor mesh is built on the first query and rebuilt when the mesh's
    vertices or faces have changed since. An empty mesh is fine: every ray
    misses. ``scale_to_box`` is accepted for compatibility and changes
    nothing: arbor's float32 test has the same relative precision at every
    scale.
    """

    def __init__(self, geometry, scale_to_box=True):
        self.mesh = geometry
        self._scale_to_box = scale_to_box
        self._built = None

    def _arbor(self):
        """The arbor mesh of the current geometry."""
        vertices, faces = self.mesh.vertices, self.mesh.faces
        key = _geometry_key(vertices, faces)
        if self._built is None or self._built[0] != key:
            vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
            faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
            self._built = (key, Mesh(vertices, faces))
        return self._built[1]

    def _locations(self, origins, directions, index_ray, index_tri, t):
        """Where each ray meets the plane of its hit triangle, in float64 (as
        trimesh reports locations), or at its float32 ``t`` when the ray runs
        along that plane."""
        o = np.asarray(origins[index_ray], dtype=np.float64)
        d = np.asarray(directions[index_ray], dtype=np.float64)
        tri = np.asarray(self.mesh.vertices, dtype=np.float64)[
            np.asarray(self.mesh.faces)[index_tri]
        ]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        along = np.einsum("ij,ij->i", normal, d)
        with np.errstate(divide="ignore", invalid="ignore"):
            t64 = np.einsum("ij,ij->i", normal, tri[:, 0] - o) / along
        t64 = np.where(np.isfinite(t64), t64, np.asarray(t, dtype=np.float64))
        return o + t64[:, None] * d

    def intersects_id(
        self,
        ray_origins,
        ray_directions,
        multiple_hits=True,
        max_hits=100,
        return_locations=False,
        **kwargs,
    ):
        """The triangles hit by each ray: every crossing sorted by ray then
        distance (at most ``max_hits`` per ray) with ``multiple_hits``, else
        the first hit of each ray that hits.

        Returns ``index_tri`` and ``index_ray`` (int64), and with
        ``return_locations`` the ``(h, 3)`` float64 hit locations.
        """
        origins, directions = _rays(ray_origins, ray_directions)
        mesh = self._arbor()
        if multiple_hits:
            hits = mesh.all_hits(origins, directions)
            index_ray, index_tri, t = hits["ray"], hits["triangle"], hits["t"]
            # Hits come sorted by ray: a hit's rank is its distance from the
            # first hit of its ray.
            first = np.searchsorted(index_ray, index_ray, side="left")
            keep = np.arange(len(index_ray)) - first < max_hits
            index_ray, index_tri, t = index_ray[keep], index_tri[keep], t[keep]
        else:
            hits = mesh.intersect(origins, directions)
            index_ray = np.nonzero(hits["triangle"] >= 0)[0]
            index_tri, t = hits["triangle"][index_ray], hits["t"][index_ray]
        index_tri = index_tri.astype(np.int64)
        index_ray = index_ray.astype(np.int64)
        if return_locations:
            locations = self._locations(origins, directions, index_ray, index_tri, t)
            return index_tri, index_ray, locations
        return index_tri, index_ray

    def intersects_location(self, ray_origins, ray_directions, multiple_hits=True, **kwargs):
        """Where rays hit the mesh: ``locations`` ``(h, 3)`` float64,
        ``index_ray`` and ``index_tri`` (int64), as :meth:`intersects_id`
        (which gets ``max_hits`` and the other keywords)."""
        kwargs["return_locations"] = True
        index_tri, index_ray, locations = self.intersects_id(
            ray_origins, ray_directions, multiple_hits=multiple_hits, **kwargs
        )
        return locations, index_ray, index_tri

    def intersects_first(self, ray_origins, ray_directions, **kwargs):
        """The first triangle each ray hits, -1 for a miss: ``(n,)`` int64."""
        origins, directions = _rays(ray_origins, ray_directions)
        return self._arbor().intersect(origins, directions)["triangle"]

    def intersects_any(self, ray_origins, ray_directions, **kwargs):
        """Whether each ray hits the mesh: ``(n,)`` bool."""
        origins, directions = _rays(ray_origins, ray_directions)
        return self._arbor().occluded(origins, directions)

    def contains_points(self, points, check_direction=None):
        """Whether each point is inside the mesh: the exact parity of one
        ray's crossings (``check_direction`` is accepted and not needed)."""
        points = as_array(points, "points").reshape(-1, 3)
        return self._arbor().contains(points)

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_built"] = None
        return state

    def __copy__(self):
        return RayMeshIntersector(self.mesh, scale_to_box=self._scale_to_box)

    def __deepcopy__(self, memo):
        return self.__copy__()
