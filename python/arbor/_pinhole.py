"""Camera rays of a pinhole camera, in Open3D's layout and conventions.

A ``(height, width, 6)`` float32 array: row ``v``, column ``u`` holds the
camera's centre and the direction through the pixel's centre
``(u + 0.5, v + 0.5)``, ``R^T K^-1 (u + 0.5, v + 0.5, 1)``, where ``K`` is
the intrinsic matrix and ``R`` the rotation of the world-to-camera
extrinsic matrix ``[R | t]`` (the centre is ``-R^T t``). Directions are not
normalised: their component along the optical axis is 1 (a hit's ``t`` is
its depth). The field-of-view form builds ``K`` and ``[R | t]`` from a
horizontal field of view and a look-at frame: the camera's z axis from the
eye to the centre, its x axis ``up x z``, its y axis ``z x x``.
"""

import math
import operator

import numpy as np

from ._inputs import as_array


def _matrix(value, what, shape):
    """``value`` as a finite float64 matrix of ``shape``."""
    m = as_array(value, what).astype(np.float64)
    if m.shape != shape:
        raise ValueError(f"{what}: expected shape {shape}, got shape {m.shape}")
    if not np.isfinite(m).all():
        raise ValueError(f"{what}: expected finite values")
    return m


def _pixels(value, what):
    """``value`` as a positive number of pixels."""
    try:
        n = operator.index(value)
    except TypeError:
        raise TypeError(f"{what}: expected an integer, got {type(value).__name__}") from None
    if n < 1:
        raise ValueError(f"{what}: expected a positive number of pixels, got {n}")
    return n


def _intrinsic_inverse(intrinsic_matrix):
    """The inverse of an upper triangular intrinsic matrix."""
    k = _matrix(intrinsic_matrix, "intrinsic_matrix", (3, 3))
    if k[1, 0] or k[2, 0] or k[2, 1]:
        raise ValueError("intrinsic_matrix: expected an upper triangular matrix")
    if not (k[0, 0] and k[1, 1] and k[2, 2]):
        raise ValueError("intrinsic_matrix: the focal lengths and k[2, 2] must not be 0")
    return np.linalg.inv(k)


def rays_from_matrices(intrinsic_matrix, extrinsic_matrix, width_px, height_px):
    """The rays of a camera given by its intrinsic ``(3, 3)`` and
    world-to-camera extrinsic ``(4, 4)`` matrices (arrays or tensors)."""
    inverse = _intrinsic_inverse(intrinsic_matrix)
    extrinsic = _matrix(extrinsic_matrix, "extrinsic_matrix", (4, 4))
    width, height = _pixels(width_px, "width_px"), _pixels(height_px, "height_px")
    # Open3D takes the extrinsic matrix as rigid: its rotation is inverted
    # by transposing it.
    rotation_t = extrinsic[:3, :3].T
    to_world = rotation_t @ inverse
    u = np.arange(width, dtype=np.float64) + 0.5
    v = np.arange(height, dtype=np.float64) + 0.5
    rays = np.empty((height, width, 6), np.float32)
    rays[..., :3] = -rotation_t @ extrinsic[:3, 3]
    rays[..., 3:] = u[None, :, None] * to_world[:, 0] + v[:, None, None] * to_world[:, 1] + to_world[:, 2]
    return rays


def _unit(vector, what):
    """``vector`` divided by its length (ValueError for a zero vector)."""
    length = np.linalg.norm(vector)
    if not length > 0:
        raise ValueError(what)
    return vector / length


def look_at_matrices(fov_deg, center, eye, up, width_px, height_px):
    """The intrinsic and extrinsic matrices of a camera at ``eye`` looking at
    ``center`` with ``up`` upwards and a horizontal field of view of
    ``fov_deg`` degrees over ``width_px`` pixels, centred on the image."""
    fov = float(fov_deg)
    if not 0 < fov < 180:
        raise ValueError(f"fov_deg: expected an angle between 0 and 180 degrees, got {fov}")
    center, eye, up = (
        _matrix(value, name, (3,)) for value, name in ((center, "center"), (eye, "eye"), (up, "up"))
    )
    z = _unit(center - eye, "center and eye: expected two different points")
    x = _unit(np.cross(up, z), "up: expected a vector not parallel to the view direction")
    y = np.cross(z, x)
    extrinsic = np.eye(4)
    extrinsic[:3, :3] = [x, y, z]
    extrinsic[:3, 3] = -extrinsic[:3, :3] @ eye
    width, height = _pixels(width_px, "width_px"), _pixels(height_px, "height_px")
    focal = 0.5 * width / math.tan(math.radians(fov) / 2)
    intrinsic = np.array([[focal, 0, 0.5 * width], [0, focal, 0.5 * height], [0, 0, 1]])
    return intrinsic, extrinsic


def rays_from_look_at(fov_deg, center, eye, up, width_px, height_px):
    """The rays of a camera at ``eye`` looking at ``center`` (see
    :func:`look_at_matrices`)."""
    intrinsic, extrinsic = look_at_matrices(fov_deg, center, eye, up, width_px, height_px)
    return rays_from_matrices(intrinsic, extrinsic, width_px, height_px)
