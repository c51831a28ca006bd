"""Small geometry helpers shared by the builtin scenes and the JSON loader.

Meshes are flat-shaded: every face has its own vertices, so any per-vertex normal a renderer
derives is the face normal.  Winding is counter-clockwise seen from the side the normal
points to (outward for solids, inward for `inward=True` shells such as a hall).
"""
from __future__ import annotations

import numpy as np

from .model import Camera, Mesh

# The six faces of the unit cube as quads (corner indices into _CORNERS), CCW seen from outside.
_CORNERS = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], np.float64)
# corner index = 4x + 2y + z
_QUADS = {
    "-x": (0, 1, 3, 2),
    "+x": (4, 6, 7, 5),
    "-y": (0, 4, 5, 1),
    "+y": (2, 3, 7, 6),
    "-z": (0, 2, 6, 4),
    "+z": (1, 5, 7, 3),
}


def _quads_to_mesh(quads: np.ndarray, albedo) -> Mesh:
    """(Q, 4, 3) quads (CCW) -> Mesh with 4 vertices and 2 triangles each."""
    q = len(quads)
    verts = quads.reshape(-1, 3).astype(np.float32)
    base = (np.arange(q, dtype=np.int32) * 4)[:, None]
    faces = np.concatenate([base + np.array([[0, 1, 2]], np.int32),
                            base + np.array([[0, 2, 3]], np.int32)], axis=1).reshape(-1, 3)
    return Mesh(verts, faces.astype(np.int32), tuple(float(a) for a in albedo))


def box_mesh(lo, hi, albedo=(0.8, 0.8, 0.8), inward: bool = False, bottom: bool = True) -> Mesh:
    """Axis-aligned box [lo, hi] as 12 triangles (10 without `bottom`).

    `inward=True` flips the winding so that the faces look into the box (a room's shell).
    `bottom=False` drops the -y face (boxes standing on the ground).
    """
    lo = np.asarray(lo, np.float64)
    hi = np.asarray(hi, np.float64)
    corners = lo + _CORNERS * (hi - lo)
    quads = [corners[list(idx)] for name, idx in _QUADS.items() if bottom or name != "-y"]
    quads = np.array(quads)
    if inward:
        quads = quads[:, ::-1]
    return _quads_to_mesh(quads, albedo)


def ramp_mesh(lo, hi, rise_axis: str = "+z", albedo=(0.8, 0.8, 0.8)) -> Mesh:
    """A wedge in the box [lo, hi]: height 0 at one end, hi.y at the end `rise_axis` points to."""
    lo = np.asarray(lo, np.float64)
    hi = np.asarray(hi, np.float64)
    # Build along +z in a unit frame, then rotate about y in 90 degree steps.
    # Unit wedge: bottom rectangle y=0, top edge at z=1, y=1.
    P = {  # name -> unit coords
        "b00": (0, 0, 0), "b10": (1, 0, 0), "b01": (0, 0, 1), "b11": (1, 0, 1),
        "t01": (0, 1, 1), "t11": (1, 1, 1),
    }
    tris = [
        ("b00", "b10", "b11"), ("b00", "b11", "b01"),      # bottom (-y)
        ("b00", "t11", "b10"), ("b00", "t01", "t11"),      # slope (faces up and -z)
        ("b01", "t11", "t01"), ("b01", "b11", "t11"),      # back wall (+z)
        ("b00", "b01", "t01"),                             # -x side
        ("b10", "t11", "b11"),                             # +x side
    ]
    v = np.array([[P[n] for n in t] for t in tris], np.float64)  # (T, 3, 3) unit
    # rotate in the unit square about its centre so that the high end points along rise_axis
    c = v - 0.5
    x, z = c[..., 0].copy(), c[..., 2].copy()
    if rise_axis == "+z":
        pass
    elif rise_axis == "-z":
        x, z = -x, -z
    elif rise_axis == "+x":
        x, z = z, -x
    elif rise_axis == "-x":
        x, z = -z, x
    else:
        raise ValueError(f"rise_axis must be one of +x, -x, +z, -z (got {rise_axis!r})")
    c[..., 0], c[..., 2] = x, z
    v = lo + (c + 0.5) * (hi - lo)
    verts = v.reshape(-1, 3).astype(np.float32)
    faces = np.arange(len(verts), dtype=np.int32).reshape(-1, 3)
    return Mesh(verts, faces, tuple(float(a) for a in albedo))


def merge_meshes(meshes: list[Mesh]) -> list[Mesh]:
    """Merge meshes of equal material and opacity into one mesh each (fewer draws),
    first-seen order."""
    groups: dict[tuple, list[Mesh]] = {}
    for m in meshes:
        groups.setdefault(m.material + (float(m.opacity),), []).append(m)
    out = []
    for key, ms in groups.items():
        verts, faces, off = [], [], 0
        for m in ms:
            verts.append(m.vertices)
            faces.append(m.faces + off)
            off += len(m.vertices)
        out.append(Mesh(np.concatenate(verts).astype(np.float32),
                        np.concatenate(faces).astype(np.int32), key[:3], key[3], key[4], key[5]))
    return out


def mesh_triangles(meshes: list[Mesh]) -> np.ndarray:
    """(T, 3, 3) float64 world-space triangles of all meshes."""
    if not meshes:
        return np.zeros((0, 3, 3))
    return np.concatenate([m.vertices.astype(np.float64)[m.faces] for m in meshes])


def triangle_count(meshes: list[Mesh]) -> int:
    return int(sum(len(m.faces) for m in meshes))


def farthest_corner_distance(position, meshes: list[Mesh]) -> float:
    """Distance from `position` to the farthest corner of the geometry's AABB (0 if none)."""
    if not meshes:
        return 0.0
    v = np.concatenate([m.vertices for m in meshes]).astype(np.float64)
    lo, hi = v.min(0), v.max(0)
    corners = lo + _CORNERS * (hi - lo)
    return float(np.linalg.norm(corners - np.asarray(position, np.float64), axis=1).max())


def max_depth_for(cameras: list[Camera], meshes: list[Mesh]) -> float:
    """Farthest view depth worth slicing: min(far, farthest AABB corner), at least 2*near,
    maximised over `cameras`."""
    best = 0.0
    for c in cameras:
        d = min(float(c.far), farthest_corner_distance(c.position, meshes) if meshes else float(c.far))
        best = max(best, d, 2.0 * float(c.near))
    return best
