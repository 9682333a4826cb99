"""Closed test meshes made from Open3D's own primitives (no downloads): a
trefoil knot (Open3D's torus bent along the knot) and a bunny-like blob
(Open3D's sphere with its radius modulated), as ``open3d.t.geometry``
meshes."""

import numpy as np
import open3d as o3d


def _knot_frame(t):
    """Points of the (2, 3) torus knot at parameters ``t`` and two unit
    normals to it there."""
    def curve(s):
        r = 2 + np.cos(3 * s)
        return np.stack([r * np.cos(2 * s), r * np.sin(2 * s), np.sin(3 * s)], axis=-1)

    h = 1e-4
    point = curve(t)
    tangent = curve(t + h) - curve(t - h)
    tangent /= np.linalg.norm(tangent, axis=-1, keepdims=True)
    # A normal from the z axis, which the knot's tangent never follows.
    normal = np.cross(tangent, [0.0, 0.0, 1.0])
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return point, normal, np.cross(tangent, normal)


def knot(tube=0.35):
    """A trefoil knot: Open3D's torus (ring radius 1) with each ring of
    its tube moved to the knot, the tube's radius ``tube``."""
    torus = o3d.geometry.TriangleMesh.create_torus(
        torus_radius=1.0, tube_radius=tube, radial_resolution=240, tubular_resolution=12
    )
    v = np.asarray(torus.vertices)
    angle = np.arctan2(v[:, 1], v[:, 0])
    ring = np.stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)], axis=-1)
    offset = v - ring
    across, up = np.einsum("ij,ij->i", offset, ring), offset[:, 2]
    point, normal, binormal = _knot_frame(angle)
    torus.vertices = o3d.utility.Vector3dVector(point + across[:, None] * normal + up[:, None] * binormal)
    return o3d.t.geometry.TriangleMesh.from_legacy(torus)


def blob():
    """A bunny-like closed blob: Open3D's sphere with bumps and ears."""
    sphere = o3d.geometry.TriangleMesh.create_sphere(radius=1.0, resolution=40)
    v = np.asarray(sphere.vertices)
    x, y, z = v.T
    radius = 1 + 0.25 * np.sin(3 * x) * np.cos(2 * y) + 0.6 * np.exp(-8 * ((x - 0.3) ** 2 + (y - 0.9) ** 2))
    sphere.vertices = o3d.utility.Vector3dVector(v * radius[:, None])
    return o3d.t.geometry.TriangleMesh.from_legacy(sphere)
